//! How the encoder expresses the details ([`Frames`]): world axes, local
//! frames whose normals come from the parent quads from a given level on,
//! or the automatic choice between such levels ([`Frames::Auto`]).
//!
//! The automatic choice encodes the mesh with parent frames from level 3
//! and from level 4, and keeps the stream whose cuts at [`AUTO_CUTS`] come
//! closer to the mesh: its score ([`cut_error`]) is `sum_k ln(mse_k)` over
//! the cuts, `mse_k` the mean squared error of cut `k` along the unit
//! normals of the finest surface at the samples ([`sample_normals`]), in
//! quantized units. If level 4 wins, later levels are tried in turn
//! ([`auto_search`]); each must beat the best so far by
//! [`AUTO_MIN_GAIN_DB`] on average over the cuts.

use qm_lift::glam::DVec3;
use qm_lift::{Coord, Layout};

use crate::Result;
use crate::compressed::{Compressed, measure_cuts};
use crate::container;

/// How the encoder expresses the details.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Frames {
    /// World axes, the three coordinates alike.
    Off,
    /// Local frames whose normals come from the parent quads from this
    /// level on (3 to `MAX_LEVEL + 1`), from the level `l - 1` quads below.
    ParentsFrom(u32),
    /// Local frames, parents from level 3 or from level 4, whichever
    /// stream's cuts come closer to the mesh (see `AUTO_CUTS`); if 4, then
    /// each of 5, 6, ... up to `L + 1` in turn replaces the best so far if
    /// it brings the cuts more than [`AUTO_MIN_GAIN_DB`] closer than that
    /// one: costs one encoding per level tried.
    /// Level 4 keeps more of the frames' gain on smooth models, level 3 is
    /// safer on dense scans, whose small, thin quads turn their normals a
    /// lot while the stream is cut; later starts help creased models at
    /// high rates.
    Auto,
}

/// The cuts at which [`Frames::Auto`] compares its candidates, as powers of
/// two below what is sent (the whole stream, or the byte budget): `1/128`,
/// `1/32` and `1/8` of it, shortest first so that each decode resumes from
/// the last. There the surface is already close but the finest details are
/// still missing (about 60 to 80 dB on the development models). More cuts
/// chose no other source (docs/decisions/012-frames-parents-from.md).
pub const AUTO_CUTS: [u32; 3] = [7, 5, 3];

/// [`Frames::Auto`] takes a start of the parent frames after level 4 only
/// if it brings the cuts at [`AUTO_CUTS`] more than this much closer than
/// the best start so far, in dB of their mean squared error on average
/// over them (a level that falls short does not end the search: two small
/// steps can make one that counts). Smaller gains come with larger
/// lossless files (a later start codes the finest levels in frames from
/// smaller quads, which costs their last passes).
pub const AUTO_MIN_GAIN_DB: f64 = 0.15;

/// How much lower than the best so far a candidate's `cut_error` must be
/// for [`Frames::Auto`] to take frame kind `kind` (parents from level
/// `kind + 2`): anything lower for level 4 against 3, [`AUTO_MIN_GAIN_DB`]
/// on average over the cuts after that (the error is a sum of natural logs
/// of mean squared errors).
fn auto_margin(kind: u32) -> f64 {
    if kind <= 2 {
        0.0
    } else {
        AUTO_CUTS.len() as f64 * AUTO_MIN_GAIN_DB * std::f64::consts::LN_10 / 10.0
    }
}

/// The last frame kind [`Frames::Auto`] tries on a layout of `level`
/// levels: `L - 1` (parents from level `L + 1`, that is from none), within
/// the kinds the container has.
pub(crate) fn last_auto_kind(level: u32) -> u32 {
    level.saturating_sub(1).min(container::MAX_FRAMES as u32)
}

/// The search of [`Frames::Auto`] over frame kinds `1..=last`, given the
/// stream of kind 1: `encode` makes the stream of a
/// kind, `score` its `cut_error`. Kind 2 replaces kind 1 if it errs less,
/// and only then are later kinds tried; each replaces the best so far if
/// it errs less by more than `auto_margin`.
pub(crate) fn auto_search<T>(
    first: T,
    last: u32,
    mut encode: impl FnMut(u32) -> Result<T>,
    mut score: impl FnMut(&T) -> Result<f64>,
) -> Result<T> {
    let mut best_score = score(&first)?;
    let mut best = first;
    for kind in 2..=last {
        let next = encode(kind)?;
        let next_score = score(&next)?;
        if next_score < best_score - auto_margin(kind) {
            (best, best_score) = (next, next_score);
        } else if kind == 2 {
            // Level 3 won: no later start is tried.
            break;
        }
    }
    Ok(best)
}

/// The stream [`Frames::Auto`] keeps: `compress_with(kind, prefix)` makes
/// the stream of a frame kind from the `quantized` samples of `layout`,
/// whole or (`Some(bytes)`) coded only as far as its first `bytes` stream
/// bytes, which are then those of the whole stream; `max_bytes` is the
/// encoder's byte budget, which the cuts compared are a share of.
///
/// Parents from level 3 and from level 4 are coded whole, at once (both
/// are always compared, and either may be kept); later starts, tried once
/// level 4 wins, are coded one after another, each only as far as the
/// longest cut compared, and the one kept is coded whole again: the choice
/// and the stream are those of whole encodings one after the other, at a
/// fraction of their time, with at most two encoders at work.
pub(crate) fn auto(
    layout: &Layout,
    quantized: &[Coord],
    max_bytes: Option<usize>,
    compress_with: impl Fn(u8, Option<usize>) -> Result<Compressed> + Sync,
) -> Result<Compressed> {
    // Parents from level 3 (kind 1) or 4 (kind 2), whichever cuts
    // come closer; if 4, each later level that brings them more than
    // `AUTO_MIN_GAIN_DB` closer than the best so far. From level
    // `L + 1` (kind `L - 1`) no level takes its frames from the
    // parents.
    let last = last_auto_kind(layout.level());
    if last < 2 {
        return compress_with(1, None);
    }
    let (first, second) = rayon::join(|| compress_with(1, None), || compress_with(2, None));
    let (first, mut second) = (first?, Some(second?));
    let normals = sample_normals(layout, quantized);
    // Cuts of what will be sent, shortest first so that each
    // decode resumes from the previous one's checkpoint.
    let sent = max_bytes.map_or(first.bytes.len(), |m| m.min(first.bytes.len()));
    let budgets = AUTO_CUTS.map(|k| sent >> k);
    // No cut reaches past the longest budget (file bytes, so more than
    // the stream bytes any cut takes).
    let longest = budgets.iter().copied().max().unwrap_or(0);
    let score = |(_, c): &(u32, Compressed)| cut_error(c, &normals, &budgets);
    // Later kinds, one at a time (each holds an encoder's memory), each
    // coded only as far as the longest cut.
    let encode = |kind: u32| -> Result<(u32, Compressed)> {
        match kind {
            2 => Ok((2, second.take().expect("kind 2 is asked for once"))),
            _ => Ok((kind, compress_with(kind as u8, Some(longest))?)),
        }
    };
    match auto_search((1, first), last, encode, score)? {
        (kind @ 3.., _) => compress_with(kind as u8, None),
        (_, whole) => Ok(whole),
    }
}

/// Unit normal of the finest surface at every sample (the sum of its quads'
/// diagonal cross products), in quantized coordinates.
pub(crate) fn sample_normals(layout: &Layout, values: &[Coord]) -> Vec<DVec3> {
    let p = |s: u32| DVec3::from(values[s as usize].map(f64::from));
    let mut normals = vec![DVec3::ZERO; values.len()];
    for [a, b, c, d] in layout.quads(layout.level()) {
        let n = (p(c) - p(a)).cross(p(d) - p(b));
        for s in [a, b, c, d] {
            normals[s as usize] += n;
        }
    }
    for n in &mut normals {
        *n = n.normalize_or_zero();
    }
    normals
}

/// Sum over the cuts `budgets` of `compressed` of the log of the mean
/// squared error along the surface normal (what a surface distance sees;
/// sliding along the surface costs nothing).
pub(crate) fn cut_error(
    compressed: &Compressed,
    normals: &[DVec3],
    budgets: &[usize],
) -> Result<f64> {
    let start = compressed.header_bytes + compressed.base_bytes;
    let stream_len = compressed.bytes.len() - start;
    let cuts: Vec<usize> = (budgets.iter())
        .map(|b| b.saturating_sub(start).min(stream_len))
        .collect();
    let errors = measure_cuts(compressed, &cuts, |values| {
        let sum: f64 = values
            .iter()
            .zip(&compressed.quantized)
            .zip(normals)
            .map(|((v, q), n)| {
                let e = DVec3::from(v.map(f64::from)) - DVec3::from(q.map(f64::from));
                e.dot(*n).powi(2)
            })
            .sum();
        sum / values.len().max(1) as f64
    })?;
    Ok(errors.iter().map(|e| (e + 1e-12).ln()).sum())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The search keeps a later start that is clearly closer than the best
    /// so far even after one that was not (rocker-arm's scores: level 5
    /// gains too little over 4, level 6 enough), never looks past level 4
    /// when 3 wins, and takes no gain within the margin.
    #[test]
    fn auto_search_looks_past_a_small_step() {
        let m = auto_margin(3);
        let search = |scores: &[f64]| {
            let mut asked = Vec::new();
            let kept = auto_search(
                1,
                scores.len() as u32,
                |kind| {
                    asked.push(kind);
                    Ok(kind)
                },
                |&kind| Ok(scores[kind as usize - 1]),
            )
            .unwrap();
            (kept, asked)
        };
        // Rocker-arm: 4 beats 3, 5 is 0.066 closer than 4, 6 is 0.141
        // closer, 7 is 0.006 closer than 6.
        let (four, six) = (-0.171, -0.171 - 0.141);
        let rocker = [0.0, four, four - 0.066, six, six - 0.006];
        assert_eq!(search(&rocker), (4, vec![2, 3, 4, 5]));
        // Level 3 wins: later starts are not even encoded.
        assert_eq!(search(&[0.0, 0.01, -5.0]), (1, vec![2]));
        // Level 4 wins by any amount; later levels only by more than `m`.
        assert_eq!(search(&[0.0, -1e-9, -1e-9 - 0.99 * m]), (2, vec![2, 3]));
        assert_eq!(search(&[0.0, -1e-9, -1e-9 - 1.01 * m]), (3, vec![2, 3]));
        assert_eq!(search(&[0.0]), (1, vec![]));
    }
}
