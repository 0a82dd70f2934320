//! Tests of the glTF reader, on files assembled here byte by byte.

use serde_json::{Value, json};

use super::*;
use crate::{AssetOptions, Format, read_asset, read_asset_bytes, read_mesh, read_mesh_bytes};

/// A GLB of `document` with `bin` as its binary chunk.
pub(crate) fn glb(document: &Value, bin: &[u8]) -> Vec<u8> {
    let mut json = serde_json::to_vec(document).unwrap();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    if !bin.is_empty() {
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
    }
    out
}

/// A PNG of `width` x `height` whose pixel (x, y) is (x, y, 7, 255).
pub(crate) fn png(width: u32, height: u32) -> Vec<u8> {
    let image = image::RgbaImage::from_fn(width, height, |x, y| {
        image::Rgba([x as u8, y as u8, 7, 255])
    });
    let mut bytes = std::io::Cursor::new(Vec::new());
    image.write_to(&mut bytes, image::ImageFormat::Png).unwrap();
    bytes.into_inner()
}

/// Bytes of little-endian `f32`s.
fn floats(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// A unit square of two triangles, textured and coloured, placed by a
/// parent node (translation 10 along x) and a child (scale 2), with a PNG in
/// the binary chunk. Returns the document and its binary chunk.
fn textured_square() -> (Value, Vec<u8>) {
    let mut bin = floats(&[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.]); // 0..48
    bin.extend(floats(&[0., 1., 1., 1., 1., 0., 0., 0.])); // 48..80 uv
    bin.extend([
        255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 128, 255, 255, 255, 255,
    ]); // 80..96
    bin.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes())); // 96..108
    bin.extend([0, 0, 0, 0]); // 108..112
    let image = png(4, 2);
    let image_len = image.len();
    bin.extend(image);
    let document = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [
            {"translation": [10.0, 0.0, 0.0], "children": [1]},
            {"scale": [2.0, 2.0, 2.0], "mesh": 0}
        ],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": 0, "TEXCOORD_0": 1, "COLOR_0": 2, "NORMAL": 0},
            "indices": 3,
            "material": 0
        }]}],
        "materials": [{
            "name": "paint",
            "pbrMetallicRoughness": {
                "baseColorFactor": [1.0, 0.21586, 0.0, 0.5],
                "baseColorTexture": {"index": 0}
            },
            "normalTexture": {"index": 0}
        }],
        "textures": [{"source": 0}],
        "images": [{"bufferView": 4, "mimeType": "image/png"}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5121, "normalized": true, "count": 4, "type": "VEC4"},
            {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 32},
            {"buffer": 0, "byteOffset": 80, "byteLength": 16},
            {"buffer": 0, "byteOffset": 96, "byteLength": 12},
            {"buffer": 0, "byteOffset": 112, "byteLength": image_len}
        ],
        "buffers": [{"byteLength": bin.len()}]
    });
    (document, bin)
}

fn read_glb(bytes: &[u8], images: bool) -> Result<Asset, MeshError> {
    let options = AssetOptions::DEFAULT.with_images(images);
    read_asset_bytes(bytes, Format::Glb, "t.glb", &options)
}

fn err(document: &Value, bin: &[u8]) -> String {
    read_glb(&glb(document, bin), false)
        .expect_err("malformed input must be refused")
        .to_string()
}

#[test]
fn round_trip_of_positions_uvs_colours_and_material() {
    let (document, bin) = textured_square();
    let bytes = glb(&document, &bin);
    let asset = read_glb(&bytes, true).unwrap();
    let mesh = &asset.mesh;
    let expected = [[10., 0., 0.], [12., 0., 0.], [12., 2., 0.], [10., 2., 0.]];
    let positions: Vec<[f64; 3]> = mesh.positions.iter().map(|p| p.to_array()).collect();
    assert_eq!(positions, expected, "parent translation after child scale");
    assert_eq!(mesh.face(0), [0, 1, 2]);
    assert_eq!(mesh.face(1), [0, 2, 3]);
    let uv = asset.tex_coords.as_ref().unwrap();
    let corners: Vec<[f32; 2]> = (0..6).map(|c| uv.get(c).unwrap()).collect();
    assert_eq!(
        corners,
        [[0., 1.], [1., 1.], [1., 0.], [0., 1.], [1., 0.], [0., 0.]]
    );
    let colors = asset.colors.as_ref().unwrap();
    assert_eq!(colors[0], [1.0, 0.0, 0.0, 1.0]);
    assert!(
        (colors[2][3] - 128.0 / 255.0).abs() < 1e-6,
        "alpha stays linear"
    );
    let material = &asset.materials[0];
    assert_eq!(material.name, "paint");
    let [r, g, b, a] = material.base_color;
    assert!((r - 1.0).abs() < 1e-6 && (g - 128.0 / 255.0).abs() < 1e-3 && b == 0.0 && a == 0.5);
    let texture = material.base_color_texture.as_ref().unwrap();
    assert!(
        matches!(&texture.source, ImageSource::Embedded { mime_type: Some(m), .. } if m == "image/png")
    );
    let image = texture.image.as_ref().unwrap();
    assert_eq!((image.width, image.height), (4, 2));
    assert_eq!(&image.rgba[4 * 5..4 * 6], [1, 1, 7, 255], "pixel (1, 1)");
    assert_eq!(asset.face_materials, None, "one material");
    let kinds: Vec<Kind> = asset.dropped.iter().map(|d| d.kind).collect();
    assert_eq!(kinds, [Kind::Normals, Kind::OtherMaps]);
    assert_eq!(asset.dropped[0].count, 4);

    // Geometry alone is the same mesh, and images are decoded only on demand.
    assert_eq!(
        read_mesh_bytes(&bytes, Format::Glb, "t.glb").unwrap(),
        *mesh
    );
    let located = read_glb(&bytes, false).unwrap();
    let texture = located.materials[0].base_color_texture.as_ref().unwrap();
    assert!(texture.image.is_none());
}

#[test]
fn sniffing_and_extensions() {
    let (document, bin) = textured_square();
    assert_eq!(Format::sniff(&glb(&document, &bin)), Some(Format::Glb));
    assert_eq!(
        Format::sniff(b"  {\"asset\": {\"version\": \"2.0\"}}"),
        Some(Format::Gltf)
    );
    assert_eq!(
        Format::from_path(std::path::Path::new("a.GLB")),
        Some(Format::Glb)
    );
    assert_eq!(
        Format::from_path(std::path::Path::new("a.gltf")),
        Some(Format::Gltf)
    );
}

/// A document of one mesh whose primitives are given, over `positions`
/// (accessor 0) and `indices` (accessor 1, `u32`), with `nodes`.
fn indexed(
    positions: &[f32],
    indices: &[u32],
    primitives: Value,
    nodes: Value,
) -> (Value, Vec<u8>) {
    let mut bin = floats(positions);
    let split = bin.len();
    bin.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    let document = json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": (0..nodes.as_array().unwrap().len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": [{"primitives": primitives}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": positions.len() / 3, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 1]},
            {"bufferView": 1, "componentType": 5125, "count": indices.len(), "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": split},
            {"buffer": 0, "byteOffset": split, "byteLength": bin.len() - split}
        ],
        "buffers": [{"byteLength": bin.len()}]
    });
    (document, bin)
}

const STRIP: [f32; 15] = [0., 0., 0., 1., 0., 0., 0., 1., 0., 1., 1., 0., 0., 2., 0.];

#[test]
fn strips_and_fans_become_triangles_and_lines_are_reported() {
    let primitives = json!([
        {"attributes": {"POSITION": 0}, "indices": 1, "mode": 5},
        {"attributes": {"POSITION": 0}, "indices": 1, "mode": 6},
        {"attributes": {"POSITION": 0}, "indices": 1, "mode": 1}
    ]);
    let (document, bin) = indexed(&STRIP, &[0, 1, 2, 3, 4], primitives, json!([{"mesh": 0}]));
    let asset = read_glb(&glb(&document, &bin), false).unwrap();
    let faces: Vec<&[u32]> = asset.mesh.faces().collect();
    // Strip: (0 1 2), (2 1 3) turned back, (2 3 4); fan: (0 1 2), (0 2 3), (0 3 4).
    assert_eq!(
        faces,
        [
            &[0, 1, 2][..],
            &[2, 1, 3],
            &[2, 3, 4],
            &[0, 1, 2],
            &[0, 2, 3],
            &[0, 3, 4]
        ]
    );
    assert_eq!(
        asset.mesh.positions.len(),
        5,
        "both primitives welded onto one set"
    );
    assert_eq!(asset.dropped[0].kind, Kind::Lines);
    assert_eq!(asset.dropped[0].count, 5);
}

#[test]
fn mirroring_nodes_reverse_windings_and_instances_repeat() {
    let primitives = json!([{"attributes": {"POSITION": 0}, "indices": 1}]);
    let nodes = json!([{"mesh": 0}, {"mesh": 0, "scale": [-1.0, 1.0, 1.0]}]);
    let (document, bin) = indexed(&STRIP[..9], &[0, 1, 2], primitives, nodes);
    let mesh = read_mesh_bytes(&glb(&document, &bin), Format::Glb, "t.glb").unwrap();
    assert_eq!(mesh.face_count(), 2);
    // (0 0 0) and (0 1 0) weld; the mirrored x axis puts (1 0 0) at (-1 0 0).
    assert_eq!(mesh.positions.len(), 4);
    assert_eq!(mesh.positions[3], DVec3::new(-1.0, 0.0, 0.0));
    let normal = |f: &[u32]| {
        let p = |k: usize| mesh.positions[f[k] as usize];
        (p(1) - p(0)).cross(p(2) - p(0)).z
    };
    assert!(
        normal(mesh.face(0)) > 0.0 && normal(mesh.face(1)) > 0.0,
        "both face +z"
    );
}

#[test]
fn unreferenced_vertices_are_left_out() {
    let primitives = json!([{"attributes": {"POSITION": 0}, "indices": 1}]);
    let (document, bin) = indexed(&STRIP, &[4, 3, 2], primitives, json!([{"mesh": 0}]));
    let mesh = read_mesh_bytes(&glb(&document, &bin), Format::Glb, "t.glb").unwrap();
    assert_eq!(mesh.positions.len(), 3);
    assert_eq!(
        mesh.positions[0],
        DVec3::new(0.0, 1.0, 0.0),
        "accessor order kept"
    );
    assert_eq!(mesh.face(0), [2, 1, 0]);
}

#[test]
fn files_beside_a_gltf_and_a_missing_image() {
    let dir = tempfile::tempdir().unwrap();
    let (mut document, bin) = textured_square();
    std::fs::write(dir.path().join("square data.bin"), &bin).unwrap();
    std::fs::create_dir(dir.path().join("tex")).unwrap();
    std::fs::write(dir.path().join("tex/skin.png"), png(3, 3)).unwrap();
    document["buffers"][0]["uri"] = json!("square%20data.bin");
    document["images"] = json!([{"uri": "tex/skin.png"}, {"uri": "tex/missing.png"}]);
    document["textures"] = json!([{"source": 0}, {"source": 1}]);
    let mut second = document["materials"][0].clone();
    second["pbrMetallicRoughness"]["baseColorTexture"]["index"] = json!(1);
    document["materials"] = json!([document["materials"][0].clone(), second]);
    document["meshes"][0]["primitives"] = json!([
        {"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 3, "material": 0},
        {"attributes": {"POSITION": 0}, "indices": 3, "material": 1},
        {"attributes": {"POSITION": 0}, "indices": 3}
    ]);
    let path = dir.path().join("square.gltf");
    std::fs::write(&path, serde_json::to_vec(&document).unwrap()).unwrap();
    let options = AssetOptions::DEFAULT.with_images(true);
    let asset = read_asset(&path, &options).unwrap();
    assert_eq!(asset.mesh.face_count(), 6);
    assert_eq!(
        asset.mesh.positions.len(),
        4,
        "three primitives, one surface"
    );
    let texture = asset.materials[0].base_color_texture.as_ref().unwrap();
    assert_eq!(
        texture.source,
        ImageSource::File(dir.path().join("tex/skin.png"))
    );
    assert_eq!(texture.image.as_ref().unwrap().width, 3);
    assert_eq!(asset.materials[1].base_color_texture, None);
    let missing = asset
        .dropped
        .iter()
        .find(|d| d.kind == Kind::Textures)
        .unwrap();
    assert!(missing.detail.contains("missing.png"), "{missing:?}");
    assert_eq!(asset.materials.len(), 3, "two and the default");
    assert_eq!(asset.face_materials, Some(vec![0, 0, 1, 1, 2, 2]));
    let uv = asset.tex_coords.unwrap();
    assert_eq!(
        uv.corners[6..],
        [TexCoords::NONE; 12],
        "untextured primitives"
    );
    assert_eq!(read_mesh(&path).unwrap(), asset.mesh);

    std::fs::remove_file(dir.path().join("square data.bin")).unwrap();
    let e = read_mesh(&path).unwrap_err().to_string();
    assert!(
        e.contains("square.gltf: cannot read buffer 0") && e.contains("square data.bin"),
        "{e}"
    );
    let e = read_mesh_bytes(
        &serde_json::to_vec(&document).unwrap(),
        Format::Gltf,
        "m.gltf",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("read from memory"), "{e}");
}

#[test]
fn hostile_documents_fail_cleanly() {
    let (document, bin) = textured_square();
    let edit = |path: &[&str], value: Value| {
        let mut d = document.clone();
        let mut at = &mut d;
        for key in path {
            at = match key.parse::<usize>() {
                Ok(k) => &mut at[k],
                Err(_) => &mut at[*key],
            };
        }
        *at = value;
        err(&d, &bin)
    };
    let cases = [
        (
            edit(&["bufferViews", "0", "byteStride"], json!(4)),
            "byte stride 4 below the element size 12",
        ),
        (edit(&["accessors", "0", "count"], json!(0)), "count 0"),
        (
            edit(&["accessors", "0", "count"], json!(4_000_000_000u64)),
            "do not fit",
        ),
        (
            edit(&["accessors", "0", "byteOffset"], json!(40)),
            "do not fit",
        ),
        (
            edit(&["bufferViews", "0", "byteLength"], json!(1 << 30)),
            "outside its buffer",
        ),
        (
            edit(&["nodes", "1", "children"], json!([0])),
            "reached twice",
        ),
        (
            edit(&["nodes", "1", "scale"], json!([1e39, 1.0, 1.0])),
            "not finite",
        ),
        (
            edit(&["accessors"], json!([])),
            "POSITION is accessor 0, of 0",
        ),
        (
            edit(&["accessors", "3", "componentType"], json!(5126)),
            "indices of type",
        ),
        (
            edit(&["accessors", "0", "type"], json!("VEC2")),
            "expected [Vec3]",
        ),
        (
            edit(
                &["extensionsRequired"],
                json!(["KHR_draco_mesh_compression"]),
            ),
            "KHR_draco_mesh_compression",
        ),
        (
            edit(&["buffers", "0", "byteLength"], json!(1 << 20)),
            "declares 1048576",
        ),
        (
            edit(
                &["buffers", "0", "uri"],
                json!("https://example.invalid/x.bin"),
            ),
            "only relative URIs",
        ),
        (
            edit(
                &["meshes", "0", "primitives", "0", "attributes", "COLOR_0"],
                json!(1),
            ),
            "expected [Vec4]",
        ),
    ];
    for (message, fragment) in cases {
        assert!(message.starts_with("t.glb: "), "{message}");
        assert!(message.contains(fragment), "{message:?} lacks {fragment:?}");
    }
    // Indices past the vertices.
    let mut bad_bin = bin.clone();
    bad_bin[100] = 9;
    assert!(err(&document, &bad_bin).contains("face index 9 out of range (4 vertices)"));
    // The GLB header.
    let mut bytes = glb(&document, &bin);
    bytes[8..12].copy_from_slice(&4u32.to_le_bytes());
    let e = read_glb(&bytes, false).unwrap_err().to_string();
    assert!(e.contains("GLB header declares 4 bytes"), "{e}");
    assert!(read_glb(b"glTF\x02\0\0", false).unwrap_err().is_truncated());
}

#[test]
fn nodes_repeating_a_mesh_are_bounded() {
    let primitives = json!([{"attributes": {"POSITION": 0}, "indices": 1}]);
    let nodes: Vec<Value> = (0..40).map(|_| json!({"mesh": 0})).collect();
    let (mut document, bin) = indexed(&STRIP[..9], &[0, 1, 2], primitives, json!(nodes));
    // Forty placements of a 3-vertex mesh are fine...
    assert!(read_glb(&glb(&document, &bin), false).is_ok());
    // ...but not of a mesh claiming 2^21 vertices, which check before reading.
    document["accessors"][0]["count"] = json!(1 << 21);
    let e = err(&document, &bin);
    assert!(e.contains("vertices once nodes repeat their meshes"), "{e}");
}

/// Structured mutations per run of the test (a longer run:
/// `QM_GLTF_MUTATIONS=200000 cargo test -p qm-io mutated`).
const MUTATIONS: usize = 2000;

#[test]
fn mutated_files_never_panic() {
    let (document, bin) = textured_square();
    let valid = glb(&document, &bin);
    let mut rng = crate::SplitMix64::new(46);
    for _ in 0..3000 {
        let mut bytes = valid.clone();
        for _ in 0..1 + rng.next_u64() % 4 {
            let at = (rng.next_u64() % bytes.len() as u64) as usize;
            bytes[at] = rng.next_u64() as u8;
        }
        let _ = read_glb(&bytes, true);
    }
    // Numbers of the JSON replaced by values at the edges.
    let text = serde_json::to_string(&document).unwrap();
    let numbers: Vec<(usize, usize)> = text
        .char_indices()
        .filter(|&(k, c)| {
            c.is_ascii_digit() && !text[..k].ends_with(|p: char| p.is_ascii_digit() || p == '.')
        })
        .map(|(k, _)| {
            (
                k,
                k + text[k..]
                    .find(|c: char| !c.is_ascii_digit() && c != '.')
                    .unwrap_or(0),
            )
        })
        .collect();
    let edges = [
        "0",
        "1",
        "2",
        "3",
        "4",
        "7",
        "255",
        "4294967295",
        "18446744073709551615",
        "1e39",
        "0.5",
        "65536",
        "-1",
    ];
    let runs = std::env::var("QM_GLTF_MUTATIONS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(MUTATIONS);
    let mut rng = crate::SplitMix64::new(48);
    for _ in 0..runs {
        let mut mutated = text.clone();
        for _ in 0..1 + rng.next_u64() % 3 {
            let (start, end) = numbers[rng.below(numbers.len())];
            if end <= mutated.len()
                && mutated.is_char_boundary(start)
                && mutated.is_char_boundary(end)
            {
                let edge = edges[rng.below(edges.len())];
                mutated.replace_range(start..end, &format!("{edge:<width$}", width = end - start));
            }
        }
        let Ok(value) = serde_json::from_str::<Value>(&mutated) else {
            continue;
        };
        let _ = read_glb(&glb(&value, &bin), true);
    }
    let mut rng = crate::SplitMix64::new(47);
    for _ in 0..300 {
        let cut = (rng.next_u64() % valid.len() as u64) as usize;
        let _ = read_glb(&valid[..cut], true);
    }
}

#[test]
fn quantized_positions_and_appearance_only_extensions() {
    // KHR_mesh_quantization: u16 positions every 8 bytes.
    let mut bin: Vec<u8> = [[0u16, 0, 0, 0], [2, 0, 0, 0], [0, 2, 0, 0]]
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    bin.extend([0u32, 1, 2].iter().flat_map(|i| i.to_le_bytes()));
    let document = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_mesh_quantization", "KHR_texture_transform"],
        "extensionsRequired": ["KHR_mesh_quantization", "KHR_texture_transform"],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5123, "count": 3, "type": "VEC3",
             "min": [0, 0, 0], "max": [2, 2, 0]},
            {"bufferView": 1, "componentType": 5125, "count": 3, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 24, "byteStride": 8},
            {"buffer": 0, "byteOffset": 24, "byteLength": 12}
        ],
        "buffers": [{"byteLength": 36}]
    });
    let asset = read_glb(&glb(&document, &bin), false).unwrap();
    assert_eq!(
        asset.mesh.positions[2],
        DVec3::new(0.0, 2.0, 0.0),
        "no scene: each mesh once"
    );
    let extensions = asset
        .dropped
        .iter()
        .find(|d| d.kind == Kind::Extensions)
        .unwrap();
    assert_eq!(
        extensions.detail,
        "glTF extensions KHR_texture_transform (not read)"
    );
}
