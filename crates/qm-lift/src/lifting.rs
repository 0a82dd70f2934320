//! Integer lifting on semi-regular quad meshes (paper section 3.2).
//!
//! Level `l` (1 ..= L) splits the samples of the level-`l` mesh into *even*
//! ones (the level `l - 1` mesh, spacing `s = 2^(L-l+1)` in finest-grid
//! units) and *odd* ones: one edge point per coarse edge and one face point
//! per coarse face.
//!
//! **Predict** (paper eq. 5, Kobbelt's interpolatory quad scheme): an edge
//! point is the 4-point rule along its grid line,
//! `(-p0 + 9 p1 + 9 p2 - p3) / 16`; a face point is its tensor product over
//! the surrounding 4 x 4 even points (weights 81, -9 and 1 over 256). Stencils
//! reach across base edges into neighbouring faces. Where a stencil point does
//! not exist (a boundary, or the extension of a grid line beyond an irregular
//! base vertex, where "straight on" has no meaning) it is extrapolated along
//! its line from the three nearest points on the near side,
//! `p0 = 3 p1 - 3 p2 + p3` (two points: `2 p1 - p2`), which turns the 4-point
//! rule into quadratic interpolation there. Missing diagonal points follow the
//! parallelogram rule. Both faces of a base edge see the same points along
//! it, so a shared edge point gets one prediction whichever face computes it.
//!
//! **Update** (paper eqs. 6-7): evens take a share of their neighbouring
//! details. The paper's uniform `A = 1/10` over the 8 neighbours does not keep
//! the mean: with `N` evens there are `2N` edge and `N` face details, and the
//! mean of the finer level equals the mean of the coarser one only if every
//! detail hands out a total weight of exactly `1/4`. [`UpdateRule::MeanPreserving`]
//! does that, `1/8` to each end of an edge detail and `1/16` to each corner of
//! a face detail, which holds at irregular vertices too because the weights
//! belong to the detail, not to the vertex.
//!
//! Every prediction and update is rounded to an integer (floor of value +
//! 1/2) from values the inverse sees unchanged, so the inverse is exact.

use serde::{Deserialize, Serialize};

use crate::frames::{self, Turn};
use crate::layout::Layout;
use crate::mesh::Coord;

type Acc = [i64; 3];

/// How details update the even samples of their level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[non_exhaustive]
pub enum UpdateRule {
    /// No update: a pure interpolating transform.
    None,
    /// The paper's eq. 7: `A = 1/10` of each of the 8 neighbouring details.
    Paper,
    /// Edge details give `1/8` to each end, face details `1/16` to each
    /// corner: the mean is preserved exactly in the regular case.
    #[default]
    MeanPreserving,
}

impl UpdateRule {
    /// `(denominator, edge weight, face weight)`.
    const fn weights(self) -> Option<(i64, i64, i64)> {
        match self {
            UpdateRule::None => None,
            UpdateRule::Paper => Some((10, 1, 1)),
            UpdateRule::MeanPreserving => Some((16, 2, 1)),
        }
    }

    /// Stable numeric code for file headers.
    pub const fn code(self) -> u8 {
        match self {
            UpdateRule::None => 0,
            UpdateRule::Paper => 1,
            UpdateRule::MeanPreserving => 2,
        }
    }

    /// Inverse of [`Self::code`].
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(UpdateRule::None),
            1 => Some(UpdateRule::Paper),
            2 => Some(UpdateRule::MeanPreserving),
            _ => None,
        }
    }
}

/// The lifting transform of one layout.
#[derive(Clone, Copy, Debug)]
pub struct Lifting<'a> {
    layout: &'a Layout,
    update: UpdateRule,
    /// Local frames, with parent-quad normals from this level on.
    frames: Option<u32>,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Direction {
    Forward,
    Inverse,
    /// Odd samples are replaced by their prediction ([`Lifting::predict`]).
    Predict,
}

/// Scratch buffers reused across faces and levels.
struct Scratch {
    pad: Vec<Acc>,
    column: Vec<Acc>,
    /// Update sums of the evens of one face, `(m + 1)^2`.
    local: Vec<Acc>,
    /// Update sums of the evens shared between faces (base vertices and edges).
    shared: Vec<Acc>,
}

impl<'a> Lifting<'a> {
    /// The transform over `layout` with the given update rule.
    pub fn new(layout: &'a Layout, update: UpdateRule) -> Self {
        Lifting {
            layout,
            update,
            frames: None,
        }
    }

    /// Expresses each level's details in the local frame of the coarser
    /// level's surface, normal component first (see [`crate::frames`]).
    pub fn with_frames(mut self, frames: bool) -> Self {
        self.frames = frames.then_some(frames::PARENTS_FROM);
        self
    }

    /// Local frames (like [`Self::with_frames`]) whose normals come from the
    /// parent quads from level `level` on (at least 2), from the level
    /// `l - 1` quads below it; `None` turns frames off.
    pub fn with_parent_frames_from(mut self, level: Option<u32>) -> Self {
        self.frames = level.map(|l| l.max(2));
        self
    }

    /// Analysis, finest to coarsest: turns sample values into the base
    /// vertices' scaling values (ids `0 .. V`) and a detail at every other id.
    pub fn forward(&self, data: &mut [Coord]) {
        let mut scratch = self.scratch();
        for level in (1..=self.layout.level()).rev() {
            self.level(level, data, Direction::Forward, &mut scratch);
            if let Some(from) = self.frames {
                frames::apply(self.layout, level, data, Turn::ToLocal, from);
            }
        }
    }

    /// Synthesis, coarsest to finest: exactly undoes [`Self::forward`].
    pub fn inverse(&self, data: &mut [Coord]) {
        self.inverse_to(data, self.layout.level());
    }

    /// Synthesis up to level `to` only: the samples of that level (see
    /// [`Layout::samples_at`]) then hold its approximation; finer ones keep
    /// their details.
    pub fn inverse_to(&self, data: &mut [Coord], to: u32) {
        self.inverse_levels(data, 0, to);
    }

    /// Synthesis from level `from` (whose samples hold its approximation,
    /// as [`Self::inverse_to`] leaves them) up to level `to`.
    pub fn inverse_levels(&self, data: &mut [Coord], from: u32, to: u32) {
        let mut scratch = self.scratch();
        for level in from + 1..=to.min(self.layout.level()) {
            if let Some(from) = self.frames {
                frames::apply(self.layout, level, data, Turn::ToWorld, from);
            }
            self.level(level, data, Direction::Inverse, &mut scratch);
        }
    }

    /// Replaces every odd sample of `level` by its prediction from the
    /// level's even samples (the level `level - 1` mesh, positions), the
    /// value the forward transform subtracts from it; the other samples are
    /// left as they are, and the update rule plays no part. For tools that
    /// shape a mesh to suit the transform, such as a remesher that makes
    /// the details normal (with [`crate::frames::normals`]).
    pub fn predict(&self, level: u32, data: &mut [Coord]) {
        let mut scratch = self.scratch();
        self.level(level, data, Direction::Predict, &mut scratch);
    }

    fn scratch(&self) -> Scratch {
        let m = self.layout.n() / 2;
        Scratch {
            pad: vec![[0; 3]; (m + 3) * (m + 3)],
            column: vec![[0; 3]; m + 3],
            local: Vec::new(),
            shared: vec![[0; 3]; self.layout.first_interior()],
        }
    }

    /// One level: going forward, predict then update; going back, the
    /// reverse; for [`Direction::Predict`], the prediction alone.
    fn level(&self, level: u32, data: &mut [Coord], dir: Direction, scratch: &mut Scratch) {
        if dir == Direction::Inverse {
            self.update(level, data, -1, scratch);
        }
        for f in 0..self.layout.face_count() {
            self.predict_face(f, level, data, dir, scratch);
        }
        if dir == Direction::Forward {
            self.update(level, data, 1, scratch);
        }
    }

    /// Update step of `level`: evens += sign * round(share of details).
    ///
    /// The details of face `f` are summed per even into a face-local buffer.
    /// An even inside the face hears only from details of this face and is
    /// updated at once; evens on base vertices and edges (ids below the first
    /// face interior, see [`Layout`]) also hear from the faces next door, so
    /// their sums go to a shared accumulator that is rounded at the end.
    fn update(&self, level: u32, data: &mut [Coord], sign: i32, scratch: &mut Scratch) {
        let Some((den, we, wf)) = self.update.weights() else {
            return;
        };
        let layout = self.layout;
        let base = layout.base();
        let s = 1usize << (layout.level() - level + 1);
        let h = s / 2;
        let side = layout.n() + 1;
        let m = layout.n() / s;
        let w = m + 1;
        let shared = &mut scratch.shared;
        let local = &mut scratch.local;
        local.clear();
        local.resize(w * w, [0; 3]);
        let add = |e: &mut Acc, wt: i64, d: Coord| {
            e[0] += wt * d[0] as i64;
            e[1] += wt * d[1] as i64;
            e[2] += wt * d[2] as i64;
        };
        let round = |e: &Acc| -> Coord {
            std::array::from_fn(|k| sign * (e[k] + den / 2).div_euclid(den) as i32)
        };
        for f in 0..layout.face_count() {
            let grid = layout.face_grid(f);
            let owns = |k: u8| base.owns(f as u32, k);
            local.fill([0; 3]);
            // Horizontal edge points on rows of evens.
            for b in 0..=m {
                if (b == 0 && !owns(0)) || (b == m && !owns(2)) {
                    continue;
                }
                let row = &grid[b * s * side..][..side];
                let acc = &mut local[b * w..][..w];
                for a in 0..m {
                    let d = data[row[a * s + h] as usize];
                    add(&mut acc[a], we, d);
                    add(&mut acc[a + 1], we, d);
                }
            }
            // Odd rows: vertical edge points and face points.
            for b in 0..m {
                let row = &grid[(b * s + h) * side..][..side];
                let (lo, hi) = local[b * w..][..2 * w].split_at_mut(w);
                for a in 0..=m {
                    if (a == 0 && !owns(3)) || (a == m && !owns(1)) {
                        continue;
                    }
                    let d = data[row[a * s] as usize];
                    add(&mut lo[a], we, d);
                    add(&mut hi[a], we, d);
                }
                for a in 0..m {
                    let d = data[row[a * s + h] as usize];
                    add(&mut lo[a], wf, d);
                    add(&mut lo[a + 1], wf, d);
                    add(&mut hi[a], wf, d);
                    add(&mut hi[a + 1], wf, d);
                }
            }
            for b in 0..=m {
                let row = &grid[b * s * side..][..side];
                let acc = &local[b * w..][..w];
                let border = b == 0 || b == m;
                for a in 0..=m {
                    let e = &acc[a];
                    let id = row[a * s] as usize;
                    if border || a == 0 || a == m {
                        let t = &mut shared[id];
                        t[0] += e[0];
                        t[1] += e[1];
                        t[2] += e[2];
                    } else if *e != [0; 3] {
                        let delta = round(e);
                        let v = &mut data[id];
                        v[0] += delta[0];
                        v[1] += delta[1];
                        v[2] += delta[2];
                    }
                }
            }
        }
        for (v, e) in data.iter_mut().zip(shared.iter_mut()) {
            if *e != [0; 3] {
                let delta = round(e);
                v[0] += delta[0];
                v[1] += delta[1];
                v[2] += delta[2];
                *e = [0; 3];
            }
        }
    }

    /// Predict step of `level` in face `f`: odd -= P(evens) going forward,
    /// odd += P(evens) going back.
    fn predict_face(
        &self,
        f: usize,
        level: u32,
        data: &mut [Coord],
        dir: Direction,
        scratch: &mut Scratch,
    ) {
        let layout = self.layout;
        let base = layout.base();
        let s = 1usize << (layout.level() - level + 1);
        let h = s / 2;
        let m = layout.n() / s;
        let w = m + 3;
        let grid = layout.face_grid(f);
        let side = layout.n() + 1;
        gather(layout, f, s, data, &mut scratch.pad);
        let pad = &scratch.pad;
        let p = |a: isize, b: isize| pad[(b + 1) as usize * w + (a + 1) as usize];
        let apply = |data: &mut [Coord], id: u32, pred: Acc| {
            let v = &mut data[id as usize];
            for k in 0..3 {
                let q = pred[k] as i32;
                v[k] = match dir {
                    Direction::Forward => v[k] - q,
                    Direction::Inverse => v[k] + q,
                    Direction::Predict => q,
                };
            }
        };
        let owns = |side: u8| base.owns(f as u32, side);
        // Horizontal edge points on rows of evens.
        for b in 0..=m {
            if (b == 0 && !owns(0)) || (b == m && !owns(2)) {
                continue;
            }
            let b = b as isize;
            for a in 0..m as isize {
                let pred = four_point(p(a - 1, b), p(a, b), p(a + 1, b), p(a + 2, b));
                apply(
                    data,
                    grid[b as usize * s * side + a as usize * s + h],
                    round_shift(pred, 4),
                );
            }
        }
        // Odd rows: vertical 4-point sums per column, then vertical edge
        // points and (their 4-point along the row) face points.
        let column = &mut scratch.column;
        for b in 0..m as isize {
            for a in -1..=(m as isize + 1) {
                column[(a + 1) as usize] =
                    four_point(p(a, b - 1), p(a, b), p(a, b + 1), p(a, b + 2));
            }
            let c = |a: isize| column[(a + 1) as usize];
            let y = b as usize * s + h;
            for a in 0..=m as isize {
                if (a == 0 && !owns(3)) || (a == m as isize && !owns(1)) {
                    continue;
                }
                apply(data, grid[y * side + a as usize * s], round_shift(c(a), 4));
            }
            for a in 0..m as isize {
                let pred = four_point(c(a - 1), c(a), c(a + 1), c(a + 2));
                apply(
                    data,
                    grid[y * side + a as usize * s + h],
                    round_shift(pred, 8),
                );
            }
        }
    }
}

/// `-p0 + 9 p1 + 9 p2 - p3` (the 4-point rule times 16).
#[inline]
fn four_point(p0: Acc, p1: Acc, p2: Acc, p3: Acc) -> Acc {
    std::array::from_fn(|k| 9 * (p1[k] + p2[k]) - p0[k] - p3[k])
}

/// `floor(v / 2^shift + 1/2)`.
#[inline]
fn round_shift(v: Acc, shift: u32) -> Acc {
    v.map(|x| (x + (1 << (shift - 1))) >> shift)
}

/// Fills `pad` with the even samples of face `f` at coarse step `s`, plus a
/// ring of one more on every side: from the neighbouring faces where they
/// exist, extrapolated otherwise (see the module docs).
fn gather(layout: &Layout, f: usize, s: usize, data: &[Coord], pad: &mut [Acc]) {
    let m = (layout.n() / s) as isize;
    let w = (m + 3) as usize;
    let at = |a: isize, b: isize| (b + 1) as usize * w + (a + 1) as usize;
    let widen = |c: Coord| c.map(i64::from);
    let fetch = |a: isize, b: isize| {
        layout
            .sample_beyond(f, (a * s as isize) as i32, (b * s as isize) as i32)
            .map(|id| widen(data[id as usize]))
    };
    let grid = layout.face_grid(f);
    let side = layout.n() + 1;
    for b in 0..=m as usize {
        let row = &grid[b * s * side..][..side];
        let out = &mut pad[(b + 1) * w + 1..][..m as usize + 1];
        for (a, p) in out.iter_mut().enumerate() {
            *p = widen(data[row[a * s] as usize]);
        }
    }
    for t in 0..=m {
        // (ghost, then the three nearest points inside on its line, inward)
        let lines = [
            [(-1, t), (0, t), (1, t), (2, t)],
            [(m + 1, t), (m, t), (m - 1, t), (m - 2, t)],
            [(t, -1), (t, 0), (t, 1), (t, 2)],
            [(t, m + 1), (t, m), (t, m - 1), (t, m - 2)],
        ];
        for [(ga, gb), (a0, b0), (a1, b1), (a2, b2)] in lines {
            pad[at(ga, gb)] = match fetch(ga, gb) {
                Some(v) => v,
                None => {
                    let (p0, p1) = (pad[at(a0, b0)], pad[at(a1, b1)]);
                    if m >= 2 {
                        let p2 = pad[at(a2, b2)];
                        std::array::from_fn(|k| 3 * p0[k] - 3 * p1[k] + p2[k])
                    } else {
                        std::array::from_fn(|k| 2 * p0[k] - p1[k])
                    }
                }
            };
        }
    }
    // Diagonal ghosts beyond the four corners.
    for (c, (ga, gb), (ca, cb)) in [
        (0u8, (-1, -1), (0, 0)),
        (1, (m + 1, -1), (m, 0)),
        (2, (m + 1, m + 1), (m, m)),
        (3, (-1, m + 1), (0, m)),
    ] {
        pad[at(ga, gb)] = match layout.sample_diagonal(f, c, s as i32) {
            Some(id) => widen(data[id as usize]),
            None => {
                let (x, y, o) = (pad[at(ga, cb)], pad[at(ca, gb)], pad[at(ca, cb)]);
                std::array::from_fn(|k| x[k] + y[k] - o[k])
            }
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::BaseMesh;

    fn cube(level: u32) -> Layout {
        Layout::new(crate::synthetic::cube(), level).unwrap()
    }

    fn open_grid(level: u32) -> Layout {
        // 3x3 grid of quads minus the centre one: a boundary and a hole.
        let (_, faces) = qm_shapes::holed_grid();
        Layout::new(BaseMesh::new(16, faces).unwrap(), level).unwrap()
    }

    fn pseudo_random(n: usize, seed: u64) -> Vec<Coord> {
        let mut x = seed;
        (0..n)
            .map(|_| {
                std::array::from_fn(|_| {
                    x ^= x << 13;
                    x ^= x >> 7;
                    x ^= x << 17;
                    (x % 65536) as i32
                })
            })
            .collect()
    }

    /// On a smooth closed surface most of the detail energy is along the
    /// coarser surface's normal once frames are on (a third if the frames
    /// were arbitrary; the rest here is the cube-to-sphere grid's uneven
    /// spacing, which is truly tangential).
    #[test]
    fn frames_put_the_energy_in_the_normal() {
        let mesh = crate::synthetic::bumpy_sphere(5);
        let quantizer = crate::Quantizer::fit(mesh.positions(), 16).unwrap();
        let mut data = quantizer.quantize_all(mesh.positions());
        let layout = mesh.layout();
        Lifting::new(layout, UpdateRule::MeanPreserving)
            .with_frames(true)
            .forward(&mut data);
        let mut energy = [0f64; 3];
        for d in &data[layout.base().vertex_count() as usize..] {
            for k in 0..3 {
                energy[k] += (d[k] as f64).powi(2);
            }
        }
        assert!(
            energy[0] > 1.5 * (energy[1] + energy[2]),
            "normal {:.3e}, tangents {:.3e} {:.3e}",
            energy[0],
            energy[1],
            energy[2]
        );
    }

    #[test]
    fn inverse_is_exact_for_every_rule() {
        for layout in [cube(4), open_grid(3), cube(1)] {
            for rule in [
                UpdateRule::None,
                UpdateRule::Paper,
                UpdateRule::MeanPreserving,
            ] {
                for frames in [None, Some(2), Some(3), Some(4), Some(13)] {
                    let original = pseudo_random(layout.sample_count(), 7);
                    let mut data = original.clone();
                    let lifting = Lifting::new(&layout, rule).with_parent_frames_from(frames);
                    lifting.forward(&mut data);
                    assert_ne!(data, original);
                    let coefs = data.clone();
                    lifting.inverse(&mut data);
                    assert_eq!(data, original, "{rule:?}, parent frames from {frames:?}");
                    // In two steps, through any level in between.
                    for middle in 0..=layout.level() {
                        let mut data = coefs.clone();
                        lifting.inverse_to(&mut data, middle);
                        lifting.inverse_levels(&mut data, middle, layout.level());
                        assert_eq!(data, original, "{rule:?}, {frames:?}, via {middle}");
                    }
                }
            }
        }
    }

    /// A level whose details are all zero comes out of the inverse as the
    /// prediction alone: its update adds nothing and its frames turn
    /// zeros, so [`Lifting::predict`] makes the same values (what a
    /// decoder uses for the levels a short prefix has no details of).
    #[test]
    fn a_level_without_details_is_its_prediction() {
        for layout in [cube(4), open_grid(3)] {
            for frames in [None, Some(2), Some(3)] {
                let lifting = Lifting::new(&layout, UpdateRule::MeanPreserving)
                    .with_parent_frames_from(frames);
                let mut coefs = pseudo_random(layout.sample_count(), 11);
                lifting.forward(&mut coefs);
                for level in 1..=layout.level() {
                    let mut data = coefs.clone();
                    let odd: Vec<u32> = {
                        let even = layout.samples_at(level - 1);
                        let all = layout.samples_at(level);
                        all.into_iter()
                            .filter(|s| even.binary_search(s).is_err())
                            .collect()
                    };
                    for &s in &odd {
                        data[s as usize] = [0; 3];
                    }
                    lifting.inverse_to(&mut data, level - 1);
                    let mut predicted = data.clone();
                    lifting.inverse_levels(&mut data, level - 1, level);
                    lifting.predict(level, &mut predicted);
                    assert_eq!(data, predicted, "level {level}, frames {frames:?}");
                    assert!(odd.iter().any(|&s| data[s as usize] != [0; 3]));
                }
            }
        }
    }

    /// A plane is reproduced exactly by every stencil (cubic precision inside,
    /// quadratic at boundaries), so all details vanish without update.
    #[test]
    fn linear_functions_have_zero_details() {
        let layout = open_grid(3);
        let n = layout.n() as i32;
        let mut data = vec![[0; 3]; layout.sample_count()];
        // Sample position in world grid units: face (x, y) of the 3x3 layout.
        let mut fi = 0;
        for y in 0..3i32 {
            for x in 0..3i32 {
                if (x, y) == (1, 1) {
                    continue;
                }
                for j in 0..=n {
                    for i in 0..=n {
                        let (u, v) = (x * n + i, y * n + j);
                        data[layout.sample(fi, i as usize, j as usize) as usize] =
                            [3 * u + 5 * v, 7 * u - 2 * v, 11];
                    }
                }
                fi += 1;
            }
        }
        let lifting = Lifting::new(&layout, UpdateRule::None);
        lifting.forward(&mut data);
        let nonzero = data[16..].iter().filter(|d| **d != [0, 0, 0]).count();
        assert_eq!(nonzero, 0);
    }

    /// Without update the evens stay as they are, so each level's details
    /// are the samples minus [`Lifting::predict`]'s values, and with frames
    /// their first coordinate is their length along [`frames::normals`].
    #[test]
    fn predict_and_normals_are_what_the_transform_uses() {
        let mesh = crate::synthetic::bumpy_sphere(4);
        let layout = mesh.layout();
        let quantizer = crate::Quantizer::fit(mesh.positions(), 16).unwrap();
        let samples = quantizer.quantize_all(mesh.positions());
        let lifting = Lifting::new(layout, UpdateRule::None);
        let mut world = samples.clone();
        lifting.forward(&mut world);
        for source in [2, frames::PARENTS_FROM, 4] {
            let mut local = samples.clone();
            lifting
                .with_parent_frames_from(Some(source))
                .forward(&mut local);
            let mut checked = 0;
            for level in 1..=layout.level() {
                let mut predicted = samples.clone();
                lifting.predict(level, &mut predicted);
                let normals = frames::normals(layout, level, &samples, source);
                let odd = layout.samples_at(level).len() - layout.samples_at(level - 1).len();
                assert_eq!(normals.len(), odd, "level {level}");
                for &(id, normal) in &normals {
                    let id = id as usize;
                    let detail: [i64; 3] =
                        std::array::from_fn(|k| (samples[id][k] - predicted[id][k]) as i64);
                    assert_eq!(
                        detail,
                        world[id].map(i64::from),
                        "level {level}, sample {id}"
                    );
                    let n = normal.map(|c| c as f64);
                    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                    assert!(len > 0.0);
                    let along: f64 = (0..3).map(|k| detail[k] as f64 * n[k] / len).sum();
                    assert!(
                        (local[id][0] as f64 - along).abs() <= 3.0,
                        "level {level}, sample {id}: {} against {along}",
                        local[id][0]
                    );
                    checked += 1;
                }
            }
            assert_eq!(checked, layout.sample_count() - 8);
        }
    }
}
