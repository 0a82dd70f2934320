//! Encoding: a semi-regular mesh to the bytes of a `.qm` file
//! ([`compress`], with [`EncodeOptions`]).
//!
//! The samples are quantized, lifted (in the local frames [`Frames`]
//! chooses), gathered into zerotree order and coded in bit planes; the base
//! vertices' level-0 values go into the base section, all but their low
//! bits, which the bit planes carry with the details' bits of the same
//! weight. The encoder then measures its own stream at many cuts and writes
//! [`crate::holds`] into the header where a longer cut would decode worse,
//! and cuts the file to a byte budget.

use qm_ezw::{Contexts, Weighting, ZeroTree};
use qm_lift::{Coord, Layout, Lifting, Quantizer, SemiRegularMesh, UpdateRule};

use crate::colour::{self, Colours};
use crate::compressed::Compressed;
use crate::container::{self, BaseSection, Header, Limits};
use crate::frames::{self, Frames};
use crate::holds::{self, Probes};
use crate::{Error, Result, basecode};

/// Default extra weight, in bits, of the normal component of the details:
/// it moves the surface, the tangential ones mostly slide samples along it
/// (docs/decisions/027-normal-weight-bits.md).
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
    compress_all(mesh, None, options, probes)
}

/// [`compress_probed`] with one 8-bit sRGB colour per sample of `mesh` (or
/// of a finer level of its base), coded in a stream of its own that the
/// file interleaves with the geometry's as their measured gains say
/// (`docs/appearance.md`), as far as [`Colours::missed`] says; the probes
/// (built when `None`) also measure the geometry for that.
pub fn compress_coloured(
    mesh: &SemiRegularMesh,
    colours: Colours<'_>,
    options: &EncodeOptions,
    probes: Option<&Probes>,
) -> Result<Compressed> {
    compress_all(mesh, Some(colours), options, probes)
}

/// [`compress_probed`], with colours or not.
fn compress_all(
    mesh: &SemiRegularMesh,
    colours: Option<Colours<'_>>,
    options: &EncodeOptions,
    probes: Option<&Probes>,
) -> Result<Compressed> {
    // With colours the budget is the interleaved file's: the geometry's
    // frames and holds are chosen for its whole stream.
    let geometry_budget = if colours.is_some() {
        None
    } else {
        options.max_bytes
    };
    for (what, value, max) in [
        ("weight bits per level", options.weighting.bits_per_level, 2),
        (
            "normal weight bits",
            options.weighting.normal_bits,
            container::MAX_NORMAL_BITS as u32,
        ),
    ] {
        // An encoder setting: the caller's parameter, not a limit to raise.
        if value > max {
            return Err(Error::Setting {
                what,
                value: value as u64,
                min: 0,
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
    let compress_with = |frames, prefix| {
        compress_with(
            mesh.layout(),
            quantizer,
            &quantized,
            options,
            frames,
            corners,
            prefix,
        )
    };
    let mut compressed = match options.frames {
        Frames::Off => compress_with(0, None)?,
        Frames::ParentsFrom(level) => {
            let kind = level.checked_sub(2).filter(|&k| k >= 1);
            let kind = kind.filter(|&k| k <= container::MAX_FRAMES as u32);
            let kind = kind.ok_or(Error::Setting {
                what: "first level of parent-quad frames",
                value: level as u64,
                min: 3,
                max: container::MAX_FRAMES as u64 + 2,
            })?;
            compress_with(kind as u8, None)?
        }
        Frames::Auto => frames::auto(mesh.layout(), &quantized, geometry_budget, compress_with)?,
    };
    let mut stream_end = None;
    let own;
    let probes = match probes {
        Some(p) => Some(p),
        None if options.holds || colours.is_some() => {
            own = Probes::on_surface(mesh);
            Some(&own)
        }
        None => None,
    };
    if let Some(probes) = probes {
        if probes.samples() != mesh.layout().sample_count() {
            return Err(Error::Setting {
                what: "samples of the probes' mesh",
                value: probes.samples() as u64,
                min: mesh.layout().sample_count() as u64,
                max: mesh.layout().sample_count() as u64,
            });
        }
    }
    // The geometry's errors the holds measured, for the colour's curve.
    let mut measured = holds::Measured::default();
    if let (true, Some(probes)) = (options.holds, probes) {
        let (mut holds, errors) = holds::find(&compressed, probes);
        measured = errors;
        if let Some(max) = geometry_budget {
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
    if let (Some(colours), Some(probes)) = (colours, probes) {
        compressed = with_colour(
            compressed,
            mesh.layout(),
            colours,
            options.update,
            probes,
            &measured,
        )?;
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
/// `frames`: the whole stream, or (`prefix`) one coded only as far as its
/// first `prefix` stream bytes, which are the whole stream's
/// ([`qm_ezw::encode_prefix`]), to measure cuts of.
fn compress_with(
    layout: &Layout,
    quantizer: Quantizer,
    quantized: &[Coord],
    options: &EncodeOptions,
    frames: u8,
    corners: Option<usize>,
    prefix: Option<usize>,
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
        whole: false,
        rounded: true,
    });

    let encoded = qm_ezw::encode_prefix(
        &tree,
        &coefs,
        in_stream,
        options.weighting,
        Contexts::Neighbours,
        options.passes,
        prefix.unwrap_or(usize::MAX),
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
        colour: None,
    };
    let section = BaseSection {
        faces: base.faces().to_vec(),
        values: values
            .iter()
            .map(|v| v.map(|x| container::rounded_high(x, low_bits)))
            .collect(),
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

/// `compressed` (geometry alone) with the colour stream of `colours`
/// interleaved, the geometry measured with `probes` where `measured` (the
/// holds' measure, before the holds) does not tell.
fn with_colour(
    compressed: Compressed,
    layout: &Layout,
    colours: Colours<'_>,
    update: UpdateRule,
    probes: &Probes,
    measured: &holds::Measured,
) -> Result<Compressed> {
    let code = colour::encode(layout, update, colours)?;
    let start = compressed.header_bytes + compressed.base_bytes;
    let geometry = &compressed.bytes[start..];
    // The geometry measured where the holds measure it, from no bytes on.
    let samples = colour::curve_work(compressed.quantized.len());
    let mut cuts = holds::cuts(geometry.len(), samples, &[]);
    cuts.extend(compressed.pass_ends.iter().map(|e| e - start));
    cuts.push(0);
    cuts.sort_unstable();
    cuts.dedup();
    // What the holds measured is known; the rest is measured now, as a
    // decoder sees it (holds and all).
    let c = container::read(&compressed.bytes, &Limits::NONE)?;
    let known = |cut: usize| measured.error_at(&c.header.holds, cut);
    let unknown: Vec<usize> = cuts
        .iter()
        .copied()
        .filter(|&cut| known(cut).is_none())
        .collect();
    let mut fresh = holds::errors(&compressed, probes, &unknown).into_iter();
    let geometry_curve: Vec<(usize, f64)> = (cuts.into_iter())
        .map(|cut| {
            (
                cut,
                known(cut).unwrap_or_else(|| fresh.next().expect("one a cut")),
            )
        })
        .collect();
    let colour_curve = code.curve;
    let runs = colour::interleave(&geometry_curve, &colour_curve);
    let stream = colour::join(&runs, geometry, &code.bytes);
    let finer = if code.header.finer > 0 {
        container::FINER_COLOUR
    } else {
        0
    };
    let header = Header {
        flags: c.header.flags | container::COLOUR | finer,
        colour: Some(container::ColourHeader {
            runs: runs.clone(),
            ..code.header
        }),
        ..c.header
    };
    let bytes = container::write(&header, &c.base, &stream)?;
    let header_bytes = header_len(&bytes);
    let prefix = bytes.len() - stream.len();
    let pass_ends = (compressed.pass_ends.iter())
        .map(|e| prefix + colour::offset_of(&runs, 0, e - start))
        .collect();
    Ok(Compressed {
        bytes,
        header_bytes,
        base_bytes: prefix - header_bytes,
        pass_ends,
        ..compressed
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

/// Magic, version, length, header and checksum of a written container.
fn header_len(bytes: &[u8]) -> usize {
    7 + u16::from_le_bytes([bytes[5], bytes[6]]) as usize + 4
}
