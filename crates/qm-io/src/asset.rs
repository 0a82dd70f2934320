//! Appearance beside the geometry: per-vertex colours, texture coordinates
//! per face corner, materials with their base colour texture, and the list of
//! what a reader saw in the file but did not keep.
//!
//! Conventions, the same for every format:
//! - Colours are RGBA in 0..1, sRGB-encoded (the space of 8-bit images and of
//!   PLY and OBJ colours); glTF's linear `COLOR_0` and `baseColorFactor` are
//!   converted on reading (glTF 2.0 spec, section 3.9.2 and 3.7.2.1).
//! - Texture coordinates put (0, 0) at the top-left corner of the image, with
//!   v growing downwards (glTF's convention, the order of image rows); OBJ's
//!   `vt`, whose v grows upwards, is read as `1 - v`.

use std::fmt;
use std::path::{Path, PathBuf};

use crate::PolyMesh;

/// A mesh and its appearance, as [`read_asset`](crate::read_asset) reads it.
#[derive(Clone, Debug, Default, PartialEq)]
#[non_exhaustive]
pub struct Asset {
    /// The geometry, exactly as [`read_mesh`](crate::read_mesh) reads it.
    pub mesh: PolyMesh,
    /// One RGBA colour per vertex of [`Asset::mesh`], sRGB-encoded, 0..1.
    pub colors: Option<Vec<[f32; 4]>>,
    /// Texture coordinates of the face corners.
    pub tex_coords: Option<TexCoords>,
    /// The materials faces refer to, in file order.
    pub materials: Vec<Material>,
    /// The material of each face (an index into [`Asset::materials`]);
    /// `None` when every face has material 0 or there are no materials.
    pub face_materials: Option<Vec<u32>>,
    /// What the file holds and the reader did not keep, at most one entry a
    /// kind.
    pub dropped: Vec<Dropped>,
}

/// Texture coordinates per face corner: OBJ indexes them apart from the
/// positions, so one vertex may have several (along a texture seam).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TexCoords {
    /// The distinct coordinates (u, v), (0, 0) at the image's top-left corner.
    pub values: Vec<[f32; 2]>,
    /// For each face corner, in the order of [`PolyMesh::faces`] with all
    /// faces concatenated, an index into `values`, or [`TexCoords::NONE`]
    /// for a corner of a face that has no coordinates.
    pub corners: Vec<u32>,
}

impl TexCoords {
    /// The corner index of a face without texture coordinates.
    pub const NONE: u32 = u32::MAX;

    /// The coordinates of face corner `corner` (counted over all faces).
    pub fn get(&self, corner: usize) -> Option<[f32; 2]> {
        let index = *self.corners.get(corner)?;
        self.values.get(index as usize).copied()
    }
}

/// A material as far as appearance goes: a base colour and its texture.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// The name in the file (OBJ `newmtl`, glTF `name`), or empty.
    pub name: String,
    /// RGBA, sRGB-encoded, 0..1: OBJ `Kd` with `d` as alpha, glTF
    /// `baseColorFactor`. Multiplies the texture where there is one.
    pub base_color: [f32; 4],
    /// OBJ `map_Kd`, glTF `baseColorTexture`.
    pub base_color_texture: Option<Texture>,
}

impl Material {
    /// A white material named `name`, without texture.
    pub(crate) fn named(name: &str) -> Self {
        Material {
            name: name.to_owned(),
            base_color: [1.0; 4],
            base_color_texture: None,
        }
    }
}

/// A texture image: where it is, and its pixels when they were asked for
/// ([`AssetOptions::images`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Where the encoded image is.
    pub source: ImageSource,
    /// The decoded image.
    pub image: Option<Image>,
}

/// Where an encoded image is.
#[derive(Clone, Debug, PartialEq)]
pub enum ImageSource {
    /// A file, its path resolved against the folder of the file that names it.
    File(PathBuf),
    /// Bytes inside the mesh file (a GLB buffer view or a `data:` URI).
    Embedded {
        /// The MIME type the file gives, if any (`image/png`, `image/jpeg`).
        mime_type: Option<String>,
        /// The encoded image.
        bytes: Vec<u8>,
    },
}

/// A decoded image: 8-bit RGBA, rows from the top.
#[derive(Clone, PartialEq, Eq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` pixels of 4 bytes (R, G, B, A), row by row.
    pub rgba: Vec<u8>,
}

impl fmt::Debug for Image {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Image({}x{} RGBA)", self.width, self.height)
    }
}

/// Settings of [`read_asset`](crate::read_asset).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct AssetOptions {
    /// Decode texture images (PNG, JPEG). Off by default: the images are
    /// then only located (a missing file is still reported).
    pub images: bool,
    /// The most memory one decoded image may take, in bytes; a larger one is
    /// reported as dropped, not decoded. Default [`AssetOptions::DEFAULT`]:
    /// 512 MiB.
    pub max_image_bytes: u64,
}

impl AssetOptions {
    /// Images located, not decoded; at most 512 MiB an image.
    pub const DEFAULT: AssetOptions = AssetOptions {
        images: false,
        max_image_bytes: 512 << 20,
    };

    /// These options with images decoded or not.
    pub const fn with_images(mut self, images: bool) -> Self {
        self.images = images;
        self
    }

    /// These options with another limit on a decoded image's memory.
    pub const fn with_max_image_bytes(mut self, bytes: u64) -> Self {
        self.max_image_bytes = bytes;
        self
    }
}

impl Default for AssetOptions {
    fn default() -> Self {
        AssetOptions::DEFAULT
    }
}

/// A kind of attribute a mesh file may hold beside positions and faces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[non_exhaustive]
pub enum AttributeKind {
    /// Per-vertex colours (PLY `red green blue`, OBJ `v x y z r g b`, glTF
    /// `COLOR_0`).
    VertexColors,
    /// Vertex colours whose alpha is below 1.
    VertexAlpha,
    /// Per-face colours (PLY face `red green blue`).
    FaceColors,
    /// The first set of texture coordinates (OBJ `vt`, glTF `TEXCOORD_0`).
    TexCoords,
    /// Further sets of texture coordinates (glTF `TEXCOORD_1` and up).
    ExtraTexCoords,
    /// Base colour textures (OBJ `map_Kd`, glTF `baseColorTexture`).
    Textures,
    /// Materials and their base colours (OBJ `.mtl`, glTF `materials`).
    Materials,
    /// Material maps other than the base colour: normal, bump, specular,
    /// metal and roughness, occlusion, emission.
    OtherMaps,
    /// Vertex normals (OBJ `vn`, PLY `nx ny nz`, glTF `NORMAL`).
    Normals,
    /// Vertex tangents (glTF `TANGENT`).
    Tangents,
    /// Skinning: joints and weights, skins.
    Skinning,
    /// Morph targets.
    MorphTargets,
    /// Animations (the rest pose is read).
    Animations,
    /// Line elements (OBJ `l`, PLY `edge`, glTF line primitives).
    Lines,
    /// Point elements (OBJ `p`, glTF point primitives).
    Points,
    /// Other per-vertex, per-face or per-element properties.
    Properties,
    /// glTF extensions that change appearance and are not read.
    Extensions,
}

impl AttributeKind {
    /// A snake-case name for machine-readable output (`vertex_colors`).
    pub fn key(self) -> &'static str {
        match self {
            AttributeKind::VertexColors => "vertex_colors",
            AttributeKind::VertexAlpha => "vertex_alpha",
            AttributeKind::FaceColors => "face_colors",
            AttributeKind::TexCoords => "tex_coords",
            AttributeKind::ExtraTexCoords => "extra_tex_coords",
            AttributeKind::Textures => "textures",
            AttributeKind::Materials => "materials",
            AttributeKind::OtherMaps => "other_maps",
            AttributeKind::Normals => "normals",
            AttributeKind::Tangents => "tangents",
            AttributeKind::Skinning => "skinning",
            AttributeKind::MorphTargets => "morph_targets",
            AttributeKind::Animations => "animations",
            AttributeKind::Lines => "lines",
            AttributeKind::Points => "points",
            AttributeKind::Properties => "properties",
            AttributeKind::Extensions => "extensions",
        }
    }
}

impl fmt::Display for AttributeKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            AttributeKind::VertexColors => "vertex colours",
            AttributeKind::VertexAlpha => "vertex alpha",
            AttributeKind::FaceColors => "face colours",
            AttributeKind::TexCoords => "texture coordinates",
            AttributeKind::ExtraTexCoords => "further texture coordinate sets",
            AttributeKind::Textures => "textures",
            AttributeKind::Materials => "materials",
            AttributeKind::OtherMaps => "other material maps",
            AttributeKind::Normals => "normals",
            AttributeKind::Tangents => "tangents",
            AttributeKind::Skinning => "skinning",
            AttributeKind::MorphTargets => "morph targets",
            AttributeKind::Animations => "animations",
            AttributeKind::Lines => "lines",
            AttributeKind::Points => "points",
            AttributeKind::Properties => "other properties",
            AttributeKind::Extensions => "extensions",
        })
    }
}

/// Something of a kind a file holds that is not kept (by a reader, or by the
/// codec: see the facade's `not_carried`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Dropped {
    /// What kind of attribute.
    pub kind: AttributeKind,
    /// How many values: vertices, corners, elements, images or materials, as
    /// `detail` says.
    pub count: u64,
    /// What exactly and why, for people (`2930 vertex normals (vn)`).
    pub detail: String,
}

impl fmt::Display for Dropped {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({}): {}", self.kind, self.count, self.detail)
    }
}

/// The longest a merged [`Dropped::detail`] grows; further details are
/// counted, not listed, so that a file with a million bad references still
/// gets a line of reasonable length.
const MAX_DETAIL: usize = 400;

/// Adds `count` of `kind` to `list`, merged with an entry of the same kind.
pub fn add_dropped(list: &mut Vec<Dropped>, kind: AttributeKind, count: u64, detail: String) {
    match list.iter_mut().find(|d| d.kind == kind) {
        Some(entry) => {
            entry.count = entry.count.saturating_add(count);
            if entry.detail.split("; ").any(|d| d == detail) {
                return;
            }
            if entry.detail.len() + detail.len() <= MAX_DETAIL {
                entry.detail.push_str("; ");
                entry.detail.push_str(&detail);
            } else if !entry.detail.ends_with("; ...") {
                entry.detail.push_str("; ...");
            }
        }
        None => list.push(Dropped {
            kind,
            count,
            detail,
        }),
    }
}

impl Asset {
    /// An asset of geometry alone.
    pub(crate) fn of(mesh: PolyMesh) -> Self {
        Asset {
            mesh,
            ..Asset::default()
        }
    }

    /// What the asset holds beside the geometry, one entry a kind: vertex
    /// colours, vertex alpha below 1, texture coordinates, textures and
    /// materials. (The kinds a reader did not keep are in [`Asset::dropped`].)
    pub fn held(&self) -> Vec<Dropped> {
        let mut held = Vec::new();
        if let Some(colors) = &self.colors {
            let detail = "RGBA per vertex".to_owned();
            add_dropped(
                &mut held,
                AttributeKind::VertexColors,
                colors.len() as u64,
                detail,
            );
            let translucent = colors.iter().filter(|c| c[3] < 1.0).count();
            if translucent > 0 {
                let detail = "vertices whose alpha is below 1".to_owned();
                add_dropped(
                    &mut held,
                    AttributeKind::VertexAlpha,
                    translucent as u64,
                    detail,
                );
            }
        }
        if let Some(uv) = &self.tex_coords {
            let corners = uv.corners.iter().filter(|&&c| c != TexCoords::NONE).count();
            let detail = "per face corner".to_owned();
            add_dropped(&mut held, AttributeKind::TexCoords, corners as u64, detail);
        }
        let textures: Vec<&Texture> = self
            .materials
            .iter()
            .filter_map(|m| m.base_color_texture.as_ref())
            .collect();
        if !textures.is_empty() {
            let names: Vec<String> = textures.iter().map(|t| t.source.to_string()).collect();
            let detail = format!("base colour images: {}", names.join(", "));
            add_dropped(
                &mut held,
                AttributeKind::Textures,
                textures.len() as u64,
                detail,
            );
        }
        if !self.materials.is_empty() {
            let detail = "base colours".to_owned();
            let count = self.materials.len() as u64;
            add_dropped(&mut held, AttributeKind::Materials, count, detail);
        }
        held
    }
}

impl fmt::Display for ImageSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ImageSource::File(path) => write!(f, "{}", path.display()),
            ImageSource::Embedded { mime_type, bytes } => write!(
                f,
                "embedded {} of {} bytes",
                mime_type.as_deref().unwrap_or("image"),
                bytes.len()
            ),
        }
    }
}

/// Locates or decodes the image of a texture. A missing, unreadable or
/// oversized image is not an error of the mesh: it is reported in
/// `dropped` and the texture left out (`None`).
pub(crate) fn load_texture(
    source: ImageSource,
    options: &AssetOptions,
    dropped: &mut Vec<Dropped>,
) -> Option<Texture> {
    let failed = |dropped: &mut Vec<Dropped>, why: String| {
        add_dropped(dropped, AttributeKind::Textures, 1, why);
        None
    };
    if !options.images {
        if let ImageSource::File(path) = &source {
            if !path.is_file() {
                return failed(dropped, format!("{}: not found", path.display()));
            }
        }
        return Some(Texture {
            source,
            image: None,
        });
    }
    let decoded = match &source {
        ImageSource::File(path) => match std::fs::read(path) {
            Ok(bytes) => decode_image(&bytes, options),
            Err(e) => Err(e.to_string()),
        },
        ImageSource::Embedded { bytes, .. } => decode_image(bytes, options),
    };
    match decoded {
        Ok(image) => Some(Texture {
            source,
            image: Some(image),
        }),
        Err(why) => failed(dropped, format!("{source}: {why}")),
    }
}

/// Decodes a PNG or JPEG image to 8-bit RGBA within the memory limit, which
/// the decoder checks against the image's header before allocating.
fn decode_image(bytes: &[u8], options: &AssetOptions) -> Result<Image, String> {
    use image::ImageDecoder as _;
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| e.to_string())?;
    if reader.format().is_none() {
        return Err("not a PNG or JPEG image".into());
    }
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(options.max_image_bytes);
    reader.limits(limits);
    let decoder = reader.into_decoder().map_err(|e| e.to_string())?;
    let (width, height) = decoder.dimensions();
    // The limit bounds what the file's own layout needs; RGBA8 needs 4
    // bytes a pixel whatever the file stores, so that is checked too.
    let needed = u64::from(width) * u64::from(height) * 4;
    if needed > options.max_image_bytes {
        return Err(format!(
            "{width}x{height} pixels need {needed} bytes, above the limit of {}",
            options.max_image_bytes
        ));
    }
    let decoded = image::DynamicImage::from_decoder(decoder).map_err(|e| e.to_string())?;
    let rgba = decoded.into_rgba8();
    Ok(Image {
        width: rgba.width(),
        height: rgba.height(),
        rgba: rgba.into_raw(),
    })
}

/// Resolves a file name written in a mesh or material file against the
/// folder of that file. Backslashes (paths written on Windows) are read as
/// separators when the name as written names no file.
pub(crate) fn resolve(folder: &Path, name: &str) -> PathBuf {
    let path = folder.join(name);
    if !path.exists() && name.contains('\\') {
        let forward = folder.join(name.replace('\\', "/"));
        if forward.exists() {
            return forward;
        }
    }
    path
}

/// sRGB encoding of a linear value in 0..1 (IEC 61966-2-1).
pub(crate) fn linear_to_srgb(linear: f32) -> f32 {
    let c = f64::from(linear.clamp(0.0, 1.0));
    let encoded = if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    encoded.clamp(0.0, 1.0) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merged_entries_add_counts_and_keep_details_short() {
        let mut list = Vec::new();
        add_dropped(
            &mut list,
            AttributeKind::Textures,
            1,
            "a.png: not found".into(),
        );
        add_dropped(&mut list, AttributeKind::Normals, 5, "5 vn".into());
        add_dropped(
            &mut list,
            AttributeKind::Textures,
            1,
            "b.png: not found".into(),
        );
        add_dropped(
            &mut list,
            AttributeKind::Textures,
            1,
            "b.png: not found".into(),
        );
        assert_eq!(list.len(), 2);
        assert_eq!(list[0].count, 3);
        assert_eq!(list[0].detail, "a.png: not found; b.png: not found");
        for k in 0..1000 {
            add_dropped(&mut list, AttributeKind::Normals, 1, format!("line {k}"));
        }
        assert!(list[1].detail.len() < MAX_DETAIL + 10);
        assert!(list[1].detail.ends_with("; ..."));
        assert_eq!(list[1].count, 1005);
    }

    #[test]
    fn srgb_encoding_has_the_standard_values() {
        assert_eq!(linear_to_srgb(0.0), 0.0);
        assert_eq!(linear_to_srgb(1.0), 1.0);
        // sRGB 128/255 is 0.21586 linear.
        assert!((linear_to_srgb(0.21586) * 255.0 - 128.0).abs() < 0.01);
    }
}
