//! Sampling a parameterized disk on a regular grid and gluing its seams.
//!
//! The square carries a `(N + 1)^2` grid, `N = K 2^L`, cut into `K x K` base
//! quads of `(2^L + 1)^2` samples. Every grid point first takes the position of
//! the surface point mapped there (barycentric interpolation in the parameter
//! triangle that holds it). Grid points on the two sides of a cut are the same
//! surface points; they are merged (union-find), as are the base vertices, so
//! the seam disappears: mates are one sample of the semi-regular mesh. Then
//! the samples may be moved off the surface so that the quads fit it in the
//! least-squares sense (see `fit`).

use qm_lift::glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::cut::Disk;
use super::square::SquareMap;
use crate::union_find::UnionFind;

/// One component's part of the semi-regular mesh.
pub struct Patch {
    /// Base quads on local base vertex ids.
    pub faces: Vec<[u32; 4]>,
    /// Number of base vertices.
    pub base_vertices: u32,
    /// Per base face, `(2^L + 1)^2` local sample ids, row-major.
    pub grids: Vec<u32>,
    /// Position of each local sample.
    pub positions: Vec<DVec3>,
    /// The disk triangle each local sample was sampled from, before the
    /// fit moved it (the disk keeps its mesh's triangle order, so this is
    /// also the component's triangle).
    pub triangles: Vec<u32>,
    /// Grid points no triangle covered (filled from a neighbour).
    pub uncovered: usize,
    /// Per local sample, whether it lies on a feature line of the base
    /// domain (charts): normal placement leaves those where they are.
    pub pinned: Vec<bool>,
}

/// Samples `disk` as laid out by `map` at level `level`; with `fit_rounds`
/// above zero, the samples are then fitted to the surface (see [`fit`]).
pub fn resample(disk: &Disk, map: &SquareMap, level: u32, fit_rounds: usize) -> Patch {
    let k = map.k;
    let n = 1usize << level;
    let big_n = k * n;
    let side = big_n + 1;
    let at = |i: usize, j: usize| j * side + i;
    // The fit needs the surface on the grid of twice the resolution, whose
    // every other point is a point of this grid (the same point to the
    // bit: the coordinates only double).
    let (positions, triangles, uncovered, fine) = if fit_rounds > 0 {
        let fine_side = 2 * big_n + 1;
        let (mut fine, mut fine_covered, mut triangles) = rasterize(disk, &map.uv, 2 * big_n, 2);
        let even = |g: usize| 2 * (g / side) * fine_side + 2 * (g % side);
        let mut positions: Vec<DVec3> = (0..side * side).map(|g| fine[even(g)]).collect();
        let mut covered: Vec<bool> = (0..side * side).map(|g| fine_covered[even(g)]).collect();
        let uncovered = fill(&mut positions, &mut covered, Some(&mut triangles), side);
        fill(&mut fine, &mut fine_covered, None, fine_side);
        (positions, triangles, uncovered, fine)
    } else {
        let (mut positions, mut covered, mut triangles) = rasterize(disk, &map.uv, big_n, 1);
        let uncovered = fill(&mut positions, &mut covered, Some(&mut triangles), side);
        (positions, triangles, uncovered, Vec::new())
    };

    // Glue mates along the perimeter.
    let perimeter = |p: usize| {
        let p = p % (4 * big_n);
        let (s, t) = (p / big_n, p % big_n);
        match s {
            0 => at(t, 0),
            1 => at(big_n, t),
            2 => at(big_n - t, big_n),
            _ => at(0, big_n - t),
        }
    };
    let mut uf = UnionFind::new(side * side);
    for (s, seg) in map.segments.iter().enumerate() {
        let Some(m) = seg.mate else { continue };
        if m < s {
            continue;
        }
        let mate = &map.segments[m];
        let span = seg.count * n;
        for o in 0..=span {
            let a = perimeter(seg.at * n + o);
            let b = perimeter(mate.at * n + span - o);
            uf.union(a as u32, b as u32);
        }
    }
    // Compact ids: samples, and separately the base vertices.
    let mut sample_id = vec![u32::MAX; side * side];
    let mut sample_positions = Vec::new();
    let mut sample_triangles = Vec::new();
    for g in 0..side * side {
        let r = uf.find(g as u32) as usize;
        if sample_id[r] == u32::MAX {
            sample_id[r] = sample_positions.len() as u32;
            sample_positions.push(positions[r]);
            sample_triangles.push(triangles[r]);
        }
        sample_id[g] = sample_id[r];
    }
    if fit_rounds > 0 {
        fit(&mut sample_positions, &sample_id, &fine, big_n, fit_rounds);
    }
    drop(fine);
    let mut base_id = vec![u32::MAX; side * side];
    let mut base_vertices = 0u32;
    let mut base = |i: usize, j: usize, uf: &mut UnionFind| {
        let r = uf.find(at(i * n, j * n) as u32) as usize;
        if base_id[r] == u32::MAX {
            base_id[r] = base_vertices;
            base_vertices += 1;
        }
        base_id[r]
    };
    let mut faces = Vec::with_capacity(k * k);
    let mut grids = Vec::with_capacity(k * k * (n + 1) * (n + 1));
    for b in 0..k {
        for a in 0..k {
            faces.push([
                base(a, b, &mut uf),
                base(a + 1, b, &mut uf),
                base(a + 1, b + 1, &mut uf),
                base(a, b + 1, &mut uf),
            ]);
            for j in 0..=n {
                for i in 0..=n {
                    grids.push(sample_id[at(a * n + i, b * n + j)]);
                }
            }
        }
    }
    Patch {
        faces,
        base_vertices,
        grids,
        pinned: vec![false; sample_positions.len()],
        positions: sample_positions,
        triangles: sample_triangles,
        uncovered,
    }
}

/// The surface point mapped to each point of the `(n + 1)^2` grid over the
/// square (row-major), whether a triangle covered it, and the disk triangle
/// of every `step`-th point of every `step`-th row (a `(n / step + 1)^2`
/// grid). Points no triangle covered are left for [`fill`].
fn rasterize(
    disk: &Disk,
    uv: &[DVec2],
    n: usize,
    step: usize,
) -> (Vec<DVec3>, Vec<bool>, Vec<u32>) {
    let side = n + 1;
    let coarse_side = n / step + 1;
    let mut positions = vec![DVec3::ZERO; side * side];
    let mut covered = vec![false; side * side];
    let mut triangles = vec![0u32; coarse_side * coarse_side];
    // Bands of rows in parallel, each going through the triangles in order:
    // a grid point takes the first triangle that covers it, as in one pass.
    // Bands of whole `step`-th rows, so that each has its own triangles.
    let rows = side.div_ceil(16).next_multiple_of(step);
    let mut bands: Vec<&mut [u32]> = triangles.chunks_mut(rows / step * coarse_side).collect();
    bands.resize_with(side.div_ceil(rows), Default::default);
    positions
        .par_chunks_mut(rows * side)
        .zip(covered.par_chunks_mut(rows * side))
        .zip(bands)
        .enumerate()
        .for_each(|(band, ((positions, covered), triangles))| {
            let first = band * rows;
            let last = first + positions.len() / side - 1;
            for (index, t) in disk.triangles.iter().enumerate() {
                let q: [DVec2; 3] = t.map(|v| uv[v as usize] * n as f64);
                let lo = q[0].min(q[1]).min(q[2]);
                let hi = q[0].max(q[1]).max(q[2]);
                let j0 = lo.y.floor().max(0.0) as usize;
                let j1 = (hi.y.ceil() as usize).min(n);
                if j1 < first || j0 > last {
                    continue;
                }
                let area = (q[1] - q[0]).perp_dot(q[2] - q[0]);
                if area <= 0.0 {
                    continue;
                }
                let p: [DVec3; 3] = t.map(|v| disk.positions[v as usize]);
                let i0 = lo.x.floor().max(0.0) as usize;
                let i1 = (hi.x.ceil() as usize).min(n);
                // In units of the coarse grid, the same at its points.
                let eps = -1e-9 * area.abs().max((step * step) as f64);
                for j in j0.max(first)..=j1.min(last) {
                    for i in i0..=i1 {
                        let g = (j - first) * side + i;
                        if covered[g] {
                            continue;
                        }
                        let x = DVec2::new(i as f64, j as f64);
                        let l0 = (q[1] - x).perp_dot(q[2] - x);
                        let l1 = (q[2] - x).perp_dot(q[0] - x);
                        let l2 = (q[0] - x).perp_dot(q[1] - x);
                        if l0 >= eps && l1 >= eps && l2 >= eps {
                            let s = l0 + l1 + l2;
                            positions[g] = (p[0] * l0 + p[1] * l1 + p[2] * l2) / s;
                            covered[g] = true;
                            if i % step == 0 && j % step == 0 {
                                triangles[(j - first) / step * coarse_side + i / step] =
                                    index as u32;
                            }
                        }
                    }
                }
            }
        });
    (positions, covered, triangles)
}

/// Fills the points of a `side^2` grid that no triangle covered (numerical
/// gaps) from the nearest covered one, growing outward, with its triangle
/// if given; returns how many there were.
fn fill(
    positions: &mut [DVec3],
    covered: &mut [bool],
    mut triangles: Option<&mut [u32]>,
    side: usize,
) -> usize {
    let at = |i: usize, j: usize| j * side + i;
    let uncovered = covered.iter().filter(|&&c| !c).count();
    if uncovered > 0 && uncovered < covered.len() {
        let mut frontier: Vec<usize> = (0..covered.len()).filter(|&g| covered[g]).collect();
        while !frontier.is_empty() {
            let mut next = Vec::new();
            for g in frontier {
                let (i, j) = (g % side, g / side);
                let around = [
                    (i.wrapping_sub(1), j),
                    (i + 1, j),
                    (i, j.wrapping_sub(1)),
                    (i, j + 1),
                ];
                for (a, b) in around {
                    if a < side && b < side && !covered[at(a, b)] {
                        covered[at(a, b)] = true;
                        positions[at(a, b)] = positions[g];
                        if let Some(triangles) = triangles.as_deref_mut() {
                            triangles[at(a, b)] = triangles[g];
                        }
                        next.push(at(a, b));
                    }
                }
            }
            frontier = next;
        }
    }
    uncovered
}

/// The quadrature of the fits along one axis of an `(n + 1)^2` grid, at
/// fine index `f` of its `(2n + 1)^2` refinement: the grid points the node
/// lies between, their hat-function values (one point when it lies on a
/// grid line) and its weight (half on the border).
pub(super) fn quadrature_axis(n: usize, f: usize) -> ([usize; 2], [f64; 2], f64) {
    let border = if f == 0 || f == 2 * n { 0.5 } else { 1.0 };
    if f % 2 == 0 {
        ([f / 2, f / 2], [1.0, 0.0], border)
    } else {
        ([f / 2, f / 2 + 1], [0.5, 0.5], border)
    }
}

/// Moves the samples off the surface so that the bilinear quads between
/// them fit it in the least-squares sense instead of interpolating it:
/// interpolation leaves the quads on the inner side of every bend (a chord
/// under an arc) and cuts across creases, while the least-squares fit
/// straddles them, with about a third of the error on a smooth arc.
///
/// `positions` are the glued samples, `id` the sample of each point of the
/// `(n + 1)^2` grid over the square, `fine` the surface at the `(2n + 1)^2`
/// grid. The points of `fine` are the quadrature nodes of the normal
/// equations `M x = b` (`M` the mass matrix of the bilinear hat functions),
/// solved by `rounds` Jacobi steps with the lumped mass. The border of the
/// square counts half: its other half is the glued side of the cut.
fn fit(positions: &mut [DVec3], id: &[u32], fine: &[DVec3], n: usize, rounds: usize) {
    let side = n + 1;
    let fine_side = 2 * n + 1;
    let axis = |f: usize| quadrature_axis(n, f);
    // Per grid point, its sums over the nodes around it; then per sample,
    // at its first grid point, those of its other grid points (a glued
    // sample's, along the cuts) added in grid order.
    let mut sums = vec![(DVec3::ZERO, 0.0f64); side * side];
    let mut first = vec![u32::MAX; positions.len()];
    let mut others = Vec::new();
    for (g, &s) in id.iter().enumerate() {
        if first[s as usize] == u32::MAX {
            first[s as usize] = g as u32;
        } else {
            others.push((first[s as usize], g as u32));
        }
    }
    // Bands of grid rows in parallel, each node row's residuals computed
    // once per band.
    let rows = side.div_ceil(4 * rayon::current_num_threads()).max(1);
    for _ in 0..rounds {
        let positions_now: &[DVec3] = positions;
        // The residuals of node row `fj`, at every node of the row.
        let residuals = |fj: usize, out: &mut Vec<DVec3>| {
            out.clear();
            let (ys, wy, _) = axis(fj);
            for fi in 0..fine_side {
                let (xs, wx, _) = axis(fi);
                let mut value = DVec3::ZERO;
                for c in 0..4 {
                    let (a, b) = (c % 2, c / 2);
                    let s = id[ys[b] * side + xs[a]];
                    value += positions_now[s as usize] * (wx[a] * wy[b]);
                }
                out.push(fine[fj * fine_side + fi] - value);
            }
        };
        sums.par_chunks_mut(rows * side)
            .enumerate()
            .for_each(|(band, sums)| {
                let first = band * rows;
                let mut node_rows = [Vec::new(), Vec::new(), Vec::new()];
                if first > 0 {
                    residuals(2 * first - 1, &mut node_rows[2]);
                }
                for (j, sums) in (first..).zip(sums.chunks_mut(side)) {
                    // Rows 2j - 1 (kept from the last grid row), 2j, 2j + 1.
                    node_rows.swap(0, 2);
                    residuals(2 * j, &mut node_rows[1]);
                    if j < n {
                        residuals(2 * j + 1, &mut node_rows[2]);
                    }
                    for (i, sum) in sums.iter_mut().enumerate() {
                        // The nodes around grid point (i, j), in the order
                        // the nodes come (the same sums, term by term, as
                        // scattering node by node).
                        let mut acc = (DVec3::ZERO, 0.0);
                        let (i0, i1) = ((2 * i).saturating_sub(1), (2 * i + 1).min(2 * n));
                        for fj in (2 * j).saturating_sub(1)..=(2 * j + 1).min(2 * n) {
                            let (ys, wy, qy) = axis(fj);
                            let b = usize::from(ys[0] != j);
                            let row = &node_rows[fj + 1 - 2 * j];
                            for (fi, &residual) in (i0..=i1).zip(&row[i0..=i1]) {
                                let (xs, wx, qx) = axis(fi);
                                let a = usize::from(xs[0] != i);
                                let (w, q) = (wx[a] * wy[b], qx * qy);
                                acc.0 += residual * (w * q);
                                acc.1 += w * q;
                            }
                        }
                        *sum = acc;
                    }
                }
            });
        for &(to, from) in &others {
            let (u, d) = sums[from as usize];
            let sum = &mut sums[to as usize];
            sum.0 += u;
            sum.1 += d;
        }
        positions.par_iter_mut().zip(&first).for_each(|(p, &g)| {
            let (u, d) = sums[g as usize];
            if d > 0.0 {
                *p += u / d;
            }
        });
    }
}

/// Adds, per sample of the `(n + 1)^2` grid `id`, the hat-weighted
/// residuals of the bilinear quads through `positions` at the `(2n + 1)^2`
/// surface nodes `nodes`, and the weights (the lumped mass): the sums of one
/// Jacobi step of the fit's normal equations, node by node.
fn scatter_residuals(
    positions: &[DVec3],
    id: &[u32],
    nodes: &[DVec3],
    n: usize,
    sums: &mut [(DVec3, f64)],
) {
    let (side, fine_side) = (n + 1, 2 * n + 1);
    for fj in 0..fine_side {
        let (ys, wy, qy) = quadrature_axis(n, fj);
        for fi in 0..fine_side {
            let (xs, wx, qx) = quadrature_axis(n, fi);
            let corners: [(u32, f64); 4] = std::array::from_fn(|c| {
                let (a, b) = (c % 2, c / 2);
                (id[ys[b] * side + xs[a]], wx[a] * wy[b])
            });
            let mut value = DVec3::ZERO;
            for &(s, w) in &corners {
                value += positions[s as usize] * w;
            }
            let residual = nodes[fj * fine_side + fi] - value;
            let q = qx * qy;
            for (s, w) in corners {
                if w > 0.0 {
                    let sum = &mut sums[s as usize];
                    sum.0 += residual * (w * q);
                    sum.1 += w * q;
                }
            }
        }
    }
}

/// [`fit`] over many grids: `grids` holds per base face the `(n + 1)^2`
/// sample ids of its grid (row-major), `fine` per face the surface at its
/// `(2n + 1)^2` refinement. Each face's border nodes count half (a quarter
/// at corners), the rest coming from the faces across; the normal
/// equations are solved by `rounds` Jacobi steps with the lumped mass, as
/// in [`fit`].
pub(super) fn fit_grids(
    positions: &mut [DVec3],
    grids: &[u32],
    fine: &[DVec3],
    n: usize,
    rounds: usize,
) {
    let side = n + 1;
    let fine_side = 2 * n + 1;
    let faces = grids.len() / (side * side);
    let chunk = faces.div_ceil(rayon::current_num_threads().max(1)).max(1);
    // No step moves a sample further than half its shortest grid edge: where
    // the map jumps (a fold, a chart seam) the fine nodes around a sample
    // may lie far from it, and the fit must not throw it there.
    let mut reach = vec![f64::INFINITY; positions.len()];
    for f in 0..faces {
        let id = &grids[f * side * side..(f + 1) * side * side];
        for j in 0..side {
            for i in 0..side {
                let s = id[j * side + i] as usize;
                for (a, b) in [(i + 1, j), (i, j + 1)] {
                    if a < side && b < side {
                        let t = id[b * side + a] as usize;
                        let half = 0.5 * positions[s].distance(positions[t]);
                        reach[s] = reach[s].min(half);
                        reach[t] = reach[t].min(half);
                    }
                }
            }
        }
    }
    for _ in 0..rounds {
        let now: &[DVec3] = positions;
        let sums = (0..faces)
            .collect::<Vec<_>>()
            .par_chunks(chunk)
            .map(|chunk| {
                let mut sums = vec![(DVec3::ZERO, 0.0f64); now.len()];
                for &f in chunk {
                    let id = &grids[f * side * side..(f + 1) * side * side];
                    let nodes = &fine[f * fine_side * fine_side..(f + 1) * fine_side * fine_side];
                    scatter_residuals(now, id, nodes, n, &mut sums);
                }
                sums
            })
            .collect::<Vec<_>>()
            // Summed in chunk order, so that the result does not depend on
            // the threads' timing.
            .into_iter()
            .reduce(|mut a, b| {
                for (x, y) in a.iter_mut().zip(b) {
                    x.0 += y.0;
                    x.1 += y.1;
                }
                a
            })
            .unwrap_or_default();
        for ((p, (u, d)), &limit) in positions.iter_mut().zip(sums).zip(&reach) {
            if d > 0.0 {
                let step = u / d;
                let length = step.length();
                *p += if length > limit {
                    step * (limit / length)
                } else {
                    step
                };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mean squared distance, at the fine points, between the bilinear
    /// quads through the coarse samples and the surface.
    fn misfit(coarse: &[DVec3], fine: &[DVec3], n: usize) -> f64 {
        let side = 2 * n + 1;
        let mut sum = 0.0;
        for j in 0..side {
            for i in 0..side {
                let (a, b) = (i / 2, j / 2);
                let (a1, b1) = (i.div_ceil(2), j.div_ceil(2));
                let c = |x: usize, y: usize| coarse[y * (n + 1) + x];
                let value = (c(a, b) + c(a1, b) + c(a, b1) + c(a1, b1)) / 4.0;
                sum += (fine[j * side + i] - value).length_squared();
            }
        }
        sum / (side * side) as f64
    }

    #[test]
    fn fitting_lowers_the_misfit_of_a_curved_surface() {
        let surface = |x: f64, y: f64| DVec3::new(x, y, (3.0 * x).sin() * (2.0 * y).cos());
        let n = 8;
        let grid = |m: usize| -> Vec<DVec3> {
            (0..=m)
                .flat_map(|j| (0..=m).map(move |i| (i, j)))
                .map(|(i, j)| surface(i as f64 / m as f64, j as f64 / m as f64))
                .collect()
        };
        let fine = grid(2 * n);
        let mut coarse = grid(n);
        let id: Vec<u32> = (0..coarse.len() as u32).collect();
        let before = misfit(&coarse, &fine, n);
        fit(&mut coarse, &id, &fine, n, 3);
        let after = misfit(&coarse, &fine, n);
        assert!(after < 0.5 * before, "misfit {before:e} -> {after:e}");
    }

    /// The fit as the normal equations read, node by node scattering its
    /// residual to its corners (what `fit` gathers per grid point).
    fn fit_by_nodes(positions: &mut [DVec3], id: &[u32], fine: &[DVec3], n: usize, rounds: usize) {
        for _ in 0..rounds {
            let mut sums = vec![(DVec3::ZERO, 0.0f64); positions.len()];
            scatter_residuals(positions, id, fine, n, &mut sums);
            for (p, (u, d)) in positions.iter_mut().zip(sums) {
                if d > 0.0 {
                    *p += u / d;
                }
            }
        }
    }

    /// Gathering per grid point in bands gives the scattered sums: the same
    /// samples bit for bit where a sample is one grid point, to rounding
    /// where it is glued from several (here the grid closed into a tube).
    #[test]
    fn fitting_by_grid_points_sums_what_the_nodes_scatter() {
        let n = 12;
        let side = n + 1;
        let tube = |x: f64, y: f64| {
            let a = std::f64::consts::TAU * x;
            DVec3::new(a.cos(), a.sin(), y + 0.1 * (5.0 * a).sin())
        };
        let fine: Vec<DVec3> = (0..=2 * n)
            .flat_map(|j| (0..=2 * n).map(move |i| (i, j)))
            .map(|(i, j)| tube(i as f64 / (2 * n) as f64, j as f64 / (2 * n) as f64))
            .collect();
        // The last column is the first one again.
        let id: Vec<u32> = (0..side * side)
            .map(|g| {
                let (i, j) = (g % side, g / side);
                (j * n + i % n) as u32
            })
            .collect();
        let mut gathered: Vec<DVec3> = (0..side * n)
            .map(|s| tube((s % n) as f64 / n as f64, (s / n) as f64 / n as f64))
            .collect();
        let start = gathered.clone();
        let mut scattered = gathered.clone();
        fit(&mut gathered, &id, &fine, n, 3);
        fit_by_nodes(&mut scattered, &id, &fine, n, 3);
        for (s, (a, b)) in gathered.iter().zip(&scattered).enumerate() {
            if s % n == 0 {
                assert!(
                    a.distance(*b) < 1e-14,
                    "glued sample {s}: {a:?} against {b:?}"
                );
            } else {
                assert_eq!(a, b, "sample {s}");
            }
        }
        // The fit moved them.
        assert!(gathered.iter().zip(&start).all(|(a, b)| a != b));
    }
}
