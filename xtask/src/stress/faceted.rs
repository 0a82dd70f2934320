//! Small closed shapes: the faceted ones of the stress set, every edge a
//! crease (`cube`, `tetrahedron`, `lprism`, `cylinder`, `torus24x12`,
//! `uvsphere8x16`), which also make up `parts300`. The UV sphere, L-prism,
//! cylinder and torus are the test meshes of `qm-shapes`.

use std::collections::HashMap;

use qm::lift::glam::DVec3;

use super::tris::Tris;

/// A unit UV sphere (`qm_shapes::uv_sphere_triangles`), every face turned
/// outward.
pub(super) fn uv_sphere(rings: u32, segments: u32) -> Tris {
    let (positions, faces) = qm_shapes::uv_sphere_triangles(rings, segments);
    let mut t = Tris { positions, faces };
    t.orient(|c| c);
    t
}

/// The surface of a box of half extents `half` with `n` segments an edge.
pub(super) fn grid_box(n: u32, half: DVec3) -> Tris {
    let mut t = Tris::default();
    let mut index: HashMap<[u32; 3], u32> = HashMap::new();
    let mut vertex = |t: &mut Tris, c: [u32; 3]| -> u32 {
        *index.entry(c).or_insert_with(|| {
            let p = DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) / n as f64 * 2.0 - 1.0;
            t.push(p * half)
        })
    };
    for axis in 0..3 {
        for side in [0, n] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            for a in 0..n {
                for b in 0..n {
                    let corner = |da: u32, db: u32| {
                        let mut c = [0u32; 3];
                        c[axis] = side;
                        c[u] = a + da;
                        c[v] = b + db;
                        c
                    };
                    let q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)]
                        .map(|c| vertex(&mut t, c));
                    t.faces.push([q[0], q[1], q[2]]);
                    t.faces.push([q[0], q[2], q[3]]);
                }
            }
        }
    }
    t.orient(|c| c);
    t
}

pub(super) fn tetrahedron() -> Tris {
    let mut t = Tris::default();
    for p in [[1., 1., 1.], [1., -1., -1.], [-1., 1., -1.], [-1., -1., 1.]] {
        t.push(DVec3::from_array(p));
    }
    t.faces = vec![[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]];
    t.orient(|c| c);
    t
}

/// An L-shaped prism: an outline of six corners, extruded, its caps in
/// four triangles each (`qm_shapes::l_prism`).
pub(super) fn l_prism() -> Tris {
    let (positions, faces) = qm_shapes::l_prism();
    Tris { positions, faces }
}

/// A closed cylinder of radius 1 and height 2, `n` segments, each cap a fan
/// around its centre (`qm_shapes::cylinder`).
pub(crate) fn cylinder(n: u32) -> Tris {
    let (positions, faces) = qm_shapes::cylinder(n);
    Tris { positions, faces }
}

/// A torus of radii 1 and `r` (`qm_shapes::torus_ring_by_ring`), every face
/// turned outward from the tube's centre line.
pub(super) fn torus(major: u32, minor: u32, r: f64) -> Tris {
    let (positions, faces) = qm_shapes::torus_ring_by_ring(major, minor, 1.0, |_, _| r);
    let mut t = Tris { positions, faces };
    t.orient(|c| c - DVec3::new(c.x, c.y, 0.0).normalize());
    t
}
