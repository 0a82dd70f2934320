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
    /// Grid points no triangle covered (filled from a neighbour).
    pub uncovered: usize,
}

struct UnionFind(Vec<u32>);

impl UnionFind {
    fn find(&mut self, x: u32) -> u32 {
        let mut r = x;
        while self.0[r as usize] != r {
            r = self.0[r as usize];
        }
        let mut x = x;
        while self.0[x as usize] != r {
            let next = self.0[x as usize];
            self.0[x as usize] = r;
            x = next;
        }
        r
    }

    fn union(&mut self, a: u32, b: u32) {
        let (a, b) = (self.find(a), self.find(b));
        if a != b {
            self.0[a.max(b) as usize] = a.min(b);
        }
    }
}

/// Samples `disk` as laid out by `map` at level `level`; with `fit_rounds`
/// above zero, the samples are then fitted to the surface (see [`fit`]).
pub fn resample(disk: &Disk, map: &SquareMap, level: u32, fit_rounds: usize) -> Patch {
    let k = map.k;
    let n = 1usize << level;
    let big_n = k * n;
    let side = big_n + 1;
    let at = |i: usize, j: usize| j * side + i;
    let (positions, uncovered) = rasterize(disk, &map.uv, big_n);

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
    let mut uf = UnionFind((0..(side * side) as u32).collect());
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
    for g in 0..side * side {
        let r = uf.find(g as u32) as usize;
        if sample_id[r] == u32::MAX {
            sample_id[r] = sample_positions.len() as u32;
            sample_positions.push(positions[r]);
        }
        sample_id[g] = sample_id[r];
    }
    if fit_rounds > 0 {
        let (fine, _) = rasterize(disk, &map.uv, 2 * big_n);
        fit(&mut sample_positions, &sample_id, &fine, big_n, fit_rounds);
    }
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
        positions: sample_positions,
        uncovered,
    }
}

/// The surface point mapped to each point of the `(n + 1)^2` grid over the
/// square (row-major), and how many grid points no triangle covered (those
/// copy the nearest covered point).
fn rasterize(disk: &Disk, uv: &[DVec2], n: usize) -> (Vec<DVec3>, usize) {
    let side = n + 1;
    let at = |i: usize, j: usize| j * side + i;
    let mut positions = vec![DVec3::ZERO; side * side];
    let mut covered = vec![false; side * side];
    // Bands of rows in parallel, each going through the triangles in order:
    // a grid point takes the first triangle that covers it, as in one pass.
    let rows = side.div_ceil(16);
    positions
        .par_chunks_mut(rows * side)
        .zip(covered.par_chunks_mut(rows * side))
        .enumerate()
        .for_each(|(band, (positions, covered))| {
            let first = band * rows;
            let last = first + positions.len() / side - 1;
            for t in &disk.triangles {
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
                let eps = -1e-9 * area.abs().max(1.0);
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
                        }
                    }
                }
            }
        });
    // Numerical gaps: copy the nearest covered neighbour, growing outward.
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
                        next.push(at(a, b));
                    }
                }
            }
            frontier = next;
        }
    }
    (positions, uncovered)
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
    let mut num = vec![DVec3::ZERO; positions.len()];
    let mut den = vec![0.0f64; positions.len()];
    for _ in 0..rounds {
        num.fill(DVec3::ZERO);
        den.fill(0.0);
        for fj in 0..fine_side {
            let (ys, wy, qy) = axis(fj);
            for fi in 0..fine_side {
                let (xs, wx, qx) = axis(fi);
                let mut corners = [(0u32, 0.0f64); 4];
                let mut value = DVec3::ZERO;
                for (c, corner) in corners.iter_mut().enumerate() {
                    let (a, b) = (c % 2, c / 2);
                    let s = id[ys[b] * side + xs[a]];
                    let w = wx[a] * wy[b];
                    *corner = (s, w);
                    value += positions[s as usize] * w;
                }
                let residual = fine[fj * fine_side + fi] - value;
                let q = qx * qy;
                for (s, w) in corners {
                    if w > 0.0 {
                        num[s as usize] += residual * (w * q);
                        den[s as usize] += w * q;
                    }
                }
            }
        }
        for ((p, &u), &d) in positions.iter_mut().zip(&num).zip(&den) {
            if d > 0.0 {
                *p += u / d;
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
}
