//! Checks of the shapes: closed ones closed and consistently oriented with
//! their Euler characteristic, flat ones with their boundary, and the
//! variants of one shape the same mesh renumbered.

use std::collections::HashMap;

use glam::DVec3;
use qm_io::PolyMesh;

use crate::*;

/// Euler characteristic and boundary edge count; panics unless every
/// directed edge is used once and every inner edge both ways.
fn topology(mesh: &PolyMesh) -> (i64, usize) {
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for f in mesh.faces() {
        assert!(f.iter().all(|&v| (v as usize) < mesh.positions.len()));
        for k in 0..f.len() {
            *directed.entry((f[k], f[(k + 1) % f.len()])).or_default() += 1;
        }
    }
    assert!(directed.values().all(|&c| c == 1), "an edge twice one way");
    let boundary = directed
        .keys()
        .filter(|&&(a, b)| !directed.contains_key(&(b, a)));
    let boundary = boundary.count();
    let edges = (directed.len() + boundary) / 2;
    let euler = mesh.positions.len() as i64 - edges as i64 + mesh.face_count() as i64;
    (euler, boundary)
}

#[test]
fn closed_shapes_are_closed() {
    let spheres = [
        poly(tetrahedron()),
        poly(tetrahedron_inward()),
        poly(cube()),
        poly(octahedron()),
        poly(l_prism()),
        uv_sphere(7, 11, 2.0),
        poly(uv_sphere_triangles(8, 16)),
        uv_sphere_poles_first(8, 16),
        poly(uv_sphere_radial(6, 12, |theta, _| 1.0 + theta)),
        poly(cylinder(5)),
        poly(cylinder_ring_by_ring(5)),
    ];
    for mesh in &spheres {
        assert_eq!(topology(mesh), (2, 0), "{mesh:?}");
    }
    let tori = [
        poly(torus(6, 4, 2.0, |_, _| 1.0)),
        poly(torus_quads(6, 4, 2.0, 1.0)),
        poly(torus_ring_by_ring(6, 4, 1.0, |_, _| 0.3)),
    ];
    for mesh in &tori {
        assert_eq!(topology(mesh), (0, 0));
    }
}

#[test]
fn flat_shapes_have_their_boundary() {
    assert_eq!(topology(&poly(grid(4, 3, false))), (1, 14));
    assert_eq!(topology(&poly(plane(5))), (1, 20));
    assert_eq!(topology(&poly(holed_grid())), (0, 16));
    assert_eq!(topology(&poly(square(0.5))), (1, 4));
    assert_eq!(topology(&poly(quad_fan(5))), (1, 10));
    assert_eq!(topology(&ngon(7)), (1, 7));
    assert_eq!(topology(&poly(open_cylinder_quads(4, 3))), (0, 8));
    let (_, faces) = grid(4, 3, false);
    assert_eq!(faces, grid_triangles(4, 3));
    let split: Vec<[u32; 3]> = grid_quads(4, 3)
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
        .collect();
    assert_eq!(split, faces);
}

/// The sphere with both poles first is the one with the south pole last,
/// renumbered, but for the signs of the south pole's zeros.
#[test]
fn sphere_variants_are_one_mesh_renumbered() {
    let (positions, faces) = uv_sphere_triangles(6, 9);
    let first = uv_sphere_poles_first(6, 9);
    let south = positions.len() as u32 - 1;
    let moved = |v: u32| match v {
        0 => 0,
        v if v == south => 1,
        v => v + 1,
    };
    let renumbered: Vec<Vec<u32>> = faces.iter().map(|f| f.map(moved).to_vec()).collect();
    assert_eq!(
        first.faces().map(<[u32]>::to_vec).collect::<Vec<_>>(),
        renumbered
    );
    assert_eq!(first.positions[1], DVec3::NEG_Z);
    assert_eq!(positions[south as usize], DVec3::NEG_Z);
    assert!(positions[south as usize].x.is_sign_negative());
    assert_eq!(first.positions[2..], positions[1..south as usize]);
}

#[test]
fn cylinder_variants_are_one_mesh_renumbered() {
    let n = 7;
    let (positions, faces) = cylinder(n);
    let (rings, ring_faces) = cylinder_ring_by_ring(n);
    let moved = |v: u32| if v < 2 * n { v / 2 + n * (v % 2) } else { v };
    let renumbered: Vec<[u32; 3]> = faces.iter().map(|f| f.map(moved)).collect();
    assert_eq!(renumbered, ring_faces);
    for (v, p) in positions.iter().enumerate() {
        assert_eq!(rings[moved(v as u32) as usize], *p);
    }
}
