//! Laying a disk's boundary on the square's perimeter.
//!
//! Main items: [`Segment`] (a run of the boundary loop between two nodes),
//! [`segments`], which finds them and pairs the two sides of each cut,
//! [`allocate`], which gives each a whole number of the perimeter's `4k`
//! base edges, and [`layout`], the smallest square that holds them.
//!
//! Each group (a real boundary's segment, or a cut's two sides) starts at
//! its least count (2 base edges, 3 for a loop), and the rest goes one
//! base edge at a time to the group furthest below its share,
//! `4k * length / total - count`. Point `p` of the perimeter (in base edges
//! counter-clockwise from the lower left corner) is on side `floor(p / k)`,
//! at `(p mod k) / k` along it ([`perimeter_point`]).

use qm_lift::glam::DVec2;

use crate::remesh::cut::Disk;
use crate::{Error, RemeshFailure, Result};

/// A run of the boundary loop between two nodes.
#[derive(Clone, Debug)]
pub struct Segment {
    /// First boundary index.
    pub start: usize,
    /// Number of boundary edges.
    pub len: usize,
    /// The other side of the same cut, or `None` for a real boundary.
    pub mate: Option<usize>,
    /// Base edges along the perimeter.
    pub count: usize,
    /// Perimeter position (in base edges from the lower left corner,
    /// counter-clockwise) where the segment starts.
    pub at: usize,
    /// It ends on the vertex it starts on (a hole's whole rim, or a loop of
    /// the cut graph).
    pub closed: bool,
}

/// Point on the unit square's perimeter at `p` base edges of `4k`.
pub fn perimeter_point(p: f64, k: usize) -> DVec2 {
    let k = k as f64;
    let p = p.rem_euclid(4.0 * k);
    let (side, t) = ((p / k).floor(), (p % k) / k);
    match side as u32 {
        0 => DVec2::new(t, 0.0),
        1 => DVec2::new(1.0, t),
        2 => DVec2::new(1.0 - t, 1.0),
        _ => DVec2::new(0.0, 1.0 - t),
    }
}

/// Splits the boundary into segments and finds mates.
pub fn segments(disk: &Disk) -> Vec<Segment> {
    let n = disk.boundary.len();
    // Degree of each mesh vertex in the cut graph (cuts and real boundaries).
    let mut degree: std::collections::HashMap<u32, u32> = std::collections::HashMap::new();
    let mut distinct = std::collections::HashSet::new();
    for (k, &(e, _)) in disk.boundary_edges.iter().enumerate() {
        if distinct.insert(e) {
            for v in [disk.boundary[k], disk.boundary[(k + 1) % n]] {
                *degree.entry(disk.origin[v as usize]).or_default() += 1;
            }
        }
    }
    let is_node = |k: usize| {
        let v = disk.origin[disk.boundary[k] as usize];
        let before = disk.boundary_edges[(k + n - 1) % n].1;
        let after = disk.boundary_edges[k].1;
        degree.get(&v).copied().unwrap_or(0) != 2 || before != after
    };
    let nodes: Vec<usize> = (0..n).filter(|&k| is_node(k)).collect();
    let nodes = if nodes.is_empty() { vec![0] } else { nodes };
    let mut segs: Vec<Segment> = nodes
        .iter()
        .enumerate()
        .map(|(i, &start)| {
            let end = nodes[(i + 1) % nodes.len()];
            let len = (end + n - start - 1) % n + 1;
            let vertex = |k: usize| disk.origin[disk.boundary[k] as usize];
            Segment {
                start,
                len,
                mate: None,
                count: 0,
                at: 0,
                closed: vertex(start) == vertex(end),
            }
        })
        .collect();
    // Mates: the segment holding the other occurrence of a segment's first edge.
    let mut seg_of = vec![0usize; n];
    for (s, seg) in segs.iter().enumerate() {
        for j in 0..seg.len {
            seg_of[(seg.start + j) % n] = s;
        }
    }
    let mut first: std::collections::HashMap<u32, usize> = std::collections::HashMap::new();
    for (k, &(e, is_cut)) in disk.boundary_edges.iter().enumerate() {
        if !is_cut {
            continue;
        }
        match first.get(&e) {
            None => {
                first.insert(e, k);
            }
            Some(&other) => {
                let (a, b) = (seg_of[other], seg_of[k]);
                segs[a].mate = Some(b);
                segs[b].mate = Some(a);
            }
        }
    }
    segs
}

/// Lays `segments` out on a perimeter of `4k` base edges. Returns `false`
/// when `k` is too small for them.
pub fn allocate(segs: &mut [Segment], lengths: &[f64], k: usize, leaves: &[usize]) -> bool {
    // Two base edges at least: with one, both ends of a cut side could glue
    // onto one base edge twice. Three for a loop (a hole's whole rim, a loop
    // of the cut): with two, its two base edges would join the same two base
    // vertices, which the base mesh takes for one edge.
    let min = |s: usize| if segs[s].closed { 3 } else { 2 };
    let units = 4 * k;
    // Groups: a cut's two sides share one count.
    let groups: Vec<usize> = (0..segs.len())
        .filter(|&s| segs[s].mate.is_none_or(|m| m > s))
        .collect();
    let weight = |s: usize| if segs[s].mate.is_some() { 2 } else { 1 };
    let total: f64 = groups.iter().map(|&s| weight(s) as f64 * lengths[s]).sum();
    // Everyone starts at the minimum; the rest goes by length below.
    let mut count: Vec<usize> = groups.iter().map(|&s| min(s)).collect();
    let used = |count: &[usize]| {
        groups
            .iter()
            .zip(count)
            .map(|(&s, &c)| weight(s) * c)
            .sum::<usize>()
    };
    if used(&count) > units {
        return false;
    }
    // Hand out what is left to the groups furthest below their share.
    while used(&count) < units {
        let left = units - used(&count);
        let best = (0..groups.len())
            .filter(|&g| weight(groups[g]) <= left)
            .max_by(|&a, &b| {
                let deficit =
                    |g: usize| lengths[groups[g]] / total * units as f64 - count[g] as f64;
                deficit(a).total_cmp(&deficit(b))
            });
        match best {
            Some(g) => count[g] += 1,
            None => return false,
        }
    }
    for (g, &s) in groups.iter().enumerate() {
        segs[s].count = count[g];
        if let Some(m) = segs[s].mate {
            segs[m].count = count[g];
        }
    }
    // Rotate so that no leaf of the cut graph lands on a square corner,
    // where one base quad would have two of its sides glued together.
    let mut starts = Vec::with_capacity(segs.len());
    let mut p = 0;
    for s in segs.iter() {
        starts.push(p);
        p += s.count;
    }
    let shift = (0..units).find(|&r| leaves.iter().all(|&s| (starts[s] + r) % k != 0));
    let Some(shift) = shift else { return false };
    for (s, seg) in segs.iter_mut().enumerate() {
        seg.at = (starts[s] + shift) % units;
    }
    true
}

/// The disk's boundary segments laid out on the smallest square of at least
/// `k_min` base quads a side that holds them, with their lengths.
pub(super) fn layout(disk: &Disk, k_min: usize) -> Result<(usize, Vec<Segment>, Vec<f64>)> {
    let n = disk.boundary.len();
    let mut segs = segments(disk);
    let lengths: Vec<f64> = segs
        .iter()
        .map(|s| {
            (0..s.len)
                .map(|j| {
                    let a = disk.boundary[(s.start + j) % n] as usize;
                    let b = disk.boundary[(s.start + j + 1) % n] as usize;
                    disk.positions[a].distance(disk.positions[b])
                })
                .sum()
        })
        .collect();
    // A segment starts at a leaf node when the segment before it is its mate.
    let leaves: Vec<usize> = (0..segs.len())
        .filter(|&s| segs[(s + segs.len() - 1) % segs.len()].mate == Some(s))
        .collect();
    let mut k = k_min.max(1);
    while !allocate(&mut segs, &lengths, k, &leaves) {
        k += 1;
        if k > 4096 {
            return Err(Error::remesh(RemeshFailure::TooManySegments));
        }
    }
    Ok((k, segs, lengths))
}

/// Moves the boundary vertex nearest each corner of the square onto it, so
/// that no triangle cuts the corner off and every grid point is covered.
/// Nodes stay where they are (they already sit on base vertices).
pub(super) fn snap_corners(disk: &Disk, segs: &[Segment], k: usize, uv: &mut [DVec2]) {
    let n = disk.boundary.len();
    let corners = [DVec2::ZERO, DVec2::X, DVec2::ONE, DVec2::Y];
    for corner in corners {
        let mut best: Option<(f64, usize)> = None;
        for seg in segs {
            // Interior vertices of the segment only: its ends are nodes.
            for j in 1..seg.len {
                let v = disk.boundary[(seg.start + j) % n] as usize;
                let d = uv[v].distance_squared(corner);
                if best.is_none_or(|(bd, _)| d < bd) {
                    best = Some((d, v));
                }
            }
        }
        let is_node_at_corner = segs
            .iter()
            .any(|s| uv[disk.boundary[s.start] as usize].distance_squared(corner) < 1e-24);
        if let (Some((d, v)), false) = (best, is_node_at_corner) {
            // Only a vertex on one of the corner's two sides can move there
            // without crossing another boundary vertex.
            if d < (1.0 / k as f64).powi(2) {
                uv[v] = corner;
            }
        }
    }
}
