//! The level a decoded prefix supports, by the decoder's own estimate of
//! its error.
//!
//! A prefix of a `.qm` stream knows the coarse levels' details well and the
//! finest levels' barely: decoding it at the finest level gives many
//! vertices that add nothing. The decoder estimates two things from what it
//! knows, both as RMS distances along the surface normal, in model units:
//!
//! - **What is still missing** ([`Estimate::remaining`]): how far the finest
//!   level at this prefix is from the finest level of the complete stream.
//!   After the passes down to weighted plane `P`, a level-`j` coordinate
//!   whose weight is `s` bits (`bits_per_level (L - j)`, plus
//!   `normal_bits` for the normal one) is known down to its bit `b = P - s`:
//!   a significant one to within `t = 2^b` (uniform error, variance
//!   `t^2 / 12`, the reconstruction being the centre of its interval), an
//!   insignificant one only as below `t`. For the latter the mean square
//!   is a measured law of the share of the level's coordinates that are
//!   significant (few significant ones: the rest are small; see
//!   [`BELOW_SCALE`]). A level-`j`
//!   coefficient moves a patch of about `4^(L-j)` finest samples as a hat,
//!   whose squared norm is `κ 4^(L-j)` with `κ = 4/9` (a bilinear hat on
//!   the grid), so the mean squared distance over the finest samples is
//!   `Σ κ 4^(L-j) w_c E[e^2] / N`, with `w_c` the share of the coordinate
//!   that moves the surface: 1 for the normal component and 0 for the
//!   tangential ones when the details are in local frames, a third each in
//!   world axes. The base values' unknown low bits count the same way (a
//!   base value is a hat over the whole base face around it). The estimate
//!   counts what the stream has not delivered; a remesh's own distance to
//!   the input it was made from is not in the stream and not in the
//!   estimate.
//! - **What a coarser level leaves out** ([`Estimate::gaps`]): the RMS
//!   distance between the surface of level `l` and that of the finest level,
//!   both at this prefix, measured on the decoded positions. Between two
//!   consecutive levels it is the distance of level `j + 1`'s samples from
//!   level `j`'s bilinear quads along the quads' normals (corners weighing
//!   a quarter, edge points a half, centres one, as they are shared); the
//!   bands of different levels are taken as orthogonal, so `gaps[l]^2` is the
//!   sum over `j >= l`. Levels above the finest one with a significant
//!   coefficient add no detail, only the subdivision's smoothing, which
//!   shrinks fourfold per level: the first of them (and level 1 at least)
//!   is measured, the rest extrapolated, so a short prefix is not lifted
//!   to the finest level.
//!
//! A level's own error is then `sqrt(remaining^2 + gaps[l]^2)` (the known
//! details and the unknown rest taken as uncorrelated), and
//! [`LevelChoice::Auto`] takes the coarsest level within a tolerance
//! ([`DEFAULT_TOLERANCE_DB`]) of the finest one's, that is with
//! `gaps[l] <= remaining sqrt(10^(tol / 10) - 1)`; the complete stream
//! decodes at the finest level.

use qm_ezw::Decoded;
use qm_lift::{BaseMesh, Coord, Layout};

use crate::container::Header;

/// How a decoder chooses the level of the mesh it outputs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum LevelChoice {
    /// The coarsest level whose estimated error is within the tolerance of
    /// the finest level's at the same prefix (see the module docs); the
    /// finest level once the stream is complete.
    #[default]
    Auto,
    /// The finest level of the file, whatever the prefix.
    Finest,
    /// This level (the finest if the file has fewer).
    Fixed(u32),
}

impl From<u32> for LevelChoice {
    fn from(level: u32) -> Self {
        LevelChoice::Fixed(level)
    }
}

/// How much worse, in dB of estimated PSNR, [`LevelChoice::Auto`] lets the
/// level it chooses be than the finest level at the same prefix.
pub const DEFAULT_TOLERANCE_DB: f64 = 0.05;

/// Share of a hat's squared norm per finest sample it covers: a bilinear
/// hat of half-width `h` samples has `(2h/3)^2` summed over its grid.
const KAPPA: f64 = 4.0 / 9.0;

/// The decoder's estimate of the error of one decoded prefix (module docs).
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct Estimate {
    /// RMS distance, in model units, from the finest level at this prefix
    /// to the finest level of the complete stream.
    pub remaining: f64,
    /// `gaps[l]`: RMS distance between the surfaces of level `l` and of the
    /// finest level, both at this prefix (`gaps[L]` is 0).
    pub gaps: Vec<f64>,
    /// Bounding-box diagonal of the decoded mesh, the PSNR's reference.
    pub diagonal: f64,
}

impl Estimate {
    /// The estimated RMS distance of level `level` at this prefix from the
    /// complete stream's finest mesh.
    pub fn error(&self, level: u32) -> f64 {
        let gap = self.gaps.get(level as usize).copied().unwrap_or(0.0);
        self.remaining.hypot(gap)
    }

    /// [`Self::error`] as PSNR, `20 log10(diagonal / error)` (infinite for
    /// no error).
    pub fn psnr_db(&self, level: u32) -> f64 {
        psnr_db(self.diagonal, self.error(level))
    }

    /// The coarsest level whose error is within `tolerance_db` of the
    /// finest level's.
    pub fn coarsest_within(&self, tolerance_db: f64) -> u32 {
        let finest = self.gaps.len().saturating_sub(1) as u32;
        let ratio = (10f64.powf(tolerance_db.max(0.0) / 10.0) - 1.0).sqrt();
        let allowed = self.remaining * ratio;
        (0..=finest)
            .find(|&l| self.gaps[l as usize] <= allowed)
            .unwrap_or(finest)
    }
}

/// `20 log10(diagonal / rms)`, infinite for `rms = 0`.
pub fn psnr_db(diagonal: f64, rms: f64) -> f64 {
    20.0 * (diagonal / rms).log10()
}

/// Sum of squared normal distances and their weight, to be divided.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct GapSum {
    sum: f64,
    weight: f64,
}

impl GapSum {
    /// The RMS distance in quantized units.
    fn rms(self) -> f64 {
        if self.weight > 0.0 {
            (self.sum / self.weight).sqrt()
        } else {
            0.0
        }
    }
}

/// The estimated RMS distance, in quantized units squared per finest
/// sample, that the unknown parts of the coefficients and base values of
/// `decoded` leave (see the module docs), times the quantization step.
/// `levels` are those of the decoded forest's nodes; `base_mesh` counts
/// every level's coefficients, built or not.
pub(crate) fn remaining(
    header: &Header,
    base_mesh: &BaseMesh,
    levels: &[u8],
    decoded: &Decoded,
    base: u32,
) -> f64 {
    let big_l = header.level as usize;
    let plane = header.planes as i32 - decoded.passes as i32;
    let weighting = header.stream_params().weighting;
    let world = header.frames == 0;
    // Per level and coordinate: significant coordinates, and the sum of
    // their squares.
    let mut significant = vec![[0u64; 3]; big_l + 1];
    let mut squares = vec![[0f64; 3]; big_l + 1];
    for e in &decoded.nonzero {
        let (l, c) = (levels[e.node as usize] as usize, e.coord as usize);
        significant[l][c] += 1;
        squares[l][c] += f64::from(e.value).powi(2);
    }
    // In a pass the stream ended in, the levels it finished are known one
    // bit further; the others are taken as they were before it, so that the
    // estimate does not rise while a pass brings new coordinates in.
    let progress = &decoded.progress;
    let mut sum = 0.0;
    for c in 0..3 {
        let weight = match (world, c) {
            (true, _) => 1.0 / 3.0,
            (false, 0) => 1.0,
            (false, _) => continue,
        };
        // Mean square of the coarser level's coordinates, as estimated.
        let mut coarser: Option<f64> = None;
        for j in 1..=big_l {
            let count =
                (base_mesh.sample_count(j as u32) - base_mesh.sample_count(j as u32 - 1)) as f64;
            let finished = decoded.truncated && j as u32 <= progress.levels;
            let fresh = match progress.fresh.get(j - 1) {
                Some(f) if decoded.truncated && !finished => u64::from(f[c]),
                _ => 0,
            };
            let s = (significant[j][c] - fresh) as f64;
            let shift = weighting.bits_per_level as i32 * (big_l - j) as i32
                + if c == 0 {
                    weighting.normal_bits as i32
                } else {
                    0
                }
                + i32::from(finished);
            let b = plane - shift;
            if b <= 0 || count == 0.0 {
                coarser = Some(squares[j][c] / count.max(1.0));
                continue;
            }
            let t = 2f64.powi(b);
            let mut below = below_share(s, count) * t * t;
            if s == 0.0
                && let Some(m) = coarser
            {
                below = below.min(m / FINER_DECAY);
            }
            // Those new in the pass in progress are at the centre of
            // `[t/2, t)`; they count as unknown.
            let known = squares[j][c] - fresh as f64 * (0.75 * t).powi(2);
            coarser = Some((known.max(0.0) + (count - s) * below) / count);
            let energy = s * t * t / 12.0 + (count - s) * below;
            sum += weight * KAPPA * 4f64.powi((big_l - j) as i32) * energy;
        }
    }
    // Base values: their unknown low bits, uniform below the lowest known.
    let k = header.stream_params().base_bits as i32;
    let s0 = weighting.base_shift(header.level as u32) as i32;
    let unknown = (plane - s0 - i32::from(decoded.truncated && progress.base)).clamp(0, k);
    if unknown > 0 {
        let t = 2f64.powi(unknown);
        // Three world coordinates, a third of each along the normal.
        sum += KAPPA * 4f64.powi(big_l as i32) * base as f64 * t * t / 12.0;
    }
    let samples = base_mesh.sample_count(big_l as u32);
    (sum / samples.max(1) as f64).sqrt() * header.step * CALIBRATION
}

/// The model's RMS is scaled by `10^(2/20)`: unscaled, it comes out 2 dB
/// below the true distance in the median over a set of inputs and
/// prefixes (docs/decisions/025-decoder-error-model.md).
const CALIBRATION: f64 = 1.26;

/// Mean square, in units of `t^2`, of the `count - significant`
/// coordinates of a level still below their threshold `t`
/// ([`BELOW_SCALE`]).
fn below_share(significant: f64, count: f64) -> f64 {
    let share = significant.max(NONE_SIGNIFICANT) / count;
    BELOW_SCALE * share.powf(BELOW_POWER)
}

/// A level none of whose coordinates is significant yet is taken to hold
/// at most a quarter of the coarser level's mean square per coordinate:
/// details of a surface shrink from one level to the next (by four in
/// energy on a smooth one; less on a noisy scan). Without this bound the
/// first cuts' estimates are far too pessimistic
/// (docs/decisions/025-decoder-error-model.md).
const FINER_DECAY: f64 = 4.0;

/// Mean square of the coordinates still below their threshold `t`, in
/// units of `t^2`, is `BELOW_SCALE * share^BELOW_POWER`, `share` being the
/// part of the level's coordinates already significant: a law of the
/// median mean square measured on the true coefficients of the
/// development models' streams, which a Laplacian law through the share
/// overestimates (docs/decisions/025-decoder-error-model.md).
const BELOW_SCALE: f64 = 0.28;

/// See [`BELOW_SCALE`].
const BELOW_POWER: f64 = 0.43;

/// The count of significant coordinates a level with none is taken to
/// have, for [`BELOW_SCALE`]'s share (what such levels' true mean squares
/// are: docs/decisions/025-decoder-error-model.md).
const NONE_SIGNIFICANT: f64 = 0.1;

/// The values of the samples of level `level` (after synthesis to that
/// level), face by face, each face's `(2^level + 1)^2` grid row by row.
pub(crate) fn level_grid(layout: &Layout, level: u32, values: &[Coord], out: &mut Vec<Coord>) {
    let n = layout.n();
    let s = 1usize << (layout.level() - level);
    out.clear();
    for f in 0..layout.face_count() {
        for j in (0..=n).step_by(s) {
            for i in (0..=n).step_by(s) {
                out.push(values[layout.sample(f, i, j) as usize]);
            }
        }
    }
}

/// Writes a [`level_grid`] back into `values`: the level's samples as
/// they were when it was taken.
pub(crate) fn put_level_grid(layout: &Layout, level: u32, grid: &[Coord], values: &mut [Coord]) {
    let n = layout.n();
    let s = 1usize << (layout.level() - level);
    let mut grid = grid.iter();
    for f in 0..layout.face_count() {
        for j in (0..=n).step_by(s) {
            for i in (0..=n).step_by(s) {
                values[layout.sample(f, i, j) as usize] = *grid.next().expect("a level grid");
            }
        }
    }
}

/// The normal distances of level `level + 1`'s samples (in `fine`, after
/// synthesis to that level) from level `level`'s bilinear quads (`coarse`,
/// a [`level_grid`]), in quantized units. `moved` says whether the
/// synthesis moved level `level`'s own samples (the update by the details
/// of level `level + 1`); when not, the quads' corners are exactly on them
/// and add nothing but their weight.
pub(crate) fn step_gap(
    layout: &Layout,
    level: u32,
    coarse: &[Coord],
    fine: &[Coord],
    moved: bool,
) -> GapSum {
    let s = 1usize << (layout.level() - level);
    let h = s / 2;
    let m = 1usize << level;
    let side = m + 1;
    let at = |c: Coord| [c[0] as f64, c[1] as f64, c[2] as f64];
    let mut total = GapSum::default();
    // Corners, edge points and centres of a cell, with their shares.
    const POINTS: [(usize, usize, f64); 9] = [
        (0, 0, 0.25),
        (2, 0, 0.25),
        (2, 2, 0.25),
        (0, 2, 0.25),
        (1, 0, 0.5),
        (2, 1, 0.5),
        (1, 2, 0.5),
        (0, 1, 0.5),
        (1, 1, 1.0),
    ];
    for f in 0..layout.face_count() {
        let grid = &coarse[f * side * side..][..side * side];
        for b in 0..m {
            for a in 0..m {
                let c = [
                    at(grid[b * side + a]),
                    at(grid[b * side + a + 1]),
                    at(grid[(b + 1) * side + a + 1]),
                    at(grid[(b + 1) * side + a]),
                ];
                let d0 = sub(c[2], c[0]);
                let d1 = sub(c[3], c[1]);
                let normal = cross(d0, d1);
                let len = dot(normal, normal).sqrt();
                if len == 0.0 {
                    continue;
                }
                let normal = normal.map(|x| x / len);
                // The bilinear quad at the points: exact in `f64` (quarters
                // of integers below 2^33), so summed in any order.
                let half = |p: [f64; 3], q: [f64; 3]| std::array::from_fn(|k| (p[k] + q[k]) * 0.5);
                let centre: [f64; 3] =
                    std::array::from_fn(|k| (c[0][k] + c[1][k] + c[2][k] + c[3][k]) * 0.25);
                let flats = [
                    c[0],
                    c[1],
                    c[2],
                    c[3],
                    half(c[0], c[1]),
                    half(c[1], c[2]),
                    half(c[2], c[3]),
                    half(c[0], c[3]),
                    centre,
                ];
                let first = if moved {
                    0
                } else {
                    // The corners' four quarters (weights are exact sums).
                    total.weight += 1.0;
                    4
                };
                for ((di, dj, w), flat) in POINTS.into_iter().zip(flats).skip(first) {
                    let id = layout.sample(f, a * s + di * h, b * s + dj * h);
                    let off = dot(sub(at(fine[id as usize]), flat), normal);
                    total.sum += w * off * off;
                    total.weight += w;
                }
            }
        }
    }
    total
}

/// `gaps[l]` from the per-level steps `steps[j]` (level `j` against
/// `j + 1`, in model units) measured for `j < measured`; the steps above
/// are the last measured one shrinking fourfold per level.
pub(crate) fn gaps_from_steps(steps: &[f64], finest: u32) -> Vec<f64> {
    let mut all: Vec<f64> = steps.to_vec();
    while all.len() < finest as usize {
        let last = all.last().copied().unwrap_or(0.0);
        all.push(last / 4.0);
    }
    let mut gaps = vec![0.0; finest as usize + 1];
    let mut sum = 0.0;
    for l in (0..finest as usize).rev() {
        sum += all[l] * all[l];
        gaps[l] = sum.sqrt();
    }
    gaps
}

/// Bounding-box diagonal of the given values, in model units.
pub(crate) fn diagonal(values: impl Iterator<Item = Coord>, step: f64) -> f64 {
    let mut lo = [i32::MAX; 3];
    let mut hi = [i32::MIN; 3];
    let mut any = false;
    for v in values {
        any = true;
        for k in 0..3 {
            lo[k] = lo[k].min(v[k]);
            hi[k] = hi[k].max(v[k]);
        }
    }
    if !any {
        return 0.0;
    }
    let d: f64 = (0..3).map(|k| (hi[k] as f64 - lo[k] as f64).powi(2)).sum();
    d.sqrt() * step
}

impl GapSum {
    /// The step's RMS distance in model units.
    pub(crate) fn model_rms(self, step: f64) -> f64 {
        self.rms() * step
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quad's points as [`step_gap`] computes them, midpoints and
    /// centre by sums, are the bilinear formula's values to the last bit
    /// (quarters of integers below 2^33 are exact in `f64`), so the gaps
    /// do not depend on which way they are written.
    #[test]
    fn bilinear_points_by_sums_are_exact() {
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 32) as i32 as f64
        };
        for _ in 0..10_000 {
            let c: [f64; 4] = std::array::from_fn(|_| next());
            let bilinear = |u: f64, v: f64| {
                c[0] * (1.0 - u) * (1.0 - v)
                    + c[1] * u * (1.0 - v)
                    + c[2] * u * v
                    + c[3] * (1.0 - u) * v
            };
            let pairs = [
                (0, 1, 0.5, 0.0),
                (1, 2, 1.0, 0.5),
                (2, 3, 0.5, 1.0),
                (0, 3, 0.0, 0.5),
            ];
            for (a, b, u, v) in pairs {
                assert_eq!(((c[a] + c[b]) * 0.5).to_bits(), bilinear(u, v).to_bits());
            }
            let centre = (c[0] + c[1] + c[2] + c[3]) * 0.25;
            assert_eq!(centre.to_bits(), bilinear(0.5, 0.5).to_bits());
            assert_eq!(c[2].to_bits(), bilinear(1.0, 1.0).to_bits());
        }
    }

    #[test]
    fn gaps_add_up_and_extrapolate() {
        let gaps = gaps_from_steps(&[4.0, 3.0], 4);
        let expect = [
            (16.0f64 + 9.0 + 0.5625 + 0.03515625).sqrt(),
            (9.0f64 + 0.5625 + 0.03515625).sqrt(),
            (0.5625f64 + 0.03515625).sqrt(),
            0.1875,
            0.0,
        ];
        for (g, e) in gaps.iter().zip(expect) {
            assert!((g - e).abs() < 1e-12, "{gaps:?}");
        }
        assert_eq!(gaps_from_steps(&[], 0), vec![0.0]);
    }
}
