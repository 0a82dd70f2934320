//! The quad base mesh of a base triangle mesh: every base triangle split
//! into three quads, through its centroid and its edges' midpoints.
//!
//! Main items: [`quads`] and its [`Quads`]; [`quad_corners`] and
//! [`bilinear`] place a quad's grid points in its base triangle.
//!
//! Corner `c`'s quad of triangle `t` has corners `t[c]`, the midpoint of
//! `t[c] t[c+1]`, the centroid and the midpoint of `t[c+2] t[c]`, so it is
//! where `t[c]`'s barycentric coordinate is the largest. A grid point
//! `(s, t)` of a quad is its bilinear combination of the four corners'
//! barycentric coordinates, `(1-s)(1-t) q0 + s(1-t) q1 + s t q2 + (1-s) t q3`.

use std::collections::HashMap;

use qm_lift::{coding_order, split_triangles};

/// The quads of base triangle `t`: corner `c`'s quad has corners `t[c]`,
/// the midpoint of `t[c] t[c+1]`, the centroid and the midpoint of
/// `t[c+2] t[c]`, counter-clockwise; in barycentric coordinates of `t`.
pub(super) fn quad_corners(c: usize) -> [[f64; 3]; 4] {
    let mut e = [[0.0; 3]; 3];
    for (i, row) in e.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    let mid = |a: usize, b: usize| std::array::from_fn(|i| 0.5 * (e[a][i] + e[b][i]));
    [
        e[c],
        mid(c, (c + 1) % 3),
        [1.0 / 3.0; 3],
        mid(c, (c + 2) % 3),
    ]
}

/// Bilinear point `(s, t)` of a quad given by its corners.
pub(super) fn bilinear(q: &[[f64; 3]; 4], s: f64, t: f64) -> [f64; 3] {
    let w = [(1.0 - s) * (1.0 - t), s * (1.0 - t), s * t, (1.0 - s) * t];
    std::array::from_fn(|i| w[0] * q[0][i] + w[1] * q[1][i] + w[2] * q[2][i] + w[3] * q[3][i])
}

/// The quad base mesh of a base triangle mesh ([`split_triangles`], whose
/// numbering the base coder relies on): the quads, the vertex count, per
/// quad its triangle and corner, and the compact id of each base vertex.
pub(crate) struct Quads {
    pub faces: Vec<[u32; 4]>,
    pub vertex_count: u32,
    pub owner: Vec<(u32, u8)>,
    pub compact: HashMap<u32, u32>,
}

pub(crate) fn quads(triangles: &[[u32; 3]]) -> Quads {
    let order = coding_order(triangles);
    let turned: Vec<[u32; 3]> = (order.iter())
        .map(|&(t, r)| std::array::from_fn(|i| triangles[t as usize][(r as usize + i) % 3]))
        .collect();
    let split = split_triangles(&turned);
    let compact = (split.corners.iter().enumerate())
        .map(|(i, &v)| (v, i as u32))
        .collect();
    let owner = (0..3 * triangles.len())
        .map(|q| {
            let (t, r) = order[q / 3];
            (t, ((r as usize + q % 3) % 3) as u8)
        })
        .collect();
    Quads {
        faces: split.faces,
        vertex_count: split.vertex_count,
        owner,
        compact,
    }
}
