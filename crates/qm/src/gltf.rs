//! A `.qm` file as a glTF 2.0 binary (`.glb`) with the extension
//! `QM_progressive_mesh` (specified in `docs/gltf.md`).
//!
//! The GLB holds one mesh of one triangle primitive. Its ordinary
//! attributes (`POSITION`, `NORMAL` and the indices) are the *fallback*: a
//! prefix of the `.qm` decoded at a coarse level, which any glTF viewer
//! shows. The extension points at the whole `.qm` (in a buffer view of the
//! GLB, or at a `uri` served beside it, where a client can fetch byte
//! ranges) and carries the file's prefix table, so that a client with a
//! qm decoder streams the rest and knows beforehand how many bytes an error
//! goal takes.

use serde_json::{Value, json};

use crate::codec::{Atlas, Textured};
use crate::{DecodeOptions, Decoded, Decoder, LevelChoice, PrefixRow, Result, StreamDecoder};

/// The extension's name.
pub const EXTENSION: &str = "QM_progressive_mesh";

/// Most triangles of the default fallback: its level is the finest one
/// with at most this many.
pub const DEFAULT_FALLBACK_TRIANGLES: u64 = 4096;

/// How [`to_glb`] writes the GLB.
#[derive(Clone, Debug, Default, PartialEq)]
#[non_exhaustive]
pub struct GltfOptions {
    /// Where the `.qm` is: `None` embeds it in the GLB; `Some(uri)` leaves
    /// it out and points at `uri` (relative to the GLB), to be served with
    /// byte ranges.
    pub uri: Option<String>,
    /// The fallback's level (default: the finest level with at most
    /// [`Self::fallback_triangles`] triangles).
    pub fallback_level: Option<u32>,
    /// Most triangles of the default fallback level (default
    /// [`DEFAULT_FALLBACK_TRIANGLES`]).
    pub fallback_triangles: Option<u64>,
    /// The prefix the fallback is decoded from (default: the shortest prefix
    /// that supports the fallback's level, by the decoder's level choice).
    pub fallback_bytes: Option<usize>,
}

impl GltfOptions {
    /// Points the extension at `uri` instead of embedding the `.qm`.
    pub fn with_uri(mut self, uri: Option<String>) -> Self {
        self.uri = uri;
        self
    }

    /// Sets the fallback's level.
    pub fn with_fallback_level(mut self, level: Option<u32>) -> Self {
        self.fallback_level = level;
        self
    }

    /// Sets the most triangles of the default fallback level.
    pub fn with_fallback_triangles(mut self, triangles: Option<u64>) -> Self {
        self.fallback_triangles = triangles;
        self
    }

    /// Sets the fallback's prefix.
    pub fn with_fallback_bytes(mut self, bytes: Option<usize>) -> Self {
        self.fallback_bytes = bytes;
        self
    }
}

/// A GLB written by [`to_glb`] (or glTF JSON by [`to_gltf`]), with what
/// went into it.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct Glb {
    /// The `.glb` file (or the `.gltf` text).
    pub bytes: Vec<u8>,
    /// The prefix the fallback was decoded from.
    pub fallback_bytes: usize,
    /// The fallback's level.
    pub fallback_level: u32,
    /// The fallback's vertices.
    pub fallback_vertices: usize,
    /// The fallback's triangles.
    pub fallback_triangles: usize,
    /// The fallback's estimated RMS error, model units.
    pub fallback_error: f64,
    /// [`Self::fallback_error`] as PSNR against the bounding-box diagonal, dB.
    pub fallback_psnr_db: f64,
    /// The prefix table written into the extension.
    pub levels: Vec<PrefixRow>,
}

/// Writes the whole `.qm` file `qm` as a GLB with a fallback and the
/// extension `QM_progressive_mesh`.
pub fn to_glb(qm: &[u8], options: &GltfOptions) -> Result<Glb> {
    let (document, bin, mut glb) = build(qm, options)?;
    glb.bytes = glb_container(&document, &bin);
    Ok(glb)
}

/// Writes the whole `.qm` file `qm` as glTF JSON (`.gltf`) whose extension
/// points at `uri` (the `.qm` beside it), the fallback's buffer inlined as
/// a base64 data URI so that the `.gltf` is one file.
pub fn to_gltf(qm: &[u8], uri: &str, options: &GltfOptions) -> Result<Glb> {
    use base64::Engine as _;
    let options = options.clone().with_uri(Some(uri.to_string()));
    let (mut document, bin, mut glb) = build(qm, &options)?;
    let data = base64::engine::general_purpose::STANDARD.encode(&bin);
    document["buffers"][0]["uri"] = json!(format!("data:application/octet-stream;base64,{data}"));
    glb.bytes = serde_json::to_vec_pretty(&document).expect("JSON values serialize");
    Ok(glb)
}

/// The glTF document, its binary buffer, and what went into them (the
/// [`Glb`]'s bytes still empty).
fn build(qm: &[u8], options: &GltfOptions) -> Result<(Value, Vec<u8>, Glb)> {
    let levels = crate::prefix_table(qm, &DecodeOptions::DEFAULT)?;
    // The header and base (checked by the table already).
    let decoder = Decoder::new(qm, &DecodeOptions::DEFAULT.limits)?;
    let finest = decoder.finest_level();
    let stream_start = decoder.stream_start();
    let most = options
        .fallback_triangles
        .unwrap_or(DEFAULT_FALLBACK_TRIANGLES);
    let level = options.fallback_level.map_or_else(
        || {
            (0..=finest)
                .rev()
                .find(|&l| decoder.triangles_at(l) <= most)
                .unwrap_or(0)
        },
        |l| l.min(finest),
    );
    let prefix = options.fallback_bytes.map_or_else(
        || {
            levels
                .iter()
                .find(|r| r.level >= level)
                .map_or(qm.len(), |r| r.bytes)
        },
        |b| b.clamp(stream_start, qm.len()),
    );
    let mut fallback = StreamDecoder::new(
        DecodeOptions::DEFAULT
            .with_max_bytes(Some(prefix))
            .with_level(LevelChoice::Fixed(level)),
    );
    fallback.push(qm)?;
    fallback.refine()?;
    let mesh = fallback.mesh().expect("refined");
    let mut positions = Vec::new();
    mesh.positions_f32(&mut positions);
    let mut bin = Bin::default();
    let mut document = json!({});
    let mut primitive = add_primitive(
        &mut bin,
        &mut document,
        &positions,
        mesh.triangles(),
        mesh.colours(),
        None,
    );
    let mut extension = json!({
        "byteLength": qm.len(),
        "streamStart": stream_start,
        "finestLevel": finest,
        "fallback": { "bytes": prefix, "level": level, "error": mesh.error() },
        "levels": levels.iter().map(|r| json!({
            "bytes": r.bytes,
            "passes": r.passes,
            "level": r.level,
            "triangles": r.triangles,
            "error": r.error,
        })).collect::<Vec<_>>(),
    });
    match &options.uri {
        Some(uri) => extension["uri"] = json!(uri),
        None => extension["bufferView"] = json!(bin.add(qm.to_vec(), None)),
    }
    primitive["extensions"] = json!({ EXTENSION: extension });
    let vertex_count = mesh.vertex_count();
    finish_document(&mut document, primitive, &bin);
    document["extensionsUsed"] = json!([EXTENSION]);
    let glb = Glb {
        bytes: Vec::new(),
        fallback_bytes: prefix,
        fallback_level: level,
        fallback_vertices: vertex_count,
        fallback_triangles: mesh.triangles().len() / 3,
        fallback_error: mesh.error(),
        fallback_psnr_db: mesh.psnr_db(),
        levels,
    };
    Ok((document, bin.data, glb))
}

/// A decode as a plain glTF 2.0 binary: its mesh as one triangle
/// primitive with normals, and its look: with a [`Decoded::texture`], the
/// texture as an embedded PNG `baseColorTexture` over `TEXCOORD_0` (a
/// vertex of several base quads split, one a quad); otherwise its colours
/// as a linear `COLOR_0`.
pub fn decoded_glb(decoded: &Decoded) -> Vec<u8> {
    let positions: Vec<f32> = (decoded.mesh.positions.iter())
        .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .collect();
    let quads: Vec<[u32; 4]> = (decoded.mesh.faces())
        .map(|f| [f[0], f[1], f[2], f[3]])
        .collect();
    let triangles: Vec<u32> = (quads.iter())
        .flat_map(|&[a, b, c, d]| [a, b, c, a, c, d])
        .collect();
    let textured = (decoded.texture().zip(decoded.corner_texcoords()))
        .map(|(atlas, corners)| (atlas, Textured::new(&quads, &corners)));
    let mut bin = Bin::default();
    let mut document = json!({});
    let primitive = add_primitive(
        &mut bin,
        &mut document,
        &positions,
        &triangles,
        decoded.colours(),
        textured.as_ref().map(|(a, t)| (*a, t)),
    );
    finish_document(&mut document, primitive, &bin);
    glb_container(&document, &bin.data)
}

/// Adds to `bin` and `document` the accessors of one triangle primitive
/// over `positions` (`x, y, z`) and `triangles`, with area-weighted
/// normals and either `colours` as a linear `COLOR_0` or, given a texture
/// and its split vertices, `TEXCOORD_0` and a material that shows the
/// texture (embedded as PNG); returns the primitive.
fn add_primitive(
    bin: &mut Bin,
    document: &mut Value,
    positions: &[f32],
    triangles: &[u32],
    colours: Option<&[[u8; 3]]>,
    texture: Option<(&Atlas, &Textured)>,
) -> Value {
    let mut normals = Vec::new();
    crate::codec::vertex_normals(positions, triangles, &mut normals);
    let (positions, normals, triangles) = match texture {
        Some((_, t)) => {
            let gather = |values: &[f32]| -> Vec<f32> {
                (t.vertices.iter())
                    .flat_map(|&v| {
                        let i = 3 * v as usize;
                        [values[i], values[i + 1], values[i + 2]]
                    })
                    .collect()
            };
            (gather(positions), gather(&normals), &t.triangles[..])
        }
        None => (positions.to_vec(), normals, triangles),
    };
    let vertex_count = positions.len() / 3;
    let mut accessors = Vec::new();
    let mut accessor = |bin: &mut Bin, bytes: Vec<u8>, target, fields: Value| {
        let mut a = json!({ "bufferView": bin.add(bytes, target) });
        a.as_object_mut()
            .expect("an object")
            .extend(fields.as_object().expect("an object").clone());
        accessors.push(a);
        accessors.len() - 1
    };
    let (min, max) = bounds(&positions);
    let position = accessor(
        bin,
        bytes_of_f32(&positions),
        Some(ARRAY_BUFFER),
        json!({ "componentType": FLOAT, "count": vertex_count, "type": "VEC3", "min": min, "max": max }),
    );
    let normal = accessor(
        bin,
        bytes_of_f32(&normals),
        Some(ARRAY_BUFFER),
        json!({ "componentType": FLOAT, "count": vertex_count, "type": "VEC3" }),
    );
    let (index_bytes, index_type) = if vertex_count <= u16::MAX as usize {
        let bytes = (triangles.iter())
            .flat_map(|&i| (i as u16).to_le_bytes())
            .collect();
        (bytes, UNSIGNED_SHORT)
    } else {
        let bytes = triangles.iter().flat_map(|&i| i.to_le_bytes()).collect();
        (bytes, UNSIGNED_INT)
    };
    let indices = accessor(
        bin,
        index_bytes,
        Some(ELEMENT_ARRAY_BUFFER),
        json!({ "componentType": index_type, "count": triangles.len(), "type": "SCALAR" }),
    );
    let mut attributes = json!({ "POSITION": position, "NORMAL": normal });
    let mut primitive = json!({ "indices": indices, "mode": 4 });
    match (texture, colours) {
        (Some((atlas, t)), _) => {
            let uv: Vec<f32> = t.texcoords.iter().flatten().copied().collect();
            attributes["TEXCOORD_0"] = json!(accessor(
                bin,
                bytes_of_f32(&uv),
                Some(ARRAY_BUFFER),
                json!({ "componentType": FLOAT, "count": vertex_count, "type": "VEC2" }),
            ));
            let png = qm_io::png_bytes(atlas.width, atlas.height, &atlas.texels);
            document["images"] =
                json!([{ "bufferView": bin.add(png, None), "mimeType": "image/png" }]);
            // Linear filtering, mipmaps, and edges clamped (the gutters).
            document["samplers"] =
                json!([{ "magFilter": 9729, "minFilter": 9987, "wrapS": 33071, "wrapT": 33071 }]);
            document["textures"] = json!([{ "sampler": 0, "source": 0 }]);
            document["materials"] = json!([{
                "pbrMetallicRoughness": {
                    "baseColorTexture": { "index": 0 },
                    "metallicFactor": 0.0,
                    "roughnessFactor": 1.0,
                },
            }]);
            primitive["material"] = json!(0);
        }
        (None, Some(colours)) => {
            // glTF's COLOR_0 is linear: the decoded sRGB colours converted.
            let linear: Vec<f32> = (colours.iter().flatten())
                .map(|&c| srgb_to_linear(c))
                .collect();
            attributes["COLOR_0"] = json!(accessor(
                bin,
                bytes_of_f32(&linear),
                Some(ARRAY_BUFFER),
                json!({ "componentType": FLOAT, "count": vertex_count, "type": "VEC3" }),
            ));
        }
        (None, None) => {}
    }
    primitive["attributes"] = attributes;
    document["accessors"] = json!(accessors);
    primitive
}

/// Completes `document` around its one mesh of `primitive`, over `bin`.
fn finish_document(document: &mut Value, primitive: Value, bin: &Bin) {
    document["asset"] = json!({
        "version": "2.0",
        "generator": concat!("qm ", env!("CARGO_PKG_VERSION")),
    });
    document["scene"] = json!(0);
    document["scenes"] = json!([{ "nodes": [0] }]);
    document["nodes"] = json!([{ "mesh": 0 }]);
    document["meshes"] = json!([{ "primitives": [primitive] }]);
    document["bufferViews"] = json!(bin.views);
    document["buffers"] = json!([{ "byteLength": bin.data.len() }]);
}

const FLOAT: u32 = 5126;
const UNSIGNED_SHORT: u32 = 5123;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// The GLB's binary chunk and its buffer views, each 4-byte aligned.
#[derive(Default)]
struct Bin {
    data: Vec<u8>,
    views: Vec<Value>,
}

impl Bin {
    /// Appends one buffer view; returns its index.
    fn add(&mut self, bytes: Vec<u8>, target: Option<u32>) -> usize {
        let mut view = json!({
            "buffer": 0,
            "byteOffset": self.data.len(),
            "byteLength": bytes.len(),
        });
        if let Some(target) = target {
            view["target"] = json!(target);
        }
        self.data.extend_from_slice(&bytes);
        self.data.resize(self.data.len().next_multiple_of(4), 0);
        self.views.push(view);
        self.views.len() - 1
    }
}

/// An 8-bit sRGB channel as linear light, 0..1 (the sRGB transfer
/// function's inverse).
fn srgb_to_linear(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn bytes_of_f32(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// Per-axis minimum and maximum of `x, y, z` triples (glTF requires them
/// for `POSITION`).
fn bounds(positions: &[f32]) -> ([f32; 3], [f32; 3]) {
    let mut min = [f32::INFINITY; 3];
    let mut max = [f32::NEG_INFINITY; 3];
    for p in positions.chunks_exact(3) {
        for k in 0..3 {
            min[k] = min[k].min(p[k]);
            max[k] = max[k].max(p[k]);
        }
    }
    (min, max)
}

/// The GLB container: a 12-byte header, the JSON chunk padded with spaces,
/// the binary chunk padded with zeros.
fn glb_container(document: &Value, bin: &[u8]) -> Vec<u8> {
    let mut text = serde_json::to_vec(document).expect("JSON values serialize");
    text.resize(text.len().next_multiple_of(4), b' ');
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::{EncodeOptions, compress};
    use crate::lift::synthetic::bumpy_sphere;

    fn chunks(glb: &[u8]) -> (Value, &[u8]) {
        assert_eq!(&glb[..4], b"glTF");
        let total = u32::from_le_bytes(glb[8..12].try_into().unwrap()) as usize;
        assert_eq!(total, glb.len());
        let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
        assert_eq!(json_len % 4, 0);
        let json = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
        let bin = &glb[28 + json_len..];
        (json, bin)
    }

    #[test]
    fn the_glb_embeds_the_file_and_a_fallback_the_decoder_makes() {
        let qm = compress(&bumpy_sphere(5), &EncodeOptions::DEFAULT)
            .unwrap()
            .bytes;
        let glb = to_glb(&qm, &GltfOptions::default()).unwrap();
        assert!(glb.fallback_triangles as u64 <= DEFAULT_FALLBACK_TRIANGLES);
        assert!(glb.fallback_level >= 2, "level {}", glb.fallback_level);
        assert!(
            glb.fallback_bytes < qm.len() / 4,
            "{} bytes",
            glb.fallback_bytes
        );
        let (json, bin) = chunks(&glb.bytes);
        let primitive = &json["meshes"][0]["primitives"][0];
        let ext = &primitive["extensions"][EXTENSION];
        let view = &json["bufferViews"][ext["bufferView"].as_u64().unwrap() as usize];
        let offset = view["byteOffset"].as_u64().unwrap() as usize;
        assert_eq!(&bin[offset..offset + qm.len()], &qm[..], "the file, whole");
        assert_eq!(ext["byteLength"], qm.len());
        assert_eq!(ext["levels"].as_array().unwrap().len(), glb.levels.len());
        assert_eq!(ext["fallback"]["bytes"], glb.fallback_bytes);
        // The fallback is the decoder's mesh of that prefix at that level.
        let options = DecodeOptions::DEFAULT
            .with_max_bytes(Some(glb.fallback_bytes))
            .with_level(LevelChoice::Fixed(glb.fallback_level));
        let decoded = crate::decode(&qm, &options).unwrap();
        assert_eq!(decoded.mesh.positions.len(), glb.fallback_vertices);
        let accessors = &json["accessors"];
        assert_eq!(accessors[0]["count"], glb.fallback_vertices);
        assert_eq!(accessors[2]["count"], 3 * glb.fallback_triangles);
        assert_eq!(accessors[2]["componentType"], UNSIGNED_SHORT);
        let first = &bin[..12];
        let p = decoded.mesh.positions[0].as_vec3();
        let expected: Vec<u8> = [p.x, p.y, p.z]
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        assert_eq!(first, &expected[..]);
    }

    /// A file with colours gives the fallback a linear `COLOR_0`: the
    /// decoder's colours of that prefix; one without has none.
    #[test]
    fn colours_reach_the_fallback_as_linear_color_0() {
        let mesh = bumpy_sphere(4);
        let colours: Vec<[u8; 3]> = (0..mesh.positions().len())
            .map(|s| [(s % 256) as u8, 200, (s / 7 % 256) as u8])
            .collect();
        let qm = crate::codec::compress_coloured(
            &mesh,
            crate::codec::Colours::new(&colours),
            &EncodeOptions::DEFAULT,
            None,
        )
        .unwrap()
        .bytes;
        let glb = to_glb(&qm, &GltfOptions::default()).unwrap();
        let (json, bin) = chunks(&glb.bytes);
        let attributes = &json["meshes"][0]["primitives"][0]["attributes"];
        let accessor = &json["accessors"][attributes["COLOR_0"].as_u64().unwrap() as usize];
        assert_eq!(accessor["count"], glb.fallback_vertices);
        assert_eq!(
            (accessor["type"].as_str(), &accessor["componentType"]),
            (Some("VEC3"), &json!(FLOAT))
        );
        let view = &json["bufferViews"][accessor["bufferView"].as_u64().unwrap() as usize];
        let offset = view["byteOffset"].as_u64().unwrap() as usize;
        let options = DecodeOptions::DEFAULT
            .with_max_bytes(Some(glb.fallback_bytes))
            .with_level(LevelChoice::Fixed(glb.fallback_level));
        let decoded = crate::decode(&qm, &options).unwrap();
        let first = decoded.colours().unwrap()[1];
        let stored: Vec<f32> = bin[offset + 12..offset + 24]
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
            .collect();
        assert_eq!(stored, first.map(srgb_to_linear).to_vec());
        assert_eq!(srgb_to_linear(255), 1.0);
        assert!((srgb_to_linear(128) - 0.2158605).abs() < 1e-6);
        let plain = compress(&mesh, &EncodeOptions::DEFAULT).unwrap().bytes;
        let (json, _) = chunks(&to_glb(&plain, &GltfOptions::default()).unwrap().bytes);
        assert!(
            json["meshes"][0]["primitives"][0]["attributes"]
                .get("COLOR_0")
                .is_none()
        );
    }

    #[test]
    fn a_uri_leaves_the_file_out_and_levels_and_bytes_can_be_chosen() {
        let qm = compress(&bumpy_sphere(4), &EncodeOptions::DEFAULT)
            .unwrap()
            .bytes;
        let options = GltfOptions::default()
            .with_uri(Some("sphere.qm".into()))
            .with_fallback_level(Some(1))
            .with_fallback_bytes(Some(qm.len() / 2));
        let glb = to_glb(&qm, &options).unwrap();
        assert!(glb.bytes.len() < qm.len(), "the .qm is not inside");
        let (json, _) = chunks(&glb.bytes);
        let ext = &json["meshes"][0]["primitives"][0]["extensions"][EXTENSION];
        assert_eq!(ext["uri"], "sphere.qm");
        assert!(ext.get("bufferView").is_none());
        let fallback = json!({ "bytes": qm.len() / 2, "level": 1, "error": glb.fallback_error });
        assert_eq!(ext["fallback"], fallback);
        assert!(to_glb(&qm[..20], &GltfOptions::default()).is_err());
    }

    #[test]
    fn gltf_json_points_at_the_file_and_inlines_the_fallback() {
        use base64::Engine as _;
        let qm = compress(&bumpy_sphere(3), &EncodeOptions::DEFAULT)
            .unwrap()
            .bytes;
        let text = to_gltf(&qm, "sphere.qm", &GltfOptions::default()).unwrap();
        let json: Value = serde_json::from_slice(&text.bytes).unwrap();
        let ext = &json["meshes"][0]["primitives"][0]["extensions"][EXTENSION];
        assert_eq!(ext["uri"], "sphere.qm");
        let uri = json["buffers"][0]["uri"].as_str().unwrap();
        let data = uri
            .strip_prefix("data:application/octet-stream;base64,")
            .unwrap();
        let bin = base64::engine::general_purpose::STANDARD
            .decode(data)
            .unwrap();
        assert_eq!(json["buffers"][0]["byteLength"], bin.len());
        let glb = to_glb(
            &qm,
            &GltfOptions::default().with_uri(Some("sphere.qm".into())),
        )
        .unwrap();
        assert_eq!(
            chunks(&glb.bytes).1,
            &bin[..],
            "the same buffer as the GLB's"
        );
    }
}
