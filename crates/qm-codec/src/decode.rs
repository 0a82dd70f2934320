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

use qm_ezw::ZeroTree;
use qm_lift::glam::DVec3;
use qm_lift::{BaseMesh, Coord, Layout, Lifting, Quantizer, SemiRegularMesh, UpdateRule};

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
