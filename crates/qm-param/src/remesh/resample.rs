//! Sampling a parameterized disk on a regular grid and gluing its seams.
//!
//! The square carries a `(N + 1)^2` grid, `N = K 2^L`, cut into `K x K` base
//! quads of `(2^L + 1)^2` samples. Every grid point takes the position of the
//! surface point mapped there (barycentric interpolation in the parameter
//! triangle that holds it). Grid points on the two sides of a cut are the same
//! surface points; they are merged (union-find), as are the base vertices, so
//! the seam disappears: mates are one sample of the semi-regular mesh.

use qm_lift::glam::{DVec2, DVec3};

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

/// Samples `disk` as laid out by `map` at level `level`.
pub fn resample(disk: &Disk, map: &SquareMap, level: u32) -> Patch {
    let k = map.k;
    let n = 1usize << level;
    let big_n = k * n;
    let side = big_n + 1;
    let at = |i: usize, j: usize| j * side + i;
    let mut positions = vec![DVec3::ZERO; side * side];
    let mut covered = vec![false; side * side];
    for t in &disk.triangles {
        let q: [DVec2; 3] = t.map(|v| map.uv[v as usize] * big_n as f64);
        let p: [DVec3; 3] = t.map(|v| disk.positions[v as usize]);
        let area = (q[1] - q[0]).perp_dot(q[2] - q[0]);
        if area <= 0.0 {
            continue;
        }
        let lo = q[0].min(q[1]).min(q[2]);
        let hi = q[0].max(q[1]).max(q[2]);
        let (i0, j0) = (
            lo.x.floor().max(0.0) as usize,
            lo.y.floor().max(0.0) as usize,
        );
        let (i1, j1) = (
            (hi.x.ceil() as usize).min(big_n),
            (hi.y.ceil() as usize).min(big_n),
        );
        let eps = -1e-9 * area.abs().max(1.0);
        for j in j0..=j1 {
            for i in i0..=i1 {
                let g = at(i, j);
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
