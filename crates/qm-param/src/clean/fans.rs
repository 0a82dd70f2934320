//! Step 6 of the clean-up: the fans of faces joined around every vertex,
//! each to become a copy of it; the edges whose faces would still share
//! both copies; and the count of edges split and paired.

use super::edges::{EdgeTable, next_corner};
use super::orient::EdgeState;
use super::report::CleanReport;
use crate::union_find::UnionFind;

/// The fan of every corner around its vertex: corners joined across
/// [`EdgeState::Joined`] edges share a root (the smallest corner of the fan).
pub(super) fn corner_groups(tris: &[[u32; 3]], edges: &EdgeTable, state: &[EdgeState]) -> Vec<u32> {
    let mut sets = UnionFind::new(3 * tris.len());
    for (e, s) in state.iter().enumerate() {
        if *s != EdgeState::Joined {
            continue;
        }
        let pair = edges.corners(e);
        let (c1, c2) = (pair[0] as usize, pair[1] as usize);
        let (n1, n2) = (next_corner(c1), next_corner(c2));
        if tris[c1 / 3][c1 % 3] == tris[c2 / 3][c2 % 3] {
            sets.union(c1 as u32, c2 as u32);
            sets.union(n1 as u32, n2 as u32);
        } else {
            sets.union(c1 as u32, n2 as u32);
            sets.union(n1 as u32, c2 as u32);
        }
    }
    (0..sets.len() as u32).map(|c| sets.find(c)).collect()
}

/// Corners whose face still shares both end copies with an earlier corner
/// of the same undirected edge without being joined to it there (the output
/// would have an edge of more than two faces), with their edge.
pub(super) fn shared_ends(
    edges: &EdgeTable,
    state: &[EdgeState],
    roots: &[u32],
) -> Vec<(usize, usize)> {
    let mut shared = Vec::new();
    let mut ends: Vec<(u32, u32, u32)> = Vec::new();
    for k in 0..edges.undirected() {
        let corners = edges.edge_corners(k);
        // One face, or two joined: nothing to share.
        let joined = |c: u32| state[edges.edge_of[c as usize] as usize] == EdgeState::Joined;
        if corners.len() < 2 || (corners.len() == 2 && joined(corners[0])) {
            continue;
        }
        ends.clear();
        for &c in corners {
            let (x, y) = (roots[c as usize], roots[next_corner(c as usize)]);
            ends.push((x.min(y), x.max(y), c));
        }
        ends.sort_unstable();
        for w in ends.windows(2) {
            let (e, f) = (
                edges.edge_of[w[0].2 as usize],
                edges.edge_of[w[1].2 as usize],
            );
            let joined = e == f && state[e as usize] == EdgeState::Joined;
            if (w[0].0, w[0].1) == (w[1].0, w[1].1) && !joined {
                shared.push((k, w[1].2 as usize));
            }
        }
    }
    shared
}

/// Counts the edges split (some face not joined across them) and paired
/// (split into sheets, and at least one of them joined).
pub(super) fn count_edges(edges: &EdgeTable, state: &[EdgeState], report: &mut CleanReport) {
    for k in 0..edges.undirected() {
        if edges.edge_corners(k).len() < 2 {
            continue;
        }
        let joined = edges
            .sheets(k)
            .filter(|&e| state[e] == EdgeState::Joined)
            .count();
        report.paired_edges += usize::from(joined > 0 && edges.sheets(k).len() > 1);
        report.split_edges += usize::from(edges.sheets(k).any(|e| state[e] != EdgeState::Joined));
    }
}
