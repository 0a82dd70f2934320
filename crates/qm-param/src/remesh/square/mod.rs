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
//! one sparse linear solve for `u` and `v` (see module `system` for how).
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
//!
//! Main items: [`parameterize`] and [`parameterize_k`], which make a
//! [`SquareMap`], and [`clearly_better`], which compares two. The modules:
//! `boundary` lays the boundary on the perimeter ([`Segment`]), `system`
//! solves for the interior.

mod boundary;
mod system;

use qm_lift::glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::cut::Disk;
use crate::Result;
pub use boundary::Segment;
use boundary::{layout, perimeter_point, snap_corners};
pub(crate) use system::LU_BELOW;
use system::System;

/// Smallest relative stretch improvement worth another reweighting (each is
/// a sparse factorization) (docs/decisions/013-square-map.md).
const STRETCH_GAIN: f64 = 0.02;

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
    // The sizes are independent: solve them in parallel, pick in order;
    // one after another where each holds a large factorization, so that
    // the peak is one system's, not one per thread.
    let map = |&k: &usize| parameterize_k(disk, density, k, iterations, None);
    let maps: Vec<Result<SquareMap>> = if unknowns(disk) < LU_BELOW {
        sizes.par_iter().map(map).collect()
    } else {
        sizes.iter().map(map).collect()
    };
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

/// The unknowns of `disk`'s systems: its vertices off the boundary.
fn unknowns(disk: &Disk) -> usize {
    disk.positions.len().saturating_sub(disk.boundary.len())
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
            // Reweighting spreads the weights over many orders of magnitude;
            // far beyond what real inputs reach the factorization loses
            // definiteness to rounding (docs/decisions/013-square-map.md).
            // Keep the best map so far, or start over from the plain weights.
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
    use super::system::symmetrized;
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
        let (flat, triangles) = qm_shapes::plane(n);
        let positions = flat
            .into_iter()
            .map(|p| DVec3::new(p.x, p.y, 0.3 * (7.0 * p.x).sin() * (5.0 * p.y).cos()))
            .collect();
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
    /// orders of magnitude, neighbour to neighbour (rougher than real inputs,
    /// docs/decisions/013-square-map.md), fold no triangle through the
    /// iterative solver, and a uniform scale of them leaves the map alone up
    /// to rounding (the row scaling that makes the system symmetric is
    /// exact).
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
