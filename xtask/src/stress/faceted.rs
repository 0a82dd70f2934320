//! Small closed shapes: the faceted ones of the stress set, every edge a
//! crease (`cube`, `tetrahedron`, `lprism`, `cylinder`, `torus24x12`,
//! `uvsphere8x16`), which also make up `parts300`.

use std::collections::HashMap;
use std::f64::consts::{PI, TAU};

use qm::lift::glam::DVec3;

use super::tris::Tris;

pub(super) fn uv_sphere(rings: u32, segments: u32) -> Tris {
    let mut t = Tris::default();
    let north = t.push(DVec3::Z);
    for r in 1..rings {
        let theta = PI * r as f64 / rings as f64;
        for s in 0..segments {
            let phi = TAU * s as f64 / segments as f64;
            t.push(DVec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ));
        }
    }
    let south = t.push(-DVec3::Z);
    let at = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    for s in 0..segments {
        t.faces.push([north, at(1, s), at(1, s + 1)]);
        t.faces
            .push([south, at(rings - 1, s + 1), at(rings - 1, s)]);
        for r in 1..rings - 1 {
            t.faces.push([at(r, s), at(r + 1, s), at(r + 1, s + 1)]);
            t.faces.push([at(r, s), at(r + 1, s + 1), at(r, s + 1)]);
        }
    }
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
/// four triangles each.
pub(super) fn l_prism() -> Tris {
    let outline = [(0., 0.), (2., 0.), (2., 1.), (1., 1.), (1., 2.), (0., 2.)];
    let mut t = Tris::default();
    for z in [0., 1.] {
        for &(x, y) in &outline {
            t.push(DVec3::new(x, y, z));
        }
    }
    for i in 0..6 {
        let j = (i + 1) % 6;
        t.faces.push([i, j, j + 6]);
        t.faces.push([i, j + 6, i + 6]);
    }
    for [a, b, c] in [[0, 2, 1], [0, 3, 2], [0, 5, 3], [3, 5, 4]] {
        t.faces.push([a, b, c]);
        t.faces.push([a + 6, c + 6, b + 6]);
    }
    t
}

/// A closed cylinder of radius 1 and height 2, `n` segments, each cap a fan
/// around its centre.
pub(crate) fn cylinder(n: u32) -> Tris {
    let mut t = Tris::default();
    for i in 0..n {
        let a = TAU * i as f64 / n as f64;
        t.push(DVec3::new(a.cos(), a.sin(), 0.0));
        t.push(DVec3::new(a.cos(), a.sin(), 2.0));
    }
    let (low, high) = (t.push(DVec3::ZERO), t.push(DVec3::new(0.0, 0.0, 2.0)));
    for i in 0..n {
        let j = (i + 1) % n;
        t.faces.push([2 * i, 2 * j, 2 * j + 1]);
        t.faces.push([2 * i, 2 * j + 1, 2 * i + 1]);
        t.faces.push([low, 2 * j, 2 * i]);
        t.faces.push([high, 2 * i + 1, 2 * j + 1]);
    }
    t
}

pub(super) fn torus(major: u32, minor: u32, r: f64) -> Tris {
    let mut t = Tris::default();
    for i in 0..major {
        let u = TAU * i as f64 / major as f64;
        for j in 0..minor {
            let v = TAU * j as f64 / minor as f64;
            let ring = 1.0 + r * v.cos();
            t.push(DVec3::new(ring * u.cos(), ring * u.sin(), r * v.sin()));
        }
    }
    let at = |i: u32, j: u32| (i % major) * minor + j % minor;
    for i in 0..major {
        for j in 0..minor {
            t.faces.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            t.faces.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    t.orient(|c| c - DVec3::new(c.x, c.y, 0.0).normalize());
    t
}
