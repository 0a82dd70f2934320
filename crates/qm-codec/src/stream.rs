//! [`StreamDecoder`]: a `.qm` file received in pieces, decoded as it grows.
//!
//! Bytes are pushed as they arrive; the header and base mesh are parsed
//! once, as soon as they are complete; each [`StreamDecoder::refine`]
//! decodes everything received so far, resuming the bit-plane decoder from
//! its last complete pass, at the level the [`DecodeOptions`] choose
//! ([`crate::LevelChoice::Auto`] by default: the level the bytes support),
//! building the finer levels' trees and layout only when the bytes reach
//! them. The mesh of the last refinement is a [`LevelMesh`]: vertices,
//! quads and triangles of that level, with the decoder's error estimate.
//! Index buffers depend only on the layout and are built once per level
//! (again when the layout grows). Every binding (the WebAssembly decoder,
//! the command line, Python) wraps this one type.

use std::collections::HashMap;
use std::sync::OnceLock;

use qm_lift::Coord;
use qm_lift::glam::DVec3;

use crate::atlas::Atlas;
use crate::decode::{DecodeOptions, DecodeStatus, Decoder, level_index};
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
        let (samples, quads) = level_index(layout, level);
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
    /// The level of the decoder's layout the index buffers were made for.
    indexed: u32,
    values: Vec<Coord>,
    last: Option<Refinement>,
    refinements: u32,
    /// For a file whose colour is finer than its geometry: the last
    /// refinement's texture and its triangles over split vertices, made
    /// when first asked for after the level or the colour bytes used
    /// changed (a lock, not a cell: the decoder stays `Sync`).
    texture: OnceLock<Option<(Atlas, Textured)>>,
    /// The level and colour bytes the texture is for.
    texture_key: Option<(u32, usize)>,
    /// How many times the texture changed.
    texture_version: u32,
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
            indexed: 0,
            values: Vec::new(),
            last: None,
            refinements: 0,
            texture: OnceLock::new(),
            texture_key: None,
            texture_version: 0,
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
                    self.levels = vec![None; decoder.finest_level() as usize + 1];
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
        self.decoder.as_ref().map_or(0, Decoder::finest_level)
    }

    /// Vertices of the mesh at `level` (at most the finest; 0 before the
    /// base mesh).
    pub fn vertices_at(&self, level: u32) -> usize {
        self.decoder
            .as_ref()
            .map_or(0, |d| d.vertices_at(level) as usize)
    }

    /// Triangles of the mesh at `level`, two per quad (0 before the base).
    pub fn triangles_at(&self, level: u32) -> u64 {
        self.decoder.as_ref().map_or(0, |d| d.triangles_at(level))
    }

    /// The index buffers of `level` (at most the layout's), made for the
    /// decoder's layout as it is.
    fn index(&mut self, level: u32) -> Option<&LevelIndex> {
        let decoder = self.decoder.as_ref()?;
        let built = decoder.layout().level();
        if built != self.indexed {
            // Sample ids are the layout's: a finer one numbers them anew.
            self.levels.fill(None);
            self.indexed = built;
        }
        let level = level.min(built);
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
        let Some(decoder) = &mut self.decoder else {
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
        self.update_texture();
        Ok(true)
    }

    /// Drops the texture of the last refinement unless the one just made
    /// has its level and used the same colour bytes (a refinement that
    /// advanced the geometry alone keeps it).
    fn update_texture(&mut self) {
        let (Some(decoder), Some(last)) = (&self.decoder, &self.last) else {
            return;
        };
        let key = (decoder.colour_bytes_used()).map(|used| (last.status.level, used));
        if key == self.texture_key {
            return;
        }
        let finer = (decoder.header().colour.as_ref()).is_some_and(|c| c.finer > 0);
        if finer {
            self.texture_version = self.texture_version.wrapping_add(1);
        }
        (self.texture, self.texture_key) = (OnceLock::new(), key);
    }

    /// For a file whose colour is finer than its geometry: the last
    /// refinement's texture atlas ([`LevelMesh::texture`]) and the mesh's
    /// triangles over vertices with one texture coordinate each
    /// ([`LevelMesh::textured`]), made on the first call after a
    /// refinement changed the level or the colour's bytes, and kept until
    /// another does. `None` for other files.
    pub fn texture(&self) -> Option<(&Atlas, &Textured)> {
        let made = self.texture.get_or_init(|| {
            let mesh = self.mesh()?;
            let atlas = mesh.texture()?;
            let textured = mesh.textured(&atlas);
            Some((atlas, textured))
        });
        made.as_ref().map(|(a, t)| (a, t))
    }

    /// For a file whose colour is finer than its geometry, changes whenever
    /// a refinement changes the level or the colour's bytes, and so
    /// [`Self::texture`]: while it stays, so do the atlas and its triangles
    /// (a viewer need not upload them again).
    pub fn texture_version(&self) -> u32 {
        self.texture_version
    }

    /// Whether more bytes could still change the mesh: false once the
    /// whole stream is decoded, the byte budget is used up, or the error
    /// goal (`max_error`) or the pass limit is met by the last refinement
    /// with the current options.
    pub fn wants_more(&self) -> bool {
        if self
            .options
            .max_bytes
            .is_some_and(|m| self.bytes.len() >= m)
        {
            return false;
        }
        match (&self.last, &self.decoder) {
            (Some(r), _) if r.options == self.options => r.status.truncated,
            // Options changed since (a smaller error goal, more passes):
            // more bytes help unless the whole stream is already decoded.
            (Some(r), Some(d)) => r.status.truncated || r.status.passes < d.header().passes as u32,
            _ => true,
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

/// What the prefix of a file that ends at one pass decodes to: a row of
/// [`prefix_table`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct PrefixRow {
    /// Bytes of the prefix: header, base mesh and the stream up to the end
    /// of [`Self::passes`].
    pub bytes: usize,
    /// Bit-plane passes the prefix holds completely.
    pub passes: u32,
    /// The level the options choose for it ([`crate::LevelChoice::Auto`]:
    /// the level the bytes support).
    pub level: u32,
    /// Vertices at that level.
    pub vertices: usize,
    /// Triangles at that level, two per quad.
    pub triangles: u64,
    /// The decoder's estimated RMS distance of that mesh from the complete
    /// stream's finest mesh, in model units.
    pub error: f64,
    /// [`Self::error`] as PSNR against the bounding-box diagonal, in dB.
    pub psnr_db: f64,
}

/// The prefix table of a whole `.qm` file: for every bit-plane pass, the
/// bytes up to its end and the mesh that prefix decodes to with `options`
/// (its level, size and estimated error), as a client that received just
/// those bytes decodes it. A client that wants an error goal or a size
/// fetches the first row that meets it; `qm info --levels` and the glTF
/// extension print it. `options.passes`, `max_bytes` and `max_error` are
/// ignored.
pub fn prefix_table(bytes: &[u8], options: &DecodeOptions) -> Result<Vec<PrefixRow>> {
    let options = options
        .with_max_bytes(None)
        .with_max_error(None)
        .with_passes(None);
    // Where each pass ends (after the base alone): decode pass by pass.
    let mut passes = StreamDecoder::new(options);
    passes.push(bytes)?;
    let mut ends = vec![passes.decoder().map_or(0, Decoder::stream_start)];
    let total = passes.decoder().map_or(0, |d| d.header().passes as u32);
    for p in 0..=total {
        passes.set_options(options.with_passes(Some(p)));
        passes.refine()?;
        let end = passes.mesh().expect("refined").bytes_used();
        if ends.last() != Some(&end) {
            ends.push(end);
        }
    }
    // What each of those prefixes decodes to.
    let mut decoder = StreamDecoder::new(options);
    let mut rows = Vec::with_capacity(ends.len());
    for end in ends {
        decoder.push(&bytes[decoder.bytes_received()..end])?;
        decoder.refine()?;
        let mesh = decoder.mesh().expect("refined");
        rows.push(PrefixRow {
            bytes: end,
            passes: mesh.passes(),
            level: mesh.level(),
            vertices: mesh.vertex_count(),
            triangles: 2 * mesh.quads().len() as u64,
            error: mesh.error(),
            psnr_db: mesh.psnr_db(),
        });
    }
    Ok(rows)
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

    /// Sample id of each vertex, in the numbering of the decoder's layout
    /// ([`Decoder::layout`]), which is as fine as this mesh or finer.
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

    /// For a file with colours: one 8-bit sRGB colour per vertex.
    pub fn colours(&self) -> Option<&'a [[u8; 3]]> {
        self.decoder.colours()
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

    /// For a file whose colours reached a finer level than this mesh's:
    /// those colours as a texture atlas ([`Decoder::texture`]), made anew
    /// on each call.
    pub fn texture(&self) -> Option<Atlas> {
        self.decoder.texture(self.status.level)
    }

    /// This mesh's triangles with `atlas`'s texture coordinates: a vertex
    /// of several base quads is one vertex per quad, since each quad has
    /// a tile of its own.
    pub fn textured(&self, atlas: &Atlas) -> Textured {
        let corners = atlas.corner_texcoords(self.decoder.layout().face_count(), self.level());
        Textured::new(&self.index.quads, &corners)
    }
}

/// A mesh's triangles over vertices that each have one texture coordinate
/// ([`LevelMesh::textured`]).
#[derive(Clone, Debug, Default, PartialEq)]
#[non_exhaustive]
pub struct Textured {
    /// For each vertex, the mesh vertex it is (positions, normals and
    /// colours are that vertex's).
    pub vertices: Vec<u32>,
    /// For each vertex, its texture coordinates, `(0, 0)` at the image's
    /// top-left corner.
    pub texcoords: Vec<[f32; 2]>,
    /// Triangle corners, three a triangle, in the order of
    /// [`LevelMesh::triangles`].
    pub triangles: Vec<u32>,
}

impl Textured {
    /// The triangles of `quads` (each `a b c d` as `a b c` and `a c d`)
    /// over one vertex per distinct pair of a quad corner's vertex and its
    /// texture coordinates, `corners` four a quad in order.
    pub fn new(quads: &[[u32; 4]], corners: &[[f32; 2]]) -> Self {
        let mut index: HashMap<(u32, [u32; 2]), u32> = HashMap::new();
        let mut out = Textured::default();
        let mut corner = |vertex: u32, uv: [f32; 2]| {
            let key = (vertex, uv.map(f32::to_bits));
            *index.entry(key).or_insert_with(|| {
                out.vertices.push(vertex);
                out.texcoords.push(uv);
                out.vertices.len() as u32 - 1
            })
        };
        let mut triangles = Vec::with_capacity(6 * quads.len());
        for (quad, uv) in quads.iter().zip(corners.chunks_exact(4)) {
            let [a, b, c, d] = std::array::from_fn(|k| corner(quad[k], uv[k]));
            triangles.extend_from_slice(&[a, b, c, a, c, d]);
        }
        out.triangles = triangles;
        out
    }
}

/// Area-weighted unit vertex normals of a triangle mesh (`x, y, z` per
/// vertex, three corners per triangle) into `out`; `0, 0, 1` where a
/// vertex has no area around it.
pub fn vertex_normals(positions: &[f32], triangles: &[u32], out: &mut Vec<f32>) {
    out.clear();
    out.resize(positions.len(), 0.0);
    let p = |i: u32| {
        let i = i as usize * 3;
        [positions[i], positions[i + 1], positions[i + 2]]
    };
    for t in triangles.chunks_exact(3) {
        let (a, b, c) = (p(t[0]), p(t[1]), p(t[2]));
        let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        for &k in t {
            let k = k as usize * 3;
            for d in 0..3 {
                out[k + d] += n[d];
            }
        }
    }
    for n in out.chunks_exact_mut(3) {
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if len > 0.0 {
            n.iter_mut().for_each(|x| *x /= len);
        } else {
            n.copy_from_slice(&[0.0, 0.0, 1.0]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::decode::decompress;
    use crate::encode::{EncodeOptions, compress};
    use qm_lift::synthetic::bumpy_sphere;

    #[test]
    fn each_prefix_row_is_what_its_bytes_decode_to() {
        let bytes = compress(&bumpy_sphere(5), &EncodeOptions::DEFAULT)
            .unwrap()
            .bytes;
        let rows = prefix_table(&bytes, &DecodeOptions::DEFAULT).unwrap();
        let last = rows.last().unwrap();
        assert_eq!((last.bytes, last.level, last.error), (bytes.len(), 5, 0.0));
        assert_eq!(
            rows[0].bytes,
            Decoder::new(&bytes, &Default::default())
                .unwrap()
                .stream_start()
        );
        assert!(rows.len() > 8, "{} rows", rows.len());
        for pair in rows.windows(2) {
            assert!(pair[0].bytes < pair[1].bytes, "{pair:?}");
            assert!(pair[0].passes <= pair[1].passes, "{pair:?}");
        }
        assert!(rows.iter().any(|r| r.level < 5), "some prefix is coarser");
        // An error goal of 0 is the whole stream, even where the estimate
        // reached 0 a pass or more before its end.
        let whole = decompress(&bytes, &DecodeOptions::DEFAULT.with_max_error(Some(0.0))).unwrap();
        assert_eq!(whole.decoded_stream_bytes, whole.stream_bytes);
        assert!(!whole.truncated);
        for row in &rows {
            let options = DecodeOptions::DEFAULT.with_max_bytes(Some(row.bytes));
            let d = decompress(&bytes, &options).unwrap();
            assert_eq!((d.level, d.passes), (row.level, row.passes), "{row:?}");
            assert_eq!(d.estimate.error(d.level), row.error, "{row:?}");
            assert_eq!(d.layout.samples_at(d.level).len(), row.vertices);
            assert_eq!(d.layout.quads(d.level).len() as u64 * 2, row.triangles);
        }
    }

    #[test]
    fn a_met_goal_wants_no_more_bytes_until_the_goal_changes() {
        let bytes = compress(&bumpy_sphere(4), &EncodeOptions::DEFAULT)
            .unwrap()
            .bytes;
        let rows = prefix_table(&bytes, &DecodeOptions::DEFAULT).unwrap();
        let goal = rows[rows.len() / 2].error;
        let mut d = StreamDecoder::new(DecodeOptions::DEFAULT.with_max_error(Some(goal)));
        for chunk in bytes.chunks(64) {
            if !d.wants_more() {
                break;
            }
            if d.push(chunk).unwrap() {
                d.refine().unwrap();
            }
        }
        assert!(!d.wants_more());
        assert!(d.bytes_received() < bytes.len());
        assert!(d.mesh().unwrap().error() <= goal);
        d.set_options(DecodeOptions::DEFAULT.with_max_error(Some(goal / 4.0)));
        assert!(d.wants_more(), "a smaller goal wants more");
        d.push(&bytes[d.bytes_received()..]).unwrap();
        d.set_options(DecodeOptions::DEFAULT);
        d.refine().unwrap();
        assert!(!d.wants_more(), "the whole stream is decoded");
        d.set_options(DecodeOptions::DEFAULT.with_max_error(Some(0.0)));
        assert!(!d.wants_more(), "nothing more to decode");
    }

    #[test]
    fn vertex_normals_of_a_square_point_up() {
        let positions = [
            0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0, 5.0, 5.0, 5.0,
        ];
        let mut normals = Vec::new();
        vertex_normals(&positions, &[0, 1, 2, 0, 2, 3], &mut normals);
        assert_eq!(&normals[..12], &[0.0, 0.0, 1.0].repeat(4)[..]);
        assert_eq!(&normals[12..], &[0.0, 0.0, 1.0], "a lone vertex");
    }
}
