//! glTF 2.0, as JSON (`.gltf`) or binary (`.glb`).
//!
//! The `gltf` crate parses and validates the document and splits a GLB into
//! its chunks; this module reads the buffers, the accessors and the images
//! itself. The crate's accessor reader is not used because hostile files
//! make it panic: a `byteStride` smaller than the element, an accessor of
//! count 0 (an overflow under debug assertions), sparse values that run out;
//! and its GLB header check underflows on a length below 12, so that is
//! checked here first.
//!
//! Geometry: every mesh primitive of the default scene (else the first
//! scene; with no scene, every mesh once), each node's transform applied
//! (windings reversed under a mirroring transform), merged into one mesh.
//! Triangle strips and fans become triangles (strip triangles with a
//! repeated corner dropped, as for PLY); point and line primitives are
//! reported. Only the vertices a primitive's triangles use are taken, and
//! vertices whose transformed positions are bit-identical are welded: glTF
//! splits a vertex wherever any attribute differs (every texture seam, every
//! material border), which would cut a connected surface into pieces
//! (docs/decisions/032-appearance-readers.md).
//! `POSITION` may be of any component type (`KHR_mesh_quantization`); sparse
//! accessors are refused.
//!
//! Appearance: `TEXCOORD_0` (per corner, so welding loses none), `COLOR_0`
//! (per vertex, linear to sRGB; a welded vertex keeps its first colour and
//! disagreements are reported), materials' `baseColorFactor` and
//! `baseColorTexture` (a GLB buffer view, a `data:` URI or a file beside the
//! glTF). Normals, tangents, further sets, skinning, morph targets,
//! animations, other maps and unread extensions are reported.
//!
//! Limits: accessor ranges are checked against their buffer views and
//! buffers before anything is read, so reading allocates in proportion to
//! the input; nodes that repeat meshes may multiply that, up to
//! [`MAX_INSTANCED`] vertices.

use std::collections::HashMap;
use std::path::PathBuf;

use base64::Engine as _;
use glam::{DMat4, DVec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use gltf::{Document, Semantic};

use super::{MAX_VERTICES, MeshBuilder, MeshError, Problem, Source};
use crate::asset::{self, add_dropped, linear_to_srgb};
use crate::{Asset, AttributeKind as Kind, Dropped, ImageSource, Material, TexCoords};

/// The most vertices the merged mesh may have where nodes repeat meshes
/// beyond what the file stores (2^26: 1.5 GiB of positions).
pub(crate) const MAX_INSTANCED: u64 = 1 << 26;

/// Required extensions this reader handles.
const SUPPORTED: [&str; 1] = ["KHR_mesh_quantization"];

/// Prefixes of extensions that change only how a surface looks: required
/// or not, the geometry reads without them (they are reported).
const APPEARANCE_ONLY: [&str; 4] = [
    "KHR_materials_",
    "KHR_texture_",
    "EXT_texture_",
    "KHR_lights_",
];

/// Whether text starts like a glTF JSON document.
pub(super) fn looks_like_gltf_json(bytes: &[u8]) -> bool {
    let head = &bytes[..bytes.len().min(4096)];
    head.trim_ascii_start().starts_with(b"{") && head.windows(7).any(|w| w == b"\"asset\"")
}

pub(super) fn read(bytes: &[u8], source: &Source) -> Result<Asset, MeshError> {
    let fail = |problem| MeshError::malformed(source.name, None, problem);
    if bytes.starts_with(b"glTF") {
        check_glb_header(bytes).map_err(fail)?;
    }
    let invalid = |e: gltf::Error| {
        let message = e.to_string();
        let message = match message.strip_prefix("invalid glTF: ") {
            Some(rest) => format!("invalid glTF: {rest}"),
            None => format!("invalid glTF: {message}"),
        };
        fail(Problem::Syntax(message))
    };
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice_without_validation(bytes).map_err(invalid)?;
    // gltf-json's validation indexes the accessors with a primitive's
    // POSITION before it checks that index (a panic): checked here first.
    let mut root = document.into_json();
    // Required extensions that change only appearance are reported later
    // (they are in `extensionsUsed` too); one that changes the geometry
    // cannot be read around. The crate refuses all it does not know, so
    // the list is emptied before its validation.
    if let Some(ext) = root.extensions_required.iter().find(|e| {
        !SUPPORTED.contains(&e.as_str()) && !APPEARANCE_ONLY.iter().any(|p| e.starts_with(p))
    }) {
        let what = format!("glTF extension {ext} (required by the file)");
        return Err(fail(Problem::Unsupported(what)));
    }
    root.extensions_required.clear();
    let accessors = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position = gltf::json::validation::Checked::Valid(Semantic::Positions);
            if let Some(index) = primitive.attributes.get(&position) {
                if index.value() >= accessors {
                    return Err(fail(Problem::Syntax(format!(
                        "mesh {m}, primitive {p}: POSITION is accessor {}, of {accessors}",
                        index.value()
                    ))));
                }
            }
        }
    }
    let document = gltf::Document::from_json(root).map_err(invalid)?;
    let owned = load_buffers(&document, source)?;
    let buffers: Vec<&[u8]> = owned
        .iter()
        .map(|b| match b {
            Some(data) => data.as_slice(),
            None => blob.as_deref().unwrap_or_default(),
        })
        .collect();
    for (buffer, data) in document.buffers().zip(&buffers) {
        if (data.len() as u64) < buffer.length() as u64 {
            let what = format!(
                "buffer {} holds {} bytes but declares {}",
                buffer.index(),
                data.len(),
                buffer.length()
            );
            return Err(fail(Problem::Truncated { what }));
        }
    }
    let reader = Reader {
        document: &document,
        buffers: &buffers,
    };
    reader.read(source).map_err(fail)
}

/// The GLB header: magic, version 2, and a length the file holds.
fn check_glb_header(bytes: &[u8]) -> Result<(), Problem> {
    let Some(header) = bytes.get(..12) else {
        return Err(Problem::Truncated {
            what: "the GLB header".into(),
        });
    };
    let word =
        |k: usize| u32::from_le_bytes([header[k], header[k + 1], header[k + 2], header[k + 3]]);
    if word(4) != 2 {
        return Err(Problem::Unsupported(format!("GLB version {}", word(4))));
    }
    let length = word(8) as usize;
    if length < 12 || length > bytes.len() {
        return Err(Problem::Syntax(format!(
            "GLB header declares {length} bytes, the file has {}",
            bytes.len()
        )));
    }
    Ok(())
}

/// Each buffer's bytes; `None` for the GLB's binary chunk.
fn load_buffers(document: &Document, source: &Source) -> Result<Vec<Option<Vec<u8>>>, MeshError> {
    let resource = |what: String, cause: String| {
        MeshError::malformed(source.name, None, Problem::Resource { what, cause })
    };
    let mut buffers = Vec::new();
    for buffer in document.buffers() {
        let what = || format!("buffer {}", buffer.index());
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => None,
            gltf::buffer::Source::Uri(uri) => Some(match data_uri(uri) {
                Some(decoded) => decoded.map_err(|cause| resource(what(), cause))?,
                None => {
                    let path = file_uri(uri, source)
                        .map_err(|cause| resource(format!("{} {uri:?}", what()), cause))?;
                    std::fs::read(&path).map_err(|e| {
                        resource(format!("{} {}", what(), path.display()), e.to_string())
                    })?
                }
            }),
        };
        buffers.push(data);
    }
    Ok(buffers)
}

/// The bytes of a `data:` URI (base64 only); `None` for any other URI.
fn data_uri(uri: &str) -> Option<Result<Vec<u8>, String>> {
    let rest = uri.strip_prefix("data:")?;
    Some(match rest.split_once(',') {
        Some((header, data)) if header.ends_with(";base64") => {
            base64::engine::general_purpose::STANDARD
                .decode(data)
                .map_err(|e| format!("invalid base64 in a data: URI ({e})"))
        }
        _ => Err("a data: URI that is not base64".into()),
    })
}

/// The path of a relative URI, resolved against the glTF's folder.
fn file_uri(uri: &str, source: &Source) -> Result<PathBuf, String> {
    let scheme = uri.split_once(':').map(|(s, _)| s);
    if uri.starts_with('/') || scheme.is_some_and(|s| s.len() > 1 && !s.contains('/')) {
        return Err("only relative URIs and data: URIs are read".into());
    }
    let Some(folder) = source.folder else {
        return Err("a file beside the glTF, which is read from memory".into());
    };
    Ok(asset::resolve(folder, &percent_decode(uri)))
}

/// Decodes `%XX` escapes (URIs name files with spaces as `%20`).
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut k = 0;
    while k < bytes.len() {
        let hex = bytes
            .get(k + 1..k + 3)
            .and_then(|h| std::str::from_utf8(h).ok())
            .and_then(|h| u8::from_str_radix(h, 16).ok());
        match (bytes[k], hex) {
            (b'%', Some(byte)) => {
                out.push(byte);
                k += 3;
            }
            (byte, _) => {
                out.push(byte);
                k += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// One placement of a mesh in the scene.
struct Instance {
    mesh: usize,
    transform: DMat4,
}

/// What one primitive instance adds, before it is merged.
struct Part {
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    colors: Option<Vec<[f32; 4]>>,
    tex_coords: Option<Vec<[f32; 2]>>,
    material: Option<usize>,
}

struct Reader<'a> {
    document: &'a Document,
    buffers: &'a [&'a [u8]],
}

impl Reader<'_> {
    fn read(&self, source: &Source) -> Result<Asset, Problem> {
        let appearance = source.appearance.is_some();
        let instances = self.instances()?;
        self.check_sizes(&instances)?;
        let mut dropped = Vec::new();
        let mut builder = MeshBuilder::with_capacity(0);
        let mut weld: HashMap<[u64; 3], u32> = HashMap::new();
        let mut colors: Vec<Option<[f32; 4]>> = Vec::new();
        let mut any_color = false;
        let mut color_conflicts = 0u64;
        let mut uv_values: Vec<[f32; 2]> = Vec::new();
        let mut uv_corners: Vec<u32> = Vec::new();
        let mut any_uv = false;
        let mut face_materials: Vec<Option<usize>> = Vec::new();
        for instance in &instances {
            let mesh = self
                .document
                .meshes()
                .nth(instance.mesh)
                .ok_or_else(|| Problem::Syntax(format!("no mesh {}", instance.mesh)))?;
            for primitive in mesh.primitives() {
                let at = |p: Problem| {
                    Problem::Syntax(format!(
                        "mesh {}, primitive {}: {p}",
                        mesh.index(),
                        primitive.index()
                    ))
                };
                let Some(part) = self
                    .part(&primitive, instance, appearance, &mut dropped)
                    .map_err(at)?
                else {
                    continue;
                };
                // Welded vertex of each of the part's vertices.
                let mut global = Vec::with_capacity(part.positions.len());
                for (k, p) in part.positions.iter().enumerate() {
                    // Adding 0.0 turns -0.0 into 0.0, so both weld.
                    let key = (*p + DVec3::ZERO).to_array().map(f64::to_bits);
                    let index = match weld.get(&key) {
                        Some(&index) => index,
                        None => {
                            let index = builder.vertex_count() as u32;
                            builder.push_position(*p).map_err(at)?;
                            weld.insert(key, index);
                            colors.push(None);
                            index
                        }
                    };
                    if let Some(part_colors) = &part.colors {
                        any_color = true;
                        let slot = &mut colors[index as usize];
                        match slot {
                            None => *slot = Some(part_colors[k]),
                            Some(c) if *c != part_colors[k] => color_conflicts += 1,
                            Some(_) => {}
                        }
                    }
                    global.push(index);
                }
                for triangle in &part.triangles {
                    let corners = triangle.map(|k| global[k as usize]);
                    builder.push_face(&corners).map_err(at)?;
                    face_materials.push(part.material);
                    if appearance {
                        for k in triangle {
                            match &part.tex_coords {
                                Some(uv) => {
                                    any_uv = true;
                                    uv_corners.push(uv_values.len() as u32);
                                    uv_values.push(uv[*k as usize]);
                                }
                                None => uv_corners.push(TexCoords::NONE),
                            }
                        }
                    }
                }
            }
        }
        let mesh = builder.finish()?;
        let mut asset = Asset::of(mesh);
        if !appearance {
            return Ok(asset);
        }
        let options = source.appearance.copied().unwrap_or_default();
        if any_color {
            // Vertices of primitives without COLOR_0 are white: the colour
            // multiplies the material's (glTF 2.0 spec, 3.7.2.1).
            asset.colors = Some(colors.into_iter().map(|c| c.unwrap_or([1.0; 4])).collect());
            if color_conflicts > 0 {
                let detail = "welded vertices with another colour than the first (kept)".to_owned();
                add_dropped(&mut dropped, Kind::VertexColors, color_conflicts, detail);
            }
        }
        if any_uv {
            asset.tex_coords = Some(TexCoords {
                values: uv_values,
                corners: uv_corners,
            });
        }
        self.materials(&mut asset, &face_materials, source, &options, &mut dropped);
        self.report_document(&mut dropped);
        asset.dropped = dropped;
        Ok(asset)
    }

    /// The mesh placements of the scene, each with its world transform.
    fn instances(&self) -> Result<Vec<Instance>, Problem> {
        let Some(scene) = self
            .document
            .default_scene()
            .or_else(|| self.document.scenes().next())
        else {
            return Ok((0..self.document.meshes().count())
                .map(|mesh| Instance {
                    mesh,
                    transform: DMat4::IDENTITY,
                })
                .collect());
        };
        let mut seen = vec![false; self.document.nodes().count()];
        let mut stack: Vec<(gltf::Node, DMat4)> =
            scene.nodes().map(|n| (n, DMat4::IDENTITY)).collect();
        let mut instances = Vec::new();
        while let Some((node, parent)) = stack.pop() {
            // The node hierarchy must be a forest; a cycle would never end.
            if std::mem::replace(&mut seen[node.index()], true) {
                return Err(Problem::Syntax(format!(
                    "node {} is reached twice from scene {} (nodes must form trees)",
                    node.index(),
                    scene.index()
                )));
            }
            let local = node.transform().matrix().map(|c| c.map(f64::from));
            let transform = parent * DMat4::from_cols_array_2d(&local);
            if !transform.is_finite() {
                return Err(Problem::Syntax(format!(
                    "node {} has a transform that is not finite",
                    node.index()
                )));
            }
            if let Some(mesh) = node.mesh() {
                instances.push(Instance {
                    mesh: mesh.index(),
                    transform,
                });
            }
            stack.extend(node.children().map(|c| (c, transform)));
        }
        // The stack visits children last-first; file order is friendlier.
        instances.reverse();
        Ok(instances)
    }

    /// Refuses, before anything is allocated, a scene whose merged mesh
    /// would exceed the index limits or repeat meshes beyond
    /// [`MAX_INSTANCED`] vertices.
    fn check_sizes(&self, instances: &[Instance]) -> Result<(), Problem> {
        let vertices_of = |mesh: &gltf::Mesh| -> u64 {
            mesh.primitives()
                .filter_map(|p| p.get(&Semantic::Positions))
                .map(|a| a.count() as u64)
                .sum()
        };
        let stored: u64 = self.document.meshes().map(|m| vertices_of(&m)).sum();
        let mut placed = 0u64;
        let mut corners = 0u64;
        for instance in instances {
            let Some(mesh) = self.document.meshes().nth(instance.mesh) else {
                continue;
            };
            placed = placed.saturating_add(vertices_of(&mesh));
            for p in mesh.primitives() {
                let n = match p.indices() {
                    Some(indices) => indices.count() as u64,
                    None => p.get(&Semantic::Positions).map_or(0, |a| a.count() as u64),
                };
                let n = match p.mode() {
                    Mode::Triangles => n,
                    // A strip or fan of n indices has n - 2 triangles.
                    Mode::TriangleStrip | Mode::TriangleFan => {
                        n.saturating_sub(2).saturating_mul(3)
                    }
                    _ => 0,
                };
                corners = corners.saturating_add(n);
            }
        }
        if placed > MAX_VERTICES {
            return Err(Problem::TooMany {
                what: "vertices",
                count: placed,
                max: MAX_VERTICES,
            });
        }
        let max = stored.max(MAX_INSTANCED);
        if placed > max {
            return Err(Problem::TooMany {
                what: "vertices once nodes repeat their meshes",
                count: placed,
                max,
            });
        }
        if corners > u64::from(u32::MAX) {
            return Err(Problem::TooMany {
                what: "face corners",
                count: corners,
                max: u32::MAX.into(),
            });
        }
        Ok(())
    }

    /// Reads one primitive of one instance; `None` for a primitive that has
    /// no triangles (points, lines), which is reported.
    fn part(
        &self,
        primitive: &gltf::Primitive,
        instance: &Instance,
        appearance: bool,
        dropped: &mut Vec<Dropped>,
    ) -> Result<Option<Part>, Problem> {
        let mode = primitive.mode();
        let position = primitive
            .get(&Semantic::Positions)
            .ok_or_else(|| Problem::Syntax("no POSITION attribute".into()))?;
        let not_surface = match mode {
            Mode::Points => Some((Kind::Points, "point")),
            Mode::Lines | Mode::LineLoop | Mode::LineStrip => Some((Kind::Lines, "line")),
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan => None,
        };
        if let Some((kind, what)) = not_surface {
            let count = position.count() as u64;
            let detail = format!("vertices of {what} primitives ({mode:?})");
            add_dropped(dropped, kind, count, detail);
            return Ok(None);
        }
        // Read (and so bounded by the input) before anything is sized by
        // the accessor's declared count.
        let xyz = self.vectors::<3>(&position, &[Dimensions::Vec3])?;
        let count = xyz.len();
        let indices: Vec<u32> = match primitive.indices() {
            Some(accessor) => {
                if !matches!(
                    accessor.data_type(),
                    DataType::U8 | DataType::U16 | DataType::U32
                ) || accessor.dimensions() != Dimensions::Scalar
                {
                    return Err(Problem::Syntax(format!(
                        "indices of type {:?} {:?}",
                        accessor.dimensions(),
                        accessor.data_type()
                    )));
                }
                let values = self.values(&accessor)?;
                let mut indices = Vec::with_capacity(values.len());
                for v in values {
                    let index = v as u32;
                    if index as usize >= count {
                        return Err(Problem::IndexOutOfRange {
                            index: index.into(),
                            vertices: count,
                        });
                    }
                    indices.push(index);
                }
                indices
            }
            None => (0..count as u32).collect(),
        };
        let mirrored = instance.transform.determinant() < 0.0;
        let mut triangles = triangles(mode, &indices);
        if mirrored {
            for t in &mut triangles {
                t.swap(1, 2);
            }
        }
        // Only the vertices the triangles use, in accessor order.
        let mut used = vec![u32::MAX; count];
        for t in &triangles {
            for &v in t {
                used[v as usize] = 0;
            }
        }
        let mut kept = Vec::new();
        for (v, slot) in used.iter_mut().enumerate() {
            if *slot == 0 {
                *slot = kept.len() as u32;
                kept.push(v);
            }
        }
        for t in &mut triangles {
            *t = t.map(|v| used[v as usize]);
        }
        let positions = kept
            .iter()
            .map(|&v| {
                instance
                    .transform
                    .transform_point3(DVec3::from_array(xyz[v]))
            })
            .collect();
        let mut part = Part {
            positions,
            triangles,
            colors: None,
            tex_coords: None,
            material: primitive.material().index(),
        };
        if appearance {
            self.attributes(primitive, &kept, &mut part, dropped)?;
        }
        Ok(Some(part))
    }

    /// Reads `COLOR_0` and `TEXCOORD_0` of the kept vertices and lists the
    /// attributes that are not read.
    fn attributes(
        &self,
        primitive: &gltf::Primitive,
        kept: &[usize],
        part: &mut Part,
        dropped: &mut Vec<Dropped>,
    ) -> Result<(), Problem> {
        for (semantic, accessor) in primitive.attributes() {
            let count = accessor.count() as u64;
            let (kind, what) = match semantic {
                Semantic::Positions => continue,
                Semantic::Colors(0) => {
                    let rgba = match accessor.dimensions() {
                        Dimensions::Vec3 => self
                            .vectors::<3>(&accessor, &[Dimensions::Vec3])?
                            .into_iter()
                            .map(|[r, g, b]| [r, g, b, 1.0])
                            .collect(),
                        _ => self.vectors::<4>(&accessor, &[Dimensions::Vec4])?,
                    };
                    check_length(&rgba, kept)?;
                    part.colors = Some(
                        kept.iter()
                            .map(|&v| {
                                let [r, g, b, a] = rgba[v].map(|c| c as f32);
                                [
                                    linear_to_srgb(r),
                                    linear_to_srgb(g),
                                    linear_to_srgb(b),
                                    a.clamp(0.0, 1.0),
                                ]
                            })
                            .collect(),
                    );
                    continue;
                }
                Semantic::TexCoords(0) => {
                    let uv = self.vectors::<2>(&accessor, &[Dimensions::Vec2])?;
                    check_length(&uv, kept)?;
                    part.tex_coords = Some(kept.iter().map(|&v| uv[v].map(|c| c as f32)).collect());
                    continue;
                }
                Semantic::Normals => (
                    Kind::Normals,
                    "NORMAL per vertex (qm computes normals from the surface)".to_owned(),
                ),
                Semantic::Tangents => (Kind::Tangents, "TANGENT per vertex".to_owned()),
                Semantic::Colors(n) => (Kind::VertexColors, format!("COLOR_{n} per vertex")),
                Semantic::TexCoords(n) => {
                    (Kind::ExtraTexCoords, format!("TEXCOORD_{n} per vertex"))
                }
                Semantic::Joints(n) => (Kind::Skinning, format!("JOINTS_{n} per vertex")),
                Semantic::Weights(n) => (Kind::Skinning, format!("WEIGHTS_{n} per vertex")),
                other => (
                    Kind::Properties,
                    format!("{} per vertex", other.to_string()),
                ),
            };
            add_dropped(dropped, kind, count, what);
        }
        let targets = primitive.morph_targets().count() as u64;
        if targets > 0 {
            add_dropped(dropped, Kind::MorphTargets, targets, "morph targets".into());
        }
        Ok(())
    }

    /// The materials, and the material of each face.
    fn materials(
        &self,
        asset: &mut Asset,
        face_materials: &[Option<usize>],
        source: &Source,
        options: &crate::AssetOptions,
        dropped: &mut Vec<Dropped>,
    ) {
        let mut materials: Vec<Material> = Vec::new();
        for m in self.document.materials() {
            let label = m.name().map_or_else(
                || format!("material {}", m.index().unwrap_or(0)),
                |n| format!("material {n:?}"),
            );
            let pbr = m.pbr_metallic_roughness();
            let [r, g, b, a] = pbr.base_color_factor();
            let texture = pbr.base_color_texture().and_then(|info| {
                if info.tex_coord() != 0 {
                    let detail = format!(
                        "{label}: base colour texture on TEXCOORD_{}",
                        info.tex_coord()
                    );
                    add_dropped(dropped, Kind::ExtraTexCoords, 0, detail);
                }
                let image = info.texture().source();
                let source = self.image_source(&image, source).map_err(|why| {
                    let detail = format!("{label}: image {}: {why}", image.index());
                    add_dropped(dropped, Kind::Textures, 1, detail);
                });
                asset::load_texture(source.ok()?, options, dropped)
            });
            let others = [
                (
                    pbr.metallic_roughness_texture().is_some(),
                    "metallicRoughnessTexture",
                ),
                (m.normal_texture().is_some(), "normalTexture"),
                (m.occlusion_texture().is_some(), "occlusionTexture"),
                (m.emissive_texture().is_some(), "emissiveTexture"),
            ];
            for (present, name) in others {
                if present {
                    add_dropped(dropped, Kind::OtherMaps, 1, format!("{label}: {name}"));
                }
            }
            materials.push(Material {
                name: m.name().unwrap_or_default().to_owned(),
                base_color: [linear_to_srgb(r), linear_to_srgb(g), linear_to_srgb(b), a],
                base_color_texture: texture,
            });
        }
        if materials.is_empty() {
            return;
        }
        if face_materials.iter().any(Option::is_none) {
            // The spec's default material: white.
            materials.push(Material::named(""));
        }
        let fallback = materials.len() - 1;
        if materials.len() > 1 {
            asset.face_materials = Some(
                face_materials
                    .iter()
                    .map(|m| m.unwrap_or(fallback) as u32)
                    .collect(),
            );
        }
        asset.materials = materials;
    }

    /// Where an image's encoded bytes are. (Read from the JSON: the crate's
    /// `Image::source` panics on an image with a buffer view and no MIME
    /// type, or with neither a buffer view nor a URI.)
    fn image_source(&self, image: &gltf::Image, source: &Source) -> Result<ImageSource, String> {
        let json = &self.document.as_json().images[image.index()];
        let mime_type = json.mime_type.as_ref().map(|m| m.0.clone());
        match (&json.buffer_view, &json.uri) {
            (Some(view), _) => {
                let view = self
                    .document
                    .views()
                    .nth(view.value())
                    .ok_or("no such buffer view")?;
                Ok(ImageSource::Embedded {
                    mime_type,
                    bytes: self.view_bytes(&view).map_err(|p| p.to_string())?.to_vec(),
                })
            }
            (None, Some(uri)) => match data_uri(uri) {
                Some(bytes) => Ok(ImageSource::Embedded {
                    mime_type,
                    bytes: bytes?,
                }),
                None => file_uri(uri, source).map(ImageSource::File),
            },
            (None, None) => Err("neither a buffer view nor a URI".into()),
        }
    }

    /// Animations, skins and extensions of the document.
    fn report_document(&self, dropped: &mut Vec<Dropped>) {
        let animations = self.document.animations().count() as u64;
        if animations > 0 {
            let detail = "animations (the rest pose is read)".to_owned();
            add_dropped(dropped, Kind::Animations, animations, detail);
        }
        let skins = self.document.skins().count() as u64;
        if skins > 0 {
            add_dropped(dropped, Kind::Skinning, skins, "skins".into());
        }
        let unread: Vec<&str> = self
            .document
            .extensions_used()
            .filter(|e| !SUPPORTED.contains(e))
            .collect();
        if !unread.is_empty() {
            let detail = format!("glTF extensions {} (not read)", unread.join(", "));
            add_dropped(dropped, Kind::Extensions, unread.len() as u64, detail);
        }
    }

    /// The bytes of a buffer view, checked against its buffer.
    fn view_bytes(&self, view: &gltf::buffer::View) -> Result<&[u8], Problem> {
        let data = self
            .buffers
            .get(view.buffer().index())
            .copied()
            .unwrap_or_default();
        view.offset()
            .checked_add(view.length())
            .and_then(|end| data.get(view.offset()..end))
            .ok_or_else(|| {
                Problem::Syntax(format!(
                    "buffer view {} ({} bytes at {}) is outside its buffer of {} bytes",
                    view.index(),
                    view.length(),
                    view.offset(),
                    data.len()
                ))
            })
    }

    /// An accessor's values as `N`-vectors; its dimensions must be one of
    /// `allowed`.
    fn vectors<const N: usize>(
        &self,
        accessor: &gltf::Accessor,
        allowed: &[Dimensions],
    ) -> Result<Vec<[f64; N]>, Problem> {
        if !allowed.contains(&accessor.dimensions()) {
            return Err(Problem::Syntax(format!(
                "accessor {} is {:?}, expected {allowed:?}",
                accessor.index(),
                accessor.dimensions()
            )));
        }
        let flat = self.values(accessor)?;
        Ok(flat
            .chunks_exact(N)
            .map(|c| std::array::from_fn(|k| c[k]))
            .collect())
    }

    /// An accessor's components as `f64`, normalized integers mapped to
    /// 0..1 or -1..1 (glTF 2.0 spec, 3.11), after checking its range against
    /// its buffer view and buffer.
    fn values(&self, accessor: &gltf::Accessor) -> Result<Vec<f64>, Problem> {
        let index = accessor.index();
        let bad = |what: String| Problem::Syntax(format!("accessor {index}: {what}"));
        if accessor.sparse().is_some() {
            return Err(Problem::Unsupported(format!("sparse accessor {index}")));
        }
        let Some(view) = accessor.view() else {
            return Err(bad("no buffer view".into()));
        };
        let dims = accessor.dimensions().multiplicity();
        let size = accessor.data_type().size();
        let element = size * dims;
        let count = accessor.count();
        let stride = view.stride().unwrap_or(element);
        if count == 0 {
            return Err(bad("count 0".into()));
        }
        if stride < element {
            return Err(bad(format!(
                "byte stride {stride} below the element size {element}"
            )));
        }
        let data = self.view_bytes(&view)?;
        let end = (count as u64 - 1)
            .checked_mul(stride as u64)
            .and_then(|v| v.checked_add(accessor.offset() as u64 + element as u64));
        if end.is_none_or(|end| end > data.len() as u64) {
            return Err(bad(format!(
                "{count} elements of {element} bytes every {stride} from {} do not fit its buffer view of {} bytes",
                accessor.offset(),
                data.len()
            )));
        }
        let normalized = accessor.normalized();
        let data_type = accessor.data_type();
        let mut values = Vec::with_capacity(count * dims);
        for k in 0..count {
            let start = accessor.offset() + k * stride;
            for c in 0..dims {
                let at = start + c * size;
                values.push(component(&data[at..at + size], data_type, normalized));
            }
        }
        if let Some(v) = values.iter().find(|v| !v.is_finite()) {
            return Err(bad(format!("value {v} is not finite")));
        }
        Ok(values)
    }
}

/// Checks that an attribute has a value for every vertex kept.
fn check_length<T>(values: &[T], kept: &[usize]) -> Result<(), Problem> {
    match kept.last() {
        Some(&last) if last >= values.len() => Err(Problem::Syntax(format!(
            "an attribute has {} values, vertex {last} needs one",
            values.len()
        ))),
        _ => Ok(()),
    }
}

/// One little-endian component.
fn component(bytes: &[u8], data_type: DataType, normalized: bool) -> f64 {
    let b = |k: usize| bytes[k];
    match data_type {
        DataType::I8 => {
            let v = f64::from(b(0) as i8);
            if normalized { (v / 127.0).max(-1.0) } else { v }
        }
        DataType::U8 => {
            let v = f64::from(b(0));
            if normalized { v / 255.0 } else { v }
        }
        DataType::I16 => {
            let v = f64::from(i16::from_le_bytes([b(0), b(1)]));
            if normalized {
                (v / 32767.0).max(-1.0)
            } else {
                v
            }
        }
        DataType::U16 => {
            let v = f64::from(u16::from_le_bytes([b(0), b(1)]));
            if normalized { v / 65535.0 } else { v }
        }
        DataType::U32 => {
            let v = f64::from(u32::from_le_bytes([b(0), b(1), b(2), b(3)]));
            if normalized {
                v / f64::from(u32::MAX)
            } else {
                v
            }
        }
        DataType::F32 => f64::from(f32::from_le_bytes([b(0), b(1), b(2), b(3)])),
    }
}

/// The triangles of a primitive's index list in `mode` (a triangle mode).
/// Strips alternate their orientation back (as PLY strips) and lose their
/// degenerate joining triangles; fans turn around their first vertex.
fn triangles(mode: Mode, indices: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::TriangleStrip => indices
            .windows(3)
            .enumerate()
            .map(|(k, w)| {
                if k % 2 == 0 {
                    [w[0], w[1], w[2]]
                } else {
                    [w[1], w[0], w[2]]
                }
            })
            .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
            .collect(),
        Mode::TriangleFan => match indices.split_first() {
            Some((&hub, rest)) => rest.windows(2).map(|w| [hub, w[0], w[1]]).collect(),
            None => Vec::new(),
        },
        _ => indices
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect(),
    }
}

#[cfg(test)]
pub(crate) mod tests;
