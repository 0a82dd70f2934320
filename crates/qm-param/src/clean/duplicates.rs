//! Steps 2 and 3 of the clean-up: bit-identical vertices merged, then
//! degenerate and duplicate triangles dropped, and the opposite pairs of
//! zero-thickness sheets cancelled where they meet other faces.
//!
//! Triangles on one vertex set cancel in pairs that run opposite ways, as
//! in a sum of oriented faces; a patch of such pairs that meets two or more
//! other faces at some edge (a thin part collapsed to zero thickness, or
//! the wall where two parts touch face to face) goes whole, else one face
//! per vertex set stays (docs/decisions/022-clean-up-sheets.md).

use qm_lift::glam::DVec3;

use super::edges::edge_key;
use super::report::CleanReport;
use crate::union_find::UnionFind;

/// Step 2: merges bit-identical positions. Returns the new index of every
/// input vertex and the unique positions, in order of first occurrence.
pub(super) fn merge_identical(positions: &[DVec3]) -> (Vec<u32>, Vec<DVec3>) {
    let mut keyed: Vec<([u64; 3], u32)> = positions
        .iter()
        .enumerate()
        .map(|(i, p)| ([p.x.to_bits(), p.y.to_bits(), p.z.to_bits()], i as u32))
        .collect();
    keyed.sort_unstable();
    // Sorted by (key, index): the first of each run is its smallest index.
    let mut first = vec![0u32; positions.len()];
    let mut run = 0;
    for k in 0..keyed.len() {
        if keyed[k].0 != keyed[run].0 {
            run = k;
        }
        first[keyed[k].1 as usize] = keyed[run].1;
    }
    let mut remap = vec![0u32; positions.len()];
    let mut unique = Vec::new();
    for i in 0..positions.len() {
        let f = first[i] as usize;
        if f == i {
            remap[i] = unique.len() as u32;
            unique.push(positions[i]);
        } else {
            remap[i] = remap[f];
        }
    }
    (remap, unique)
}

/// Step 3: renumbers and drops degenerate and duplicate triangles, and
/// (with `cancel`) cancels attached zero-thickness sheets (see the module
/// documentation).
pub(super) fn drop_bad_triangles(
    tris: Vec<[u32; 3]>,
    remap: &[u32],
    positions: &[DVec3],
    cancel: bool,
    report: &mut CleanReport,
) -> Vec<[u32; 3]> {
    let mut kept = Vec::with_capacity(tris.len());
    for t in tris {
        let [a, b, c] = t.map(|v| remap[v as usize]);
        let [pa, pb, pc] = [a, b, c].map(|v| positions[v as usize]);
        if a == b || b == c || a == c || (pb - pa).cross(pc - pa) == DVec3::ZERO {
            report.dropped_degenerate += 1;
        } else {
            kept.push([a, b, c]);
        }
    }
    let mut keyed: Vec<([u32; 3], u32)> = kept
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let mut s = *t;
            s.sort_unstable();
            (s, i as u32)
        })
        .collect();
    keyed.sort_unstable();
    // Whether a triangle's corners are a rotation of their sorted order.
    let even = |t: &[u32; 3]| (t[0] < t[1]) as u8 + (t[1] < t[2]) as u8 + (t[2] < t[0]) as u8 == 2;
    let mut keep = vec![false; kept.len()];
    // Per vertex set, triangles cancel in opposite pairs: the first pair
    // stands for them (both kept for now), and of the orientation left over
    // one triangle is kept; the rest are duplicates.
    let mut twins: Vec<Twins> = Vec::new();
    for run in keyed.chunk_by(|x, y| x.0 == y.0) {
        if let [(_, f)] = run {
            keep[*f as usize] = true;
            continue;
        }
        // The run's triangles of one orientation, in order.
        let kept = &kept;
        let of = |ab: bool| {
            run.iter()
                .map(|x| x.1)
                .filter(move |&f| even(&kept[f as usize]) == ab)
        };
        let (n_ab, n_ba) = (of(true).count(), of(false).count());
        let pairs = n_ab.min(n_ba);
        let left =
            (n_ab != n_ba).then(|| of(n_ab > n_ba).nth(pairs).expect("a triangle left over"));
        if let (Some(f), Some(g)) = (of(true).next(), of(false).next()) {
            twins.push(Twins { pair: [f, g], left });
            keep[f as usize] = true;
            keep[g as usize] = true;
        }
        if let Some(l) = left {
            keep[l as usize] = true;
        }
        report.dropped_duplicate += run.len() - 2 * pairs.min(1) - usize::from(left.is_some());
    }
    cancel_sheets(&kept, &twins, &mut keep, cancel, report);
    let mut i = 0;
    kept.retain(|_| {
        i += 1;
        keep[i - 1]
    });
    kept
}

/// The triangles of one vertex set that run both ways: the first of each
/// orientation, and the one left over when the orientations do not balance.
struct Twins {
    pair: [u32; 2],
    left: Option<u32>,
}

/// Cancels the opposite pairs (`twins`) of every patch of such pairs (pairs
/// sharing edges) that meets two or more other faces at some edge: a thin
/// part collapsed to zero thickness, or the wall where two parts touch face
/// to face, whose rim would otherwise have four faces to an edge. A patch
/// that meets at most one other face at each edge (a free two-sided sheet,
/// or a face stored again, reversed, on a surface) keeps one face per
/// vertex set instead: the one left over if any, else one of the pair.
/// Without `cancel`, the pairs of the patches that would cancel stay.
fn cancel_sheets(
    tris: &[[u32; 3]],
    twins: &[Twins],
    keep: &mut [bool],
    cancel: bool,
    report: &mut CleanReport,
) {
    if twins.is_empty() {
        return;
    }
    const NONE: u32 = u32::MAX;
    let mut pair_of = vec![NONE; tris.len()];
    for (p, t) in twins.iter().enumerate() {
        for f in t.pair.into_iter().chain(t.left) {
            pair_of[f as usize] = p as u32;
        }
    }
    let mut edges: Vec<(u64, u32)> = Vec::with_capacity(3 * tris.len());
    for (f, t) in tris.iter().enumerate() {
        if keep[f] {
            for i in 0..3 {
                edges.push((edge_key(t[i], t[(i + 1) % 3]), pair_of[f]));
            }
        }
    }
    edges.sort_unstable();
    let mut sets = UnionFind::new(twins.len());
    // Per pair: meets more than one other face at some edge.
    let mut many = vec![false; twins.len()];
    for run in edges.chunk_by(|x, y| x.0 == y.0) {
        // Sorted by pair, the faces of no pair last.
        let p = run[0].1;
        if p == NONE {
            continue;
        }
        for &(_, q) in run.iter().take_while(|x| x.1 != NONE) {
            sets.union(p, q);
        }
        many[p as usize] |= run.iter().filter(|x| x.1 == NONE).count() > 1;
    }
    for p in 0..twins.len() {
        let root = sets.find(p as u32) as usize;
        many[root] |= many[p];
    }
    for (p, t) in twins.iter().enumerate() {
        let root = sets.find(p as u32) as usize;
        let [f, g] = t.pair;
        if many[root] && !cancel {
            // Both faces stay, for the pairing to place; a third copy goes.
            if let Some(l) = t.left {
                keep[l as usize] = false;
                report.dropped_duplicate += 1;
            }
            continue;
        }
        keep[g as usize] = false;
        if many[root] {
            keep[f as usize] = false;
            report.cancelled_faces += 2;
        } else if t.left.is_some() {
            keep[f as usize] = false;
            report.dropped_duplicate += 2;
        } else {
            report.dropped_duplicate += 1;
        }
    }
}
