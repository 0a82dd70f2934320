//! Small closed polyhedra: the corner tetrahedron (outward and inward), the
//! unit cube, the octahedron, and an L-shaped prism.

use glam::DVec3;

use crate::{Quads, Triangles};

/// The tetrahedron on the origin and the three unit axes (vertices 0, x, y,
/// z in that order), its faces outward.
pub fn tetrahedron() -> Triangles {
    let faces = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
    (corner_tetrahedron(), faces)
}

/// [`tetrahedron`]'s vertices with every face turned inward, and listed in
/// another order (`0 1 2`, `0 2 3`, `0 3 1`, `1 3 2`).
pub fn tetrahedron_inward() -> Triangles {
    let faces = vec![[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]];
    (corner_tetrahedron(), faces)
}

fn corner_tetrahedron() -> Vec<DVec3> {
    vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z]
}

/// The unit cube `[0, 1]^3`: vertex `i` at `(i & 1, i >> 1 & 1, i >> 2)`,
/// six outward quads (bottom, top, front, back, left, right).
pub fn cube() -> Quads {
    let positions = (0..8u32)
        .map(|i| {
            DVec3::new(
                f64::from(i & 1),
                f64::from((i >> 1) & 1),
                f64::from((i >> 2) & 1),
            )
        })
        .collect();
    let faces = vec![
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    (positions, faces)
}

/// The octahedron on the unit axes (`+x +y -x -y +z -z`): closed, genus 0,
/// four triangles around `+z`, then four around `-z`.
pub fn octahedron() -> Triangles {
    let positions = vec![
        DVec3::X,
        DVec3::Y,
        DVec3::NEG_X,
        DVec3::NEG_Y,
        DVec3::Z,
        DVec3::NEG_Z,
    ];
    let triangles = vec![
        [0, 1, 4],
        [1, 2, 4],
        [2, 3, 4],
        [3, 0, 4],
        [1, 0, 5],
        [2, 1, 5],
        [3, 2, 5],
        [0, 3, 5],
    ];
    (positions, triangles)
}

/// An L-shaped prism: an outline of six corners at `z = 0`, the same at
/// `z = 1` (12 vertices), two triangles on each side, each cap in four
/// triangles. Every edge is a crease.
pub fn l_prism() -> Triangles {
    let outline = [(0., 0.), (2., 0.), (2., 1.), (1., 1.), (1., 2.), (0., 2.)];
    let mut positions = Vec::new();
    for z in [0., 1.] {
        for &(x, y) in &outline {
            positions.push(DVec3::new(x, y, z));
        }
    }
    let mut faces = Vec::new();
    for i in 0..6 {
        let j = (i + 1) % 6;
        faces.push([i, j, j + 6]);
        faces.push([i, j + 6, i + 6]);
    }
    for [a, b, c] in [[0, 2, 1], [0, 3, 2], [0, 5, 3], [3, 5, 4]] {
        faces.push([a, b, c]);
        faces.push([a + 6, c + 6, b + 6]);
    }
    (positions, faces)
}
