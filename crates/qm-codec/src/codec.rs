//! The whole codec: semi-regular mesh to `.qm` bytes and back.
//!
//! Encoding quantizes the samples, lifts them, gathers the details into
//! zerotree order and codes them in bit planes; the base vertices' level-0
//! values go into the base section, all but their low bits, which the bit
//! planes carry with the details' bits of the same weight. Decoding reverses each
//! step on whatever prefix of the stream is present, base values with
//! missing low bits at the centre of what is left.

use qm_ezw::{Contexts, Weighting, ZeroTree};
use qm_lift::glam::DVec3;
use qm_lift::{BaseMesh, Coord, Layout, Lifting, Quantizer, SemiRegularMesh, UpdateRule};
use rayon::prelude::*;

use crate::container::{self, BaseSection, Header, Limits};
use crate::holds::{self, Probes};
use crate::levels::{self, DEFAULT_TOLERANCE_DB, Estimate, LevelChoice};
use crate::{Error, Result, basecode};

/// Default extra weight, in bits, of the normal component of the details.
pub const DEFAULT_NORMAL_BITS: u32 = 2;

/// Encoder settings.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct EncodeOptions {
    /// Quantization bits per coordinate ([`qm_lift::DEFAULT_BITS`]).
    pub bits: u32,
    /// Most passes to code; `None` codes all, down to lossless.
    pub passes: Option<u32>,
    /// Most bytes for the whole file; the stream is cut to fit.
    pub max_bytes: Option<usize>,
    /// Lifting update rule.
    pub update: UpdateRule,
    /// Level and normal weighting of the bit-plane coder.
    pub weighting: Weighting,
    /// How details are expressed: world axes or local frames, normal
    /// first (see [`qm_lift::frames`]).
    pub frames: Frames,
    /// Measure the stream at many cuts and write holds where a longer cut
    /// would decode worse than a shorter one (see [`crate::holds`];
    /// default: on).
    pub holds: bool,
}

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
/// still missing (about 60 to 80 dB on the development models). Five cuts
/// (every power from 3 to 7) chose the same source on all ten development
/// models.
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
fn last_auto_kind(level: u32) -> u32 {
    level.saturating_sub(1).min(container::MAX_FRAMES as u32)
}

/// The search of [`Frames::Auto`] over frame kinds `1..=last`, given the
/// stream of kind 1: `encode` makes the stream of a
/// kind, `score` its `cut_error`. Kind 2 replaces kind 1 if it errs less,
/// and only then are later kinds tried; each replaces the best so far if
/// it errs less by more than `auto_margin`.
fn auto_search<T>(
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

impl EncodeOptions {
    /// The defaults: 16 bits, every pass, no size cap, mean-preserving
    /// update, one bit of weight per level.
    pub const DEFAULT: EncodeOptions = EncodeOptions {
        bits: qm_lift::DEFAULT_BITS,
        passes: None,
        max_bytes: None,
        update: UpdateRule::MeanPreserving,
        weighting: Weighting::LEVELS.with_normal_bits(DEFAULT_NORMAL_BITS),
        frames: Frames::Auto,
        holds: true,
    };

    /// Sets the quantization bits.
    pub const fn with_bits(mut self, bits: u32) -> Self {
        self.bits = bits;
        self
    }

    /// Sets the pass limit.
    pub const fn with_passes(mut self, passes: Option<u32>) -> Self {
        self.passes = passes;
        self
    }

    /// Sets the byte budget.
    pub const fn with_max_bytes(mut self, max_bytes: Option<usize>) -> Self {
        self.max_bytes = max_bytes;
        self
    }

    /// Sets the update rule.
    pub const fn with_update(mut self, update: UpdateRule) -> Self {
        self.update = update;
        self
    }

    /// Sets the level weighting.
    pub const fn with_weighting(mut self, weighting: Weighting) -> Self {
        self.weighting = weighting;
        self
    }

    /// Turns local frames on ([`Frames::Auto`]) or off.
    pub const fn with_frames(mut self, frames: bool) -> Self {
        self.frames = if frames { Frames::Auto } else { Frames::Off };
        self
    }

    /// Sets how details are expressed.
    pub const fn with_frame_source(mut self, frames: Frames) -> Self {
        self.frames = frames;
        self
    }

    /// Turns holds on or off.
    pub const fn with_holds(mut self, holds: bool) -> Self {
        self.holds = holds;
        self
    }
}

impl Default for EncodeOptions {
    fn default() -> Self {
        EncodeOptions::DEFAULT
    }
}

/// An encoded mesh and what went into it.
#[derive(Clone, Debug)]
pub struct Compressed {
    /// The `.qm` file contents.
    pub bytes: Vec<u8>,
    /// Bytes of magic, version, header and checksum.
    pub header_bytes: usize,
    /// Bytes of the base section.
    pub base_bytes: usize,
    /// File size at which the first `k + 1` passes end, for each pass. A
    /// file cut there decodes them, unless the cut falls inside a hold
    /// ([`container::Header::hold_cut`]): then it decodes as the hold's
    /// start, which the encoder measured closer to the input.
    pub pass_ends: Vec<usize>,
    /// The quantized samples the stream reproduces exactly when complete.
    pub quantized: Vec<Coord>,
    /// The quantizer used.
    pub quantizer: Quantizer,
}

/// Compresses a semi-regular mesh; holds, if asked for, are measured
/// against the mesh itself ([`Probes::on_surface`]).
pub fn compress(mesh: &SemiRegularMesh, options: &EncodeOptions) -> Result<Compressed> {
    compress_probed(mesh, options, None)
}

/// [`compress`], measuring the cuts for holds with `probes` (built from the
/// input the semi-regular mesh was made from: [`Probes::new`]) instead.
pub fn compress_probed(
    mesh: &SemiRegularMesh,
    options: &EncodeOptions,
    probes: Option<&Probes>,
) -> Result<Compressed> {
    for (what, value, max) in [
        ("weight bits per level", options.weighting.bits_per_level, 2),
        (
            "normal weight bits",
            options.weighting.normal_bits,
            container::MAX_NORMAL_BITS as u32,
        ),
    ] {
        if value > max {
            return Err(Error::Limit {
                what,
                value: value as u64,
                max: max as u64,
            });
        }
    }
    let quantizer = Quantizer::fit(mesh.positions(), options.bits)?;
    let mut quantized = quantizer.quantize_all(mesh.positions());
    // A level-0 split base whose midpoints and centres lie on its flat
    // triangles (the input's own triangles) is sent as its corners alone.
    let base = mesh.layout().base();
    let corners = (mesh.layout().level() == 0)
        .then(|| basecode::split_triangles_of(base.faces(), base.vertex_count() as usize))
        .flatten()
        .filter(|t| basecode::snap_split(base.faces(), t, &mut quantized, basecode::SNAP_STEPS))
        .map(|t| basecode::corner_count(&t));
    let compress_with = |frames| {
        compress_with(
            mesh.layout(),
            quantizer,
            &quantized,
            options,
            frames,
            corners,
        )
    };
    let mut compressed = match options.frames {
        Frames::Off => compress_with(0)?,
        Frames::ParentsFrom(level) => {
            let kind = level.checked_sub(2).filter(|&k| k >= 1);
            let kind = kind.filter(|&k| k <= container::MAX_FRAMES as u32);
            let kind = kind.ok_or(Error::Setting {
                what: "first level of parent-quad frames",
                value: level as u64,
                min: 3,
                max: container::MAX_FRAMES as u64 + 2,
            })?;
            compress_with(kind as u8)?
        }
        Frames::Auto => {
            // Parents from level 3 (kind 1) or 4 (kind 2), whichever cuts
            // come closer; if 4, each later level that brings them more than
            // `AUTO_MIN_GAIN_DB` closer than the best so far. From level
            // `L + 1` (kind `L - 1`) no level takes its frames from the
            // parents.
            let first = compress_with(1)?;
            let last = last_auto_kind(mesh.layout().level());
            if last < 2 {
                first
            } else {
                let normals = sample_normals(mesh.layout(), &quantized);
                // Cuts of what will be sent, shortest first so that each
                // decode resumes from the previous one's checkpoint.
                let sent = options
                    .max_bytes
                    .map_or(first.bytes.len(), |m| m.min(first.bytes.len()));
                let budgets = AUTO_CUTS.map(|k| sent >> k);
                let score = |c: &Compressed| cut_error(c, &normals, &budgets);
                auto_search(first, last, |kind| compress_with(kind as u8), score)?
            }
        }
    };
    let mut stream_end = None;
    if options.holds {
        let own;
        let probes = match probes {
            Some(p) => p,
            None => {
                own = Probes::on_surface(mesh);
                &own
            }
        };
        if probes.samples() != mesh.layout().sample_count() {
            return Err(Error::Setting {
                what: "samples of the probes' mesh",
                value: probes.samples() as u64,
                min: mesh.layout().sample_count() as u64,
                max: mesh.layout().sample_count() as u64,
            });
        }
        let mut holds = holds::find(&compressed, probes);
        if let Some(max) = options.max_bytes {
            // A budget that ends inside a hold would carry bytes no decoder
            // reads: the stream ends at the hold's start instead. Holds
            // from there on would be header bytes for nothing.
            let header_bytes = if holds.is_empty() {
                compressed.header_bytes
            } else {
                holds_header(&compressed, &holds)?.len()
            };
            let room = max.saturating_sub(header_bytes + compressed.base_bytes);
            let end = container::hold_cut(&holds, room);
            holds.retain(|&[from, _]| (from as usize) < end);
            stream_end = Some(end);
        }
        compressed = with_holds(compressed, holds)?;
    }
    if let Some(max) = options.max_bytes {
        let prefix = compressed.header_bytes + compressed.base_bytes;
        if max < prefix {
            return Err(Error::Budget {
                budget: max as u64,
                needed: prefix as u64,
            });
        }
        // The kept holds all end by `stream_end`: the header they shrank
        // leaves room that would only reach into a dropped one.
        let end = prefix + stream_end.map_or(max - prefix, |e| e.min(max - prefix));
        compressed.bytes.truncate(end);
        for pass_end in &mut compressed.pass_ends {
            *pass_end = (*pass_end).min(end);
        }
    }
    Ok(compressed)
}

/// [`compress`] of the `quantized` samples with header frame kind
/// `frames`, whole stream.
fn compress_with(
    layout: &Layout,
    quantizer: Quantizer,
    quantized: &[Coord],
    options: &EncodeOptions,
    frames: u8,
    corners: Option<usize>,
) -> Result<Compressed> {
    let mut data = quantized.to_vec();
    Lifting::new(layout, options.update)
        .with_parent_frames_from(container::parent_frames_from(frames))
        .forward(&mut data);
    let tree = ZeroTree::new(layout);
    let coefs = tree.gather(&data);
    let base = layout.base();
    let values = &data[..base.vertex_count() as usize];
    // An implied split base (its `corners`) sends its corners alone, high
    // bits in the base section and the rest in the stream, plane by plane;
    // the midpoints and centres follow from them. Any other level-0 mesh
    // keeps its base values whole in the base section, as before.
    let implied = corners.is_some();
    let most = if layout.level() == 0 && !implied {
        0
    } else {
        basecode::noise_bits(base.faces(), values, container::VERSION, implied)
    };
    let in_stream = Some(qm_ezw::BaseBits {
        values: &values[..corners.unwrap_or(values.len())],
        most,
    });

    let encoded = qm_ezw::encode(
        &tree,
        &coefs,
        in_stream,
        options.weighting,
        Contexts::Neighbours,
        options.passes,
    );
    let low_bits = encoded.params.base_bits;
    let header = Header {
        bits: options.bits as u8,
        level: layout.level() as u8,
        update: options.update.code(),
        weight_bits: options.weighting.bits_per_level as u8,
        normal_bits: options.weighting.normal_bits as u8,
        frames,
        origin: quantizer.origin,
        step: quantizer.step,
        base_vertices: base.vertex_count(),
        base_faces: base.faces().len() as u32,
        planes: encoded.params.planes as u8,
        passes: encoded.params.passes as u8,
        flags: low_bits | if implied { container::IMPLIED_SPLIT } else { 0 },
        holds: Vec::new(),
    };
    let section = BaseSection {
        faces: base.faces().to_vec(),
        values: values.iter().map(|v| v.map(|x| x >> low_bits)).collect(),
        low_bits,
    };
    let bytes = container::write(&header, &section, &encoded.bytes)?;
    let prefix = bytes.len() - encoded.bytes.len();
    let header_bytes = header_len(&bytes);
    let base_bytes = prefix - header_bytes;
    let pass_ends = encoded.pass_ends.iter().map(|e| prefix + e).collect();
    Ok(Compressed {
        bytes,
        header_bytes,
        base_bytes,
        pass_ends,
        quantized: quantized.to_vec(),
        quantizer,
    })
}

/// `compressed` (without holds) rewritten with `holds` in its header;
/// unchanged if there are none.
fn with_holds(compressed: Compressed, holds: Vec<[u32; 2]>) -> Result<Compressed> {
    if holds.is_empty() {
        return Ok(compressed);
    }
    // Only the header changes: the base section and the stream are
    // spliced on as they are.
    let mut bytes = holds_header(&compressed, &holds)?;
    let header_bytes = bytes.len();
    bytes.extend_from_slice(&compressed.bytes[compressed.header_bytes..]);
    let shift = header_bytes - compressed.header_bytes;
    let pass_ends = compressed.pass_ends.iter().map(|e| e + shift).collect();
    Ok(Compressed {
        pass_ends,
        header_bytes,
        bytes,
        ..compressed
    })
}

/// Magic, version, length, header and checksum of `compressed` (without
/// holds) with `holds`.
fn holds_header(compressed: &Compressed, holds: &[[u32; 2]]) -> Result<Vec<u8>> {
    let c = container::read(&compressed.bytes, &Limits::NONE)?;
    let header = Header {
        holds: holds.to_vec(),
        ..c.header
    };
    let mut bytes = container::write(&header, &c.base, &[])?;
    bytes.truncate(header_len(&bytes));
    Ok(bytes)
}

/// Unit normal of the finest surface at every sample (the sum of its quads'
/// diagonal cross products), in quantized coordinates.
fn sample_normals(layout: &Layout, values: &[Coord]) -> Vec<DVec3> {
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
fn cut_error(compressed: &Compressed, normals: &[DVec3], budgets: &[usize]) -> Result<f64> {
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

/// `measure` of the decoded samples of `compressed` at each of the stream
/// cuts `cuts` (ascending), as a decoder sees them (holds and all).
/// Contiguous runs of cuts decode on each thread, each cut resuming from
/// the last one's checkpoint.
pub(crate) fn measure_cuts(
    compressed: &Compressed,
    cuts: &[usize],
    measure: impl Fn(&[Coord]) -> f64 + Sync,
) -> Result<Vec<f64>> {
    // The encoder's own bytes: the decoder's default limits do not apply.
    let decoder = Decoder::new(&compressed.bytes, &Limits::NONE)?;
    let stream = &compressed.bytes[decoder.stream_start()..];
    let run = cuts.len().div_ceil(rayon::current_num_threads()).max(1);
    let runs: Vec<(Decoder, &[usize])> = (cuts.chunks(run))
        .map(|run| (decoder.clone(), run))
        .collect();
    Ok((runs.into_par_iter())
        .flat_map_iter(|(decoder, run)| {
            let mut values = Vec::new();
            run.iter()
                .map(|&cut| {
                    decoder.decode_into(&stream[..cut], None, None, &mut values);
                    measure(&values)
                })
                .collect::<Vec<_>>()
        })
        .collect())
}

/// Magic, version, length, header and checksum of a written container.
fn header_len(bytes: &[u8]) -> usize {
    7 + u16::from_le_bytes([bytes[5], bytes[6]]) as usize + 4
}

/// Decoder settings.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct DecodeOptions {
    /// Use only the first this many bytes, as if the rest never arrived.
    pub max_bytes: Option<usize>,
    /// Decode at most this many passes.
    pub passes: Option<u32>,
    /// Which level to reconstruct (default: [`LevelChoice::Auto`], the
    /// level the bytes support).
    pub level: LevelChoice,
    /// Stop at the first pass end whose estimated error
    /// ([`Estimate::remaining`], model units) is at most this, using no
    /// more of the stream; 0 decodes everything (the estimate can reach 0
    /// before the last pass).
    pub max_error: Option<f64>,
    /// Output no level with more triangles than this (two per quad; level
    /// 0 if even that has more).
    pub max_triangles: Option<u64>,
    /// How much worse, in dB of estimated PSNR, [`LevelChoice::Auto`] lets
    /// its level be than the finest ([`DEFAULT_TOLERANCE_DB`]).
    pub tolerance_db: f64,
    /// Limits on what the header may ask for.
    pub limits: Limits,
}

impl Default for DecodeOptions {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl DecodeOptions {
    /// Everything received, the level the bytes support, default limits.
    pub const DEFAULT: DecodeOptions = DecodeOptions {
        max_bytes: None,
        passes: None,
        level: LevelChoice::Auto,
        max_error: None,
        max_triangles: None,
        tolerance_db: DEFAULT_TOLERANCE_DB,
        limits: Limits::DEFAULT,
    };

    /// [`Self::DEFAULT`] at the finest level whatever the prefix, as the
    /// codec's rate-distortion measurements decode.
    pub const FINEST: DecodeOptions = Self::DEFAULT.with_level(LevelChoice::Finest);

    /// Sets the byte budget.
    pub const fn with_max_bytes(mut self, max_bytes: Option<usize>) -> Self {
        self.max_bytes = max_bytes;
        self
    }

    /// Sets the pass limit.
    pub const fn with_passes(mut self, passes: Option<u32>) -> Self {
        self.passes = passes;
        self
    }

    /// Sets how the output level is chosen.
    pub const fn with_level(mut self, level: LevelChoice) -> Self {
        self.level = level;
        self
    }

    /// Sets the error goal.
    pub const fn with_max_error(mut self, max_error: Option<f64>) -> Self {
        self.max_error = max_error;
        self
    }

    /// Sets the triangle cap.
    pub const fn with_max_triangles(mut self, max_triangles: Option<u64>) -> Self {
        self.max_triangles = max_triangles;
        self
    }

    /// Sets the tolerance of [`LevelChoice::Auto`].
    pub const fn with_tolerance_db(mut self, tolerance_db: f64) -> Self {
        self.tolerance_db = tolerance_db;
        self
    }

    /// Sets the limits.
    pub const fn with_limits(mut self, limits: Limits) -> Self {
        self.limits = limits;
        self
    }
}

/// A decoded mesh.
#[derive(Clone, Debug)]
pub struct Decompressed {
    /// The sample layout (finest level).
    pub layout: Layout,
    /// Reconstructed quantized values; at [`Self::level`] below the finest,
    /// only the samples of that level hold positions.
    pub values: Vec<Coord>,
    /// The quantizer of the header.
    pub quantizer: Quantizer,
    /// The level reconstructed.
    pub level: u32,
    /// The header.
    pub header: Header,
    /// Passes decoded completely.
    pub passes: u32,
    /// Whether the stream ended before the passes asked for.
    pub truncated: bool,
    /// Bytes of header and base section.
    pub header_bytes: usize,
    /// Bytes of the base section.
    pub base_bytes: usize,
    /// Stream bytes present.
    pub stream_bytes: usize,
    /// Stream bytes decoded: fewer than present when the cut falls inside
    /// one of the header's holds ([`container::Header::hold_cut`]) or an
    /// error goal was met sooner.
    pub decoded_stream_bytes: usize,
    /// The decoder's estimate of the error of each level at this prefix.
    pub estimate: Estimate,
}

impl Decompressed {
    /// The mesh at the decoded level: positions of that level's samples and
    /// its quads, indices into those positions.
    pub fn level_mesh(&self) -> (Vec<DVec3>, Vec<[u32; 4]>) {
        let samples = self.layout.samples_at(self.level);
        let mut index = vec![u32::MAX; self.layout.sample_count()];
        for (i, &s) in samples.iter().enumerate() {
            index[s as usize] = i as u32;
        }
        let positions = samples.iter().map(|&s| self.position(s as usize)).collect();
        let quads = self
            .layout
            .quads(self.level)
            .iter()
            .map(|q| q.map(|s| index[s as usize]))
            .collect();
        (positions, quads)
    }

    /// World position of sample `s`.
    pub fn position(&self, s: usize) -> DVec3 {
        self.quantizer.dequantize(self.values[s].map(f64::from))
    }

    /// The finest-level semi-regular mesh (only meaningful when decoded at
    /// the finest level).
    pub fn to_semi_regular(&self) -> Result<SemiRegularMesh> {
        let positions = (0..self.values.len()).map(|s| self.position(s)).collect();
        Ok(SemiRegularMesh::new(self.layout.clone(), positions)?)
    }
}

/// Decompresses `.qm` bytes, which may be cut anywhere after the base mesh.
pub fn decompress(bytes: &[u8], options: &DecodeOptions) -> Result<Decompressed> {
    let bytes = &bytes[..options
        .max_bytes
        .map_or(bytes.len(), |m| m.min(bytes.len()))];
    let decoder = Decoder::new(bytes, &options.limits)?;
    let mut values = Vec::new();
    let (status, estimate) = decoder.decode_choosing(
        &bytes[decoder.stream_start()..],
        options,
        &mut values,
        false,
    );
    let Decoder {
        header,
        layout,
        quantizer,
        header_bytes,
        base_bytes,
        ..
    } = decoder;
    let stream_bytes = bytes.len() - header_bytes - base_bytes;
    Ok(Decompressed {
        decoded_stream_bytes: status.decoded_bytes,
        stream_bytes,
        values,
        quantizer,
        level: status.level,
        header,
        passes: status.passes,
        truncated: status.truncated,
        header_bytes,
        base_bytes,
        layout,
        estimate,
    })
}

/// A parsed header and base mesh, ready to decode stream prefixes again and
/// again: a viewer that receives a file in pieces builds the layout and the
/// trees once and decodes each longer prefix with [`Decoder::decode_into`].
///
/// It also keeps the bit-plane decoder's state at the last complete pass
/// (a [`qm_ezw::Checkpoint`]), so a longer cut of the same stream resumes
/// there instead of decoding every pass again. The result never depends on
/// it: any stream, cut or pass limit gives what [`decompress`] gives.
#[derive(Clone, Debug)]
pub struct Decoder {
    checkpoint: std::cell::RefCell<Option<qm_ezw::Checkpoint>>,
    header: Header,
    /// The base section's values: high parts when the stream holds low bits
    /// (with the split implied, those of the corners, and zeros).
    base_values: Vec<Coord>,
    /// With the split implied ([`container::IMPLIED_SPLIT`]): the base's
    /// triangles, whose corners alone have values, the other base values
    /// being made from them.
    split: Option<Vec<[u32; 3]>>,
    layout: Layout,
    tree: ZeroTree,
    quantizer: Quantizer,
    header_bytes: usize,
    base_bytes: usize,
}

/// What one call of [`Decoder::decode_into`] achieved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct DecodeStatus {
    /// The level reconstructed.
    pub level: u32,
    /// Passes decoded completely.
    pub passes: u32,
    /// Whether the stream ended before the passes asked for.
    pub truncated: bool,
    /// Stream bytes used: fewer than given when the cut falls inside one
    /// of the header's holds ([`container::Header::hold_cut`]), or when the
    /// passes asked for (or an error goal) ended sooner.
    pub decoded_bytes: usize,
}

impl Decoder {
    /// Parses the header and base mesh at the start of `bytes` (a file or
    /// any prefix of it that holds the base section).
    pub fn new(bytes: &[u8], limits: &Limits) -> Result<Self> {
        let c = container::read(bytes, limits)?;
        let h = c.header;
        let base = BaseMesh::new(h.base_vertices, c.base.faces)?;
        let layout = Layout::new(base, h.level as u32)?;
        let tree = ZeroTree::new(&layout);
        let quantizer = Quantizer {
            bits: h.bits as u32,
            origin: h.origin,
            step: h.step,
        };
        // The base section's decoder checked that an implied base is a split.
        let split = h
            .implied()
            .then(|| basecode::split_triangles_of(layout.base().faces(), h.base_vertices as usize))
            .flatten();
        Ok(Decoder {
            checkpoint: std::cell::RefCell::new(None),
            header: h,
            split,
            base_values: c.base.values,
            layout,
            tree,
            quantizer,
            header_bytes: c.header_bytes,
            base_bytes: c.base_bytes,
        })
    }

    /// Offset of the embedded stream in the file.
    pub fn stream_start(&self) -> usize {
        self.header_bytes + self.base_bytes
    }

    /// The header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// The sample layout (finest level).
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// The quantizer of the header.
    pub fn quantizer(&self) -> &Quantizer {
        &self.quantizer
    }

    /// Decodes `stream` (the bytes after [`Self::stream_start`], cut
    /// anywhere; a cut inside a hold decodes as the hold's start) up to
    /// `passes` passes and reconstructs `level` (default: the finest) into
    /// `values`, one quantized value per sample id; at a level below the
    /// finest only that level's samples hold positions.
    pub fn decode_into(
        &self,
        stream: &[u8],
        passes: Option<u32>,
        level: Option<u32>,
        values: &mut Vec<Coord>,
    ) -> DecodeStatus {
        self.decode_with(stream, passes, level, values, true)
    }

    /// [`Self::decode_into`], keeping a checkpoint for the next call or not.
    fn decode_with(
        &self,
        stream: &[u8],
        passes: Option<u32>,
        level: Option<u32>,
        values: &mut Vec<Coord>,
        resume: bool,
    ) -> DecodeStatus {
        let (decoded, used) = self.coefficients(stream, passes, resume);
        self.fill(&decoded, values);
        let level = level.map_or(self.layout.level(), |l| l.min(self.layout.level()));
        self.lifting().inverse_to(values, level);
        DecodeStatus {
            level,
            passes: decoded.passes,
            truncated: decoded.truncated,
            decoded_bytes: used,
        }
    }

    /// Decodes `stream` (as [`Self::decode_into`]) with `options`' pass
    /// limit, error goal and level choice (its byte budget is the
    /// caller's), into `values` at the level chosen; the decoder's estimate
    /// of the error of each level (see [`crate::levels`]).
    pub fn decode_choosing(
        &self,
        stream: &[u8],
        options: &DecodeOptions,
        values: &mut Vec<Coord>,
        resume: bool,
    ) -> (DecodeStatus, Estimate) {
        let limit = options.passes.map_or(self.header.passes as u32, |p| {
            p.min(self.header.passes as u32)
        });
        let (decoded, used) = match options.max_error {
            Some(goal) => self.coefficients_to(stream, limit, goal, resume),
            None => self.coefficients(stream, Some(limit), resume),
        };
        self.fill(&decoded, values);
        let big_l = self.layout.level();
        let diagonal = levels::diagonal(
            values[..self.layout.base().vertex_count() as usize]
                .iter()
                .copied(),
            self.header.step,
        );
        let remaining = levels::remaining(&self.header, &self.tree, &decoded, self.base_count());
        let complete = !decoded.truncated && decoded.passes == self.header.passes as u32;
        let lifting = self.lifting();
        let status = |level| DecodeStatus {
            level,
            passes: decoded.passes,
            truncated: decoded.truncated,
            decoded_bytes: used,
        };
        let cap = |level: u32| match options.max_triangles {
            Some(max) => (0..=level)
                .rev()
                .find(|&l| self.triangles_at(l) <= max)
                .unwrap_or(0),
            None => level,
        };
        let unknown = || {
            let mut gaps = vec![f64::NAN; big_l as usize + 1];
            gaps[big_l as usize] = 0.0;
            gaps
        };
        if options.level == LevelChoice::Finest {
            let level = cap(big_l);
            lifting.inverse_to(values, level);
            let estimate = Estimate {
                remaining,
                gaps: unknown(),
                diagonal,
            };
            return (status(level), estimate);
        }
        // Levels past the finest one holding a significant coefficient
        // add only the subdivision's smoothing: lift one level past it (two
        // at least: on whole base faces the stencils reach irregular
        // vertices everywhere and fall back to linear, so the step from
        // level 0 to 1 has none to measure).
        let levels = self.tree.levels();
        let top = decoded
            .nonzero
            .iter()
            .map(|e| levels[e.node as usize] as u32)
            .max()
            .unwrap_or(0);
        let reach = (top + 1).max(2).min(big_l);
        let mut steps = Vec::with_capacity(reach as usize);
        let mut grid = Vec::new();
        for j in 0..reach {
            levels::level_grid(&self.layout, j, values, &mut grid);
            lifting.inverse_levels(values, j, j + 1);
            let gap = levels::step_gap(&self.layout, j, &grid, values);
            steps.push(gap.model_rms(self.header.step));
        }
        let estimate = Estimate {
            remaining,
            gaps: levels::gaps_from_steps(&steps, big_l),
            diagonal,
        };
        let wanted = match options.level {
            LevelChoice::Fixed(l) => l.min(big_l),
            _ if complete => big_l,
            _ => estimate.coarsest_within(options.tolerance_db),
        };
        let level = cap(wanted);
        if level < reach {
            self.fill(&decoded, values);
            lifting.inverse_to(values, level);
        } else {
            lifting.inverse_levels(values, reach, level);
        }
        (status(level), estimate)
    }

    /// Triangles of the mesh at `level`, two per quad.
    pub fn triangles_at(&self, level: u32) -> u64 {
        let level = level.min(self.layout.level());
        2 * self.layout.face_count() as u64 * (1u64 << (2 * level))
    }

    /// How many base vertices have their low bits in the stream.
    fn base_count(&self) -> u32 {
        match &self.split {
            Some(triangles) => basecode::corner_count(triangles) as u32,
            None => self.header.base_vertices,
        }
    }

    /// The lifting transform of the header.
    fn lifting(&self) -> Lifting<'_> {
        let update = UpdateRule::from_code(self.header.update).expect("checked by the container");
        Lifting::new(&self.layout, update).with_parent_frames_from(self.header.parent_frames_from())
    }

    /// The stream's coefficients up to `passes` passes, and how many of
    /// the stream's bytes they used.
    fn coefficients(
        &self,
        stream: &[u8],
        passes: Option<u32>,
        resume: bool,
    ) -> (qm_ezw::Decoded, usize) {
        let mut params = self.header.stream_params();
        params.base_values = self.base_count();
        let stream = &stream[..self.header.hold_cut(stream.len())];
        let decoded = if resume {
            let from = self.checkpoint.take();
            let (decoded, checkpoint) =
                qm_ezw::decode_resuming(&self.tree, params, stream, passes, from);
            self.checkpoint.replace(checkpoint);
            decoded
        } else {
            qm_ezw::decode(&self.tree, params, stream, passes)
        };
        let used = if decoded.truncated {
            stream.len()
        } else {
            decoded.bytes_read.min(stream.len())
        };
        (decoded, used)
    }

    /// The coefficients of the first pass end, up to `limit` passes, whose
    /// estimated remaining error is at most `goal` (or of everything, if
    /// none is), pass by pass from the checkpoints.
    fn coefficients_to(
        &self,
        stream: &[u8],
        limit: u32,
        goal: f64,
        resume: bool,
    ) -> (qm_ezw::Decoded, usize) {
        let base = self.base_count();
        let mut passes = 0;
        loop {
            let (decoded, used) = self.coefficients(stream, Some(passes), resume);
            // A goal of 0 is the lossless mesh: the estimate reaches 0 on
            // the last passes' tangential bits, which it does not weigh.
            let met =
                goal > 0.0 && levels::remaining(&self.header, &self.tree, &decoded, base) <= goal;
            if met || decoded.truncated || passes >= limit {
                return (decoded, used);
            }
            passes += 1;
        }
    }

    /// Base values, their low bits and the split base's derived values,
    /// then the coefficients at their samples.
    fn fill(&self, decoded: &qm_ezw::Decoded, values: &mut Vec<Coord>) {
        let k = self.header.stream_params().base_bits;
        values.clear();
        values.resize(self.layout.sample_count(), [0; 3]);
        values[..self.base_values.len()].copy_from_slice(&self.base_values);
        if !decoded.base_low.is_empty() {
            // The container checked that high and low parts fit 32 bits.
            for (v, low) in values.iter_mut().zip(&decoded.base_low) {
                *v = std::array::from_fn(|c| (v[c] << k) + low[c]);
            }
        }
        if let Some(triangles) = &self.split {
            let base = self.layout.base();
            let values = &mut values[..base.vertex_count() as usize];
            basecode::snap_split(base.faces(), triangles, values, i64::MAX);
        }
        decoded.scatter(self.tree.samples(), values);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use qm_lift::synthetic::bumpy_sphere as sphere;

    /// Level 0: a split base on flat triangles is sent as its corners (the
    /// midpoints and centres snapped, a step or two away); a split base off
    /// them, and a base that is no split, keep every value whole in the
    /// base section, as before the flag; all come back exactly.
    #[test]
    fn level_0_bases_implied_only_where_flat() {
        let cases = [
            (qm_lift::synthetic::flat_split_octahedron(), true),
            (qm_lift::synthetic::bumpy_split_octahedron(0), false),
            (sphere(0), false),
        ];
        for (i, (mesh, flat)) in cases.into_iter().enumerate() {
            let c = compress(&mesh, &EncodeOptions::DEFAULT).unwrap();
            let d = decompress(&c.bytes, &DecodeOptions::default()).unwrap();
            assert_eq!(d.values, c.quantized, "case {i}");
            assert_eq!(d.header.implied(), flat, "case {i}");
            let q = Quantizer::fit(mesh.positions(), 16).unwrap();
            let exact = q.quantize_all(mesh.positions());
            let moved = exact
                .iter()
                .zip(&c.quantized)
                .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
                .max()
                .unwrap();
            if flat {
                assert!((1..=2).contains(&moved), "case {i}: moved {moved}");
                assert!(d.header.planes > 0 && d.header.stream_params().base_bits > 0);
            } else {
                assert_eq!(moved, 0, "case {i}");
                assert_eq!((d.header.planes, d.header.flags), (0, 0), "case {i}");
            }
        }
    }

    #[test]
    fn lossless_at_the_last_pass() {
        let mesh = sphere(4);
        let c = compress(&mesh, &EncodeOptions::DEFAULT).unwrap();
        let d = decompress(&c.bytes, &DecodeOptions::default()).unwrap();
        assert_eq!(d.values, c.quantized);
        assert!(!d.truncated);
        assert_eq!(d.passes, d.header.planes as u32);
    }

    /// A decoder fed longer and longer cuts, resuming from its checkpoints,
    /// gives what decompressing each cut gives.
    #[test]
    fn incremental_decoding_equals_decompress() {
        let c = compress(&sphere(4), &EncodeOptions::DEFAULT).unwrap();
        let decoder = Decoder::new(&c.bytes, &Limits::DEFAULT).unwrap();
        let start = decoder.stream_start();
        let mut values = Vec::new();
        for cut in (start..=c.bytes.len()).step_by(97).chain([c.bytes.len()]) {
            let status = decoder.decode_into(&c.bytes[start..cut], None, None, &mut values);
            let d = decompress(&c.bytes[..cut], &DecodeOptions::FINEST).unwrap();
            assert_eq!(values, d.values, "cut {cut}");
            assert_eq!((status.passes, status.truncated), (d.passes, d.truncated));
        }
        assert_eq!(values, c.quantized);
    }

    /// The base values' low bits arrive with the passes of their weight:
    /// after `p` passes each is within half the weight of its first unknown
    /// bit of the true level-0 value (what the whole stream gives), a bound that halves with every pass that carries base bits.
    /// (One value can move away: one at the centre of its interval is off
    /// by a quarter of it once the next bit is known.)
    #[test]
    fn base_values_sharpen_pass_by_pass() {
        let mesh = sphere(4);
        let stream = compress(&mesh, &EncodeOptions::DEFAULT).unwrap();
        let whole = decompress(
            &stream.bytes,
            &DecodeOptions::default().with_level(LevelChoice::Fixed(0)),
        );
        let mut truth = whole.unwrap().values;
        let decoder = Decoder::new(&stream.bytes, &Limits::DEFAULT).unwrap();
        truth.truncate(decoder.header().base_vertices as usize);
        let (h, k) = (decoder.header(), decoder.header().stream_params().base_bits);
        let s0 = h.stream_params().weighting.base_shift(h.level as u32);
        assert!(k > 3 && k <= h.planes as u32 - s0, "{k} base bits");
        let stream_bytes = &stream.bytes[decoder.stream_start()..];
        let mut values = Vec::new();
        let mut worst = i32::MAX;
        for p in 0..=h.planes as u32 {
            decoder.decode_into(stream_bytes, Some(p), Some(0), &mut values);
            worst = (values.iter().zip(&truth))
                .flat_map(|(v, t)| (0..3).map(move |c| (v[c] - t[c]).abs()))
                .max()
                .unwrap();
            let unknown = (h.planes as u32 - p).saturating_sub(s0).min(k);
            assert!(worst <= (1 << unknown) / 2, "pass {p}: off by {worst}");
            assert!(p > 0 || worst > 1 << (k - 3), "pass 0 knows no low bit");
        }
        assert_eq!(worst, 0);
    }

    #[test]
    fn byte_budget_and_coarser_levels() {
        let mesh = sphere(4);
        let budget = EncodeOptions::DEFAULT.with_max_bytes(Some(600));
        assert_eq!(
            compress(&mesh, &budget.with_holds(false))
                .unwrap()
                .bytes
                .len(),
            600
        );
        // With holds the file may end sooner: at a hold's start, and without
        // the header bytes of holds past the budget.
        let c = compress(&mesh, &budget).unwrap();
        assert!((500..=600).contains(&c.bytes.len()), "{}", c.bytes.len());
        let d = decompress(
            &c.bytes,
            &DecodeOptions::default().with_level(LevelChoice::Fixed(2)),
        )
        .unwrap();
        assert!(d.truncated);
        let (positions, quads) = d.level_mesh();
        assert_eq!(quads.len(), 6 * 16);
        assert_eq!(positions.len(), 6 * 16 + 2);
        assert!(compress(&mesh, &EncodeOptions::DEFAULT.with_max_bytes(Some(10))).is_err());
    }

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

    /// Each frame source is written into the header and decodes losslessly;
    /// the automatic choice is, byte for byte, the candidate the documented
    /// rule picks from the errors of their cuts along the normal. This
    /// sphere prefers level 4 to 3 and then level 5 to 4, so the search past
    /// level 4 is exercised (at 5 levels the same sphere keeps 4).
    #[test]
    fn frame_sources_round_trip_and_auto_keeps_the_closest_one() {
        let mesh = sphere(7);
        // Without holds: the choice is made before them, on the bare streams.
        let options = EncodeOptions::DEFAULT.with_holds(false);
        let with = |frames| compress(&mesh, &options.with_frame_source(frames)).unwrap();
        let (from3, from4, auto) = (
            with(Frames::ParentsFrom(3)),
            with(Frames::ParentsFrom(4)),
            with(Frames::Auto),
        );
        for (c, kind) in [(&from3, 1), (&from4, 2), (&with(Frames::Off), 0)] {
            let d = decompress(&c.bytes, &DecodeOptions::default()).unwrap();
            assert_eq!(d.header.frames, kind);
            assert_eq!(d.values, c.quantized);
        }
        assert_ne!(from3.bytes, from4.bytes);
        let normals = sample_normals(mesh.layout(), &from3.quantized);
        let budgets = AUTO_CUTS.map(|k| from3.bytes.len() >> k);
        let error = |c: &Compressed| cut_error(c, &normals, &budgets).unwrap();
        // The search (tested on its own in `auto_search_looks_past_a_small_step`)
        // over the streams of each frame source, scored by their cuts.
        assert!(
            error(&from4) < error(&from3),
            "the test mesh no longer tries levels past 4"
        );
        let chosen = auto_search(
            from3.clone(),
            last_auto_kind(mesh.layout().level()),
            |kind| Ok(with(Frames::ParentsFrom(kind + 2))),
            |c| Ok(error(c)),
        )
        .unwrap();
        assert_eq!(auto.bytes, chosen.bytes);
        assert_ne!(auto.bytes, from4.bytes, "the search no longer goes past 4");
        for level in [0, 2, 14] {
            let options = EncodeOptions::DEFAULT.with_frame_source(Frames::ParentsFrom(level));
            assert!(compress(&mesh, &options).is_err(), "parents from {level}");
        }
    }
}
