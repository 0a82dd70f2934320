//! `heightfield`: an open height field like a range scan, a regular grid of
//! a sum of sines inside a ragged outline with a few missing patches and
//! per-vertex noise; one connected manifold surface with boundary.

use std::f64::consts::TAU;

use qm::lift::glam::DVec3;

use super::tris::{Tris, between, unit};

/// Vertices per side of the height field's grid.
pub(super) const FIELD_SIDE: usize = 300;

/// The height field's surface over `[-1, 1]^2`.
fn height(x: f64, y: f64) -> f64 {
    0.12 * (2.1 * x + 0.3).sin() * (1.7 * y).cos()
        + 0.05 * (5.3 * x - 3.1 * y).sin()
        + 0.025 * (11.0 * x + 0.5).cos() * (9.0 * y + 1.0).sin()
        + 0.008 * (31.0 * x + 17.0 * y).sin()
}

pub(super) fn height_field(side: usize) -> Tris {
    let cells = side - 1;
    let coord = |i: usize| -1.0 + 2.0 * i as f64 / cells as f64;
    // The outline: radius modulated by angle at several frequencies.
    let phase: Vec<f64> = (0..5).map(|k| between(41, k, 0.0, TAU)).collect();
    let outline = |a: f64| {
        0.78 + 0.07 * (3.0 * a + phase[0]).sin()
            + 0.04 * (7.0 * a + phase[1]).sin()
            + 0.025 * (13.0 * a + phase[2]).sin()
            + 0.012 * (29.0 * a + phase[3]).sin()
            + 0.006 * (61.0 * a + phase[4]).sin()
    };
    // Missing patches inside: (centre, radii of an ellipse).
    let patches: Vec<(f64, f64, f64, f64)> = (0..6u64)
        .map(|k| {
            let a = TAU * (k as f64 + between(42, k, 0.0, 0.5)) / 6.0;
            let r = between(43, k, 0.15, 0.5);
            let s = between(44, k, 0.03, 0.07);
            (r * a.cos(), r * a.sin(), s, s * between(45, k, 0.5, 1.5))
        })
        .collect();
    let mut keep = vec![false; cells * cells];
    let mut patch = vec![false; cells * cells];
    for j in 0..cells {
        for i in 0..cells {
            let (x, y) = (
                (coord(i) + coord(i + 1)) / 2.0,
                (coord(j) + coord(j + 1)) / 2.0,
            );
            let (r, a) = (x.hypot(y), y.atan2(x));
            let margin = outline(a) - r;
            let c = (j * cells + i) as u64;
            // Near the border some cells drop out, as on a real scan.
            let ragged = margin < 0.03 && unit(46, c) < 0.35;
            let hole = patches
                .iter()
                .any(|&(px, py, rx, ry)| ((x - px) / rx).powi(2) + ((y - py) / ry).powi(2) < 1.0);
            keep[j * cells + i] = margin > 0.0 && !ragged && !hole;
            patch[j * cells + i] = hole;
        }
    }
    // Dropped cells the outside does not reach are filled again: the
    // border is ragged, and the only holes inside are the patches.
    let outside = reach_from_border(&keep, cells);
    for c in 0..cells * cells {
        keep[c] |= !outside[c] && !patch[c];
    }
    clean_cells(&mut keep, cells);
    let mut tris = Tris::default();
    for j in 0..side {
        for i in 0..side {
            let (x, y) = (coord(i), coord(j));
            let noise = between(47, (j * side + i) as u64, -0.0015, 0.0015);
            tris.push(DVec3::new(x, y, height(x, y) + noise));
        }
    }
    let v = |i: usize, j: usize| (j * side + i) as u32;
    for j in 0..cells {
        for i in 0..cells {
            if keep[j * cells + i] {
                let q = [v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)];
                tris.faces.push([q[0], q[1], q[2]]);
                tris.faces.push([q[0], q[2], q[3]]);
            }
        }
    }
    tris.compact();
    tris
}

/// The edge neighbours of cell `c` of an `n x n` grid.
fn neighbours(c: usize, n: usize) -> impl Iterator<Item = usize> {
    let (i, j) = (c % n, c / n);
    [
        (i > 0).then(|| c - 1),
        (i + 1 < n).then(|| c + 1),
        (j > 0).then(|| c - n),
        (j + 1 < n).then(|| c + n),
    ]
    .into_iter()
    .flatten()
}

/// The cells not kept that the grid's border reaches through cells not kept.
fn reach_from_border(keep: &[bool], n: usize) -> Vec<bool> {
    let mut seen = vec![false; n * n];
    let mut stack: Vec<usize> = (0..n * n)
        .filter(|&c| {
            let (i, j) = (c % n, c / n);
            !keep[c] && (i == 0 || j == 0 || i + 1 == n || j + 1 == n)
        })
        .collect();
    for &c in &stack {
        seen[c] = true;
    }
    while let Some(c) = stack.pop() {
        for d in neighbours(c, n) {
            if !keep[d] && !seen[d] {
                seen[d] = true;
                stack.push(d);
            }
        }
    }
    seen
}

/// Makes the kept cells of an `n x n` grid one edge-connected set with no
/// vertex where only two diagonally opposite cells meet.
fn clean_cells(keep: &mut [bool], n: usize) {
    let at = |i: usize, j: usize| j * n + i;
    loop {
        let mut changed = false;
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let q = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)].map(|c| keep[c]);
                if q == [true, false, true, false] {
                    keep[at(i, j)] = false;
                    changed = true;
                } else if q == [false, true, false, true] {
                    keep[at(i + 1, j)] = false;
                    changed = true;
                }
            }
        }
        if !changed {
            break;
        }
    }
    // The largest edge-connected set of cells stays.
    let mut label = vec![usize::MAX; n * n];
    let mut best = (0, usize::MAX);
    for start in 0..n * n {
        if !keep[start] || label[start] != usize::MAX {
            continue;
        }
        let mut stack = vec![start];
        label[start] = start;
        let mut size = 0;
        while let Some(c) = stack.pop() {
            size += 1;
            for d in neighbours(c, n) {
                if keep[d] && label[d] == usize::MAX {
                    label[d] = start;
                    stack.push(d);
                }
            }
        }
        if size > best.0 {
            best = (size, start);
        }
    }
    for c in 0..n * n {
        keep[c] = keep[c] && label[c] == best.1;
    }
}

#[cfg(test)]
mod tests {
    use super::super::topology::Topology;
    use super::*;

    #[test]
    fn height_field_is_one_open_sheet() {
        let t = Topology::of(&height_field(120));
        assert!(t.whole.manifold, "{t}");
        assert_eq!(t.parts.len(), 1, "{t}");
        assert!(
            t.whole.boundary_loops >= 1 && t.whole.boundary_edges > 0,
            "{t}"
        );
        assert_eq!(t.genus(), Some(0), "{t}");
    }
}
