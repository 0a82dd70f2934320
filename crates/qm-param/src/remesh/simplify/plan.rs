//! Planning the removal of a vertex: the cheapest collapse of it into a
//! ring neighbour whose fan does not fold, or its ring retriangulated.
//!
//! The ring is flattened conformally (MAPS's `z^a`: the angles around `v`
//! scaled to a full turn, or a half turn on a boundary, the radii raised to
//! the same power); a fan from ring vertex `u` is allowed where every new
//! triangle keeps its turn in the flattening and along the ring's normal,
//! and is no thinner than the shape bound (or than [`SLIVER_SLACK`] times
//! the thinnest triangle it removes). The cost of removing `v` into
//! `u` is the quadric error of the merged region at `u`, over its area,
//! plus [`AREA_WEIGHT`] times the ring's area, divided by the quality of
//! the fan's thinnest triangle (1 for the equilateral). A vertex on a
//! feature line goes only along it, and the link condition keeps the
//! topology.

use std::cmp::Ordering;

use qm_lift::glam::{DVec2, DVec3};

use super::ring::{Ring, edge_key};
use super::simplifier::Simplifier;

/// Weight of the ring's area against the squared quadric error.
const AREA_WEIGHT: f64 = 0.02;

/// A removal may make triangles down to this share of the quality of the
/// thinnest it removes, where that is under the shape bound.
const SLIVER_SLACK: f64 = 0.5;

/// Most neighbours of a vertex that may be removed. Its hole is
/// retriangulated by a dynamic programme cubic in the ring, and a removal
/// next to it plans it again. Removals around such a hub bring it under
/// the bound (docs/decisions/006-high-valence-bounds.md).
const MAX_RING: usize = 32;

/// A planned removal of `v` into `u`: a half-edge collapse, whose new
/// triangles are the fan from `u`, or the ring retriangulated (`u` then the
/// ring vertex nearest `v`, which takes its quadric).
pub(super) struct Plan {
    pub(super) u: u32,
    pub(super) cost: f64,
    /// The new triangles (ring positions, counter-clockwise) where they are
    /// not the fan from `u`.
    pub(super) triangles: Option<Vec<[usize; 3]>>,
}

impl Simplifier<'_> {
    /// MAPS's conformal flattening of `v`'s ring: `v` at the origin. On a
    /// feature line (a boundary, or `line`: the ring positions of an
    /// interior crease's two ends) each side of the line is opened to a half
    /// turn, radii kept, so that the line comes out straight through `v`
    /// and no point crosses it when `v` goes.
    pub(super) fn flatten(
        &self,
        v: u32,
        ring: &Ring,
        line: Option<(usize, usize)>,
    ) -> Option<Vec<DVec2>> {
        let p = self.positions[v as usize];
        let k = ring.verts.len();
        let spokes: Vec<DVec3> = ring
            .verts
            .iter()
            .map(|&w| self.positions[w as usize] - p)
            .collect();
        let lengths: Vec<f64> = spokes.iter().map(|s| s.length()).collect();
        let longest = lengths.iter().copied().fold(0.0, f64::max);
        if longest.is_nan() || longest <= 0.0 || lengths.iter().any(|&l| l.is_nan() || l <= 0.0) {
            return None;
        }
        let angle = |i: usize, j: usize| spokes[i].angle_between(spokes[j]);
        let angles: Vec<f64> = (0..ring.faces.len())
            .map(|i| angle(i, (i + 1) % k))
            .collect();
        let total: f64 = angles.iter().sum();
        if total.is_nan() || total <= 1e-9 || angles.iter().any(|&a| a.is_nan() || a <= 0.0) {
            return None;
        }
        let mut out = vec![DVec2::ZERO; k];
        if let (Some((ui, bi)), true) = (line, ring.closed) {
            // Edge i runs from ring position i to i + 1; side 0 from u to b.
            let side0: f64 = (0..k)
                .filter(|&i| (i + k - ui) % k < (bi + k - ui) % k)
                .map(|i| angles[i])
                .sum();
            let side1 = total - side0;
            if side0 <= 1e-9 || side1 <= 1e-9 {
                return None;
            }
            let mut phi = 0.0f64;
            for step in 0..k {
                let i = (ui + step) % k;
                let r = (lengths[i] / longest).powf(std::f64::consts::TAU / total);
                out[i] = DVec2::new(r * phi.cos(), r * phi.sin());
                let scale = if step < (bi + k - ui) % k {
                    std::f64::consts::PI / side0
                } else {
                    std::f64::consts::PI / side1
                };
                phi += scale * angles[i];
            }
            return Some(out);
        }
        let turn = if ring.closed {
            std::f64::consts::TAU
        } else {
            std::f64::consts::PI
        };
        let a = turn / total;
        let mut phi = 0.0f64;
        for (i, slot) in out.iter_mut().enumerate() {
            let r = (lengths[i] / longest).powf(if ring.closed { a } else { 1.0 });
            *slot = DVec2::new(r * phi.cos(), r * phi.sin());
            if i < angles.len() {
                phi += a * angles[i];
            }
        }
        Some(out)
    }

    /// The fan from ring position `ui`: per ring edge `i` not at `u`,
    /// `(i, [u, w_i, w_i+1])`.
    pub(super) fn fan(ring: &Ring, ui: usize) -> Vec<(usize, [usize; 3])> {
        Self::fan_triangles(ring, ui).map(|t| (t[1], t)).collect()
    }

    /// The triangles of [`Self::fan`] alone, without a list.
    fn fan_triangles(ring: &Ring, ui: usize) -> impl Iterator<Item = [usize; 3]> {
        let k = ring.verts.len();
        (0..ring.faces.len()).filter_map(move |i| {
            let j = (i + 1) % k;
            (i != ui && j != ui).then_some([ui, i, j])
        })
    }

    /// The side of ring edge `i` for a crease collapse into ring position
    /// `ui` with the other crease neighbour at `bi`: 0 from `u` to `b`, 1
    /// from `b` to `u`; all 0 without a crease.
    pub(super) fn side(ring: &Ring, ui: usize, bi: Option<usize>, i: usize) -> u8 {
        let Some(bi) = bi else { return 0 };
        let k = ring.verts.len();
        let from_u = (i + k - ui) % k;
        let to_b = (bi + k - ui) % k;
        u8::from(from_u >= to_b)
    }

    /// Whether the part is down to so few faces or vertices that no
    /// removal is allowed.
    pub(super) fn exhausted(&self) -> bool {
        let min_faces = if self.closed { 4 } else { 1 };
        self.alive_faces <= min_faces + 2 || self.alive_vertices <= 4
    }

    /// How many of `near` (sorted, no repeats, at most 64: a ring) are
    /// neighbours of `u`, `u` aside: marked in a bit set from `u`'s faces,
    /// with no list of `u`'s neighbours made.
    fn common_neighbours(&self, u: u32, near: &[u32]) -> usize {
        let mut marked = 0u64;
        for &f in &self.vfaces[u as usize] {
            for w in self.faces[f as usize] {
                if w != u
                    && let Ok(i) = near.binary_search(&w)
                {
                    marked |= 1 << i;
                }
            }
        }
        marked.count_ones() as usize
    }

    /// The best removal of `v`, if any is allowed.
    pub(super) fn plan(&self, v: u32) -> Option<Plan> {
        if self.removed[v as usize] || self.keep.get(v as usize) == Some(&true) {
            return None;
        }
        let degree = self.crease_degree[v as usize];
        if degree != 0 && degree != 2 {
            return None;
        }
        let ring = self.ring(v)?;
        if ring.verts.len() > MAX_RING {
            return None;
        }
        if self.exhausted() {
            return None;
        }
        // A boundary vertex lies on feature lines (its two boundary edges).
        if !ring.closed && degree != 2 {
            return None;
        }
        if !ring.closed && ring.faces.len() < 2 {
            return None;
        }
        let plain = self.flatten(v, &ring, None)?;
        // Most vertices lie on no feature line: no look-ups for them.
        let crease_ends: Vec<usize> = if degree == 0 {
            Vec::new()
        } else {
            (0..ring.verts.len())
                .filter(|&i| self.creases.contains(&edge_key(v, ring.verts[i])))
                .collect()
        };
        let candidates: Vec<usize> = if degree == 2 {
            crease_ends.clone()
        } else {
            (0..ring.verts.len()).collect()
        };
        // `v`'s neighbours: its ring, which holds each once (the clean-up
        // leaves no face holding a vertex twice, and removals make none).
        let mut v_neighbours = ring.verts.clone();
        v_neighbours.sort_unstable();
        let ring_area: f64 = ring
            .faces
            .iter()
            .map(|&f| self.area3(self.faces[f as usize]))
            .sum();
        let ring_normal: DVec3 = ring
            .faces
            .iter()
            .map(|&f| self.normal3(self.faces[f as usize]))
            .sum::<DVec3>()
            .normalize_or_zero();
        // A removal may make triangles down to half as thin as the thinnest
        // it removes: a scan's slivers would otherwise hold every vertex
        // around them.
        let floor = ring
            .faces
            .iter()
            .map(|&f| SLIVER_SLACK * self.quality3(self.faces[f as usize]))
            .fold(self.min_quality, f64::min);
        // The cost of removing `v` into `u`, making triangles of `quality`.
        let cost = |u: u32, quality: f64| {
            let mut q = self.quadric[v as usize];
            q.add(&self.quadric[u as usize]);
            let err = q.eval(self.positions[u as usize]) / q.area.max(1e-300);
            (err + AREA_WEIGHT * ring_area) / quality.min(1.0)
        };
        let mut best: Option<Plan> = None;
        for ui in candidates {
            let u = ring.verts[ui];
            let bi = (degree == 2)
                .then(|| crease_ends.iter().copied().find(|&i| i != ui))
                .flatten();
            if let Some(bi) = bi
                && self.creases.contains(&edge_key(u, ring.verts[bi]))
            {
                continue;
            }
            // Each side of an interior crease keeps a triangle: a side of
            // one (`v, u, b`) would be squashed onto the line `u b`, and
            // its points with it.
            if let Some(bi) = bi
                && ring.closed
            {
                let k = ring.verts.len();
                let arc = (bi + k - ui) % k;
                if arc < 2 || k - arc < 2 {
                    continue;
                }
            }
            if !ring.closed && ui != 0 && ui != ring.verts.len() - 1 {
                continue;
            }
            // The cost at the best shape (quality 1) bounds it from below
            // where it is not negative (a quality is never negative and is
            // capped at 1): a candidate that cannot beat the best so far is
            // not shaped (docs/decisions/033-exact-speedups.md).
            let least = cost(u, 1.0);
            if least >= 0.0 && best.as_ref().is_some_and(|b| least >= b.cost) {
                continue;
            }
            let lined;
            let flat = match bi {
                Some(bi) if ring.closed => {
                    let Some(f) = self.flatten(v, &ring, Some((ui, bi))) else {
                        continue;
                    };
                    lined = f;
                    &lined
                }
                _ => &plain,
            };
            let quality = Self::fan_triangles(&ring, ui)
                .map(|t| self.new_quality(&ring, flat, t, ring_normal))
                .try_fold(f64::INFINITY, |q, t| t.map(|t| q.min(t)));
            let Some(quality) = quality.filter(|&q| q >= floor) else {
                continue;
            };
            // The same division as `cost(u, quality)`.
            let cost = least / quality.min(1.0);
            if best
                .as_ref()
                .is_some_and(|b| cost.partial_cmp(&b.cost) != Some(Ordering::Less))
            {
                continue;
            }
            // Link condition (checked last, for the one candidate that
            // would win): the common neighbours of u and v are the
            // vertices opposite their edge.
            let opposite = ring
                .faces
                .iter()
                .map(|&f| self.faces[f as usize])
                .filter(|t| t.contains(&u))
                .count();
            let common = self.common_neighbours(u, &v_neighbours);
            if common == opposite {
                best = Some(Plan {
                    u,
                    cost,
                    triangles: None,
                });
            }
        }
        // Where no fan is valid (a noisy scan's ring that no ring vertex
        // sees whole), MAPS's removal: the flattened ring retriangulated.
        if best.is_none()
            && degree == 0
            && ring.closed
            && let Some((quality, triangles)) = self.retriangulate(&ring, &plain, ring_normal)
            && quality >= floor
        {
            let p = self.positions[v as usize];
            let nearest = ring.verts.iter().copied().min_by(|&a, &b| {
                let d = |w: u32| self.positions[w as usize].distance_squared(p);
                d(a).total_cmp(&d(b))
            })?;
            best = Some(Plan {
                u: nearest,
                cost: cost(nearest, quality),
                triangles: Some(triangles),
            });
        }
        best
    }

    /// The triangulation of the closed ring's flattened polygon `flat` whose
    /// thinnest triangle is thickest (dynamic programming over the
    /// polygon's sub-chains), with every triangle turned the right way in
    /// the flattening and along `normal`, and no new edge that the mesh
    /// already has. Its least quality and triangles (ring positions,
    /// counter-clockwise), if there is one.
    fn retriangulate(
        &self,
        ring: &Ring,
        flat: &[DVec2],
        normal: DVec3,
    ) -> Option<(f64, Vec<[usize; 3]>)> {
        let k = ring.verts.len();
        // Whether positions i < j may be joined: a ring edge, or a new edge.
        let joinable = |i: usize, j: usize| {
            j == i + 1 || (i == 0 && j == k - 1) || !self.adjacent(ring.verts[i], ring.verts[j])
        };
        let score = |a: usize, b: usize, c: usize| {
            self.new_quality(ring, flat, [a, b, c], normal)
                .unwrap_or(f64::NEG_INFINITY)
        };
        // best[i][j]: the sub-chain i..=j closed by the edge i j.
        let mut best = vec![vec![(f64::NEG_INFINITY, usize::MAX); k]; k];
        for i in 0..k - 1 {
            best[i][i + 1] = (f64::INFINITY, usize::MAX);
        }
        for span in 2..k {
            for i in 0..k - span {
                let j = i + span;
                if !joinable(i, j) {
                    continue;
                }
                for m in i + 1..j {
                    let value = best[i][m].0.min(best[m][j].0).min(score(i, m, j));
                    if value > best[i][j].0 {
                        best[i][j] = (value, m);
                    }
                }
            }
        }
        let (quality, _) = best[0][k - 1];
        if !quality.is_finite() {
            return None;
        }
        let mut triangles = Vec::with_capacity(k - 2);
        let mut stack = vec![(0, k - 1)];
        while let Some((i, j)) = stack.pop() {
            if j > i + 1 {
                let m = best[i][j].1;
                triangles.push([i, m, j]);
                stack.push((i, m));
                stack.push((m, j));
            }
        }
        Some((quality, triangles))
    }

    /// The quality of a triangle a removal would make, on ring positions
    /// `[a, b, c]`: `None` if it is not turned the right way in the
    /// flattening `flat` and along `normal`.
    fn new_quality(
        &self,
        ring: &Ring,
        flat: &[DVec2],
        [a, b, c]: [usize; 3],
        normal: DVec3,
    ) -> Option<f64> {
        let (pa, pb, pc) = (flat[a], flat[b], flat[c]);
        let area2 = (pb - pa).perp_dot(pc - pa);
        let scale =
            (pb - pa).length_squared() + (pc - pb).length_squared() + (pa - pc).length_squared();
        let t = [ring.verts[a], ring.verts[b], ring.verts[c]];
        if area2.is_nan() || area2 <= 1e-12 * scale || self.normal3(t).dot(normal) <= 0.0 {
            return None;
        }
        Some(self.quality3(t))
    }
}
