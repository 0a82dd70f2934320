//! [`StreamDecoder`]: a `.qm` file received in pieces, decoded as it grows.
//!
//! Bytes are pushed as they arrive; the header and base mesh are parsed
//! once, as soon as they are complete; each [`StreamDecoder::refine`]
//! decodes everything received so far, resuming the bit-plane decoder from
//! its last complete pass, at the level the [`DecodeOptions`] choose
//! ([`crate::LevelChoice::Auto`] by default: the level the bytes support). The
//! mesh of the last refinement is a [`LevelMesh`]: vertices, quads and
//! triangles of that level, with the decoder's error estimate. Index
//! buffers depend only on the layout and are built once per level. Every
//! binding (the WebAssembly decoder, the command line, Python) wraps this
//! one type.

use qm_lift::Coord;
use qm_lift::glam::DVec3;

use crate::codec::{DecodeOptions, DecodeStatus, Decoder};
use crate::levels::Estimate;
use crate::{Error, Result};

/// The index buffers of one subdivision level, made from the layout alone.
#[derive(Clone, Debug)]
struct LevelIndex {
    /// Sample ids of the level's vertices, in vertex order.
    samples: Vec<u32>,
    /// Quads as vertex indices, counter-clockwise.
    quads: Vec<[u32; 4]>,
    /// Two triangles per quad, split along its first diagonal.
    triangles: Vec<u32>,
}

impl LevelIndex {
    fn new(layout: &qm_lift::Layout, level: u32) -> Self {
        let samples = layout.samples_at(level);
        let mut local = vec![u32::MAX; layout.sample_count()];
        for (i, &s) in samples.iter().enumerate() {
            local[s as usize] = i as u32;
        }
        let quads: Vec<[u32; 4]> = layout
            .quads(level)
            .iter()
            .map(|q| q.map(|s| local[s as usize]))
            .collect();
        let triangles = quads
            .iter()
            .flat_map(|&[a, b, c, d]| [a, b, c, a, c, d])
            .collect();
        LevelIndex {
            samples,
            quads,
            triangles,
        }
    }
}

/// What the last refinement made.
#[derive(Clone, Debug)]
struct Refinement {
    /// Bytes received when it ran.
    received: usize,
    /// The options it ran with.
    options: DecodeOptions,
    status: DecodeStatus,
    estimate: Estimate,
}

/// An incremental decoder: push bytes, refine, read the mesh.
///
/// ```
/// # use qm_codec::{StreamDecoder, DecodeOptions, compress, EncodeOptions};
/// # let file = compress(&qm_codec::qm_lift::synthetic::bumpy_sphere(3), &EncodeOptions::DEFAULT)?.bytes;
/// let mut decoder = StreamDecoder::new(DecodeOptions::default());
/// for chunk in file.chunks(500) {
///     if decoder.push(chunk)? && decoder.refine()? {
///         let mesh = decoder.mesh().expect("refined");
///         println!("level {}, {} triangles, about {:.1} dB",
///             mesh.level(), mesh.triangles().len() / 3, mesh.psnr_db());
///     }
/// }
/// # Ok::<(), qm_codec::Error>(())
/// ```
#[derive(Clone, Debug)]
pub struct StreamDecoder {
    options: DecodeOptions,
    bytes: Vec<u8>,
    decoder: Option<Decoder>,
    /// Before the decoder: the least bytes the header and base need, as
    /// far as known.
    needed: usize,
    levels: Vec<Option<LevelIndex>>,
    values: Vec<Coord>,
    last: Option<Refinement>,
    refinements: u32,
}

impl Default for StreamDecoder {
    fn default() -> Self {
        Self::new(DecodeOptions::default())
    }
}

impl StreamDecoder {
    /// An empty decoder. `options.max_bytes` caps the bytes it keeps;
    /// `options.limits` bound what a header may ask for.
    pub fn new(options: DecodeOptions) -> Self {
        StreamDecoder {
            options,
            bytes: Vec::new(),
            decoder: None,
            needed: 0,
            levels: Vec::new(),
            values: Vec::new(),
            last: None,
            refinements: 0,
        }
    }

    /// The options.
    pub fn options(&self) -> &DecodeOptions {
        &self.options
    }

    /// Changes the options for the next refinements (a new goal, another
    /// level); the bytes and the parsed base are kept. New limits apply to
    /// files not parsed yet.
    pub fn set_options(&mut self, options: DecodeOptions) {
        self.options = options;
    }

    /// Appends the next bytes of the file (past `max_bytes`, they are
    /// dropped). Returns whether the header and base mesh are complete, so
    /// that [`Self::refine`] can make a mesh. A file that is not `.qm`, is
    /// corrupt or exceeds the limits is an error as soon as enough bytes
    /// arrived to tell, and stays one.
    pub fn push(&mut self, chunk: &[u8]) -> Result<bool> {
        let room = self
            .options
            .max_bytes
            .map_or(usize::MAX, |m| m.saturating_sub(self.bytes.len()));
        self.bytes
            .extend_from_slice(&chunk[..chunk.len().min(room)]);
        if self.decoder.is_none() && self.bytes.len() >= self.needed {
            match Decoder::new(&self.bytes, &self.options.limits) {
                Ok(decoder) => {
                    self.levels = vec![None; decoder.layout().level() as usize + 1];
                    self.decoder = Some(decoder);
                }
                Err(Error::Truncated { needed, .. }) => {
                    self.needed = needed;
                    return Ok(false);
                }
                Err(e) => return Err(e),
            }
        }
        Ok(self.decoder.is_some())
    }

    /// Whether the header and base mesh have arrived.
    pub fn ready(&self) -> bool {
        self.decoder.is_some()
    }

    /// Before [`Self::ready`]: the least number of bytes the header and base
    /// mesh need, as far as the bytes so far tell (0 once ready).
    pub fn bytes_needed(&self) -> usize {
        if self.ready() { 0 } else { self.needed }
    }

    /// The parsed header and base, once [`Self::ready`].
    pub fn decoder(&self) -> Option<&Decoder> {
        self.decoder.as_ref()
    }

    /// Bytes kept so far.
    pub fn bytes_received(&self) -> usize {
        self.bytes.len()
    }

    /// The bytes kept so far.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// The finest subdivision level of the file (0 before the header).
    pub fn finest_level(&self) -> u32 {
        self.decoder.as_ref().map_or(0, |d| d.layout().level())
    }

    /// Vertices of the mesh at `level` (at most the finest; 0 before the
    /// base mesh). Builds that level's index buffers once.
    pub fn vertices_at(&mut self, level: u32) -> usize {
        self.index(level).map_or(0, |i| i.samples.len())
    }

    /// Triangles of the mesh at `level`, two per quad (0 before the base).
    pub fn triangles_at(&self, level: u32) -> u64 {
        self.decoder.as_ref().map_or(0, |d| d.triangles_at(level))
    }

    fn index(&mut self, level: u32) -> Option<&LevelIndex> {
        let decoder = self.decoder.as_ref()?;
        let level = level.min(decoder.layout().level());
        Some(
            self.levels[level as usize]
                .get_or_insert_with(|| LevelIndex::new(decoder.layout(), level)),
        )
    }

    /// Decodes everything received so far with the options. Returns false
    /// when nothing changed since the last refinement (no new bytes, same
    /// options); an error before the base mesh is complete
    /// ([`Error::is_truncated`]).
    pub fn refine(&mut self) -> Result<bool> {
        let Some(decoder) = &self.decoder else {
            return Err(Error::Truncated {
                needed: self.needed.max(self.bytes.len() + 1),
                available: self.bytes.len(),
            });
        };
        // With the same options, a refinement that used fewer bytes than it
        // had (the passes or the error goal were met, or the stream is
        // complete) stays what it is whatever else arrives.
        if let Some(last) = &mut self.last
            && last.options == self.options
            && (last.received == self.bytes.len() || !last.status.truncated)
        {
            last.received = self.bytes.len();
            return Ok(false);
        }
        let stream = &self.bytes[decoder.stream_start()..];
        let (status, estimate) =
            decoder.decode_choosing(stream, &self.options, &mut self.values, true);
        self.index(status.level);
        self.last = Some(Refinement {
            received: self.bytes.len(),
            options: self.options,
            status,
            estimate,
        });
        self.refinements += 1;
        Ok(true)
    }

    /// Whether more bytes could still change the mesh: false once the
    /// whole stream is decoded, the byte budget is used up, or the error
    /// goal (`max_error`) or the pass limit is met.
    pub fn wants_more(&self) -> bool {
        if self
            .options
            .max_bytes
            .is_some_and(|m| self.bytes.len() >= m)
        {
            return false;
        }
        match &self.last {
            None => true,
            Some(r) => r.status.truncated,
        }
    }

    /// How many refinements decoded (skipped ones do not count).
    pub fn refinements(&self) -> u32 {
        self.refinements
    }

    /// The mesh of the last refinement.
    pub fn mesh(&self) -> Option<LevelMesh<'_>> {
        let decoder = self.decoder.as_ref()?;
        let last = self.last.as_ref()?;
        let index = self.levels[last.status.level as usize].as_ref()?;
        Some(LevelMesh {
            decoder,
            values: &self.values,
            index,
            status: last.status,
            estimate: &last.estimate,
        })
    }
}

/// The mesh of one refinement: one level's vertices and faces.
#[derive(Clone, Copy, Debug)]
pub struct LevelMesh<'a> {
    decoder: &'a Decoder,
    values: &'a [Coord],
    index: &'a LevelIndex,
    status: DecodeStatus,
    estimate: &'a Estimate,
}

impl<'a> LevelMesh<'a> {
    /// The subdivision level (0 is the base mesh).
    pub fn level(&self) -> u32 {
        self.status.level
    }

    /// Bit-plane passes decoded completely.
    pub fn passes(&self) -> u32 {
        self.status.passes
    }

    /// Whether the bytes ended inside a pass (more would refine it).
    pub fn truncated(&self) -> bool {
        self.status.truncated
    }

    /// Bytes of the file this mesh used: header, base and the stream
    /// bytes decoded.
    pub fn bytes_used(&self) -> usize {
        self.decoder.stream_start() + self.status.decoded_bytes
    }

    /// The decoder's estimate for every level at this prefix.
    pub fn estimate(&self) -> &'a Estimate {
        self.estimate
    }

    /// Estimated RMS distance of this mesh from the complete stream's
    /// finest mesh, in model units.
    pub fn error(&self) -> f64 {
        self.estimate.error(self.status.level)
    }

    /// [`Self::error`] as PSNR against the bounding-box diagonal, in dB.
    pub fn psnr_db(&self) -> f64 {
        self.estimate.psnr_db(self.status.level)
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.index.samples.len()
    }

    /// Sample id of each vertex (finest-layout numbering).
    pub fn samples(&self) -> &'a [u32] {
        &self.index.samples
    }

    /// Quantized value of each vertex.
    pub fn quantized(&self) -> impl ExactSizeIterator<Item = Coord> + 'a {
        let values = self.values;
        self.index.samples.iter().map(move |&s| values[s as usize])
    }

    /// Vertex positions in model units.
    pub fn positions(&self) -> Vec<DVec3> {
        let q = self.decoder.quantizer();
        self.quantized()
            .map(|v| q.dequantize(v.map(f64::from)))
            .collect()
    }

    /// Vertex positions as `x, y, z` in `f32`, appended to `out` (cleared).
    pub fn positions_f32(&self, out: &mut Vec<f32>) {
        let q = self.decoder.quantizer();
        out.clear();
        out.reserve(3 * self.vertex_count());
        for v in self.quantized() {
            let p = q.dequantize(v.map(f64::from));
            out.extend_from_slice(&[p.x as f32, p.y as f32, p.z as f32]);
        }
    }

    /// Quads as vertex indices, counter-clockwise.
    pub fn quads(&self) -> &'a [[u32; 4]] {
        &self.index.quads
    }

    /// Triangle corners as vertex indices, three a triangle: each quad
    /// `a b c d` as `a b c` and `a c d`.
    pub fn triangles(&self) -> &'a [u32] {
        &self.index.triangles
    }
}
