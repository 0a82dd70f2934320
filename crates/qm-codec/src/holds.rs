//! Holds: where a longer cut of the stream would decode worse than a
//! shorter one, the decoder stays at the shorter one.
//!
//! A bit-plane pass refines the coefficients one tree after another. With
//! the update step every wavelet has zero mean, so the errors of a whole
//! region's coefficients, of one sign, cancel; a pass that has refined half
//! of them leaves errors of both signs, which do not (`docs/holds.md`). Inside such a pass the surface moves away from the input
//! for a while. The encoder sees this: it decodes its own stream at many
//! cuts, measures each against the surface with [`Probes`], and writes a
//! *hold* `[from, to]` into the header wherever the cuts
//! after `from` are worse than `from` until `to`. A decoder given a cut
//! inside a hold decodes its first `from` bytes instead
//! ([`crate::container::Header::hold_cut`]), so the error never grows with
//! the bytes, as far as the encoder's measure goes.
//!
//! The measure is the area-weighted mean squared distance along the normal
//! between the decoded surface and the input, at probe points (three in
//! each triangle of the finest quads): the decoded point's offset from the
//! point's foot on the input, along the normal of its triangle. The feet
//! are either the lossless surface itself ([`Probes::on_surface`]: the
//! encoder knows nothing else) or the closest points of the mesh the
//! semi-regular mesh was made from ([`Probes::new`]), whose own distance
//! (the remesh's error) then adds in with its sign, as it does in a Metro
//! distance.

use qm_lift::glam::DVec3;
use qm_lift::{Coord, Quantizer, SemiRegularMesh};
use rayon::prelude::*;

use crate::compressed::{Compressed, measure_cuts};
use crate::container;

/// Where a triangle carries its probe points: the degree-2 rule of three
/// interior points, exact for the mean square of an offset that is linear
/// over the triangle.
const WEIGHTS: [[f64; 3]; 3] = [
    [2.0 / 3.0, 1.0 / 6.0, 1.0 / 6.0],
    [1.0 / 6.0, 2.0 / 3.0, 1.0 / 6.0],
    [1.0 / 6.0, 1.0 / 6.0, 2.0 / 3.0],
];

/// Most probe points; above, every `k`-th quad carries them (`cargo xtask
/// rd-curve` measures with 200,000 samples per side).
pub const MAX_PROBES: usize = 1 << 17;

/// Most cut decodes times samples per stream: the finer the mesh, the fewer
/// log-spaced cuts, down to [`MIN_CUTS`]. Each cut is a decode with a whole
/// inverse lifting (docs/decisions/011-holds-thresholds.md).
pub const CUT_WORK: usize = 1 << 24;

/// Fewest cuts tried (besides the pass ends), however fine the mesh.
pub const MIN_CUTS: usize = 24;

/// A longer cut's error must exceed the best shorter one's by this factor
/// (0.1 dB) for a hold to pay its header bytes: a finer rise buys a few
/// hundredths of a dB with header bytes every cut pays
/// (docs/decisions/011-holds-thresholds.md).
pub(crate) const RISE: f64 = 1.023_292_992_3;

/// The rise a hold needs in a stream of [`LONG_STREAM`] bytes or more
/// (0.02 dB): there a hold's few header bytes are a small part of every cut
/// but the first few hundred bytes (docs/decisions/011-holds-thresholds.md).
const RISE_LONG: f64 = 1.004_615_794_8;

/// Streams this long hold rises of 0.02 dB instead of 0.1 dB.
pub const LONG_STREAM: usize = 1 << 16;

/// Points where the encoder measures its cuts against the input surface.
#[derive(Clone, Debug)]
pub struct Probes {
    points: Vec<Probe>,
    /// The power of two the points are scaled by ([`qm_lift::unit_scale`]
    /// of the mesh), so that squared distances of meshes in far units
    /// neither overflow nor vanish.
    scale: f64,
    /// Samples of the mesh the probes were built on.
    samples: usize,
}

#[derive(Clone, Copy, Debug)]
struct Probe {
    /// The triangle's samples.
    corners: [u32; 3],
    /// The point's barycentric coordinates in it.
    weights: [f64; 3],
    /// The point's foot on the input surface (scaled world coordinates).
    foot: DVec3,
    /// Unit normal of the triangle.
    normal: DVec3,
    /// Area the point stands for.
    weight: f64,
}

/// A point of a semi-regular mesh's surface where it is measured: inside
/// one of the two triangles (`a b c`, `a c d`) each finest quad is drawn
/// with, at one of three interior points (the degree-2 rule, exact for the
/// mean square of a value linear over the triangle).
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    /// The triangle's samples.
    pub corners: [u32; 3],
    /// The point's barycentric coordinates in it.
    pub weights: [f64; 3],
    /// The point, in the mesh's coordinates times the scale asked for.
    pub point: DVec3,
    /// Unit normal of the triangle.
    pub normal: DVec3,
    /// The area the point stands for (scaled as `point` squared).
    pub weight: f64,
}

/// The points [`Probes`] measure `mesh` at, its coordinates times `scale`
/// (a power of two keeps them exact): three in each triangle of the finest
/// quads, of every `k`-th quad beyond [`MAX_PROBES`] points, each standing
/// for `k` times a third of its triangle's area.
pub fn surface_points(mesh: &SemiRegularMesh, scale: f64) -> Vec<SurfacePoint> {
    let layout = mesh.layout();
    let quads = layout.quads(layout.level());
    let per_quad = 2 * WEIGHTS.len();
    let stride = (per_quad * quads.len()).div_ceil(MAX_PROBES).max(1);
    let p = |s: u32| mesh.positions()[s as usize] * scale;
    (quads.par_iter().step_by(stride))
        .flat_map_iter(|&[a, b, c, d]| {
            [[a, b, c], [a, c, d]].into_iter().flat_map(move |corners| {
                let [p0, p1, p2] = corners.map(p);
                let cross = (p1 - p0).cross(p2 - p0);
                let weight = 0.5 * cross.length() * stride as f64 / WEIGHTS.len() as f64;
                WEIGHTS.map(|weights| SurfacePoint {
                    corners,
                    weights,
                    point: weights[0] * p0 + weights[1] * p1 + weights[2] * p2,
                    normal: cross.normalize_or_zero(),
                    weight,
                })
            })
        })
        .collect()
}

impl Probes {
    /// Probes at three points of each of the finest quads' two triangles
    /// of `mesh` (of every `k`-th quad beyond [`MAX_PROBES`]), their feet
    /// at `foot` of each point (the closest point of the input surface).
    pub fn new(mesh: &SemiRegularMesh, foot: impl Fn(DVec3) -> DVec3 + Sync) -> Self {
        let scale = qm_lift::unit_scale(mesh.positions());
        let foot = &foot;
        let points = surface_points(mesh, scale)
            .into_par_iter()
            .map(|p| Probe {
                corners: p.corners,
                weights: p.weights,
                foot: foot(p.point / scale) * scale,
                normal: p.normal,
                weight: p.weight,
            })
            .collect();
        Probes {
            points,
            scale,
            samples: mesh.layout().sample_count(),
        }
    }

    /// Probes whose feet are on `mesh` itself: the cuts are measured
    /// against the lossless surface before quantization.
    pub fn on_surface(mesh: &SemiRegularMesh) -> Self {
        Probes::new(mesh, |p| p)
    }

    /// Samples of the mesh the probes were built on: a stream of another
    /// mesh is refused.
    pub fn samples(&self) -> usize {
        self.samples
    }

    /// Area-weighted mean squared distance along the normal of the
    /// quantized `values` from the feet, at the probes' scale.
    fn error(&self, quantizer: &Quantizer, values: &[Coord]) -> f64 {
        let at = |s: u32| quantizer.dequantize(values[s as usize].map(f64::from)) * self.scale;
        let (sum, weight) = self.points.iter().fold((0.0, 0.0), |(sum, weight), p| {
            let [a, b, c] = p.corners.map(at);
            let [u, v, w] = p.weights;
            let offset = (u * a + v * b + w * c - p.foot).dot(p.normal);
            (sum + p.weight * offset * offset, weight + p.weight)
        });
        if weight > 0.0 { sum / weight } else { 0.0 }
    }
}

/// The cuts (stream offsets) at which [`find`] measures a stream of
/// `len` bytes over `samples` samples: every pass end and log-spaced cuts
/// from the first byte, as many as [`CUT_WORK`] allows.
pub(crate) fn cuts(len: usize, samples: usize, pass_ends: &[usize]) -> Vec<usize> {
    let count = (CUT_WORK / samples.max(1)).max(MIN_CUTS);
    let ratio = (len.max(2) as f64).powf(1.0 / count as f64);
    let mut cuts: Vec<usize> = (0..=count)
        .map(|k| (ratio.powi(k as i32).round() as usize).min(len))
        .chain(pass_ends.iter().copied().filter(|&e| e <= len))
        .chain([len])
        .collect();
    cuts.sort_unstable();
    cuts.dedup();
    cuts
}

/// The holds of `compressed` (a complete container without holds): its
/// stream decoded at [`cuts`], measured with `probes`; and those cuts with
/// their errors, without holds ([`Measured`]).
pub(crate) fn find(compressed: &Compressed, probes: &Probes) -> (Vec<[u32; 2]>, Measured) {
    let start = compressed.header_bytes + compressed.base_bytes;
    let ends: Vec<usize> = compressed.pass_ends.iter().map(|e| e - start).collect();
    let samples = compressed.quantized.len();
    let len = compressed.bytes.len() - start;
    let cuts = cuts(len, samples, &ends);
    let rise = if len >= LONG_STREAM { RISE_LONG } else { RISE };
    let errors = errors(compressed, probes, &cuts);
    let holds = select(&cuts, &errors, rise);
    (holds, Measured { cuts, errors })
}

/// Stream cuts (ascending) of a stream without holds, and the error
/// [`Probes`] measured at each.
#[derive(Clone, Debug, Default)]
pub(crate) struct Measured {
    cuts: Vec<usize>,
    errors: Vec<f64>,
}

impl Measured {
    /// The error at stream cut `cut` once `holds` are written: that of the
    /// cut a decoder stays at ([`container::hold_cut`]), if it was
    /// measured.
    pub(crate) fn error_at(&self, holds: &[[u32; 2]], cut: usize) -> Option<f64> {
        let at = container::hold_cut(holds, cut);
        let i = self.cuts.binary_search(&at).ok()?;
        Some(self.errors[i])
    }
}

/// The error of `compressed` at each of the stream cuts `cuts` (ascending),
/// as a decoder sees them (holds and all).
pub(crate) fn errors(compressed: &Compressed, probes: &Probes, cuts: &[usize]) -> Vec<f64> {
    measure_cuts(compressed, cuts, |values| {
        probes.error(&compressed.quantizer, values)
    })
    .expect("the encoder's own bytes")
}

/// Holds from the errors at the cuts: from the best cut so far to the
/// first later cut at least as good, wherever a cut in between is worse
/// by more than the factor `rise`; then joined where that loses little
/// ([`JOIN`]).
fn select(cuts: &[usize], errors: &[f64], rise: f64) -> Vec<[u32; 2]> {
    // Each hold with the error at its start.
    let mut holds: Vec<([u32; 2], f64)> = Vec::new();
    let mut hold = |from: usize, to: usize| {
        let error = errors[from];
        // Stream offsets fit 32 bits: the container's holds are u32.
        let span = [cuts[from], cuts[to]].map(|c| u32::try_from(c).unwrap_or(u32::MAX));
        match holds.last_mut() {
            // A hold costs 2 to 10 header bytes, which every cut pays; the
            // cuts between two holds whose starts are nearly as good gain
            // little over the first start. Still monotone: the joined
            // hold's end is at least as good as both starts.
            Some((last, last_error)) if *last_error <= error * JOIN => last[1] = span[1],
            _ => holds.push((span, error)),
        }
    };
    let mut best = 0;
    let mut rising = false;
    for (i, &e) in errors.iter().enumerate() {
        if e <= errors[best] {
            if rising {
                hold(best, i);
            }
            best = i;
            rising = false;
        } else if e > errors[best] * rise {
            rising = true;
        }
    }
    if rising {
        // The whole stream decodes whole, whatever its error.
        hold(best, cuts.len() - 1);
    }
    holds.into_iter().map(|(span, _)| span).collect()
}

/// Two holds are joined when the first one's start errs by at most this
/// factor (0.05 dB) more than the second one's.
const JOIN: f64 = 1.011_579_454_1;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn holds_span_each_rise_from_the_best_cut_to_recovery() {
        let cuts = [1, 2, 3, 4, 5, 6, 7, 8];
        let errors = [9.0, 5.0, 6.0, 7.0, 4.0, 4.01, 3.0, 3.5];
        // 2..5 rises by 40%: held; 5..6 by 0.25%: not; 7..8 never recovers.
        assert_eq!(select(&cuts, &errors, RISE), vec![[2, 5], [7, 8]]);
        // Holds from 10 and from 30 start 0.04 dB apart: joined; the one
        // from 50 starts 0.3 dB lower: not.
        let cuts = [10, 20, 30, 40, 50, 60, 70];
        let errors = [1.01, 1.1, 1.0, 1.1, 0.93, 1.0, 0.9];
        assert_eq!(select(&cuts, &errors, RISE), vec![[10, 50], [50, 70]]);
        assert!(select(&cuts, &[3.0, 2.0, 1.0], RISE).is_empty());
    }

    #[test]
    fn cuts_cover_the_stream_and_its_pass_ends() {
        let c = cuts(10_000, 1 << 20, &[17, 5_000]);
        assert_eq!((c[0], c[c.len() - 1]), (1, 10_000));
        assert!(c.contains(&17) && c.contains(&5_000));
        assert!(c.len() > MIN_CUTS && c.windows(2).all(|w| w[0] < w[1]));
        // A small mesh gets a cut at nearly every byte.
        assert_eq!(cuts(300, 64, &[]).len(), 300);
    }
}
