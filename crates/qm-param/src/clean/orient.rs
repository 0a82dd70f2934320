//! Step 5 of the clean-up: faces oriented greedily, breadth first, each
//! sheet joined where its two faces can agree and cut where they cannot.

use std::collections::VecDeque;

use super::edges::EdgeTable;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum EdgeState {
    /// One face: a boundary edge, or a face left alone on an edge of more.
    Boundary,
    /// Two faces, not yet decided.
    Open,
    /// Two faces joined with agreeing orientations.
    Joined,
    /// Shared by faces that are not joined across it.
    Cut,
}

/// Step 5: greedy breadth-first orientation. Returns whether each face is
/// flipped relative to the input, and each sheet's state.
pub(super) fn orient(tris: &[[u32; 3]], edges: &EdgeTable) -> (Vec<bool>, Vec<EdgeState>) {
    let mut state: Vec<EdgeState> = (0..edges.count())
        .map(|e| match edges.corners(e).len() {
            1 => EdgeState::Boundary,
            2 => EdgeState::Open,
            _ => EdgeState::Cut,
        })
        .collect();
    let mut flip = vec![false; tris.len()];
    let mut seen = vec![false; tris.len()];
    let mut queue = VecDeque::new();
    for seed in 0..tris.len() {
        if seen[seed] {
            continue;
        }
        seen[seed] = true;
        queue.push_back(seed);
        while let Some(f) = queue.pop_front() {
            for i in 0..3 {
                let c = 3 * f + i;
                let e = edges.edge_of[c] as usize;
                if state[e] != EdgeState::Open {
                    continue;
                }
                let pair = edges.corners(e);
                let other = if pair[0] as usize == c {
                    pair[1]
                } else {
                    pair[0]
                } as usize;
                let g = other / 3;
                // Both faces run the edge the same way in the input.
                let same = tris[f][i] == tris[g][other % 3];
                if !seen[g] {
                    seen[g] = true;
                    flip[g] = flip[f] ^ same;
                    queue.push_back(g);
                    state[e] = EdgeState::Joined;
                } else if !same ^ flip[f] ^ flip[g] {
                    state[e] = EdgeState::Joined;
                } else {
                    state[e] = EdgeState::Cut;
                }
            }
        }
    }
    (flip, state)
}
