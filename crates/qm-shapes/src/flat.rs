//! Flat meshes in the plane `z = 0`: grids of triangles or quads (and their
//! faces alone, for callers with their own positions), the unit plane, a
//! 3 x 3 grid with a hole, the unit square, a fan of quads and an n-gon.

use std::f64::consts::{PI, TAU};

use glam::DVec3;
use qm_io::PolyMesh;

use crate::{Quads, Triangles, cell_quads, cell_triangles, rows};

/// A `w` by `h` grid of cells on the integer points `(x, y, 0)`, numbered
/// row by row; each cell split into two triangles ([`grid_triangles`]).
/// With `scramble`, all but every third triangle are turned over.
pub fn grid(w: u32, h: u32, scramble: bool) -> Triangles {
    let mut positions = Vec::new();
    for y in 0..=h {
        for x in 0..=w {
            positions.push(DVec3::new(f64::from(x), f64::from(y), 0.0));
        }
    }
    let mut faces = grid_triangles(w, h);
    if scramble {
        for (k, t) in faces.iter_mut().enumerate() {
            if k % 3 != 0 {
                t.swap(1, 2);
            }
        }
    }
    (positions, faces)
}

/// The triangles of a `w` by `h` grid of `(w + 1) (h + 1)` vertices
/// numbered row by row: cell by cell, row by row, corners `a b c d`
/// counter-clockwise from the lowest, the triangles `a b c` and `a c d`.
pub fn grid_triangles(w: u32, h: u32) -> Vec<[u32; 3]> {
    cell_triangles(rows(w, h), |x, y| y * (w + 1) + x)
}

/// The quads of a `w` by `h` grid numbered as in [`grid_triangles`], each
/// `a b c d`.
pub fn grid_quads(w: u32, h: u32) -> Vec<[u32; 4]> {
    cell_quads(rows(w, h), |x, y| y * (w + 1) + x)
}

/// The unit square as an `n` by `n` [`grid`], each position divided by `n`.
pub fn plane(n: u32) -> Triangles {
    let (mut positions, faces) = grid(n, n, false);
    for p in &mut positions {
        *p /= f64::from(n);
    }
    (positions, faces)
}

/// A 3 x 3 grid of quads without its centre quad (a boundary and a hole):
/// 16 vertices at `(v % 4, v / 4, 0)`, eight quads row by row.
pub fn holed_grid() -> Quads {
    let positions = (0..16u32)
        .map(|v| DVec3::new((v % 4) as f64, (v / 4) as f64, 0.0))
        .collect();
    let cells = rows(3, 3).filter(|&cell| cell != (1, 1));
    (positions, cell_quads(cells, |i, j| i + 4 * j))
}

/// The unit square at height `z`, one quad.
pub fn square(z: f64) -> Quads {
    let positions = vec![
        DVec3::new(0.0, 0.0, z),
        DVec3::new(1.0, 0.0, z),
        DVec3::new(1.0, 1.0, z),
        DVec3::new(0.0, 1.0, z),
    ];
    (positions, vec![[0, 1, 2, 3]])
}

/// An open disc of `valence` quads around one interior vertex (0): the
/// rim alternates spoke ends at radius 1 (odd vertices) and corners at
/// radius 1.5 (even vertices).
pub fn quad_fan(valence: u32) -> Quads {
    let mut positions = vec![DVec3::ZERO];
    for k in 0..2 * valence {
        let angle = PI * k as f64 / valence as f64;
        let radius = if k % 2 == 0 { 1.0 } else { 1.5 };
        positions.push(DVec3::new(radius * angle.cos(), radius * angle.sin(), 0.0));
    }
    let faces = (0..valence)
        .map(|k| [0, 1 + 2 * k, 2 + 2 * k, 1 + (2 * k + 2) % (2 * valence)])
        .collect();
    (positions, faces)
}

/// One flat `n`-gon on the unit circle, counter-clockwise: a single face.
pub fn ngon(n: u32) -> PolyMesh {
    let points: Vec<DVec3> = (0..n)
        .map(|i| {
            let a = TAU * f64::from(i) / f64::from(n);
            DVec3::new(a.cos(), a.sin(), 0.0)
        })
        .collect();
    let mut polygon = PolyMesh::from_faces::<3>(points, &[]);
    polygon.push_face(&(0..n).collect::<Vec<u32>>());
    polygon
}
