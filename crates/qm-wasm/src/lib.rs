//! The `.qm` decoder for the browser and Node (WebAssembly, wasm-bindgen).
//!
//! [`Buffers`] is a thin layer over [`qm_codec::StreamDecoder`], the
//! library's one incremental decoder: it keeps the last refinement's
//! vertex buffers as JavaScript wants them (`f32` positions, area-weighted
//! unit normals, `u32` triangle indices, and for a file with colours 8-bit
//! sRGB colours) and reuses them from one refinement to the next. [`QmDecoder`] exposes it with `wasm-bindgen`;
//! its errors are JavaScript `Error`s with a `code` property
//! ([`error_code`]). No decoding happens here that the native decoder does
//! not do in the same code.

use qm_codec::{
    Atlas, DecodeOptions, Error, LevelChoice, Limits, StreamDecoder, Textured, vertex_normals,
};
use wasm_bindgen::prelude::*;

/// The browser decoder's memory limit
/// ([`qm_codec::container::BROWSER_DECODE_MEMORY`]).
pub const WASM_MAX_MEMORY: u64 = qm_codec::container::BROWSER_DECODE_MEMORY;

/// A [`StreamDecoder`] and the buffers of its last refinement.
#[derive(Clone, Debug)]
pub struct Buffers {
    decoder: StreamDecoder,
    positions: Vec<f32>,
    normals: Vec<f32>,
}

impl Default for Buffers {
    fn default() -> Self {
        Self::new(DecodeOptions::default().with_limits(wasm_limits(0)))
    }
}

/// The default limits with memory capped at `max_memory` bytes (0:
/// [`WASM_MAX_MEMORY`]).
pub fn wasm_limits(max_memory: u64) -> Limits {
    let memory = if max_memory == 0 {
        WASM_MAX_MEMORY
    } else {
        max_memory
    };
    Limits::DEFAULT.with_max_memory(memory)
}

impl Buffers {
    /// An empty decoder with these options.
    pub fn new(options: DecodeOptions) -> Self {
        Buffers {
            decoder: StreamDecoder::new(options),
            positions: Vec::new(),
            normals: Vec::new(),
        }
    }

    /// The decoder.
    pub fn decoder(&self) -> &StreamDecoder {
        &self.decoder
    }

    /// The decoder, to push bytes or change options.
    pub fn decoder_mut(&mut self) -> &mut StreamDecoder {
        &mut self.decoder
    }

    /// [`StreamDecoder::refine`], then the vertex buffers of the new mesh.
    pub fn refine(&mut self) -> qm_codec::Result<bool> {
        if !self.decoder.refine()? {
            return Ok(false);
        }
        let mesh = self.decoder.mesh().expect("just refined");
        mesh.positions_f32(&mut self.positions);
        vertex_normals(&self.positions, mesh.triangles(), &mut self.normals);
        Ok(true)
    }

    /// [`StreamDecoder::texture_version`]: changes whenever a refinement
    /// makes the texture anew.
    pub fn texture_version(&self) -> u32 {
        self.decoder.texture_version()
    }

    /// [`StreamDecoder::texture`]: for a file whose colour is finer than
    /// its geometry, the last refinement's colours as a texture atlas, and
    /// its triangles over vertices that each have one texture coordinate.
    pub fn texture(&self) -> Option<(&Atlas, &Textured)> {
        self.decoder.texture()
    }

    /// Vertex positions of the last refinement, `x, y, z` per vertex.
    pub fn positions(&self) -> &[f32] {
        &self.positions
    }

    /// Unit vertex normals (area-weighted over the adjacent triangles).
    pub fn normals(&self) -> &[f32] {
        &self.normals
    }

    /// For a file with colours: one 8-bit sRGB colour per vertex of the
    /// last refinement (the decoder's, not a copy); `None` without colours
    /// or before the first refinement.
    pub fn colours(&self) -> Option<&[[u8; 3]]> {
        self.decoder.mesh().and_then(|m| m.colours())
    }

    /// Whether the file carries colours (false before the header arrived).
    pub fn has_colours(&self) -> bool {
        (self.decoder.decoder()).is_some_and(|d| d.header().colour.is_some())
    }

    /// Triangle corner indices of the last refinement.
    pub fn triangles(&self) -> &[u32] {
        self.decoder.mesh().map_or(&[], |m| m.triangles())
    }

    /// [`mesh_checksum`] of the last refinement.
    pub fn checksum(&self) -> u64 {
        self.decoder
            .mesh()
            .map_or(0, |m| mesh_checksum(m.quantized(), m.triangles()))
    }
}

/// The `code` of a decoder error as JavaScript sees it: `not-qm`,
/// `unsupported-version`, `truncated`, `corrupt`, `limit` or `memory`.
pub fn error_code(e: &Error) -> &'static str {
    match e {
        Error::NotQm => "not-qm",
        Error::UnsupportedVersion { .. } => "unsupported-version",
        Error::Truncated { .. } => "truncated",
        Error::Limit { .. } => "limit",
        Error::Memory { .. } => "memory",
        _ => "corrupt",
    }
}

/// A JavaScript `Error` with the message and [`error_code`] of `e`.
fn js_error(e: &Error) -> JsValue {
    let value: JsValue = JsError::new(&e.to_string()).into();
    // Setting a property on a fresh Error object cannot fail.
    let _ = js_sys::Reflect::set(&value, &"code".into(), &error_code(e).into());
    value
}

/// FNV-1a (64 bit) over the little-endian bytes of the vertex count, the
/// quantized values, the triangle count and the triangle indices: the same
/// value for the same mesh, whichever decoder built it.
pub fn mesh_checksum(values: impl Iterator<Item = [i32; 3]>, triangles: &[u32]) -> u64 {
    let mut h = FNV_START;
    let mut eat = |bytes: &[u8]| h = fnv1a(h, bytes);
    let mut count = 0u64;
    let mut body = Vec::new();
    for v in values {
        for c in v {
            body.extend_from_slice(&c.to_le_bytes());
        }
        count += 1;
    }
    eat(&count.to_le_bytes());
    eat(&body);
    eat(&(triangles.len() as u64 / 3).to_le_bytes());
    for t in triangles {
        eat(&t.to_le_bytes());
    }
    h
}

/// FNV-1a (64 bit) over the colours' bytes, `r, g, b` per vertex: what a
/// test computes over the `Uint8Array` a JavaScript decoder returns.
pub fn colour_checksum(colours: &[[u8; 3]]) -> u64 {
    fnv1a(FNV_START, colours.as_flattened())
}

/// The FNV-1a offset basis.
const FNV_START: u64 = 0xcbf2_9ce4_8422_2325;

/// FNV-1a (64 bit): `h` with `bytes` mixed in.
fn fnv1a(mut h: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// [`mesh_checksum`] of a one-shot native decode (each quad split along its
/// first diagonal, as the viewer does), with its vertex and triangle counts.
pub fn decompressed_checksum(d: &qm_codec::Decompressed) -> (u64, usize, usize) {
    let samples = d.layout.samples_at(d.level);
    let mut local = vec![u32::MAX; d.layout.sample_count()];
    for (i, &s) in samples.iter().enumerate() {
        local[s as usize] = i as u32;
    }
    let mut triangles = Vec::new();
    for q in d.layout.quads(d.level) {
        let [a, b, c, e] = q.map(|s| local[s as usize]);
        triangles.extend_from_slice(&[a, b, c, a, c, e]);
    }
    let values = samples.iter().map(|&s| d.values[s as usize]);
    let checksum = mesh_checksum(values, &triangles);
    (checksum, samples.len(), triangles.len() / 3)
}

/// The incremental decoder for JavaScript.
#[wasm_bindgen]
pub struct QmDecoder {
    inner: Buffers,
}

#[wasm_bindgen]
impl QmDecoder {
    /// An empty decoder whose file may take at most `max_memory` bytes
    /// (0: 512 MiB); it outputs the level the bytes support.
    #[wasm_bindgen(constructor)]
    pub fn new(max_memory: f64) -> QmDecoder {
        let limits = wasm_limits(if max_memory > 0.0 {
            max_memory as u64
        } else {
            0
        });
        QmDecoder {
            inner: Buffers::new(DecodeOptions::default().with_limits(limits)),
        }
    }

    fn set(&mut self, change: impl FnOnce(DecodeOptions) -> DecodeOptions) {
        let options = change(*self.inner.decoder().options());
        self.inner.decoder_mut().set_options(options);
    }

    /// The level to output: -1 the level the bytes support (the default),
    /// -2 the finest, 0 or more that level.
    #[wasm_bindgen(js_name = setLevel)]
    pub fn set_level(&mut self, level: i32) {
        let choice = match level {
            -2 => LevelChoice::Finest,
            l if l < 0 => LevelChoice::Auto,
            l => LevelChoice::Fixed(l as u32),
        };
        self.set(|o| o.with_level(choice));
    }

    /// Use no more of the stream than reaches this estimated RMS error,
    /// in model units (0 or less: no goal).
    #[wasm_bindgen(js_name = setMaxError)]
    pub fn set_max_error(&mut self, rms: f64) {
        self.set(|o| o.with_max_error((rms > 0.0).then_some(rms)));
    }

    /// Output no level with more triangles than this (0: no cap).
    #[wasm_bindgen(js_name = setMaxTriangles)]
    pub fn set_max_triangles(&mut self, triangles: f64) {
        self.set(|o| o.with_max_triangles((triangles >= 1.0).then_some(triangles as u64)));
    }

    /// How much worse, in dB, the automatic level may be than the finest.
    #[wasm_bindgen(js_name = setTolerance)]
    pub fn set_tolerance(&mut self, db: f64) {
        self.set(|o| o.with_tolerance_db(db.max(0.0)));
    }

    /// Keep no more than this many bytes of the file (0: no budget).
    #[wasm_bindgen(js_name = setMaxBytes)]
    pub fn set_max_bytes(&mut self, bytes: f64) {
        self.set(|o| o.with_max_bytes((bytes >= 1.0).then_some(bytes as usize)));
    }

    /// Appends bytes; true once the base mesh is complete. Throws on a file
    /// that is not `.qm`, is corrupt or asks for too much.
    pub fn push(&mut self, chunk: &[u8]) -> Result<bool, JsValue> {
        self.inner
            .decoder_mut()
            .push(chunk)
            .map_err(|e| js_error(&e))
    }

    /// Decodes the bytes so far with the settings; false when nothing
    /// changed. Throws before the base mesh is complete.
    pub fn refine(&mut self) -> Result<bool, JsValue> {
        self.inner.refine().map_err(|e| js_error(&e))
    }

    /// Whether the base mesh is complete.
    #[wasm_bindgen(getter)]
    pub fn ready(&self) -> bool {
        self.inner.decoder().ready()
    }

    /// Before the base mesh is complete: the least total bytes it needs,
    /// as far as known (0 once ready).
    #[wasm_bindgen(getter, js_name = bytesNeeded)]
    pub fn bytes_needed(&self) -> usize {
        self.inner.decoder().bytes_needed()
    }

    /// Whether more bytes could still change the mesh (false once the
    /// goal is met or the stream is complete).
    #[wasm_bindgen(getter, js_name = wantsMore)]
    pub fn wants_more(&self) -> bool {
        self.inner.decoder().wants_more()
    }

    /// Bytes kept so far.
    #[wasm_bindgen(getter, js_name = bytesReceived)]
    pub fn bytes_received(&self) -> usize {
        self.inner.decoder().bytes_received()
    }

    /// Bytes of the file the last mesh used.
    #[wasm_bindgen(getter, js_name = bytesUsed)]
    pub fn bytes_used(&self) -> usize {
        self.inner.decoder().mesh().map_or(0, |m| m.bytes_used())
    }

    /// Offset of the embedded stream (header plus base section), 0 before
    /// the base mesh is complete.
    #[wasm_bindgen(getter, js_name = streamStart)]
    pub fn stream_start(&self) -> usize {
        self.inner
            .decoder()
            .decoder()
            .map_or(0, qm_codec::Decoder::stream_start)
    }

    /// Finest subdivision level of the file.
    #[wasm_bindgen(getter, js_name = finestLevel)]
    pub fn finest_level(&self) -> u32 {
        self.inner.decoder().finest_level()
    }

    /// Bit-plane passes in the complete file.
    #[wasm_bindgen(getter, js_name = totalPasses)]
    pub fn total_passes(&self) -> u32 {
        self.inner
            .decoder()
            .decoder()
            .map_or(0, |d| u32::from(d.header().passes))
    }

    /// Passes decoded completely by the last refinement.
    #[wasm_bindgen(getter)]
    pub fn passes(&self) -> u32 {
        self.inner.decoder().mesh().map_or(0, |m| m.passes())
    }

    /// Level of the last refinement.
    #[wasm_bindgen(getter)]
    pub fn level(&self) -> u32 {
        self.inner.decoder().mesh().map_or(0, |m| m.level())
    }

    /// Whether the last refinement's bytes ended inside a pass.
    #[wasm_bindgen(getter)]
    pub fn truncated(&self) -> bool {
        self.inner.decoder().mesh().is_none_or(|m| m.truncated())
    }

    /// Estimated RMS distance of the last mesh from the complete stream's
    /// finest mesh, in model units.
    #[wasm_bindgen(getter, js_name = errorEstimate)]
    pub fn error_estimate(&self) -> f64 {
        self.inner.decoder().mesh().map_or(f64::NAN, |m| m.error())
    }

    /// The same as PSNR in dB against the bounding-box diagonal.
    #[wasm_bindgen(getter, js_name = psnrEstimate)]
    pub fn psnr_estimate(&self) -> f64 {
        self.inner
            .decoder()
            .mesh()
            .map_or(f64::NAN, |m| m.psnr_db())
    }

    /// Vertices of the last refinement.
    #[wasm_bindgen(getter, js_name = vertexCount)]
    pub fn vertex_count(&self) -> usize {
        self.inner.positions().len() / 3
    }

    /// Vertices of the mesh at `level` (0 before the base mesh).
    #[wasm_bindgen(js_name = vertexCountAt)]
    pub fn vertex_count_at(&mut self, level: u32) -> usize {
        self.inner.decoder_mut().vertices_at(level)
    }

    /// Triangles of the mesh at `level` (0 before the base mesh).
    #[wasm_bindgen(js_name = triangleCountAt)]
    pub fn triangle_count_at(&self, level: u32) -> f64 {
        self.inner.decoder().triangles_at(level) as f64
    }

    /// Triangles of the last refinement.
    #[wasm_bindgen(getter, js_name = triangleCount)]
    pub fn triangle_count(&self) -> usize {
        self.inner.triangles().len() / 3
    }

    /// Refinements that decoded.
    #[wasm_bindgen(getter)]
    pub fn refinements(&self) -> u32 {
        self.inner.decoder().refinements()
    }

    /// Positions of the last refinement (a copy), `x, y, z` per vertex.
    pub fn positions(&self) -> Vec<f32> {
        self.inner.positions().to_vec()
    }

    /// Unit vertex normals of the last refinement (a copy).
    pub fn normals(&self) -> Vec<f32> {
        self.inner.normals().to_vec()
    }

    /// Triangle indices of the last refinement (a copy).
    pub fn indices(&self) -> Vec<u32> {
        self.inner.triangles().to_vec()
    }

    /// For a file with colours: the last refinement's vertex colours (a
    /// copy), `r, g, b` per vertex, 8-bit sRGB; `undefined` without.
    pub fn colors(&self) -> Option<Vec<u8>> {
        self.inner.colours().map(|c| c.as_flattened().to_vec())
    }

    /// Whether the file carries colours (known once the header arrived).
    #[wasm_bindgen(getter, js_name = hasColors)]
    pub fn has_colors(&self) -> bool {
        self.inner.has_colours()
    }

    /// Width of the last refinement's texture in texels; 0 without one
    /// (a file whose colour is no finer than its geometry).
    #[wasm_bindgen(getter, js_name = textureWidth)]
    pub fn texture_width(&self) -> u32 {
        self.inner.texture().map_or(0, |(a, _)| a.width)
    }

    /// Height of the last refinement's texture in texels; 0 without one.
    #[wasm_bindgen(getter, js_name = textureHeight)]
    pub fn texture_height(&self) -> u32 {
        self.inner.texture().map_or(0, |(a, _)| a.height)
    }

    /// A number that changes whenever a refinement makes the texture (and
    /// its textured triangles) anew; while it stays the same, so do they.
    #[wasm_bindgen(getter, js_name = textureVersion)]
    pub fn texture_version(&self) -> u32 {
        self.inner.texture_version()
    }

    /// The last refinement's texture (a copy), `r, g, b, 255` per texel,
    /// 8-bit sRGB, rows from the top; `undefined` without one.
    #[wasm_bindgen(js_name = textureRgba)]
    pub fn texture_rgba(&self) -> Option<Vec<u8>> {
        let (atlas, _) = self.inner.texture()?;
        Some(
            (atlas.texels.iter())
                .flat_map(|&[r, g, b]| [r, g, b, 255])
                .collect(),
        )
    }

    /// With a texture: the mesh vertex of each textured vertex (a vertex
    /// of several base quads is one textured vertex a quad); `undefined`
    /// without.
    #[wasm_bindgen(js_name = texturedVertices)]
    pub fn textured_vertices(&self) -> Option<Vec<u32>> {
        Some(self.inner.texture()?.1.vertices.clone())
    }

    /// With a texture: each textured vertex's coordinates, `u, v`, `(0, 0)`
    /// at the image's top-left corner; `undefined` without.
    pub fn uvs(&self) -> Option<Vec<f32>> {
        Some(self.inner.texture()?.1.texcoords.as_flattened().to_vec())
    }

    /// With a texture: the triangles over the textured vertices, in the
    /// order of [`Self::indices`]; `undefined` without.
    #[wasm_bindgen(js_name = texturedIndices)]
    pub fn textured_indices(&self) -> Option<Vec<u32>> {
        Some(self.inner.texture()?.1.triangles.clone())
    }

    /// [`mesh_checksum`] of the last refinement, as 16 hex digits.
    pub fn checksum(&self) -> String {
        format!("{:016x}", self.inner.checksum())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use qm_codec::qm_lift::synthetic::bumpy_sphere;
    use qm_codec::{Decoder, EncodeOptions, compress, decompress};

    /// What the one-shot native decoder makes of the first `n` bytes.
    fn native(bytes: &[u8], n: usize, level: LevelChoice) -> (u64, usize, u32, u32) {
        let d = decompress(
            bytes,
            &DecodeOptions::default()
                .with_max_bytes(Some(n))
                .with_level(level),
        )
        .unwrap();
        let (checksum, vertices, _) = decompressed_checksum(&d);
        (checksum, vertices, d.passes, d.level)
    }

    fn sphere_file() -> Vec<u8> {
        compress(&bumpy_sphere(4), &EncodeOptions::DEFAULT)
            .unwrap()
            .bytes
    }

    fn buffers() -> Buffers {
        Buffers::default()
    }

    #[test]
    fn chunked_pushes_match_the_native_decoder_at_every_prefix() {
        let bytes = sphere_file();
        let start = Decoder::new(&bytes, &Limits::DEFAULT)
            .unwrap()
            .stream_start();
        for choice in [
            LevelChoice::Auto,
            LevelChoice::Finest,
            LevelChoice::Fixed(2),
        ] {
            let mut inc = Buffers::new(DecodeOptions::default().with_level(choice));
            let mut shown = 0;
            let mut last_passes = 0;
            for chunk in bytes.chunks(97) {
                let ready = inc.decoder_mut().push(chunk).unwrap();
                let received = inc.decoder().bytes_received();
                assert_eq!(ready, received >= start);
                if !ready {
                    assert!(inc.refine().unwrap_err().is_truncated());
                    continue;
                }
                assert!(inc.refine().unwrap());
                let (sum, vertices, passes, level) = native(&bytes, received, choice);
                let mesh = inc.decoder().mesh().unwrap();
                assert_eq!(inc.checksum(), sum, "{choice:?} at {received} bytes");
                assert_eq!(mesh.vertex_count(), vertices);
                assert_eq!((mesh.passes(), mesh.level()), (passes, level));
                assert!(passes >= last_passes);
                last_passes = passes;
                assert_eq!(inc.normals().len(), inc.positions().len());
                shown += 1;
            }
            assert!(shown > 3);
            let mesh = inc.decoder().mesh().unwrap();
            assert!(!mesh.truncated());
            assert!(!inc.decoder().wants_more());
            let full = decompress(&bytes, &DecodeOptions::default().with_level(choice)).unwrap();
            assert_eq!(mesh.passes(), full.passes);
            // The final positions are the native decoder's, rounded to f32.
            let (positions, _) = full.level_mesh();
            assert_eq!(positions.len(), mesh.vertex_count());
            for (p, q) in positions.iter().zip(inc.positions().chunks_exact(3)) {
                assert_eq!([p.x as f32, p.y as f32, p.z as f32], [q[0], q[1], q[2]]);
            }
        }
    }

    /// A level-0 split base (a mesh sent as its own triangles) streams its
    /// corners' low bits: every cut past the base matches the native
    /// decoder, which makes the midpoints and centres from the corners.
    #[test]
    fn a_level_0_file_streams_its_corners() {
        let mesh = qm_codec::qm_lift::synthetic::flat_split_octahedron();
        let bytes = compress(&mesh, &EncodeOptions::DEFAULT).unwrap().bytes;
        let decoder = Decoder::new(&bytes, &Limits::DEFAULT).unwrap();
        assert!(decoder.header().implied());
        assert!(decoder.stream_start() + 4 < bytes.len());
        let mut inc = buffers();
        for chunk in bytes.chunks(5) {
            if inc.decoder_mut().push(chunk).unwrap() {
                assert!(inc.refine().unwrap());
                let n = inc.decoder().bytes_received();
                let (sum, vertices, _, _) = native(&bytes, n, LevelChoice::Auto);
                assert_eq!(inc.checksum(), sum, "at {n} bytes");
                assert_eq!(inc.positions().len(), 3 * vertices);
            }
        }
        assert!(!inc.decoder().mesh().unwrap().truncated());
    }

    #[test]
    fn refinement_is_skipped_without_new_bytes_and_levels_switch() {
        let bytes = sphere_file();
        let half = bytes.len() / 2;
        let mut inc = buffers();
        inc.decoder_mut().push(&bytes[..half]).unwrap();
        assert!(inc.refine().unwrap());
        assert!(!inc.refine().unwrap());
        assert_eq!(inc.decoder().refinements(), 1);
        let finest = inc.decoder().finest_level();
        for level in 0..=finest {
            let options = inc
                .decoder()
                .options()
                .with_level(LevelChoice::Fixed(level));
            inc.decoder_mut().set_options(options);
            assert!(inc.refine().unwrap());
            let (sum, vertices, _, _) = native(&bytes, half, LevelChoice::Fixed(level));
            assert_eq!(inc.checksum(), sum, "level {level}");
            assert_eq!(inc.positions().len(), 3 * vertices);
            assert_eq!(inc.decoder().mesh().unwrap().level(), level);
            assert_eq!(inc.triangles().len(), 3 * 6 * 2 * 4usize.pow(level));
        }
        assert_eq!(inc.decoder_mut().vertices_at(0), 8);
        let at_finest = inc.decoder_mut().vertices_at(finest);
        assert_eq!(inc.decoder_mut().vertices_at(finest + 1), at_finest);
        inc.decoder_mut().push(&bytes[half..]).unwrap();
        assert!(inc.refine().unwrap());
        assert_eq!(
            inc.checksum(),
            native(&bytes, bytes.len(), LevelChoice::Finest).0
        );
    }

    #[test]
    fn bad_files_fail_early_with_codes() {
        let mut inc = buffers();
        assert!(!inc.decoder_mut().push(b"\x89Q").unwrap());
        let e = inc
            .decoder_mut()
            .push(b"X-not-a-qm-file-at-all")
            .unwrap_err();
        assert_eq!(error_code(&e), "not-qm");
        let mut bytes = sphere_file();
        let start = Decoder::new(&bytes, &Limits::DEFAULT)
            .unwrap()
            .stream_start();
        let mut inc = buffers();
        assert!(!inc.decoder_mut().push(&bytes[..20]).unwrap());
        assert!(inc.decoder().bytes_needed() > 20);
        assert_eq!(error_code(&inc.refine().unwrap_err()), "truncated");
        bytes[start - 6] ^= 0x55; // inside the base section: its CRC fails
        let mut inc = buffers();
        let e = inc.decoder_mut().push(&bytes[..start]).unwrap_err();
        assert_eq!(error_code(&e), "corrupt");
        let tiny = Buffers::new(DecodeOptions::default().with_limits(wasm_limits(1000)));
        let e = { tiny }.decoder_mut().push(&sphere_file()).unwrap_err();
        assert_eq!(error_code(&e), "memory");
    }

    /// The file of `mesh` with `rgb`, coded as the browser encoder codes it.
    fn coloured_file(mesh: &qm_codec::qm_lift::SemiRegularMesh, rgb: &[[u8; 3]]) -> Vec<u8> {
        let colours = qm_codec::Colours::new(rgb);
        (qm_codec::compress_coloured(mesh, colours, &EncodeOptions::DEFAULT, None).unwrap()).bytes
    }

    /// A coloured sphere pushed in pieces: at every refinement one colour
    /// per vertex, the native decoder's at the same bytes and level; at the
    /// end (finest level) the input's colours exactly.
    #[test]
    fn colours_arrive_with_every_refinement_and_end_exact() {
        let mesh = bumpy_sphere(3);
        // A colour per sample that no smooth field predicts exactly.
        let rgb: Vec<[u8; 3]> = (0..mesh.positions().len())
            .map(|s| [s as u8, (s * 7 / 3) as u8, 255 - (s % 200) as u8])
            .collect();
        let bytes = coloured_file(&mesh, &rgb);
        let plain = sphere_file();
        for options in [DecodeOptions::FINEST, DecodeOptions::default()] {
            let mut inc = Buffers::new(options);
            assert!(!inc.has_colours() && inc.colours().is_none());
            let mut shown = 0;
            for chunk in bytes.chunks(113) {
                if !inc.decoder_mut().push(chunk).unwrap() || !inc.refine().unwrap() {
                    continue;
                }
                assert!(inc.has_colours());
                let colours = inc.colours().unwrap();
                assert_eq!(3 * colours.len(), inc.positions().len());
                let n = inc.decoder().bytes_received();
                let native = decompress(&bytes, &options.with_max_bytes(Some(n))).unwrap();
                assert_eq!(native.colours.as_deref(), Some(colours), "at {n} bytes");
                shown += 1;
            }
            assert!(shown > 3, "{shown} refinements");
            assert!(!inc.decoder().wants_more());
            if options.level == LevelChoice::Finest {
                assert_eq!(inc.colours(), Some(&rgb[..]));
            }
        }
        // A file without colours has none, whatever arrived.
        let mut inc = buffers();
        inc.decoder_mut().push(&plain).unwrap();
        inc.refine().unwrap();
        assert!(!inc.has_colours() && inc.colours().is_none());
    }

    #[test]
    fn normals_are_unit_and_point_outwards_on_a_sphere() {
        let bytes = sphere_file();
        let mut inc = buffers();
        inc.decoder_mut().push(&bytes).unwrap();
        inc.refine().unwrap();
        let p = inc.positions();
        let n = (p.len() / 3) as f32;
        let centre: Vec<f32> = (0..3)
            .map(|d| p.iter().skip(d).step_by(3).sum::<f32>() / n)
            .collect();
        for (q, m) in p.chunks_exact(3).zip(inc.normals().chunks_exact(3)) {
            let len = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
            assert!((len - 1.0).abs() < 1e-4);
            let out: f32 = (0..3).map(|d| (q[d] - centre[d]) * m[d]).sum();
            assert!(out > 0.0);
        }
    }
}
