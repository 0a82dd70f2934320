//! Where every sample of a semi-regular mesh lives.
//!
//! Each base face carries an `(n + 1) x (n + 1)` grid, `n = 2^level`, with
//! face-local coordinates `(i, j)`: corner 0 at `(0, 0)`, corner 1 at `(n, 0)`,
//! corner 2 at `(n, n)`, corner 3 at `(0, n)`. Samples on base vertices and base
//! edges are shared by the faces that meet there and stored once:
//!
//! | ids | what |
//! |---|---|
//! | `0 .. V` | base vertices |
//! | `V .. V + E (n - 1)` | edge interiors, `n - 1` per edge, from `ends[0]` |
//! | the rest | face interiors, `(n - 1)^2` per face, row-major |

use crate::base::BaseMesh;
use crate::{Error, Result};

/// Highest subdivision level supported (a 4097 x 4097 grid per base face).
pub const MAX_LEVEL: u32 = 12;

/// Most samples a layout may hold (keeps ids in `u32` and memory bounded).
pub const MAX_SAMPLES: u64 = 1 << 28;

/// How a layout numbers its samples (the table in the module docs), as
/// arithmetic: the id of a point from where it lies, and back.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Numbering {
    vertices: u32,
    edges: u32,
    level: u32,
}

/// Where a sample lies ([`Numbering::place`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Place {
    /// On a base vertex.
    Vertex(u32),
    /// Inside base edge `edge`, point `along` (`1..n`) from its `ends[0]`.
    Edge { edge: u32, along: u32 },
    /// Inside base face `face`, at `(i, j)` (both in `1..n`).
    Face { face: u32, i: u32, j: u32 },
}

impl Numbering {
    /// The numbering of `base` refined `level` times (its ids must fit in
    /// `u32`, which [`Layout::new`] checks).
    pub fn new(base: &BaseMesh, level: u32) -> Self {
        Numbering {
            vertices: base.vertex_count(),
            edges: base.edges().len() as u32,
            level,
        }
    }

    /// Grid size per face side, `2^level`.
    #[inline]
    pub const fn n(self) -> u32 {
        1 << self.level
    }

    /// The refinement level this numbering counts.
    #[inline]
    pub const fn level(self) -> u32 {
        self.level
    }

    /// The numbering of the same base mesh refined `level` times.
    #[inline]
    pub const fn at_level(self, level: u32) -> Self {
        Numbering { level, ..self }
    }

    /// The id, in `finer` (a numbering of the same base mesh at this
    /// level or a finer one, [`Self::at_level`]), of this numbering's
    /// sample `s`: the same point, counted among more samples. The order of
    /// ids is kept, so a coarse level's samples come in the same order in
    /// either numbering.
    #[inline]
    pub const fn refine(self, s: u32, finer: Numbering) -> u32 {
        let shift = finer.level - self.level;
        match self.place(s) {
            Place::Vertex(v) => v,
            Place::Edge { edge, along } => finer.edge_sample(edge, along << shift),
            Place::Face { face, i, j } => finer.face_sample(face, i << shift, j << shift),
        }
    }

    /// The first id of the face interiors.
    #[inline]
    pub const fn first_interior(self) -> u32 {
        self.vertices + self.edges * (self.n() - 1)
    }

    /// The id of point `along` (`1..n`) of base edge `edge`, from its
    /// `ends[0]`.
    #[inline]
    pub const fn edge_sample(self, edge: u32, along: u32) -> u32 {
        self.vertices + edge * (self.n() - 1) + along - 1
    }

    /// The id of interior point `(i, j)` (both in `1..n`) of base face
    /// `face`.
    #[inline]
    pub const fn face_sample(self, face: u32, i: u32, j: u32) -> u32 {
        let m = self.n() - 1;
        self.first_interior() + (face * m + j - 1) * m + i - 1
    }

    /// The id of point `t` (`1..n`, from corner `side`) of side `side` of
    /// base face `face`: the point of its edge counted from the edge's
    /// `ends[0]` when the face owns the edge, from the other end if not.
    #[inline]
    pub fn side_sample(self, base: &BaseMesh, face: u32, side: u8, t: u32) -> u32 {
        let along = if base.owns(face, side) {
            t
        } else {
            self.n() - t
        };
        self.edge_sample(base.face_edges()[face as usize][side as usize], along)
    }

    /// Where sample `s` lies.
    #[inline]
    pub const fn place(self, s: u32) -> Place {
        let m = self.n() - 1;
        if s < self.vertices {
            Place::Vertex(s)
        } else if s < self.first_interior() {
            let r = s - self.vertices;
            Place::Edge {
                edge: r / m,
                along: r % m + 1,
            }
        } else {
            let r = s - self.first_interior();
            let (face, r) = (r / (m * m), r % (m * m));
            Place::Face {
                face,
                i: r % m + 1,
                j: r / m + 1,
            }
        }
    }
}

/// The sample layout of a base mesh refined `level` times.
#[derive(Clone, Debug)]
pub struct Layout {
    base: BaseMesh,
    level: u32,
    /// `grid[f * (n+1)^2 + j * (n+1) + i]` = sample id.
    grid: Vec<u32>,
    sample_count: u32,
}

/// Point at parameter `t` along side `k` (from corner `k`) and depth `d` into
/// the face, in face-local coordinates of an `n`-grid.
pub const fn side_point(n: i32, k: u8, t: i32, d: i32) -> (i32, i32) {
    match k & 3 {
        0 => (t, d),
        1 => (n - d, t),
        2 => (n - t, n - d),
        _ => (d, n - t),
    }
}

/// Inverse of [`side_point`]: parameter and depth of `(i, j)` relative to side `k`.
pub const fn side_coords(n: i32, k: u8, i: i32, j: i32) -> (i32, i32) {
    match k & 3 {
        0 => (i, j),
        1 => (j, n - i),
        2 => (n - i, n - j),
        _ => (n - j, i),
    }
}

impl Layout {
    /// Lays out the samples of `base` refined `level` times.
    pub fn new(base: BaseMesh, level: u32) -> Result<Self> {
        Self::check(&base, level)?;
        let n = 1usize << level;
        let side = n + 1;
        let numbering = Numbering::new(&base, level);
        let samples = base.sample_count(level) as u32;
        let mut grid = vec![0u32; base.faces().len() * side * side];
        for (fi, corners) in base.faces().iter().enumerate() {
            let g = &mut grid[fi * side * side..(fi + 1) * side * side];
            for j in 1..n {
                for i in 1..n {
                    g[j * side + i] = numbering.face_sample(fi as u32, i as u32, j as u32);
                }
            }
            for k in 0..4u8 {
                let (ci, cj) = side_point(n as i32, k, 0, 0);
                g[cj as usize * side + ci as usize] = corners[k as usize];
                for t in 1..n {
                    let (i, j) = side_point(n as i32, k, t as i32, 0);
                    g[j as usize * side + i as usize] =
                        numbering.side_sample(&base, fi as u32, k, t as u32);
                }
            }
        }
        Ok(Layout {
            base,
            level,
            grid,
            sample_count: samples,
        })
    }

    /// Whether `base` refined `level` times can be laid out: the error
    /// [`Self::new`] would give (a level above [`MAX_LEVEL`], more samples
    /// than [`MAX_SAMPLES`]), found without building anything.
    pub fn check(base: &BaseMesh, level: u32) -> Result<()> {
        if level > MAX_LEVEL {
            return Err(Error::LevelTooHigh {
                level,
                max: MAX_LEVEL,
            });
        }
        let n = 1u64 << level;
        let samples = base.sample_count(level);
        let grid_len = base.faces().len() as u64 * (n + 1) * (n + 1);
        if samples > MAX_SAMPLES || grid_len > 2 * MAX_SAMPLES {
            return Err(Error::TooManySamples {
                samples,
                max: MAX_SAMPLES,
            });
        }
        Ok(())
    }

    /// The base mesh.
    #[inline]
    pub fn base(&self) -> &BaseMesh {
        &self.base
    }

    /// The number of refinement levels.
    #[inline]
    pub fn level(&self) -> u32 {
        self.level
    }

    /// Grid size per face side, `2^level`.
    #[inline]
    pub fn n(&self) -> usize {
        1 << self.level
    }

    /// Number of samples (distinct vertices of the finest mesh).
    #[inline]
    pub fn sample_count(&self) -> usize {
        self.sample_count as usize
    }

    /// First id of the face interiors: ids below it lie on base vertices and
    /// edges, shared by the faces that meet there.
    pub(crate) fn first_interior(&self) -> usize {
        self.numbering().first_interior() as usize
    }

    /// The numbering of the samples, as arithmetic.
    #[inline]
    pub fn numbering(&self) -> Numbering {
        Numbering::new(&self.base, self.level)
    }

    /// Number of base faces.
    #[inline]
    pub fn face_count(&self) -> usize {
        self.base.faces().len()
    }

    /// The grid of face `f`: `(n + 1)^2` sample ids, row-major.
    #[inline]
    pub fn face_grid(&self, f: usize) -> &[u32] {
        let side = self.n() + 1;
        &self.grid[f * side * side..(f + 1) * side * side]
    }

    /// Sample id at `(i, j)` of face `f`.
    #[inline]
    pub fn sample(&self, f: usize, i: usize, j: usize) -> u32 {
        let side = self.n() + 1;
        self.grid[(f * side + j) * side + i]
    }

    /// Sample id of a point that may lie just outside face `f`, across one of
    /// its sides (at most one coordinate out of `0..=n`). `None` when there is
    /// no face there (a boundary) or when the point lies on the extension of a
    /// side beyond an irregular corner, where "straight on" has no meaning.
    pub fn sample_beyond(&self, f: usize, i: i32, j: i32) -> Option<u32> {
        let n = self.n() as i32;
        let inside = |x: i32| (0..=n).contains(&x);
        if inside(i) && inside(j) {
            return Some(self.sample(f, i as usize, j as usize));
        }
        let k: u8 = if j < 0 && inside(i) {
            0
        } else if i > n && inside(j) {
            1
        } else if j > n && inside(i) {
            2
        } else if i < 0 && inside(j) {
            3
        } else {
            return None;
        };
        let (t, d) = side_coords(n, k, i, j);
        // On a corner line: only straight on through a regular vertex.
        if t == 0 || t == n {
            let corner = if t == 0 { k } else { (k + 1) & 3 };
            if !self.base.is_regular(self.base.faces()[f][corner as usize]) {
                return None;
            }
        }
        let other = self.base.across(f as u32, k);
        if !other.exists() {
            return None;
        }
        let (gi, gj) = side_point(n, other.side, n - t, -d);
        if inside(gi) && inside(gj) {
            Some(self.sample(other.face as usize, gi as usize, gj as usize))
        } else {
            None
        }
    }

    /// Sample id diagonally beyond corner `c` of face `f`, at distance `d` along
    /// both grid directions: only defined around a regular vertex.
    pub fn sample_diagonal(&self, f: usize, c: u8, d: i32) -> Option<u32> {
        if !self.base.is_regular(self.base.faces()[f][c as usize]) {
            return None;
        }
        // Around a regular vertex the face diagonally opposite is two steps on.
        let (g, gc) = self.base.rotate(f as u32, c)?;
        let (h, hc) = self.base.rotate(g, gc)?;
        let n = self.n() as i32;
        let (i, j) = side_point(n, hc, d, d);
        Some(self.sample(h as usize, i as usize, j as usize))
    }

    /// The quads of the mesh at refinement `level` (0 = base mesh, up to
    /// [`Self::level`]), as sample ids, counter-clockwise.
    pub fn quads(&self, level: u32) -> Vec<[u32; 4]> {
        let level = level.min(self.level);
        let s = 1usize << (self.level - level);
        let cells = 1usize << level;
        let mut quads = Vec::with_capacity(self.face_count() * cells * cells);
        for f in 0..self.face_count() {
            for b in 0..cells {
                for a in 0..cells {
                    let (i, j) = (a * s, b * s);
                    quads.push([
                        self.sample(f, i, j),
                        self.sample(f, i + s, j),
                        self.sample(f, i + s, j + s),
                        self.sample(f, i, j + s),
                    ]);
                }
            }
        }
        quads
    }

    /// The samples that exist at refinement `level`, in increasing id order
    /// (coarser levels use a subset of the finest samples).
    pub fn samples_at(&self, level: u32) -> Vec<u32> {
        let level = level.min(self.level);
        let s = 1usize << (self.level - level);
        let n = self.n();
        let mut used = vec![false; self.sample_count()];
        for f in 0..self.face_count() {
            for j in (0..=n).step_by(s) {
                for i in (0..=n).step_by(s) {
                    used[self.sample(f, i, j) as usize] = true;
                }
            }
        }
        (0..self.sample_count() as u32)
            .filter(|&i| used[i as usize])
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::cube;

    #[test]
    fn side_coords_invert_side_point() {
        for k in 0..4 {
            for (t, d) in [(0, 0), (3, 1), (8, 5), (2, -2)] {
                let (i, j) = side_point(8, k, t, d);
                assert_eq!(side_coords(8, k, i, j), (t, d));
            }
        }
    }

    #[test]
    fn every_sample_is_used_and_counts_match() {
        let layout = Layout::new(cube(), 3).unwrap();
        assert_eq!(layout.sample_count(), 6 * 64 + 2);
        let mut seen = vec![0u32; layout.sample_count()];
        for f in 0..6 {
            for &s in layout.face_grid(f) {
                seen[s as usize] += 1;
            }
        }
        assert!(seen.iter().all(|&c| c > 0));
        // Corners of a cube are shared by three faces, edge samples by two.
        assert_eq!(seen.iter().filter(|&&c| c == 3).count(), 8);
        assert_eq!(seen.iter().filter(|&&c| c == 2).count(), 12 * 7);
        assert_eq!(layout.quads(3).len(), 6 * 64);
        assert_eq!(layout.samples_at(0).len(), 8);
        assert_eq!(layout.samples_at(1).len(), 26);
    }

    /// [`Numbering::place`] finds every grid point where the grid has it:
    /// corners on their vertex, side points on their edge (counted from
    /// `ends[0]`), the rest inside their face.
    #[test]
    fn numbering_places_every_sample_where_the_grid_has_it() {
        let layout = Layout::new(cube(), 3).unwrap();
        let numbering = layout.numbering();
        let n = layout.n() as u32;
        let base = layout.base();
        for f in 0..layout.face_count() {
            for j in 0..=n {
                for i in 0..=n {
                    let s = layout.sample(f, i as usize, j as usize);
                    let place = numbering.place(s);
                    let on_side = |x: u32| x == 0 || x == n;
                    match (on_side(i), on_side(j)) {
                        (true, true) => assert_eq!(place, Place::Vertex(s)),
                        (false, false) => {
                            assert_eq!(
                                place,
                                Place::Face {
                                    face: f as u32,
                                    i,
                                    j
                                }
                            );
                            assert_eq!(numbering.face_sample(f as u32, i, j), s);
                        }
                        _ => {
                            let Place::Edge { edge, along } = place else {
                                panic!("{s} at ({i}, {j}) of face {f}: {place:?}");
                            };
                            assert_eq!(numbering.edge_sample(edge, along), s);
                            // Point `along` of the edge, from `ends[0]`.
                            let e = base.edges()[edge as usize];
                            let from = (0..4).any(|c| {
                                let (ci, cj) = side_point(n as i32, c, 0, 0);
                                layout.sample(f, ci as usize, cj as usize) == e.ends[0]
                                    && (i as i32 - ci).abs() + (j as i32 - cj).abs() == along as i32
                            });
                            assert!(from, "{s}: point {along} of edge {edge}");
                        }
                    }
                }
            }
        }
    }

    /// A coarse numbering's ids refine to the finer layout's ids of the
    /// same grid points, in the same order.
    #[test]
    fn refined_ids_are_the_same_points_in_the_same_order() {
        let coarse = Layout::new(cube(), 2).unwrap();
        let fine = Layout::new(cube(), 4).unwrap();
        let (from, to) = (coarse.numbering(), fine.numbering());
        assert_eq!(from.at_level(4), to);
        for f in 0..coarse.face_count() {
            for j in 0..=4 {
                for i in 0..=4 {
                    let s = coarse.sample(f, i, j);
                    assert_eq!(from.refine(s, to), fine.sample(f, 4 * i, 4 * j));
                    assert_eq!(from.refine(s, from), s);
                }
            }
        }
        let refined: Vec<u32> = (0..coarse.sample_count() as u32)
            .map(|s| from.refine(s, to))
            .collect();
        assert!(refined.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(refined, fine.samples_at(2));
    }

    #[test]
    fn shared_edges_agree_and_beyond_lookups_land_next_door() {
        let layout = Layout::new(cube(), 2).unwrap();
        let n = 4;
        for f in 0..6 {
            for k in 0..4u8 {
                let other = layout.base().across(f as u32, k);
                for t in 0..=n {
                    let (i, j) = side_point(n, k, t, 0);
                    let (gi, gj) = side_point(n, other.side, n - t, 0);
                    assert_eq!(
                        layout.sample(f, i as usize, j as usize),
                        layout.sample(other.face as usize, gi as usize, gj as usize)
                    );
                }
                // One step outside, mid-side: the neighbour's first interior row.
                let (i, j) = side_point(n, k, 2, -1);
                let (gi, gj) = side_point(n, other.side, 2, 1);
                assert_eq!(
                    layout.sample_beyond(f, i, j),
                    Some(layout.sample(other.face as usize, gi as usize, gj as usize))
                );
                // Straight on past a cube corner (valence 3) is undefined.
                let (i, j) = side_point(n, k, 0, -1);
                assert_eq!(layout.sample_beyond(f, i, j), None);
            }
        }
    }

    #[test]
    fn straight_through_a_regular_vertex() {
        // 2x2 grid; the centre vertex 4 is regular.
        let base = BaseMesh::new(9, qm_shapes::grid_quads(2, 2)).unwrap();
        let layout = Layout::new(base, 1).unwrap();
        // Face 0 spans the lower-left quarter; its corner 2 is the centre.
        // One step right of (2, 2) along row 2 is face 1's (1, 2) ...
        assert_eq!(layout.sample_beyond(0, 3, 2), Some(layout.sample(1, 1, 2)));
        // ... and diagonally beyond the centre lies face 3's (1, 1).
        assert_eq!(
            layout.sample_diagonal(0, 2, 1),
            Some(layout.sample(3, 1, 1))
        );
    }
}
