//! Colour: one 8-bit RGB colour per sample, coded in a bit-plane stream of
//! its own and interleaved with the geometry's, so that every prefix of a
//! file gives both.
//!
//! **Values.** A colour becomes three integers by the reversible YCoCg-R
//! transform (luma, orange and green chroma; exact inverse), centred at
//! `2^(VALUE_BITS - 1)` so that every value, lifted or not, lies in
//! `0 .. 2^VALUE_BITS`: the stream then carries every bit of the base
//! values (`qm_ezw::BaseBits::whole`) and the base section nothing, and a
//! prefix with no colour bits yet decodes as mid grey. The values go
//! through the same lifting as the geometry (world axes, no frames), the
//! same trees and the same bit-plane coder. Errors in luma count about
//! four times those of either chroma in RGB's squared error (`R = Y + Co/2
//! - Cg/2`, `G = Y + Cg/2`, `B = Y - Co/2 - Cg/2`), so the luma gets one
//! bit of extra weight ([`LUMA_BITS`]), as the geometry's normal does.
//!
//! **Interleaving.** How a byte budget is shared between geometry and
//! colour is a rate-distortion choice, made by measurement: the encoder
//! measures each stream at each of its pass ends (the geometry with the
//! holds' probes against the input surface, the colour against the
//! sampled colours, each with a floor for the error it can never remove),
//! takes each curve's upper convex hull in (bytes, dB) and merges the
//! hulls' segments by decreasing slope. Each byte thus goes where it buys
//! the most decibels, geometry's or colour's: at any cut the sum of the
//! two PSNRs is as high as whole segments allow, which is to say the
//! product of the two mean squared errors as low (no exchange rate
//! between millimetres and colour levels is needed). The header's runs
//! ([`ColourHeader::runs`]) record the merged order.

use qm_ezw::{BaseBits, Contexts, Weighting, ZeroTree};
use qm_lift::{Coord, Layout, Lifting, UpdateRule};

use crate::container::{ColourHeader, MAX_FINER_COLOUR};
use crate::{Error, Result};

/// The reconstruction of a base value known to lie in the `2^unknown`
/// values whose centre is `centre`: the centre of their overlap with
/// `lo ..= hi`, or, where they miss the range, the one of them nearest to
/// it.
fn within_range(centre: i32, unknown: u8, (lo, hi): (i32, i32)) -> i32 {
    if unknown == 0 {
        return centre;
    }
    let from = centre - (1 << (unknown - 1));
    let to = from + (1 << unknown) - 1;
    let (a, b) = (from.max(lo), to.min(hi));
    if a <= b {
        a + (b - a) / 2
    } else if to < lo {
        to
    } else {
        from
    }
}

/// Most bits of a colour base value less its channel's least: lifted
/// values are local means of values that span 511 at most.
pub const VALUE_BITS: u32 = 12;

/// The value of no colour information: mid grey, no chroma.
const CENTRE: i32 = 1 << (VALUE_BITS - 1);

/// Extra weight, in bits, of the luma against the chroma.
pub const LUMA_BITS: u32 = 1;

/// The colour stream's weighting: one bit per level (the L2 norm of the
/// basis functions, as the geometry's), the luma's extra bit.
pub(crate) const WEIGHTING: Weighting = Weighting::LEVELS.with_normal_bits(LUMA_BITS);

/// The error, in squared 8-bit levels per channel, that a lossless colour
/// stream keeps: the rounding to 8 bits.
const ROUNDING_ERROR: f64 = 1.0 / 12.0;

/// The value of an 8-bit sRGB colour: YCoCg-R, centred.
pub fn to_value(rgb: [u8; 3]) -> Coord {
    let [r, g, b] = rgb.map(i32::from);
    let co = r - b;
    let t = b + (co >> 1);
    let cg = g - t;
    let y = t + (cg >> 1);
    [y - 128 + CENTRE, co + CENTRE, cg + CENTRE]
}

/// The colour of a value, clamped to 8 bits: the exact inverse of
/// [`to_value`] on its values.
pub fn from_value(v: Coord) -> [u8; 3] {
    let [y, co, cg] = [v[0] + 128 - CENTRE, v[1] - CENTRE, v[2] - CENTRE];
    let t = y - (cg >> 1);
    let g = cg + t;
    let b = t - (co >> 1);
    let r = b + co;
    [r, g, b].map(|x| x.clamp(0, 255) as u8)
}

/// Colours to code beside the geometry ([`crate::compress_coloured`]): one
/// 8-bit sRGB colour per sample of the mesh's level or of a finer one (up
/// to six levels finer), and, where the caller measured it, what the colour
/// those samples draw misses of the colour they were taken from.
#[derive(Clone, Copy, Debug)]
#[non_exhaustive]
pub struct Colours<'a> {
    /// One colour per sample.
    pub samples: &'a [[u8; 3]],
    /// The mean squared error per channel, in 8-bit levels, of the
    /// samples' colour drawn over the mesh (interpolated across each
    /// triangle of the finest quads) against the colour of the surface they
    /// were sampled from, area-weighted: the error the colour stream can
    /// never remove, however long. Where it is above what 8-bit rounding
    /// alone leaves (1/12), the colour stream ends at the first pass whose
    /// error against the samples is a quarter of it (the passes after would
    /// buy less than 1 dB against that surface); otherwise, and without
    /// it, colours at the mesh's level are coded losslessly, and finer ones
    /// estimate it (the error of dropping their finest level of details).
    pub missed: Option<f64>,
}

impl<'a> Colours<'a> {
    /// `samples`, with nothing measured.
    pub const fn new(samples: &'a [[u8; 3]]) -> Self {
        Colours {
            samples,
            missed: None,
        }
    }

    /// These colours, their [`Colours::missed`] measured.
    pub const fn with_missed(mut self, missed: f64) -> Self {
        self.missed = Some(missed);
        self
    }
}

/// A coded colour stream and its measured errors.
#[derive(Clone, Debug)]
pub(crate) struct ColourCode {
    /// The arithmetic-coded stream.
    pub bytes: Vec<u8>,
    /// Its parameters, for the header.
    pub header: ColourHeader,
    /// The measured curve: (stream bytes, mean squared error per channel
    /// in 8-bit RGB levels with the floor added) at no bytes, at
    /// [`crate::holds::cuts`] of the stream and at its end.
    pub curve: Vec<(usize, f64)>,
}

/// The levels of colour beyond `layout`'s that `count` colours fill: the
/// `finer` with one colour per sample of `layout`'s base at `level +
/// finer`, up to [`MAX_FINER_COLOUR`]; an error for another count.
pub(crate) fn finer_levels(layout: &Layout, count: usize) -> Result<u32> {
    let base = layout.base();
    (0..=MAX_FINER_COLOUR as u32)
        .find(|&finer| {
            let level = layout.level() + finer;
            Layout::check(base, level).is_ok() && base.sample_count(level) == count as u64
        })
        .ok_or(Error::Setting {
            what: "colours (one per sample of the mesh's level or a finer one)",
            value: count as u64,
            min: layout.sample_count() as u64,
            max: base.sample_count(layout.level() + MAX_FINER_COLOUR as u32),
        })
}

/// Codes `colours`, one per sample of `layout` or of a level of its base
/// up to [`MAX_FINER_COLOUR`] finer ([`finer_levels`]), lifted with
/// `update`, as far as [`Colours::missed`] says.
pub(crate) fn encode(layout: &Layout, update: UpdateRule, given: Colours) -> Result<ColourCode> {
    let colours = given.samples;
    let finer = finer_levels(layout, colours.len())?;
    let fine;
    let layout = if finer == 0 {
        layout
    } else {
        fine = Layout::new(layout.base().clone(), layout.level() + finer)?;
        &fine
    };
    let lifting = Lifting::new(layout, update);
    let mut data: Vec<Coord> = colours.iter().map(|&c| to_value(c)).collect();
    lifting.forward(&mut data);
    let tree = ZeroTree::new(layout);
    let coefs = tree.gather(&data);
    // The base values less their channel's least, in as few bits as their
    // spread takes: no bit plane above is spent on them, and none straddles
    // a power of two the values do not fill.
    let base = &data[..layout.base().vertex_count() as usize];
    let base_min: [i32; 3] = std::array::from_fn(|k| base.iter().map(|v| v[k]).min().unwrap_or(0));
    let base_max: [i32; 3] = std::array::from_fn(|k| base.iter().map(|v| v[k]).max().unwrap_or(0));
    let spread = (0..3).map(|k| base_max[k] - base_min[k]).max().unwrap_or(0);
    let bits = 32 - (spread as u32).leading_zeros();
    if bits > VALUE_BITS {
        // Lifted colours are weighted means: a spread this wide is a bug.
        return Err(Error::Malformed {
            what: format!("lifted base colours spread over {spread}"),
        });
    }
    let values: Vec<Coord> = (base.iter())
        .map(|v| std::array::from_fn(|k| v[k] - base_min[k]))
        .collect();
    let base = BaseBits {
        values: &values,
        most: bits.max(1),
        whole: true,
        rounded: false,
    };
    // The floor: what the samples miss of the surface's colour, measured
    // by the caller (a measure no higher than rounding says they hold it as
    // well as 8 bits can: they are coded exactly), or else what the lossless
    // stream keeps (rounding) and what the samples miss between them, taken
    // as what dropping the finest level of details would cost.
    let missed = given.missed.filter(|&m| m > ROUNDING_ERROR);
    let floor = match missed {
        Some(missed) => missed,
        None if layout.level() == 0 => ROUNDING_ERROR,
        None => {
            let mut coarse = data.clone();
            for k in tree.level_range(layout.level()) {
                coarse[tree.samples()[k] as usize] = [0; 3];
            }
            lifting.inverse(&mut coarse);
            ROUNDING_ERROR + mean_squared(&coarse, colours)
        }
    };
    let encode = |max_passes| {
        qm_ezw::encode(
            &tree,
            &coefs,
            Some(base),
            WEIGHTING,
            Contexts::Neighbours,
            max_passes,
        )
    };
    let mut encoded = encode(None);
    let mut header = ColourHeader {
        planes: encoded.params.planes as u8,
        passes: encoded.params.passes as u8,
        weight_bits: WEIGHTING.bits_per_level as u8,
        luma_bits: WEIGHTING.normal_bits as u8,
        base_bits: encoded.params.base_bits as u8,
        base_min,
        base_max,
        runs: Vec::new(),
        finer: finer as u8,
    };
    // Colours whose floor is measured, or finer than the geometry (a
    // texture resampled): the stream ends at the first pass whose error is
    // a quarter of what the samples miss, beyond which a pass buys less
    // than 1 dB against the surface's colour.
    if finer > 0 || missed.is_some() {
        let mut measure = Measure::new(layout, &lifting, &header, colours);
        let stop = (encoded.pass_ends.iter())
            .position(|&end| measure.at(&encoded.bytes[..end]) <= floor / 4.0);
        if let Some(k) = stop
            && k + 1 < encoded.pass_ends.len()
        {
            encoded = encode(Some(k as u32 + 1));
            header.passes = encoded.params.passes as u8;
        }
    }
    let mut cuts = crate::holds::cuts(
        encoded.bytes.len(),
        curve_work(colours.len()),
        &encoded.pass_ends,
    );
    cuts.insert(0, 0);
    let mut measure = Measure::new(layout, &lifting, &header, colours);
    let curve = (cuts.into_iter())
        .map(|cut| (cut, measure.at(&encoded.bytes[..cut]) + floor))
        .collect();
    Ok(ColourCode {
        bytes: encoded.bytes,
        header,
        curve,
    })
}

/// The error of longer and longer prefixes of a colour stream, each
/// decode resuming from the last.
struct Measure<'a> {
    layout: &'a Layout,
    lifting: &'a Lifting<'a>,
    header: &'a ColourHeader,
    colours: &'a [[u8; 3]],
    tree: ZeroTree,
    checkpoint: Option<qm_ezw::Checkpoint>,
    values: Vec<Coord>,
}

impl<'a> Measure<'a> {
    fn new(
        layout: &'a Layout,
        lifting: &'a Lifting<'a>,
        header: &'a ColourHeader,
        colours: &'a [[u8; 3]],
    ) -> Self {
        Measure {
            layout,
            lifting,
            header,
            colours,
            tree: ZeroTree::new(layout),
            checkpoint: None,
            values: Vec::new(),
        }
    }

    /// Mean squared RGB error per channel of the decode of `prefix`, at
    /// least as long as the last one measured.
    fn at(&mut self, prefix: &[u8]) -> f64 {
        let params = self.header.stream_params(self.layout.base().vertex_count());
        let (decoded, next) =
            qm_ezw::decode_resuming(&mut self.tree, params, prefix, None, self.checkpoint.take());
        self.checkpoint = next;
        fill(
            self.layout,
            &self.tree,
            &decoded,
            self.header,
            &mut self.values,
        );
        self.lifting.inverse(&mut self.values);
        mean_squared(&self.values, self.colours)
    }
}

/// Most cuts of each stream the interleaving measures, besides the pass
/// ends: enough to place the runs within a pass, few enough that a small
/// mesh does not decode thousands of times.
const CURVE_CUTS: usize = 128;

/// The sample count to give [`crate::holds::cuts`] for a curve of
/// `samples` samples: as many cuts as the holds' work allows, at most
/// [`CURVE_CUTS`].
pub(crate) fn curve_work(samples: usize) -> usize {
    samples.max(crate::holds::CUT_WORK / CURVE_CUTS)
}

/// Mean squared RGB error per channel of `values` against `colours`.
fn mean_squared(values: &[Coord], colours: &[[u8; 3]]) -> f64 {
    let sum: f64 = (values.iter().zip(colours))
        .map(|(&v, c)| {
            let d = from_value(v);
            (0..3)
                .map(|k| (d[k] as f64 - c[k] as f64).powi(2))
                .sum::<f64>()
        })
        .sum();
    sum / (3 * colours.len().max(1)) as f64
}

/// The colour values of a decode: the base values from the stream's low
/// bits (their high parts are zero), each at the centre of what its known
/// bits leave *within the range of colour values* (a colour is never
/// darker than black: bit-plane intervals wider than the colours' range
/// would otherwise decode far outside it), the details at their samples,
/// numbered as `layout`'s (at least as fine as `tree`'s).
pub(crate) fn fill(
    layout: &Layout,
    tree: &ZeroTree,
    decoded: &qm_ezw::Decoded,
    header: &ColourHeader,
    values: &mut Vec<Coord>,
) {
    values.clear();
    values.resize(layout.sample_count(), [0; 3]);
    for ((v, centre), unknown) in values
        .iter_mut()
        .zip(&decoded.base_low)
        .zip(&decoded.base_unknown)
    {
        *v = std::array::from_fn(|c| {
            let (lo, hi) = (header.base_min[c], header.base_max[c]);
            lo + within_range(centre[c], unknown[c], (0, hi - lo))
        });
    }
    let (from, to) = (tree.numbering(), layout.numbering());
    let samples = tree.samples();
    for e in &decoded.nonzero {
        let s = from.refine(samples[e.node as usize], to);
        values[s as usize][e.coord as usize] = e.value;
    }
}

/// The interleaving of two streams by their measured curves: `geometry`
/// and `colour` each list (stream bytes, mean squared error) at zero bytes
/// and at each pass end, bytes increasing; the last point ends the
/// stream. Runs as [`ColourHeader::runs`] (see the module docs).
pub(crate) fn interleave(geometry: &[(usize, f64)], colour: &[(usize, f64)]) -> Vec<[u32; 2]> {
    let hulls = [hull(geometry), hull(colour)];
    let mut next = [0usize; 2];
    let mut runs: Vec<[u32; 2]> = Vec::new();
    let mut last = None;
    loop {
        let slope = |k: usize| {
            hulls[k]
                .get(next[k])
                .map(|&(bytes, gain)| gain / bytes as f64)
        };
        let k = match (slope(0), slope(1)) {
            (None, None) => break,
            (Some(_), None) => 0,
            (None, Some(_)) => 1,
            // Ties to the geometry.
            (Some(g), Some(c)) => usize::from(c > g),
        };
        let bytes = hulls[k][next[k]].0 as u32;
        next[k] += 1;
        match (last, runs.last_mut()) {
            (Some(j), Some(run)) if j == k || (k == 1 && run[1] == 0) => run[k] += bytes,
            _ if k == 0 => runs.push([bytes, 0]),
            _ => runs.push([0, bytes]),
        }
        last = Some(k);
    }
    runs
}

/// The segments of the upper convex hull of a curve of (bytes, mean
/// squared error) points in (bytes, dB): each as (bytes, dB gained), in
/// order, slopes decreasing. Segments of no bytes join the next.
fn hull(curve: &[(usize, f64)]) -> Vec<(usize, f64)> {
    let db = |e: f64| -10.0 * e.max(f64::MIN_POSITIVE).log10();
    let mut points: Vec<(usize, f64)> = Vec::with_capacity(curve.len());
    for &(bytes, error) in curve {
        let p = (bytes, db(error));
        if let Some(last) = points.last_mut()
            && last.0 == p.0
        {
            last.1 = last.1.max(p.1);
            continue;
        }
        // Drop points below the chord from their predecessor to `p`.
        while points.len() >= 2 {
            let (a, b) = (points[points.len() - 2], points[points.len() - 1]);
            let cross = (b.0 - a.0) as f64 * (p.1 - a.1) - (p.0 - a.0) as f64 * (b.1 - a.1);
            if cross >= 0.0 {
                points.pop();
            } else {
                break;
            }
        }
        points.push(p);
    }
    // A stream's end is reached even where it gains nothing.
    points
        .windows(2)
        .map(|w| (w[1].0 - w[0].0, w[1].1 - w[0].1))
        .collect()
}

/// The two streams' prefixes in the first `n` bytes of an interleaved
/// stream: geometry, colour.
pub(crate) fn split(runs: &[[u32; 2]], stream: &[u8]) -> (Vec<u8>, Vec<u8>) {
    let mut parts = [Vec::new(), Vec::new()];
    let mut at = 0;
    'runs: for run in runs {
        for (part, &len) in parts.iter_mut().zip(run) {
            let end = (at + len as usize).min(stream.len());
            part.extend_from_slice(&stream[at..end]);
            at = end;
            if at == stream.len() {
                break 'runs;
            }
        }
    }
    let [geometry, colour] = parts;
    (geometry, colour)
}

/// The two streams interleaved by `runs`.
pub(crate) fn join(runs: &[[u32; 2]], geometry: &[u8], colour: &[u8]) -> Vec<u8> {
    let streams = [geometry, colour];
    let mut at = [0usize; 2];
    let mut out = Vec::with_capacity(geometry.len() + colour.len());
    for run in runs {
        for k in 0..2 {
            let end = at[k] + run[k] as usize;
            out.extend_from_slice(&streams[k][at[k]..end]);
            at[k] = end;
        }
    }
    debug_assert_eq!(at, [geometry.len(), colour.len()]);
    out
}

/// Bytes of the interleaved stream up to the end of byte `n` of stream
/// `k` (0 geometry, 1 colour), where that stream's first `n` bytes are all
/// in (0 for `n = 0`).
pub(crate) fn offset_of(runs: &[[u32; 2]], k: usize, n: usize) -> usize {
    if n == 0 {
        return 0;
    }
    let (mut at, mut seen) = (0, 0);
    for run in runs {
        for (j, &len) in run.iter().enumerate() {
            let len = len as usize;
            if j == k && seen + len >= n {
                return at + n - seen;
            }
            if j == k {
                seen += len;
            }
            at += len;
        }
    }
    at
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_exact_and_centred() {
        for r in (0..=255).step_by(5) {
            for g in (0..=255).step_by(3) {
                for b in (0..=255).step_by(7) {
                    let v = to_value([r, g, b]);
                    assert_eq!(from_value(v), [r, g, b]);
                    assert!(v.iter().all(|x| (CENTRE - 256..CENTRE + 256).contains(x)));
                }
            }
        }
        assert_eq!(from_value([CENTRE; 3]), [128; 3], "no information is grey");
    }

    #[test]
    fn base_values_are_reconstructed_within_the_colour_range() {
        let range = (0, 300);
        // Nothing known of 9 bits: the middle of the range, not of 512.
        assert_eq!(within_range(256, 9, range), 150);
        // The top bit: the lower part of 256 values, or what is left.
        assert_eq!(within_range(128, 8, range), 127);
        assert_eq!(within_range(384, 8, range), 278);
        // An interval beside the range: its end nearer it; known: itself.
        assert_eq!(within_range(448, 6, range), 416);
        assert_eq!(within_range(7, 0, range), 7);
    }

    #[test]
    fn interleaving_follows_the_steepest_segments() {
        // Geometry gains 10 dB for 100 bytes, then 10 dB for 1000; colour
        // 10 dB for 300, then 3 dB for 100 (a dip first: hulled): the
        // colour runs join.
        let geometry = [(0, 1.0), (100, 0.1), (1100, 0.01)];
        let colour = [(0, 1.0), (150, 2.0), (300, 0.1), (400, 0.05)];
        let runs = interleave(&geometry, &colour);
        assert_eq!(runs, vec![[100, 400], [1000, 0]]);
        let g: Vec<u8> = (0..1100).map(|i| i as u8).collect();
        let c: Vec<u8> = (0..400).map(|i| (i * 7) as u8).collect();
        let joined = join(&runs, &g, &c);
        assert_eq!(split(&runs, &joined), (g.clone(), c.clone()));
        // Any prefix splits into prefixes.
        for n in [0, 50, 100, 250, 400, 450, 500, 1000, 1500] {
            let (a, b) = split(&runs, &joined[..n]);
            assert_eq!((a.len() + b.len()), n);
            assert!(g.starts_with(&a) && c.starts_with(&b));
            assert!(offset_of(&runs, 0, a.len()) <= n && offset_of(&runs, 1, b.len()) <= n);
        }
        assert_eq!(offset_of(&runs, 0, 100), 100);
        assert_eq!(offset_of(&runs, 1, 1), 101);
        assert_eq!(offset_of(&runs, 0, 101), 501);
        assert_eq!(offset_of(&runs, 1, 400), 500);
    }
}
