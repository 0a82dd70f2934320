//! Decoding: the bytes of a `.qm` file, or any prefix of them that holds
//! the base section, back to a mesh ([`decompress`], with
//! [`DecodeOptions`], into a [`Decompressed`]); [`Decoder`] does so again
//! and again for a growing stream.
//!
//! Each step of the encoder is reversed on whatever prefix of the stream is
//! present: the bit planes give the coefficients known so far, the base
//! values get their low bits (those missing at the centre of what is
//! left), a split base sent as its corners gets its midpoints and centres
//! back, and the inverse lifting rebuilds the level the options choose
//! ([`crate::levels`]). A cut inside one of the header's holds decodes as
//! the hold's start.
//!
//! **Only the levels a prefix reaches.** A short prefix holds coefficients
//! of the coarse levels alone: the bit-plane walk reaches a level only
//! through an open subtree, which opens only over a significant
//! coefficient (`qm_ezw`'s module `walk`). So the decoder builds its trees
//! ([`qm_ezw::ZeroTree::partial`]) and its sample layout level by level as
//! the stream and the level choice reach them, and numbers the samples as
//! the finest level built does: a preview costs time and memory in
//! proportion to its own size, not the file's finest level
//! (docs/decisions/031-decode-only-the-levels-reached.md). The result is
//! the same, bit for bit, as with every level built: the lifting of a
//! level reads only that level's and coarser samples.

use qm_ezw::ZeroTree;
use qm_lift::glam::DVec3;
use qm_lift::{BaseMesh, Coord, Layout, Lifting, Quantizer, SemiRegularMesh, UpdateRule};

use crate::atlas::Atlas;
use crate::container::{self, Header, Limits};
use crate::levels::{self, DEFAULT_TOLERANCE_DB, Estimate, LevelChoice};
use crate::{Result, basecode};

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
    /// The sample layout of the levels the decoder built: at least
    /// [`Self::level`], at most the file's finest ([`Header::level`]); the
    /// finest whenever the mesh is.
    pub layout: Layout,
    /// Reconstructed quantized values, one per sample of [`Self::layout`];
    /// at [`Self::level`] below the layout's, only the samples of that
    /// level hold positions.
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
    /// For a file with colours: one 8-bit sRGB colour per vertex of the
    /// mesh at [`Self::level`], in the order of [`Self::level_mesh`]'s
    /// positions.
    pub colours: Option<Vec<[u8; 3]>>,
    /// For a file whose colours reached a finer level than the mesh's:
    /// those colours as a texture ([`Decoder::texture`]); the texture
    /// coordinates of the mesh's corners are [`Atlas::corner_texcoords`].
    pub texture: Option<Atlas>,
}

impl Decompressed {
    /// The mesh at the decoded level: positions of that level's samples and
    /// its quads, indices into those positions.
    pub fn level_mesh(&self) -> (Vec<DVec3>, Vec<[u32; 4]>) {
        let (samples, quads) = level_index(&self.layout, self.level);
        let positions = samples.iter().map(|&s| self.position(s as usize)).collect();
        (positions, quads)
    }

    /// World position of sample `s`.
    pub fn position(&self, s: usize) -> DVec3 {
        self.quantizer.dequantize(self.values[s].map(f64::from))
    }

    /// The semi-regular mesh of [`Self::layout`] (only meaningful when
    /// decoded at its level, as at the finest level).
    pub fn to_semi_regular(&self) -> Result<SemiRegularMesh> {
        let positions = (0..self.values.len()).map(|s| self.position(s)).collect();
        Ok(SemiRegularMesh::new(self.layout.clone(), positions)?)
    }
}

/// The samples of `layout` (a layout of level `level` or finer) that exist
/// at `level`, in increasing id order, and that level's quads as indices
/// into them, counter-clockwise. A sample's index is its id in a level
/// `level` layout ([`qm_lift::Numbering::refine`] keeps the order), so
/// nothing the size of the finer layout is made.
pub(crate) fn level_index(layout: &Layout, level: u32) -> (Vec<u32>, Vec<[u32; 4]>) {
    let level = level.min(layout.level());
    let to = layout.numbering();
    let from = to.at_level(level);
    let count = layout.base().sample_count(level) as u32;
    let samples = (0..count).map(|s| from.refine(s, to)).collect();
    let own = Layout::new(layout.base().clone(), level).expect("coarser than a layout");
    (samples, own.quads(level))
}

/// Decompresses `.qm` bytes, which may be cut anywhere after the base mesh.
pub fn decompress(bytes: &[u8], options: &DecodeOptions) -> Result<Decompressed> {
    let bytes = &bytes[..options
        .max_bytes
        .map_or(bytes.len(), |m| m.min(bytes.len()))];
    Ok(decompress_with(
        Decoder::new(bytes, &options.limits)?,
        bytes,
        options,
    ))
}

/// [`decompress`] of `bytes` (cut to the budget already) by `decoder`,
/// made from them.
pub(crate) fn decompress_with(
    mut decoder: Decoder,
    bytes: &[u8],
    options: &DecodeOptions,
) -> Decompressed {
    let mut values = Vec::new();
    let (status, estimate) = decoder.decode_choosing(
        &bytes[decoder.stream_start()..],
        options,
        &mut values,
        false,
    );
    let colours = decoder.colours().map(<[_]>::to_vec);
    let texture = decoder.texture(status.level);
    let Decoder {
        header,
        layout,
        quantizer,
        header_bytes,
        base_bytes,
        ..
    } = decoder;
    let stream_bytes = bytes.len() - header_bytes - base_bytes;
    Decompressed {
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
        colours,
        texture,
    }
}

/// A parsed header and base mesh, ready to decode stream prefixes again and
/// again: a viewer that receives a file in pieces keeps one and decodes
/// each longer prefix with [`Decoder::decode_into`].
///
/// It builds the trees and the layout only as far as the prefixes so far
/// reached (see the module docs), and keeps them for the next, longer
/// prefix; it also keeps the bit-plane decoder's state at the last
/// complete pass (a [`qm_ezw::Checkpoint`]), so a longer cut of the same
/// stream resumes there instead of decoding every pass again. The result
/// never depends on either: any stream, cut or pass limit gives what
/// [`decompress`] gives.
#[derive(Clone, Debug)]
pub struct Decoder {
    checkpoint: Option<qm_ezw::Checkpoint>,
    header: Header,
    /// The base section's values: high parts when the stream holds low bits
    /// (with the split implied, those of the corners, and zeros).
    base_values: Vec<Coord>,
    /// What to subtract from a base value joined from its high part and
    /// low bits ([`container::base_offset`]).
    base_offset: i32,
    /// With the split implied ([`container::IMPLIED_SPLIT`]): the base's
    /// triangles, whose corners alone have values, the other base values
    /// being made from them.
    split: Option<Vec<[u32; 3]>>,
    /// The layout of the levels built (at least as fine as the tree's).
    layout: Layout,
    /// The trees of the levels the stream reached ([`ZeroTree::partial`]).
    tree: ZeroTree,
    quantizer: Quantizer,
    header_bytes: usize,
    base_bytes: usize,
    /// For a file with colours: the colour stream's decoder.
    colour: Option<Box<ColourDecoder>>,
}

/// The colour stream's decoder state (see [`crate::colour`]).
#[derive(Clone, Debug)]
struct ColourDecoder {
    header: container::ColourHeader,
    /// The colour's own sample layout, as fine as its trees and the level
    /// of the last decode (finer colour than geometry has samples the
    /// geometry's layout never has).
    layout: Layout,
    /// The trees the colour stream reached.
    tree: ZeroTree,
    checkpoint: Option<qm_ezw::Checkpoint>,
    /// The coefficients of the last decode.
    decoded: Option<qm_ezw::Decoded>,
    /// Colour stream bytes the last decode used.
    used: usize,
    /// Whether the last decode's colour stream ended before its last pass.
    truncated: bool,
    /// The last decode's colours, one per vertex of its level.
    colours: Vec<[u8; 3]>,
}

impl ColourDecoder {
    /// The colour values of `decoded` (this decoder's last coefficients,
    /// none finer than `top`) lifted up to level `to`, numbered as its
    /// layout (which reaches `to`); `update` is the header's rule.
    fn values(&self, update: u8, decoded: &qm_ezw::Decoded, to: u32, top: u32) -> Vec<Coord> {
        let mut values = Vec::new();
        crate::colour::fill(&self.layout, &self.tree, decoded, &self.header, &mut values);
        let update = UpdateRule::from_code(update).expect("checked by the container");
        synthesize(&Lifting::new(&self.layout, update), &mut values, 0, to, top);
        values
    }
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
        Layout::check(&base, container::colour_level(&h))?;
        let tree = ZeroTree::partial(&base, h.level as u32, 1);
        let layout = Layout::new(base, 0)?;
        let quantizer = Quantizer {
            bits: h.bits as u32,
            origin: h.origin,
            step: h.step,
        };
        // The base section's decoder checked that an implied base is a split.
        let colour = h.colour.clone().map(|header| {
            Box::new(ColourDecoder {
                header,
                layout: layout.clone(),
                tree: ZeroTree::partial(layout.base(), container::colour_level(&h), 1),
                checkpoint: None,
                decoded: None,
                used: 0,
                truncated: false,
                colours: Vec::new(),
            })
        });
        let split = h
            .implied()
            .then(|| basecode::split_triangles_of(layout.base().faces(), h.base_vertices as usize))
            .flatten();
        let base_offset = container::base_offset(c.version, h.stream_params().base_bits);
        Ok(Decoder {
            checkpoint: None,
            header: h,
            split,
            base_values: c.base.values,
            base_offset,
            layout,
            tree,
            quantizer,
            header_bytes: c.header_bytes,
            base_bytes: c.base_bytes,
            colour,
        })
    }

    /// For a file with colours: the colour stream bytes the last decode
    /// used (its colours, and its texture, change only with them and the
    /// level).
    pub fn colour_bytes_used(&self) -> Option<usize> {
        self.colour.as_ref().map(|c| c.used)
    }

    /// For a file with colours, those of the last decode: one 8-bit sRGB
    /// colour per vertex of its level's mesh, in the order of
    /// [`Decompressed::level_mesh`] (empty before the first decode).
    pub fn colours(&self) -> Option<&[[u8; 3]]> {
        self.colour.as_ref().map(|c| &c.colours[..])
    }

    /// For a file whose colours are finer than its geometry
    /// ([`container::FINER_COLOUR`]): the colours of the last decode as a
    /// texture atlas ([`crate::atlas::Atlas`]) for its mesh at `level`, at
    /// the finest colour level the colour stream reached, at most the
    /// file's colour level. `None` for other files, before the first
    /// decode, or where the colours reached no finer level than `level`
    /// (the vertices' colours carry them all).
    pub fn texture(&self, level: u32) -> Option<Atlas> {
        let colour = self.colour.as_ref()?;
        if colour.header.finer == 0 {
            return None;
        }
        let decoded = colour.decoded.as_ref()?;
        let finest = container::colour_level(&self.header);
        let top = top_level(&colour.tree, decoded).min(finest);
        let layout = &colour.layout;
        if top <= level || top > layout.level() {
            return None;
        }
        let values = colour.values(self.header.update, decoded, top, top);
        let s = 1usize << (layout.level() - top);
        Some(Atlas::new(layout.face_count(), top, |f, i, j| {
            let sample = layout.sample(f, i as usize * s, j as usize * s);
            crate::colour::from_value(values[sample as usize])
        }))
    }

    /// Splits an interleaved `stream` and decodes the colour part's
    /// coefficients; the geometry part (all of `stream` without colours).
    fn colour_coefficients<'s>(
        &mut self,
        stream: &'s [u8],
        resume: bool,
    ) -> std::borrow::Cow<'s, [u8]> {
        let Some(colour) = &mut self.colour else {
            return stream.into();
        };
        let (geometry, coloured) = crate::colour::split(&colour.header.runs, stream);
        let params = colour.header.stream_params(self.header.base_vertices);
        let decoded = if resume {
            let from = colour.checkpoint.take();
            let (decoded, checkpoint) =
                qm_ezw::decode_resuming(&mut colour.tree, params, &coloured, None, from);
            colour.checkpoint = checkpoint;
            decoded
        } else {
            qm_ezw::decode(&mut colour.tree, params, &coloured, None)
        };
        colour.truncated = decoded.truncated;
        colour.used = if decoded.truncated {
            coloured.len()
        } else {
            decoded.bytes_read.min(coloured.len())
        };
        colour.decoded = Some(decoded);
        geometry.into()
    }

    /// The colours of the last colour coefficients at `status.level` (the
    /// layout reaches it), and `status` (the geometry's) with the
    /// interleaved stream's bytes used and truncated if the colour's was.
    fn colour_values(&mut self, mut status: DecodeStatus) -> DecodeStatus {
        let Some(colour) = &mut self.colour else {
            return status;
        };
        let Some(decoded) = &colour.decoded else {
            return status;
        };
        let level = status.level;
        let reach = level.max(colour.tree.depth());
        if reach > colour.layout.level() {
            let base = colour.layout.base().clone();
            colour.layout = Layout::new(base, reach).expect("checked by Decoder::new");
        }
        let top = top_level(&colour.tree, decoded);
        let values = colour.values(self.header.update, decoded, level, top);
        let (samples, _) = level_index(&colour.layout, level);
        colour.colours = (samples.iter())
            .map(|&s| crate::colour::from_value(values[s as usize]))
            .collect();
        let runs = &colour.header.runs;
        status.decoded_bytes = crate::colour::offset_of(runs, 0, status.decoded_bytes)
            .max(crate::colour::offset_of(runs, 1, colour.used));
        status.truncated |= colour.truncated;
        status
    }

    /// Offset of the embedded stream in the file.
    pub fn stream_start(&self) -> usize {
        self.header_bytes + self.base_bytes
    }

    /// The header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// The sample layout of the levels built so far: as fine as the
    /// levels the decodes so far reached or reconstructed (0 before the
    /// first), at most [`Self::finest_level`]. The values a decode writes
    /// are numbered as its samples.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// The finest subdivision level of the file.
    pub fn finest_level(&self) -> u32 {
        self.header.level as u32
    }

    /// The quantizer of the header.
    pub fn quantizer(&self) -> &Quantizer {
        &self.quantizer
    }

    /// Decodes `stream` (the bytes after [`Self::stream_start`], cut
    /// anywhere; a cut inside a hold decodes as the hold's start) up to
    /// `passes` passes and reconstructs `level` (default: the finest) into
    /// `values`, one quantized value per sample of [`Self::layout`] (which
    /// then has at least `level`); at a level below the layout's only that
    /// level's samples hold positions.
    pub fn decode_into(
        &mut self,
        stream: &[u8],
        passes: Option<u32>,
        level: Option<u32>,
        values: &mut Vec<Coord>,
    ) -> DecodeStatus {
        self.decode_with(stream, passes, level, values, true)
    }

    /// [`Self::decode_into`], keeping a checkpoint for the next call or not.
    fn decode_with(
        &mut self,
        stream: &[u8],
        passes: Option<u32>,
        level: Option<u32>,
        values: &mut Vec<Coord>,
        resume: bool,
    ) -> DecodeStatus {
        let stream = self.colour_coefficients(stream, resume);
        let (decoded, used) = self.coefficients(&stream, passes, resume);
        let finest = self.finest_level();
        let level = level.map_or(finest, |l| l.min(finest));
        self.build_layout(level);
        self.fill(&decoded, values);
        let top = self.top_level(&decoded);
        self.synthesize(values, 0, level, top);
        self.colour_values(DecodeStatus {
            level,
            passes: decoded.passes,
            truncated: decoded.truncated,
            decoded_bytes: used,
        })
    }

    /// Decodes `stream` (as [`Self::decode_into`]) with `options`' pass
    /// limit, error goal and level choice (its byte budget is the
    /// caller's), into `values` at the level chosen; the decoder's estimate
    /// of the error of each level (see [`crate::levels`]).
    pub fn decode_choosing(
        &mut self,
        stream: &[u8],
        options: &DecodeOptions,
        values: &mut Vec<Coord>,
        resume: bool,
    ) -> (DecodeStatus, Estimate) {
        let stream = self.colour_coefficients(stream, resume);
        let (status, estimate) = self.geometry_choosing(&stream, options, values, resume);
        (self.colour_values(status), estimate)
    }

    /// [`Self::decode_choosing`] of the geometry stream.
    fn geometry_choosing(
        &mut self,
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
        let big_l = self.finest_level();
        let faces = self.layout.face_count();
        let remaining = levels::remaining(
            &self.header,
            self.layout.base(),
            self.tree.levels(),
            &decoded,
            self.base_count(),
        );
        let complete = !decoded.truncated && decoded.passes == self.header.passes as u32;
        let status = |level| DecodeStatus {
            level,
            passes: decoded.passes,
            truncated: decoded.truncated,
            decoded_bytes: used,
        };
        let cap = |level: u32| match options.max_triangles {
            Some(max) => (0..=level)
                .rev()
                .find(|&l| triangles(faces, l) <= max)
                .unwrap_or(0),
            None => level,
        };
        let unknown = || {
            let mut gaps = vec![f64::NAN; big_l as usize + 1];
            gaps[big_l as usize] = 0.0;
            gaps
        };
        // Levels past the finest one holding a significant coefficient
        // add only the subdivision's smoothing: lift one level past it (two
        // at least: on whole base faces the stencils reach irregular
        // vertices everywhere and fall back to linear, so the step from
        // level 0 to 1 has none to measure).
        let top = self.top_level(&decoded);
        let reach = (top + 1).max(2).min(big_l);
        // The layout as far as the levels lifted: to the output level, or
        // to the steps measured before the level is chosen.
        let finest = options.level == LevelChoice::Finest;
        self.build_layout(if finest { cap(big_l) } else { reach });
        self.fill(&decoded, values);
        let diagonal = levels::diagonal(
            values[..self.layout.base().vertex_count() as usize]
                .iter()
                .copied(),
            self.header.step,
        );
        if finest {
            let level = cap(big_l);
            self.synthesize(values, 0, level, top);
            let estimate = Estimate {
                remaining,
                gaps: unknown(),
                diagonal,
            };
            return (status(level), estimate);
        }
        let mut steps = Vec::with_capacity(reach as usize);
        let mut grid = Vec::new();
        for j in 0..reach {
            levels::level_grid(&self.layout, j, values, &mut grid);
            self.synthesize(values, j, j + 1, top);
            let gap = levels::step_gap(&self.layout, j, &grid, values, j < top);
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
            // The details again, and the level's samples as synthesized:
            // the last grid taken is level `reach - 1`'s.
            self.fill(&decoded, values);
            if level + 1 == reach {
                levels::put_level_grid(&self.layout, level, &grid, values);
            } else {
                self.synthesize(values, 0, level, top);
            }
        } else if level > reach {
            // Finer than the layout built: the same points, numbered anew;
            // the finer samples' details are zero (`reach > top`).
            let coarse = self.layout.numbering();
            self.build_layout(level);
            let fine = self.layout.numbering();
            if fine != coarse {
                let mut refined = vec![[0; 3]; self.layout.sample_count()];
                for (s, &v) in values.iter().enumerate() {
                    refined[coarse.refine(s as u32, fine) as usize] = v;
                }
                *values = refined;
            }
            self.synthesize(values, reach, level, top);
        }
        (status(level), estimate)
    }

    /// Makes the layout reach `level` and the tree's levels (the layout
    /// only grows).
    fn build_layout(&mut self, level: u32) {
        let level = level.max(self.tree.depth());
        if level > self.layout.level() {
            let base = self.layout.base().clone();
            self.layout = Layout::new(base, level).expect("checked by Decoder::new");
        }
    }

    /// Builds every level before decoding, as the decoder did before it
    /// built only those reached: the reference of the tests that it
    /// changes nothing.
    #[cfg(test)]
    pub(crate) fn build_every_level(&mut self) {
        while !self.tree.is_complete() {
            self.tree.grow();
        }
        self.build_layout(self.finest_level());
    }

    /// The finest level with a coefficient that is not zero (0 for none).
    fn top_level(&self, decoded: &qm_ezw::Decoded) -> u32 {
        top_level(&self.tree, decoded)
    }

    /// The inverse lifting of `values` from level `from` to `to`. The
    /// levels above `top` have no details: their update and their frames
    /// turn zeros, so the prediction alone makes them, at less cost (the
    /// same values).
    fn synthesize(&self, values: &mut [Coord], from: u32, to: u32, top: u32) {
        synthesize(&self.lifting(), values, from, to, top);
    }

    /// Vertices of the mesh at `level` (at most the finest), built or not.
    pub fn vertices_at(&self, level: u32) -> u64 {
        self.layout
            .base()
            .sample_count(level.min(self.finest_level()))
    }

    /// Triangles of the mesh at `level` (at most the finest), two per quad.
    pub fn triangles_at(&self, level: u32) -> u64 {
        triangles(self.layout.face_count(), level.min(self.finest_level()))
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
        &mut self,
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
                qm_ezw::decode_resuming(&mut self.tree, params, stream, passes, from);
            self.checkpoint = checkpoint;
            decoded
        } else {
            qm_ezw::decode(&mut self.tree, params, stream, passes)
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
        &mut self,
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
            let met = goal > 0.0
                && levels::remaining(
                    &self.header,
                    self.layout.base(),
                    self.tree.levels(),
                    &decoded,
                    base,
                ) <= goal;
            if met || decoded.truncated || passes >= limit {
                return (decoded, used);
            }
            passes += 1;
        }
    }

    /// Base values, their low bits and the split base's derived values,
    /// then the coefficients at their samples, numbered as the layout's
    /// (which is at least as fine as the tree's).
    fn fill(&self, decoded: &qm_ezw::Decoded, values: &mut Vec<Coord>) {
        let k = self.header.stream_params().base_bits;
        values.clear();
        values.resize(self.layout.sample_count(), [0; 3]);
        values[..self.base_values.len()].copy_from_slice(&self.base_values);
        if !decoded.base_low.is_empty() {
            // The container checked that high and low parts fit 32 bits;
            // a hostile file's lowest high part, less the offset, saturates.
            for (v, low) in values.iter_mut().zip(&decoded.base_low) {
                *v = std::array::from_fn(|c| {
                    ((v[c] << k) + low[c]).saturating_sub(self.base_offset)
                });
            }
        }
        if let Some(triangles) = &self.split {
            let base = self.layout.base();
            let values = &mut values[..base.vertex_count() as usize];
            basecode::snap_split(base.faces(), triangles, values, i64::MAX);
        }
        let (from, to) = (self.tree.numbering(), self.layout.numbering());
        if from == to {
            decoded.scatter(self.tree.samples(), values);
        } else {
            let samples = self.tree.samples();
            for e in &decoded.nonzero {
                let s = from.refine(samples[e.node as usize], to);
                values[s as usize][e.coord as usize] = e.value;
            }
        }
    }
}

/// The finest level of `tree` with a coefficient of `decoded` that is not
/// zero (0 for none).
fn top_level(tree: &ZeroTree, decoded: &qm_ezw::Decoded) -> u32 {
    let levels = tree.levels();
    (decoded.nonzero.iter())
        .map(|e| levels[e.node as usize] as u32)
        .max()
        .unwrap_or(0)
}

/// The inverse `lifting` of `values` from level `from` to `to`, the
/// levels above `top` (which have no details) by the prediction alone.
fn synthesize(lifting: &Lifting, values: &mut [Coord], from: u32, to: u32, top: u32) {
    let detailed = to.min(top.max(from));
    lifting.inverse_levels(values, from, detailed);
    for level in detailed + 1..=to {
        lifting.predict(level, values);
    }
}

/// Triangles of the mesh of `faces` base quads at `level`, two per quad.
fn triangles(faces: usize, level: u32) -> u64 {
    2 * faces as u64 * (1u64 << (2 * level))
}
