//! Parameterizing a disk over the unit square.
//!
//! The disk's boundary loop is split into *segments* at its nodes (cut-graph
//! branch points and ends, and where a cut meets a real boundary). The square's
//! perimeter is divided into `4K` base edges (`K` per side) and each segment
//! gets a whole number of them, in proportion to its length; the two sides of
//! a cut get the same number, so that gluing them matches sample to sample.
//! Boundary vertices sit on the perimeter by arc length within their segment.
//!
//! The interior follows Floater's mean-value coordinates (each vertex the
//! weighted mean of its neighbours, weights `(tan(a/2) + tan(b/2)) / |e|`),
//! one sparse linear solve for `u` and `v` (see [`System`] for how).
//! Positive weights and a convex boundary guarantee an embedding (Tutte,
//! Floater). The weights
//! are then divided by each neighbour's L2 stretch and the system solved again
//! (Yoshizawa, Belyaev and Seidel 2004), which spreads the samples more evenly
//! over the surface: the best of the iterations is kept. The stretch is
//! weighted by a per-triangle sample density (Sander, Gortler, Snyder and
//! Hoppe's signal-specialized stretch, 2002), so that the samples crowd where
//! the surface bends and thin out where it is flat.
//!
//! The solves of one disk share the matrix pattern and its symbolic
//! factorization; each square size keeps its numeric storage across its
//! reweightings, and the sizes tried run in parallel.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::matrix_free::bicgstab::{BicgParams, bicgstab, bicgstab_scratch};
use faer::matrix_free::{IdentityPrecond, LinOp, Precond};
use faer::sparse::linalg::cholesky::LltRef;
use faer::sparse::linalg::cholesky::{SymmetricOrdering, factorize_symbolic_cholesky};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Mat, MatMut, MatRef, Par, Side};
use qm_lift::glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::cut::Disk;
use crate::{Error, RemeshFailure, Result};

/// Smallest relative stretch improvement worth another reweighting (each is
/// a sparse factorization) (docs/decisions/013-square-map.md).
const STRETCH_GAIN: f64 = 0.02;

/// Systems with fewer unknowns are solved by a sparse LU (module `lu`);
/// larger ones by BiCGSTAB with a Cholesky preconditioner (see [`System`]).
const LU_BELOW: usize = 100_000;

/// A disk's symbolic factorization, of the kind its size asks for.
pub enum Symbolic {
    Lu(super::lu::Symbolic),
    Cholesky(faer::sparse::linalg::cholesky::SymbolicCholesky<usize>),
}

/// Most BiCGSTAB iterations per solve (see [`System`]).
const REFINEMENTS: usize = 200;

/// Relative residual at which BiCGSTAB stops.
const REFINED: f64 = 1e-8;

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

/// A disk laid out over the square.
pub struct SquareMap {
    /// Base quads per side.
    pub k: usize,
    /// Parameter coordinates in `[0, 1]^2` of every disk vertex.
    pub uv: Vec<DVec2>,
    /// Boundary segments.
    pub segments: Vec<Segment>,
    /// Area- and density-weighted L2 stretch of the map (1 = samples spread
    /// exactly as the density asks).
    pub stretch: f64,
    /// Per disk vertex density-weighted L2 stretch.
    pub vertex_stretch: Vec<f64>,
    /// Triangles with negative parameter area (folds).
    pub flipped: usize,
    /// Per disk vertex, the product of its stretches over the reweightings
    /// that led to this map: the mean-value weight towards a vertex was
    /// divided by it. Another square size can start from it.
    pub divisor: Vec<f64>,
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

/// Parameterizes `disk` over the unit square with at least `k_min` base
/// quads per side. A larger square lets the perimeter follow the segments'
/// lengths more closely, so `k_min`, twice and four times it (up to 16, and
/// up to `k_max`) are tried (in parallel) and the lowest stretch wins.
/// `density` is the sample density to aim for per disk triangle
/// (area-weighted mean 1).
pub fn parameterize(
    disk: &Disk,
    density: &[f64],
    k_min: usize,
    k_max: usize,
    iterations: usize,
) -> Result<SquareMap> {
    let first = layout(disk, k_min)?.0;
    let mut sizes = vec![first];
    let mut k = first;
    while 2 * k <= 16.max(k_min).min(k_max) && k < 16 {
        k *= 2;
        sizes.push(k);
    }
    // The sizes are independent: solve them in parallel, pick in order.
    let maps: Vec<Result<SquareMap>> = sizes
        .par_iter()
        .map(|&k| parameterize_k(disk, density, k, iterations, None))
        .collect();
    let mut maps = maps.into_iter();
    let mut best = maps.next().expect("at least one size")?;
    for trial in maps {
        let trial = trial?;
        if clearly_better(&trial, &best) {
            best = trial;
        }
    }
    Ok(best)
}

/// Whether map `a` is clearly better than map `b`: fewer folds, or as many
/// and an L2 stretch at least 2% lower (of the whole stretch, not of its
/// excess over 1). A larger square or an extra cut has costs the stretch
/// does not show (more base quads, more seams), so a sliver of stretch does
/// not pay for them (docs/decisions/013-square-map.md). A NaN stretch is
/// never better.
pub(super) fn clearly_better(a: &SquareMap, b: &SquareMap) -> bool {
    lower((a.flipped, a.stretch), (b.flipped, b.stretch))
}

/// [`clearly_better`] on `(folds, stretch)` pairs.
fn lower(a: (usize, f64), b: (usize, f64)) -> bool {
    a < (b.0, 0.98 * b.1)
}

/// The disk's boundary segments laid out on the smallest square of at least
/// `k_min` base quads a side that holds them, with their lengths.
fn layout(disk: &Disk, k_min: usize) -> Result<(usize, Vec<Segment>, Vec<f64>)> {
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

/// [`parameterize`] with `k_min` base quads per side at least, then
/// `iterations` stretch-reweighting steps. With `start` (the
/// [`SquareMap::divisor`] of a map of the same disk), the weights start
/// reweighted as they ended there.
pub fn parameterize_k(
    disk: &Disk,
    density: &[f64],
    k_min: usize,
    iterations: usize,
    start: Option<&[f64]>,
) -> Result<SquareMap> {
    parameterize_with(disk, density, k_min, iterations, start, LU_BELOW)
}

/// [`parameterize_k`], by LU below `lu_below` unknowns (see [`System`]).
fn parameterize_with(
    disk: &Disk,
    density: &[f64],
    k_min: usize,
    iterations: usize,
    start: Option<&[f64]>,
    lu_below: usize,
) -> Result<SquareMap> {
    let n = disk.boundary.len();
    let (k, segs, lengths) = layout(disk, k_min)?;
    // Boundary positions by arc length within each segment.
    let mut uv = vec![DVec2::ZERO; disk.positions.len()];
    let mut fixed = vec![false; disk.positions.len()];
    for (s, seg) in segs.iter().enumerate() {
        let mut walked = 0.0;
        for j in 0..seg.len {
            let v = disk.boundary[(seg.start + j) % n] as usize;
            let t = if lengths[s] > 0.0 {
                walked / lengths[s]
            } else {
                j as f64 / seg.len as f64
            };
            uv[v] = perimeter_point(seg.at as f64 + t * seg.count as f64, k);
            fixed[v] = true;
            let w = disk.boundary[(seg.start + j + 1) % n] as usize;
            walked += disk.positions[v].distance(disk.positions[w]);
        }
    }
    snap_corners(disk, &segs, k, &mut uv);
    let weights = mean_value_weights(disk);
    let mut divisor = match start {
        Some(d) => d.to_vec(),
        None => vec![1.0; disk.positions.len()],
    };
    let mut system = System::new(disk, &weights, &fixed, lu_below);
    let mut best: Option<SquareMap> = None;
    for _ in 0..=iterations {
        if let Err(e) = system.solve(&weights, &divisor, &mut uv) {
            // Reweighting spreads the weights over many orders of magnitude
            // (up to 1e10 on the bunny); far beyond that the factorization
            // loses definiteness to rounding. Keep the best map so far, or
            // start over from the plain weights.
            if best.is_some() {
                break;
            }
            if divisor.iter().all(|&d| d == 1.0) {
                return Err(e);
            }
            divisor.fill(1.0);
            system.solve(&weights, &divisor, &mut uv)?;
        }
        let (stretch, vertex_stretch, flipped) = stretch(disk, density, &uv);
        let previous = best.as_ref().map(|b| (b.flipped, b.stretch));
        if previous.is_none_or(|p| (flipped, stretch) < p) {
            best = Some(SquareMap {
                k,
                uv: uv.clone(),
                segments: segs.clone(),
                stretch,
                vertex_stretch: vertex_stretch.clone(),
                flipped,
                divisor: divisor.clone(),
            });
        }
        // Each iteration is a sparse factorization: stop once it stops paying.
        if previous.is_some_and(|(f, s)| flipped >= f && stretch > s * (1.0 - STRETCH_GAIN)) {
            break;
        }
        // Yoshizawa et al.: divide each weight by the stretch at its far end.
        for (d, s) in divisor.iter_mut().zip(&vertex_stretch) {
            *d *= s.max(1e-12);
        }
    }
    Ok(best.expect("at least one solve"))
}

/// Moves the boundary vertex nearest each corner of the square onto it, so
/// that no triangle cuts the corner off and every grid point is covered.
/// Nodes stay where they are (they already sit on base vertices).
fn snap_corners(disk: &Disk, segs: &[Segment], k: usize, uv: &mut [DVec2]) {
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

/// Floater's mean-value weights of each vertex's neighbours,
/// `(i, [(j, w_ij)])` with `w_ij = (tan(a/2) + tan(b/2)) / |e|`, the angles
/// at `i`. Degenerate corners give zero or non-finite weights: a tiny
/// positive one instead, relative to the disk's weights, keeps the system
/// definite without moving anything.
fn mean_value_weights(disk: &Disk) -> Vec<Vec<(u32, f64)>> {
    let mut w: Vec<Vec<(u32, f64)>> = vec![Vec::new(); disk.positions.len()];
    let mut add = |i: u32, j: u32, x: f64| {
        let row = &mut w[i as usize];
        match row.iter_mut().find(|(k, _)| *k == j) {
            Some((_, v)) => *v += x,
            None => row.push((j, x)),
        }
    };
    for t in &disk.triangles {
        for c in 0..3 {
            let (i, j, k) = (t[c], t[(c + 1) % 3], t[(c + 2) % 3]);
            let p = |v: u32| disk.positions[v as usize];
            let (a, b) = (p(j) - p(i), p(k) - p(i));
            let (la, lb) = (a.length(), b.length());
            let angle = a.angle_between(b);
            let half_tan = (angle / 2.0).tan();
            add(i, j, half_tan / la);
            add(i, k, half_tan / lb);
        }
    }
    let (sum, count) = w
        .iter()
        .flatten()
        .filter(|(_, x)| x.is_finite() && *x > 0.0)
        .fold((0.0, 0usize), |(s, n), (_, x)| (s + x, n + 1));
    let floor = 1e-12 * if count > 0 { sum / count as f64 } else { 1.0 };
    for (_, x) in w.iter_mut().flatten() {
        if !(x.is_finite() && *x > 0.0) {
            *x = floor;
        }
    }
    w
}

/// The symmetric part of `weights`, `(w_ij + w_ji) / 2`: still positive,
/// and with the stretch divisors a positive definite system (see
/// [`System`]). Every triangle adds both directions of its edges, so each
/// entry has its mirror; the sum is commutative, so the two halves come out
/// bit-identical.
fn symmetrized(weights: &[Vec<(u32, f64)>]) -> Vec<Vec<(u32, f64)>> {
    let mirror = |i: usize, j: u32| -> f64 {
        weights[j as usize]
            .iter()
            .find(|&&(k, _)| k as usize == i)
            .map_or(0.0, |&(_, x)| x)
    };
    (0..weights.len())
        .map(|i| {
            weights[i]
                .iter()
                .map(|&(j, x)| (j, (x + mirror(i, j)) / 2.0))
                .collect()
        })
        .collect()
}

/// The sparse system of one disk's parameterization: the interior vertices
/// are the unknowns, the boundary vertices fixed.
///
/// Row `i` asks `sum_j a_ij (u_i - u_j) = 0` with `a_ij = w_ij / d_j`: the
/// mean-value weights `w` divided by the far end's accumulated stretch `d`.
/// Scaling row `i` by `1 / d_i` leaves the solution alone and gives
/// `w_ij / (d_i d_j)`, whose symmetric part (`w` symmetrized) is a
/// Dirichlet Laplacian, positive definite.
///
/// Below [`LU_BELOW`] unknowns a sparse LU solves the system directly,
/// without pivoting (the matrix is an M-matrix) on the Cholesky structure
/// of its symmetric pattern (module `lu`). Above, the symmetric part's
/// sparse Cholesky factorization (AMD ordering) preconditions BiCGSTAB on
/// the mean-value system itself, which converges in a few iterations. The
/// symmetric solution alone would not do: without the mean-value weights'
/// linear precision flat parts are sampled unevenly
/// (docs/decisions/013-square-map.md).
///
/// For the Cholesky factorization only the lower triangle is stored. The
/// pattern is built once; every solve refills the values and reuses the
/// disk's symbolic factorization and this system's factor storage and
/// factorization scratch (the BiCGSTAB vectors are allocated per solve).
struct System<'a> {
    disk: &'a Disk,
    /// The unknown of each disk vertex (`u32::MAX` for fixed ones).
    index: Vec<u32>,
    /// Column pointers and row indices of the matrix (of its lower triangle
    /// for the Cholesky factorization).
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// Per vertex, where its weight row starts in `slot`.
    row_start: Vec<usize>,
    /// Value position of each weight: `usize::MAX` for fixed neighbours
    /// and for the upper triangle (the mirror entry carries it).
    slot: Vec<usize>,
    /// Value position of each unknown's diagonal.
    diagonal: Vec<usize>,
    values: Vec<f64>,
    /// Small systems: an LU of the mean-value system itself, and its
    /// factors.
    lu: bool,
    numeric: super::lu::Numeric,
    /// Large ones: the Cholesky factor of its symmetric part, made from
    /// the symmetrized weights.
    factor: Vec<f64>,
    symmetric: Option<Vec<Vec<(u32, f64)>>>,
    scratch: Option<MemBuffer>,
}

impl<'a> System<'a> {
    fn new(disk: &'a Disk, weights: &[Vec<(u32, f64)>], fixed: &[bool], lu_below: usize) -> Self {
        let n = disk.positions.len();
        let mut index = vec![u32::MAX; n];
        let mut free = 0u32;
        for v in 0..n {
            if !fixed[v] {
                index[v] = free;
                free += 1;
            }
        }
        let lu = (free as usize) < lu_below;
        // Entries as (column, row, key): key < slot count for a weight,
        // above it for a diagonal. For the Cholesky factorization only the
        // lower triangle, row > column.
        let mut row_start = Vec::with_capacity(n + 1);
        let mut entries = Vec::new();
        let mut keys = 0usize;
        for v in 0..n {
            row_start.push(keys);
            for &(j, _) in &weights[v] {
                let (r, c) = (index[v], index[j as usize]);
                if r != u32::MAX && c != u32::MAX && (r > c || lu) {
                    entries.push((c as usize, r as usize, keys));
                }
                keys += 1;
            }
        }
        row_start.push(keys);
        for r in 0..free as usize {
            entries.push((r, r, keys + r));
        }
        entries.sort_unstable();
        let free = free as usize;
        let mut col_ptr = vec![0usize; free + 1];
        let mut row_idx = Vec::with_capacity(entries.len());
        let mut slot = vec![usize::MAX; keys];
        let mut diagonal = vec![0usize; free];
        for (position, &(col, row, key)) in entries.iter().enumerate() {
            col_ptr[col + 1] += 1;
            row_idx.push(row);
            if key < keys {
                slot[key] = position;
            } else {
                diagonal[key - keys] = position;
            }
        }
        for c in 0..free {
            col_ptr[c + 1] += col_ptr[c];
        }
        System {
            disk,
            index,
            values: vec![0.0; row_idx.len()],
            col_ptr,
            row_idx,
            row_start,
            slot,
            diagonal,
            lu,
            numeric: Default::default(),
            factor: Vec::new(),
            symmetric: (!lu).then(|| symmetrized(weights)),
            scratch: None,
        }
    }

    /// Solves for the free vertices' `uv` given the fixed ones: the system
    /// of the mean-value `weights` divided by `divisor` at the far end.
    fn solve(
        &mut self,
        weights: &[Vec<(u32, f64)>],
        divisor: &[f64],
        uv: &mut [DVec2],
    ) -> Result<()> {
        let free = self.diagonal.len();
        if free == 0 {
            return Ok(());
        }
        if self.lu {
            self.solve_lu(weights, divisor, uv)
        } else {
            self.solve_cholesky(weights, divisor, uv)
        }
    }

    /// Fills the matrix entries (those the pattern holds) from `weights`,
    /// each divided by `divisor(i, j)`, and returns the right-hand side,
    /// the fixed neighbours' pull.
    fn fill(
        &mut self,
        weights: &[Vec<(u32, f64)>],
        divisor: impl Fn(usize, usize) -> f64,
        uv: &[DVec2],
    ) -> Mat<f64> {
        let mut rhs = Mat::<f64>::zeros(self.diagonal.len(), 2);
        for (v, row) in weights.iter().enumerate() {
            let r = self.index[v];
            if r == u32::MAX {
                continue;
            }
            let r = r as usize;
            let mut diagonal = 0.0;
            for (key, &(j, w)) in (self.row_start[v]..).zip(row) {
                // Positive: `mean_value_weights` floors the weights, the
                // divisors are stretches (floored too).
                let a = w / divisor(v, j as usize);
                diagonal += a;
                if self.index[j as usize] == u32::MAX {
                    rhs[(r, 0)] += a * uv[j as usize].x;
                    rhs[(r, 1)] += a * uv[j as usize].y;
                } else if self.slot[key] != usize::MAX {
                    self.values[self.slot[key]] = -a;
                }
            }
            self.values[self.diagonal[r]] = diagonal;
        }
        rhs
    }

    /// The disk's symbolic factorization, made by `make` on first use.
    fn symbolic<E: std::fmt::Debug>(
        &self,
        pattern: SymbolicSparseColMatRef<'_, usize>,
        make: impl FnOnce(SymbolicSparseColMatRef<'_, usize>) -> std::result::Result<Symbolic, E>,
    ) -> Result<&'a Symbolic> {
        self.disk
            .symbolic
            .get_or_init(|| make(pattern).map_err(|e| format!("{e:?}")))
            .as_ref()
            .map_err(|e| {
                Error::remesh(RemeshFailure::Step(format!(
                    "factoring the parameterization: {e}"
                )))
            })
    }

    /// A direct LU solve of the mean-value system, row `i` as it is:
    /// `a_ij = w_ij / d_j`.
    fn solve_lu(
        &mut self,
        weights: &[Vec<(u32, f64)>],
        divisor: &[f64],
        uv: &mut [DVec2],
    ) -> Result<()> {
        let free = self.diagonal.len();
        let mut rhs = self.fill(weights, |_, j| divisor[j], uv);
        let pattern =
            SymbolicSparseColMatRef::new_checked(free, free, &self.col_ptr, None, &self.row_idx);
        let symbolic = self.symbolic(pattern, |p| super::lu::Symbolic::new(p).map(Symbolic::Lu))?;
        let Symbolic::Lu(symbolic) = symbolic else {
            unreachable!("a disk's systems all have its size")
        };
        symbolic
            .factorize(&self.values, &mut self.numeric)
            .map_err(|i| {
                Error::remesh(RemeshFailure::Step(format!(
                    "factoring the parameterization: pivot {i}"
                )))
            })?;
        symbolic.solve(&self.numeric, rhs.as_mut());
        write_back(&self.index, &rhs, uv);
        Ok(())
    }

    /// The mean-value system by BiCGSTAB, preconditioned by the Cholesky
    /// factorization of its row-scaled symmetric part, from that part's
    /// own solution.
    fn solve_cholesky(
        &mut self,
        weights: &[Vec<(u32, f64)>],
        divisor: &[f64],
        uv: &mut [DVec2],
    ) -> Result<()> {
        let free = self.diagonal.len();
        let symmetric = self.symmetric.take().expect("made for this path");
        self.fill(&symmetric, |v, j| divisor[v] * divisor[j], uv);
        self.symmetric = Some(symmetric);
        let pattern =
            SymbolicSparseColMatRef::new_checked(free, free, &self.col_ptr, None, &self.row_idx);
        let matrix = SparseColMatRef::new(pattern, &self.values);
        let symbolic = self.symbolic(pattern, |p| {
            factorize_symbolic_cholesky(p, Side::Lower, SymmetricOrdering::Amd, Default::default())
                .map(Symbolic::Cholesky)
        })?;
        let Symbolic::Cholesky(symbolic) = symbolic else {
            unreachable!("a disk's systems all have its size")
        };
        let scratch = self.scratch.get_or_insert_with(|| {
            MemBuffer::new(StackReq::any_of(&[
                symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
                symbolic.solve_in_place_scratch::<f64>(2, Par::Seq),
            ]))
        });
        self.factor.resize(symbolic.len_val(), 0.0);
        let llt = symbolic
            .factorize_numeric_llt(
                &mut self.factor,
                matrix,
                Side::Lower,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(scratch),
                Default::default(),
            )
            .map_err(|e| {
                Error::remesh(RemeshFailure::Step(format!(
                    "factoring the parameterization: {e:?}"
                )))
            })?;
        let (operator, b) = MeanValueSystem::new(weights, divisor, &self.index, uv, free);
        let preconditioner = Preconditioner {
            llt,
            row_sums: &operator.diagonal,
        };
        let mut x = b.clone();
        preconditioner.apply_in_place(x.as_mut(), Par::Seq, MemStack::new(scratch));
        let symmetric_solution = x.clone();
        let identity = IdentityPrecond { dim: free };
        let mut memory = MemBuffer::new(bicgstab_scratch(
            identity,
            &preconditioner,
            &operator,
            2,
            Par::Seq,
        ));
        let params = BicgParams {
            rel_tolerance: REFINED,
            max_iters: REFINEMENTS,
            ..Default::default()
        };
        let solved = bicgstab(
            x.as_mut(),
            identity,
            &preconditioner,
            &operator,
            b.as_ref(),
            params,
            |_| {},
            Par::Seq,
            MemStack::new(&mut memory),
        );
        // Should it not converge, the better of its last iterate and the
        // symmetric solution stays.
        let x = if solved.is_ok()
            || operator.residual(&x, &b) < operator.residual(&symmetric_solution, &b)
        {
            x
        } else {
            symmetric_solution
        };
        write_back(&self.index, &x, uv);
        Ok(())
    }
}

/// Copies the unknowns `x` into the free vertices' `uv`.
fn write_back(index: &[u32], x: &Mat<f64>, uv: &mut [DVec2]) {
    for (v, p) in uv.iter_mut().enumerate() {
        let r = index[v];
        if r != u32::MAX {
            *p = DVec2::new(x[(r as usize, 0)], x[(r as usize, 1)]);
        }
    }
}

/// The free block of the mean-value system with each row divided by its
/// diagonal, `(A x)_i = x_i - sum_j p_ij x_j` over free neighbours `j`,
/// `p_ij = a_ij / sum_k a_ik` with `a_ij = w_ij / (d_i d_j)`, in compact
/// rows. Every row is then a weighted mean, in parameter units, so a small
/// relative residual means every vertex is close, however unevenly the
/// reweighting scaled the rows.
#[derive(Debug)]
struct MeanValueSystem {
    /// Per unknown, where its entries start in `column` and `value`.
    start: Vec<usize>,
    column: Vec<u32>,
    value: Vec<f64>,
    /// Per unknown, the row's sum `sum_k a_ik` it was divided by.
    diagonal: Vec<f64>,
}

impl MeanValueSystem {
    /// The system of `weights` divided by `divisor` at both ends, for the
    /// unknowns `index`, and its right-hand side: the fixed neighbours'
    /// pull `b_i = sum a_ij uv_j`.
    fn new(
        weights: &[Vec<(u32, f64)>],
        divisor: &[f64],
        index: &[u32],
        uv: &[DVec2],
        free: usize,
    ) -> (Self, Mat<f64>) {
        let mut system = MeanValueSystem {
            start: Vec::with_capacity(free + 1),
            column: Vec::new(),
            value: Vec::new(),
            diagonal: Vec::with_capacity(free),
        };
        let mut b = Mat::<f64>::zeros(free, 2);
        for (v, row) in weights.iter().enumerate() {
            let r = index[v];
            if r == u32::MAX {
                continue;
            }
            system.start.push(system.column.len());
            let mut diagonal = 0.0;
            for &(j, w) in row {
                let a = w / (divisor[v] * divisor[j as usize]);
                diagonal += a;
                match index[j as usize] {
                    u32::MAX => {
                        b[(r as usize, 0)] += a * uv[j as usize].x;
                        b[(r as usize, 1)] += a * uv[j as usize].y;
                    }
                    c => {
                        system.column.push(c);
                        system.value.push(a);
                    }
                }
            }
            system.diagonal.push(diagonal);
            for a in &mut system.value[*system.start.last().expect("pushed")..] {
                *a /= diagonal;
            }
            b[(r as usize, 0)] /= diagonal;
            b[(r as usize, 1)] /= diagonal;
        }
        system.start.push(system.column.len());
        (system, b)
    }

    /// `|b - A x|`.
    fn residual(&self, x: &Mat<f64>, b: &Mat<f64>) -> f64 {
        let mut ax = Mat::<f64>::zeros(self.diagonal.len(), 2);
        self.apply(ax.as_mut(), x.as_ref(), Par::Seq, MemStack::new(&mut []));
        (b - &ax).norm_l2()
    }
}

impl LinOp<f64> for MeanValueSystem {
    fn apply_scratch(&self, _rhs_ncols: usize, _par: Par) -> StackReq {
        StackReq::EMPTY
    }

    fn nrows(&self) -> usize {
        self.diagonal.len()
    }

    fn ncols(&self) -> usize {
        self.diagonal.len()
    }

    fn apply(&self, mut out: MatMut<'_, f64>, rhs: MatRef<'_, f64>, _: Par, _: &mut MemStack) {
        for k in 0..rhs.ncols() {
            let x = rhs.col(k);
            let mut y = out.as_mut().col_mut(k);
            for r in 0..self.diagonal.len() {
                let entries = self.start[r]..self.start[r + 1];
                let mut sum = x[r];
                for (&c, &a) in self.column[entries.clone()]
                    .iter()
                    .zip(&self.value[entries])
                {
                    sum -= a * x[c as usize];
                }
                y[r] = sum;
            }
        }
    }

    fn conj_apply(
        &self,
        out: MatMut<'_, f64>,
        rhs: MatRef<'_, f64>,
        par: Par,
        stack: &mut MemStack,
    ) {
        self.apply(out, rhs, par, stack);
    }
}

/// The symmetric part's Cholesky factorization as a preconditioner of the
/// row-normalized system: `M^-1 diag(row sums) r`.
#[derive(Debug)]
struct Preconditioner<'a> {
    llt: LltRef<'a, usize, f64>,
    row_sums: &'a [f64],
}

impl LinOp<f64> for Preconditioner<'_> {
    fn apply_scratch(&self, rhs_ncols: usize, par: Par) -> StackReq {
        self.llt
            .symbolic()
            .solve_in_place_scratch::<f64>(rhs_ncols, par)
    }

    fn nrows(&self) -> usize {
        self.row_sums.len()
    }

    fn ncols(&self) -> usize {
        self.row_sums.len()
    }

    fn apply(
        &self,
        mut out: MatMut<'_, f64>,
        rhs: MatRef<'_, f64>,
        par: Par,
        stack: &mut MemStack,
    ) {
        out.copy_from(rhs);
        self.apply_in_place(out, par, stack);
    }

    fn conj_apply(
        &self,
        out: MatMut<'_, f64>,
        rhs: MatRef<'_, f64>,
        par: Par,
        stack: &mut MemStack,
    ) {
        self.apply(out, rhs, par, stack);
    }
}

impl Precond<f64> for Preconditioner<'_> {
    fn apply_in_place_scratch(&self, rhs_ncols: usize, par: Par) -> StackReq {
        self.apply_scratch(rhs_ncols, par)
    }

    fn apply_in_place(&self, mut rhs: MatMut<'_, f64>, par: Par, stack: &mut MemStack) {
        for k in 0..rhs.ncols() {
            for (r, &d) in self.row_sums.iter().enumerate() {
                rhs[(r, k)] *= d;
            }
        }
        self.llt.solve_in_place_with_conj(Conj::No, rhs, par, stack);
    }

    fn conj_apply_in_place(&self, rhs: MatMut<'_, f64>, par: Par, stack: &mut MemStack) {
        self.apply_in_place(rhs, par, stack);
    }
}

/// Sander et al.'s L2 stretch: the area-weighted mean over triangles, scaled
/// so that a map preserving area up to one global factor scores 1, and per
/// vertex; plus the number of triangles with non-positive parameter area.
/// Each triangle's squared stretch is multiplied by its `density` (area-
/// weighted mean 1), so a map scores 1 when its parameter area per surface
/// area follows the density (the signal-specialized metric of Sander et al.
/// 2002 with the density as the signal's weight).
fn stretch(disk: &Disk, density: &[f64], uv: &[DVec2]) -> (f64, Vec<f64>, usize) {
    let mut sum = 0.0;
    let mut area3 = 0.0;
    let mut area2 = 0.0;
    let mut flipped = 0;
    let mut per_vertex = vec![(0.0, 0.0); disk.positions.len()];
    for (t, &d) in disk.triangles.iter().zip(density) {
        let [p1, p2, p3]: [DVec3; 3] = t.map(|v| disk.positions[v as usize]);
        let [q1, q2, q3]: [DVec2; 3] = t.map(|v| uv[v as usize]);
        let a2 = 0.5 * ((q2 - q1).perp_dot(q3 - q1));
        let a3 = 0.5 * (p2 - p1).cross(p3 - p1).length();
        area3 += a3;
        // Zero area happens when all three corners lie on one side of the
        // square (a triangle along a bend of the cut): not a fold.
        if a2 < 0.0 {
            flipped += 1;
        }
        if a2 <= 0.0 {
            continue;
        }
        area2 += a2;
        let ss = (p1 * (q2.y - q3.y) + p2 * (q3.y - q1.y) + p3 * (q1.y - q2.y)) / (2.0 * a2);
        let st = (p1 * (q3.x - q2.x) + p2 * (q1.x - q3.x) + p3 * (q2.x - q1.x)) / (2.0 * a2);
        let s2 = d * (ss.length_squared() + st.length_squared()) / 2.0;
        sum += a3 * s2;
        for &v in t {
            let e = &mut per_vertex[v as usize];
            e.0 += a3 * s2;
            e.1 += a3;
        }
    }
    let scale = if area3 > 0.0 { area2 / area3 } else { 1.0 };
    let total = (sum / area3.max(1e-300) * scale).sqrt();
    let per_vertex = per_vertex
        .iter()
        .map(|&(s, a)| if a > 0.0 { (s / a * scale).sqrt() } else { 1.0 })
        .collect();
    (total, per_vertex, flipped)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::TriMesh;
    use crate::remesh::cut;

    #[test]
    fn clearly_better_needs_fewer_folds_or_two_percent_less_stretch() {
        // The sphere's extra cut: 0.7% less stretch is not enough.
        assert!(!lower((0, 1.2506), (0, 1.2589)));
        assert!(lower((0, 1.19), (0, 1.2589)));
        // Fewer folds win whatever the stretch; more never do.
        assert!(lower((0, 2.0), (1, 1.1)));
        assert!(!lower((2, 1.0), (1, 2.0)));
        // NaN on either side is not better.
        assert!(!lower((0, f64::NAN), (0, 1.3)));
        assert!(!lower((0, 1.0), (0, f64::NAN)));
    }

    /// A bumpy open `n x n` grid patch: one boundary loop, already a disk.
    fn patch(n: u32) -> TriMesh {
        let mut positions = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
                let z = 0.3 * (7.0 * x).sin() * (5.0 * y).cos();
                positions.push(DVec3::new(x, y, z));
            }
        }
        let at = |i: u32, j: u32| j * (n + 1) + i;
        let mut triangles = Vec::new();
        for j in 0..n {
            for i in 0..n {
                triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        TriMesh {
            positions,
            triangles,
        }
    }

    #[test]
    fn weights_are_symmetric_and_positive() {
        let mesh = patch(8);
        let disk = cut::cut_to_disk(&mesh, &cut::Topology::new(&mesh), &[]);
        let w = symmetrized(&mean_value_weights(&disk));
        for (i, row) in w.iter().enumerate() {
            for &(j, x) in row {
                assert!(x > 0.0 && x.is_finite());
                let back = w[j as usize].iter().find(|&&(k, _)| k as usize == i);
                assert_eq!(back.map(|&(_, y)| y), Some(x), "w[{i}][{j}]");
            }
        }
    }

    /// A patch's disk, a uniform density, and divisors spread uniformly in
    /// log scale over `orders` decades.
    fn uneven_patch(orders: f64) -> (cut::Disk, Vec<f64>, Vec<f64>) {
        let mesh = patch(24);
        let disk = cut::cut_to_disk(&mesh, &cut::Topology::new(&mesh), &[]);
        let density = vec![1.0; disk.triangles.len()];
        let mut rng = qm_io::SplitMix64::new(0x9e37_79b9_7f4a_7c15);
        let divisor = (0..disk.positions.len())
            .map(|_| 10f64.powf((rng.next_f64() - 0.5) * orders))
            .collect();
        (disk, density, divisor)
    }

    /// How far apart two maps of one disk put any vertex.
    fn farthest(a: &SquareMap, b: &SquareMap) -> f64 {
        a.uv.iter()
            .zip(&b.uv)
            .map(|(p, q)| p.distance(*q))
            .fold(0.0, f64::max)
    }

    /// Positive weights give an embedding however unevenly the stretch
    /// reweighting scales them (Tutte): divisors spread at random over 8
    /// orders of magnitude, neighbour to neighbour (the bunny's reach over
    /// the whole surface is 10, varying smoothly), fold no triangle through
    /// the iterative solver, and a uniform scale
    /// of them leaves the map alone up to rounding (the row scaling that
    /// makes the system symmetric is exact).
    #[test]
    fn uneven_reweighting_folds_nothing() {
        let (disk, density, divisor) = uneven_patch(8.0);
        let map = parameterize_with(&disk, &density, 3, 0, Some(&divisor), 0).unwrap();
        assert_eq!(map.flipped, 0);
        let scaled: Vec<f64> = divisor.iter().map(|d| d * 1e6).collect();
        let again = parameterize_with(&disk, &density, 3, 0, Some(&scaled), 0).unwrap();
        let moved = farthest(&map, &again);
        // Rounding only: far below a sample spacing (1e-3 to 1e-4).
        assert!(moved < 1e-6, "a uniform scale moved a vertex by {moved:e}");
    }

    /// The two solvers solve the same mean-value system: the LU directly,
    /// BiCGSTAB through the symmetric part's Cholesky factorization.
    #[test]
    fn lu_and_preconditioned_bicgstab_agree() {
        let (disk, density, divisor) = uneven_patch(4.0);
        let (other, _, _) = uneven_patch(4.0);
        let lu = parameterize_with(&disk, &density, 3, 0, Some(&divisor), usize::MAX).unwrap();
        let iterative = parameterize_with(&other, &density, 3, 0, Some(&divisor), 0).unwrap();
        let apart = farthest(&lu, &iterative);
        assert!(apart < 1e-7, "the solvers differ by {apart:e}");
        // And the symmetric part alone would not do: the mean-value system
        // is not symmetric.
        let weights = mean_value_weights(&disk);
        assert_ne!(weights, symmetrized(&weights));
    }

    /// Beyond what rounding allows (30 orders of magnitude, where the
    /// Cholesky factorization meets a non-positive pivot), the map starts
    /// over from the plain weights rather than failing or folding.
    #[test]
    fn hopeless_reweighting_falls_back_to_the_plain_weights() {
        let (disk, density, divisor) = uneven_patch(30.0);
        let map = parameterize_with(&disk, &density, 3, 0, Some(&divisor), 0).unwrap();
        let plain = parameterize_with(&disk, &density, 3, 0, None, 0).unwrap();
        assert_eq!(map.flipped, 0);
        assert_eq!(map.uv, plain.uv);
    }
}
