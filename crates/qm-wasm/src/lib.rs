//! An incremental `.qm` decoder for viewers that receive a file in pieces,
//! compiled to WebAssembly for the browser viewer in `web/`.
//!
//! [`Incremental`] is a thin layer over [`qm_codec::Decoder`]: bytes are pushed
//! as they arrive, the header and base mesh are parsed once as soon as they
//! are complete, and [`Incremental::refine`] decodes the longest prefix
//! received so far into a value buffer that is reused from one refinement to
//! the next. The index buffers (which samples exist at a level, the
//! triangles between them) depend only on the layout and are built once per
//! level. The decoding is the native decoder's own code.
//!
//! [`QmDecoder`] wraps it for JavaScript with `wasm-bindgen`.

use qm_codec::{DecodeStatus, Decoder, Limits};
use wasm_bindgen::prelude::*;

/// The index buffers of one subdivision level, derived from the layout only.
#[derive(Clone, Debug)]
struct LevelIndex {
    /// Sample ids present at the level, in the order of the vertex buffers.
    samples: Vec<u32>,
    /// Triangles as indices into `samples`, two per quad, counter-clockwise.
    triangles: Vec<u32>,
}

impl LevelIndex {
    fn new(layout: &qm_codec::qm_lift::Layout, level: u32) -> Self {
        let samples = layout.samples_at(level);
        let mut local = vec![u32::MAX; layout.sample_count()];
        for (i, &s) in samples.iter().enumerate() {
            local[s as usize] = i as u32;
        }
        let mut triangles = Vec::new();
        for q in layout.quads(level) {
            let [a, b, c, d] = q.map(|s| local[s as usize]);
            triangles.extend_from_slice(&[a, b, c, a, c, d]);
        }
        LevelIndex { samples, triangles }
    }
}

/// The buffers of one refinement (see [`Incremental::mesh`]).
#[derive(Clone, Copy, Debug)]
pub struct MeshView<'a> {
    /// `x, y, z` per vertex.
    pub positions: &'a [f32],
    /// Unit normal per vertex.
    pub normals: &'a [f32],
    /// Three vertex indices per triangle, counter-clockwise.
    pub triangles: &'a [u32],
    /// The level shown.
    pub level: u32,
    /// Passes decoded completely.
    pub passes: u32,
    /// Whether the bytes ended before all passes.
    pub truncated: bool,
}

/// An incremental decoder: push bytes, then ask for the mesh they describe.
#[derive(Clone, Debug)]
pub struct Incremental {
    bytes: Vec<u8>,
    limits: Limits,
    decoder: Option<Decoder>,
    levels: Vec<Option<LevelIndex>>,
    values: Vec<[i32; 3]>,
    /// Bytes and level of the last refinement (to skip redundant work).
    decoded: Option<(usize, u32)>,
    status: Option<DecodeStatus>,
    positions: Vec<f32>,
    normals: Vec<f32>,
    refinements: u32,
}

impl Default for Incremental {
    fn default() -> Self {
        Self::new()
    }
}

/// The browser decoder's memory limit: 512 MiB, an eighth of the largest
/// WebAssembly heap, so that a hostile file cannot crash the tab.
pub const WASM_MAX_MEMORY: u64 = 512 << 20;

impl Incremental {
    /// An empty decoder with the default limits, memory capped at
    /// [`WASM_MAX_MEMORY`].
    pub fn new() -> Self {
        Self::with_limits(Limits::DEFAULT.with_max_memory(WASM_MAX_MEMORY))
    }

    /// An empty decoder with the given limits.
    pub fn with_limits(limits: Limits) -> Self {
        Incremental {
            bytes: Vec::new(),
            limits,
            decoder: None,
            levels: Vec::new(),
            values: Vec::new(),
            decoded: None,
            status: None,
            positions: Vec::new(),
            normals: Vec::new(),
            refinements: 0,
        }
    }

    /// Appends the next bytes of the file. Returns whether the header and
    /// base mesh are complete (so that [`Self::refine`] can show a mesh).
    /// A file that is not `.qm`, is corrupt or exceeds the limits is an
    /// error as soon as enough bytes arrived to tell.
    pub fn push(&mut self, chunk: &[u8]) -> qm_codec::Result<bool> {
        self.bytes.extend_from_slice(chunk);
        if self.decoder.is_none() {
            match Decoder::new(&self.bytes, &self.limits) {
                Ok(decoder) => {
                    self.levels = vec![None; decoder.layout().level() as usize + 1];
                    self.decoder = Some(decoder);
                }
                Err(e) if e.is_truncated() => return Ok(false),
                Err(e) => return Err(e),
            }
        }
        Ok(true)
    }

    /// Whether the header and base mesh have arrived.
    pub fn ready(&self) -> bool {
        self.decoder.is_some()
    }

    /// The parsed decoder, once [`Self::ready`].
    pub fn decoder(&self) -> Option<&Decoder> {
        self.decoder.as_ref()
    }

    /// Bytes pushed so far.
    pub fn bytes_received(&self) -> usize {
        self.bytes.len()
    }

    /// The bytes pushed so far.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// The finest subdivision level of the file (0 before the header).
    pub fn finest_level(&self) -> u32 {
        self.decoder.as_ref().map_or(0, |d| d.layout().level())
    }

    /// Vertices of the mesh at `level` (at most the finest; 0 before the
    /// base mesh is complete). Builds that level's index buffers once.
    pub fn vertices_at(&mut self, level: u32) -> usize {
        let Some(decoder) = &self.decoder else {
            return 0;
        };
        let level = level.min(decoder.layout().level());
        self.levels[level as usize]
            .get_or_insert_with(|| LevelIndex::new(decoder.layout(), level))
            .samples
            .len()
    }

    /// Decodes everything received so far at `level` (default and at most
    /// the finest) into the vertex buffers. Returns `Ok(false)` when nothing
    /// changed since the last refinement (no new bytes, same level) and
    /// nothing was done, and `Ok(true)` when the buffers were rebuilt; an
    /// error only before the base mesh is complete.
    pub fn refine(&mut self, level: Option<u32>) -> qm_codec::Result<bool> {
        let Some(decoder) = &self.decoder else {
            return Err(qm_codec::Error::Truncated {
                needed: self.bytes.len() + 1,
                available: self.bytes.len(),
            });
        };
        let level = level.map_or(decoder.layout().level(), |l| {
            l.min(decoder.layout().level())
        });
        if self.decoded == Some((self.bytes.len(), level)) {
            return Ok(false);
        }
        let status = decoder.decode_into(
            &self.bytes[decoder.stream_start()..],
            None,
            Some(level),
            &mut self.values,
        );
        let index = self.levels[level as usize]
            .get_or_insert_with(|| LevelIndex::new(decoder.layout(), level));
        let quantizer = decoder.quantizer();
        self.positions.clear();
        for &s in &index.samples {
            let p = quantizer.dequantize(self.values[s as usize].map(f64::from));
            self.positions
                .extend_from_slice(&[p.x as f32, p.y as f32, p.z as f32]);
        }
        vertex_normals(&self.positions, &index.triangles, &mut self.normals);
        self.decoded = Some((self.bytes.len(), level));
        self.status = Some(status);
        self.refinements += 1;
        Ok(true)
    }

    /// The mesh of everything received so far at `level` (default: the
    /// finest): [`Self::refine`], then a view of the buffers.
    pub fn mesh(&mut self, level: Option<u32>) -> qm_codec::Result<MeshView<'_>> {
        self.refine(level)?;
        let status = self.status.expect("set by refine");
        Ok(MeshView {
            positions: &self.positions,
            normals: &self.normals,
            triangles: self.current_index().map_or(&[], |i| &i.triangles),
            level: status.level,
            passes: status.passes,
            truncated: status.truncated,
        })
    }

    /// What the last refinement achieved.
    pub fn status(&self) -> Option<DecodeStatus> {
        self.status
    }

    /// How many refinements actually decoded (skipped ones do not count).
    pub fn refinements(&self) -> u32 {
        self.refinements
    }

    /// Vertex positions of the last refinement, `x, y, z` per vertex.
    pub fn positions(&self) -> &[f32] {
        &self.positions
    }

    /// Unit vertex normals (area-weighted over the adjacent triangles).
    pub fn normals(&self) -> &[f32] {
        &self.normals
    }

    /// Triangle corner indices of the last refinement's level.
    pub fn triangles(&self) -> &[u32] {
        self.current_index().map_or(&[], |i| &i.triangles)
    }

    /// Sample ids of the vertices of the last refinement, in buffer order.
    pub fn samples(&self) -> &[u32] {
        self.current_index().map_or(&[], |i| &i.samples)
    }

    /// Vertices of the last refinement.
    pub fn vertex_count(&self) -> usize {
        self.positions.len() / 3
    }

    /// Quantized values of the last refinement's vertices, in buffer order.
    pub fn quantized(&self) -> impl Iterator<Item = [i32; 3]> + '_ {
        self.samples().iter().map(|&s| self.values[s as usize])
    }

    /// A checksum of the last refinement: its vertices' quantized values in
    /// buffer order and its triangles (see [`mesh_checksum`]).
    pub fn checksum(&self) -> u64 {
        mesh_checksum(self.quantized(), self.triangles())
    }

    fn current_index(&self) -> Option<&LevelIndex> {
        let (_, level) = self.decoded?;
        self.levels[level as usize].as_ref()
    }
}

/// FNV-1a (64 bit) over the little-endian bytes of the vertex count, the
/// quantized values, the triangle count and the triangle indices: the same
/// value for the same mesh, whichever decoder built it.
pub fn mesh_checksum(values: impl Iterator<Item = [i32; 3]>, triangles: &[u32]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325_u64;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
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

/// Area-weighted unit vertex normals of a triangle mesh into `out`.
fn vertex_normals(positions: &[f32], triangles: &[u32], out: &mut Vec<f32>) {
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

/// The incremental decoder for JavaScript.
#[wasm_bindgen]
pub struct QmDecoder {
    inner: Incremental,
}

impl Default for QmDecoder {
    fn default() -> Self {
        Self::new()
    }
}

#[wasm_bindgen]
impl QmDecoder {
    /// An empty decoder.
    #[wasm_bindgen(constructor)]
    pub fn new() -> QmDecoder {
        QmDecoder {
            inner: Incremental::new(),
        }
    }

    /// Appends bytes; true once the base mesh is complete. Throws on a file
    /// that is not `.qm`, is corrupt or too large.
    pub fn push(&mut self, chunk: &[u8]) -> Result<bool, JsError> {
        self.inner
            .push(chunk)
            .map_err(|e| JsError::new(&e.to_string()))
    }

    /// Decodes the bytes so far at `level` (negative: the finest); false when
    /// nothing changed. Throws before the base mesh is complete.
    pub fn refine(&mut self, level: i32) -> Result<bool, JsError> {
        let level = u32::try_from(level).ok();
        self.inner
            .refine(level)
            .map_err(|e| JsError::new(&e.to_string()))
    }

    /// Whether the base mesh is complete.
    pub fn ready(&self) -> bool {
        self.inner.ready()
    }

    /// Bytes pushed so far.
    #[wasm_bindgen(getter, js_name = bytesReceived)]
    pub fn bytes_received(&self) -> usize {
        self.inner.bytes_received()
    }

    /// Offset of the embedded stream (header plus base section), 0 before
    /// the base mesh is complete.
    #[wasm_bindgen(getter, js_name = streamStart)]
    pub fn stream_start(&self) -> usize {
        self.inner.decoder().map_or(0, Decoder::stream_start)
    }

    /// Finest subdivision level of the file.
    #[wasm_bindgen(getter, js_name = finestLevel)]
    pub fn finest_level(&self) -> u32 {
        self.inner.finest_level()
    }

    /// Bit-plane passes in the complete file.
    #[wasm_bindgen(getter, js_name = totalPasses)]
    pub fn total_passes(&self) -> u32 {
        self.inner
            .decoder()
            .map_or(0, |d| u32::from(d.header().passes))
    }

    /// Passes decoded completely by the last refinement.
    #[wasm_bindgen(getter)]
    pub fn passes(&self) -> u32 {
        self.inner.status().map_or(0, |s| s.passes)
    }

    /// Level shown by the last refinement.
    #[wasm_bindgen(getter)]
    pub fn level(&self) -> u32 {
        self.inner.status().map_or(0, |s| s.level)
    }

    /// Whether the last refinement's stream ended before all passes.
    #[wasm_bindgen(getter)]
    pub fn truncated(&self) -> bool {
        self.inner.status().is_none_or(|s| s.truncated)
    }

    /// Vertices of the last refinement.
    #[wasm_bindgen(getter, js_name = vertexCount)]
    pub fn vertex_count(&self) -> usize {
        self.inner.vertex_count()
    }

    /// Vertices of the mesh at `level` (0 before the base mesh).
    #[wasm_bindgen(js_name = vertexCountAt)]
    pub fn vertex_count_at(&mut self, level: u32) -> usize {
        self.inner.vertices_at(level)
    }

    /// Triangles of the last refinement.
    #[wasm_bindgen(getter, js_name = triangleCount)]
    pub fn triangle_count(&self) -> usize {
        self.inner.triangles().len() / 3
    }

    /// Refinements that decoded.
    #[wasm_bindgen(getter)]
    pub fn refinements(&self) -> u32 {
        self.inner.refinements()
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

    /// [`mesh_checksum`] of the last refinement, as 16 hex digits.
    pub fn checksum(&self) -> String {
        format!("{:016x}", self.inner.checksum())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use qm_codec::qm_lift::synthetic::bumpy_sphere;
    use qm_codec::{DecodeOptions, EncodeOptions, compress, decompress};

    /// What the one-shot native decoder makes of the first `n` bytes.
    fn native(bytes: &[u8], n: usize, level: Option<u32>) -> (u64, usize, u32) {
        let d = decompress(
            bytes,
            &DecodeOptions::default()
                .with_max_bytes(Some(n))
                .with_level(level),
        )
        .unwrap();
        let (checksum, vertices, _) = decompressed_checksum(&d);
        (checksum, vertices, d.passes)
    }

    fn sphere_file() -> Vec<u8> {
        compress(&bumpy_sphere(4), &EncodeOptions::DEFAULT)
            .unwrap()
            .bytes
    }

    #[test]
    fn chunked_pushes_match_the_native_decoder_at_every_prefix() {
        let bytes = sphere_file();
        let mut inc = Incremental::new();
        let mut shown = 0;
        let mut last_passes = 0;
        for chunk in bytes.chunks(97) {
            let ready = inc.push(chunk).unwrap();
            assert_eq!(
                ready,
                inc.bytes_received() >= {
                    let d = Decoder::new(&bytes, &Limits::DEFAULT).unwrap();
                    d.stream_start()
                }
            );
            if !ready {
                assert!(inc.refine(None).unwrap_err().is_truncated());
                continue;
            }
            assert!(inc.refine(None).unwrap());
            let (sum, vertices, passes) = native(&bytes, inc.bytes_received(), None);
            assert_eq!(inc.checksum(), sum, "at {} bytes", inc.bytes_received());
            assert_eq!(inc.vertex_count(), vertices);
            assert_eq!(inc.status().unwrap().passes, passes);
            assert!(passes >= last_passes);
            last_passes = passes;
            assert_eq!(inc.normals().len(), inc.positions().len());
            shown += 1;
        }
        assert!(shown > 3);
        let status = inc.status().unwrap();
        assert!(!status.truncated);
        let full = decompress(&bytes, &DecodeOptions::default()).unwrap();
        assert_eq!(status.passes, full.passes);
        // The final positions are the native decoder's, rounded to f32.
        let (positions, _) = full.level_mesh();
        assert_eq!(positions.len(), inc.vertex_count());
        for (p, q) in positions.iter().zip(inc.positions().chunks_exact(3)) {
            assert_eq!([p.x as f32, p.y as f32, p.z as f32], [q[0], q[1], q[2]]);
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
        let mut inc = Incremental::new();
        for chunk in bytes.chunks(5) {
            if inc.push(chunk).unwrap() {
                assert!(inc.refine(None).unwrap());
                let (sum, vertices, _) = native(&bytes, inc.bytes_received(), None);
                assert_eq!(inc.checksum(), sum, "at {} bytes", inc.bytes_received());
                assert_eq!(inc.vertex_count(), vertices);
            }
        }
        assert!(!inc.status().unwrap().truncated);
    }

    #[test]
    fn refinement_is_skipped_without_new_bytes_and_levels_switch() {
        let bytes = sphere_file();
        let mut inc = Incremental::new();
        inc.push(&bytes[..bytes.len() / 2]).unwrap();
        assert!(inc.refine(None).unwrap());
        assert!(!inc.refine(None).unwrap());
        assert_eq!(inc.refinements(), 1);
        let finest = inc.finest_level();
        for level in 0..=finest {
            assert!(inc.refine(Some(level)).unwrap());
            let (sum, vertices, _) = native(&bytes, bytes.len() / 2, Some(level));
            assert_eq!(inc.checksum(), sum, "level {level}");
            assert_eq!(inc.vertex_count(), vertices);
            assert_eq!(inc.status().unwrap().level, level);
            assert_eq!(inc.triangles().len(), 3 * 6 * 2 * 4usize.pow(level));
        }
        assert_eq!(inc.vertices_at(0), 8);
        assert_eq!(inc.vertices_at(finest + 1), inc.vertices_at(finest));
        // Beyond the finest level is the finest level.
        assert!(!inc.refine(Some(finest + 5)).unwrap());
        inc.push(&bytes[bytes.len() / 2..]).unwrap();
        let mesh = inc.mesh(Some(finest)).unwrap();
        assert!(!mesh.truncated);
        assert_eq!(mesh.level, finest);
        assert_eq!(mesh.positions.len(), mesh.normals.len());
        assert_eq!(mesh.triangles.len(), 3 * 6 * 2 * 4usize.pow(finest));
        assert_eq!(inc.checksum(), native(&bytes, bytes.len(), None).0);
    }

    #[test]
    fn bad_files_fail_early() {
        let mut inc = Incremental::new();
        assert!(!inc.push(b"\x89Q").unwrap());
        assert!(inc.push(b"X-not-a-qm-file-at-all").is_err());
        let mut bytes = sphere_file();
        let start = Decoder::new(&bytes, &Limits::DEFAULT)
            .unwrap()
            .stream_start();
        bytes[start - 6] ^= 0x55; // inside the base section: its CRC fails
        let mut inc = Incremental::new();
        assert!(inc.push(&bytes[..start]).is_err());
    }

    #[test]
    fn normals_are_unit_and_point_outwards_on_a_sphere() {
        let bytes = sphere_file();
        let mut inc = Incremental::new();
        inc.push(&bytes).unwrap();
        inc.refine(None).unwrap();
        let p = inc.positions();
        let n = inc.vertex_count() as f32;
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
