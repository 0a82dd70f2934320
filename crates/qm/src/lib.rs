//! qm: progressive compression of meshes.
//!
//! A mesh goes in; an *embedded* bitstream comes out, and any prefix of that
//! stream decodes to a crack-free mesh whose error falls as more bytes
//! arrive.
//!
//! ```no_run
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let mesh = qm::read_mesh("model.obj")?;
//! let encoded = qm::encode(&mesh, &qm::Options::default())?;
//! // Any prefix after the base mesh decodes.
//! let cut = &encoded.bytes[..encoded.bytes.len() / 2];
//! let decoded = qm::decode(cut, &qm::DecodeOptions::default())?;
//! qm::write_mesh("coarse.obj", &decoded.mesh)?;
//! # Ok(()) }
//! ```
//!
//! The pipeline is a one-way ladder of crates, each usable alone and
//! re-exported here:
//!
//! | module | crate | owns |
//! |---|---|---|
//! | [`io`] | `qm-io` | [`PolyMesh`], [`Asset`] and mesh files (OBJ, PLY, OFF, STL, glTF) |
//! | [`lift`] | `qm-lift` | base quad meshes, sample layouts, quantization, the integer lifting transform |
//! | [`tree`] | `qm-tree` | zerotrees over edge and face coefficients |
//! | [`ezw`] | `qm-ezw` | bit-plane zerotree coding, the arithmetic coder |
//! | [`param`] | `qm-param` | input mesh to semi-regular mesh; surface distance |
//! | [`codec`] | `qm-codec` | the `.qm` container, compress/decompress of a semi-regular mesh, the incremental [`StreamDecoder`] and the level choice |
//!
//! [`gltf`] writes a `.qm` as a glTF binary with the extension
//! `QM_progressive_mesh` and a fallback mesh.

#[cfg(doctest)]
#[doc = include_str!("../../../README.md")]
pub struct ReadmeDoctests;

mod choice;
mod error;
pub mod gltf;

use std::path::Path;

pub use error::{Error, ErrorKind, Result};
pub use qm_codec as codec;
pub use qm_ezw as ezw;
pub use qm_io as io;
pub use qm_lift as lift;
pub use qm_param as param;
pub use qm_tree as tree;

pub use qm_codec::{
    Contexts, DecodeOptions, DecodeStatus, Decoder, Decompressed, EncodeOptions, Estimate, Frames,
    LevelChoice, LevelMesh, Limits, PrefixRow, StreamDecoder, UpdateRule, Weighting, prefix_table,
};
pub use qm_io::{Asset, AssetOptions, PolyMesh};
pub use qm_lift::SemiRegularMesh;
pub use qm_param::{Detected, RemeshOptions, RemeshReport, Remeshed};

/// Reads a mesh file (OBJ, PLY, OFF or STL, by extension or content).
pub fn read_mesh(path: impl AsRef<Path>) -> Result<PolyMesh> {
    Ok(qm_io::read_mesh(path.as_ref())?)
}

/// Reads a mesh file with its appearance (OBJ, PLY, OFF, STL, glTF or GLB):
/// the geometry [`read_mesh`] reads, and vertex colours, texture coordinates
/// and materials with their base colour texture where the format has them,
/// with what was not kept ([`io`]'s module docs; `docs/appearance.md`). A
/// missing material library or image is listed, not an error.
pub fn read_asset(path: impl AsRef<Path>, options: &AssetOptions) -> Result<Asset> {
    Ok(qm_io::read_asset(path.as_ref(), options)?)
}

/// What of `asset` a `.qm` stream made by [`encode_asset`] does not carry,
/// one entry a kind, in the order of [`io::AttributeKind`]: everything its
/// reader did not keep ([`Asset::dropped`]: normals, which decoders
/// compute from the surface, further UV sets, other maps, ...), and of
/// what the asset holds ([`Asset::held`]) all but its look. When the asset
/// has appearance ([`param::ColourSurface::has_appearance`]) its surface
/// colour is carried, one colour per sample: vertex colours and materials'
/// base colours are then not listed, while alpha, texture coordinates and
/// the images themselves are (the images' colours are resampled, finer
/// than the mesh where the images are: [`finer_colour_levels`]). Without
/// appearance, the stream holds the geometry alone.
pub fn not_carried(asset: &Asset) -> Vec<io::Dropped> {
    let coloured = qm_param::ColourSurface::has_appearance(asset);
    let mut list = asset.held();
    if coloured {
        use io::AttributeKind::{Materials, TexCoords, Textures, VertexColors};
        list.retain(|d| !matches!(d.kind, VertexColors | Materials));
        for d in &mut list {
            match d.kind {
                TexCoords => d.detail.push_str(
                    " (the texture's colours are carried per sample, and where the texture \
                     is finer than the mesh as a texture whose coordinates decoders derive)",
                ),
                Textures => d.detail.push_str(
                    " (resampled: their colours per sample, finer than the mesh where \
                     they are)",
                ),
                _ => {}
            }
        }
    }
    for d in &asset.dropped {
        qm_io::add_dropped(&mut list, d.kind, d.count, d.detail.clone());
    }
    list.sort_by_key(|d| d.kind);
    list
}

/// Writes a mesh file (OBJ or PLY, by extension), atomically: a failure
/// leaves no half-written file.
pub fn write_mesh(path: impl AsRef<Path>, mesh: &PolyMesh) -> Result<()> {
    Ok(qm_io::write_mesh(path.as_ref(), mesh)?)
}

/// [`write_mesh`] with an 8-bit sRGB colour for each vertex (PLY `uchar red
/// green blue`, OBJ `v x y z r g b`); a colour count other than the vertex
/// count is an error naming the file.
pub fn write_coloured_mesh(
    path: impl AsRef<Path>,
    mesh: &PolyMesh,
    colours: &[[u8; 3]],
) -> Result<()> {
    Ok(qm_io::write_coloured_mesh(path.as_ref(), mesh, colours)?)
}

/// Settings of [`encode`]: how to remesh and how to code.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[non_exhaustive]
pub struct Options {
    /// The remesher's settings (unused for a quad mesh that already has
    /// subdivision connectivity).
    pub remesh: RemeshOptions,
    /// The encoder's settings.
    pub encode: EncodeOptions,
}

impl Options {
    /// These options with other remesher settings.
    pub const fn with_remesh(mut self, remesh: RemeshOptions) -> Self {
        self.remesh = remesh;
        self
    }

    /// These options with other encoder settings.
    pub const fn with_encode(mut self, encode: EncodeOptions) -> Self {
        self.encode = encode;
        self
    }
}

/// A compressed mesh: the bytes of a `.qm` file and what went into them.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct Encoded {
    /// The whole `.qm` file; any prefix of it past the base mesh decodes.
    pub bytes: Vec<u8>,
    /// Bytes of magic, version, header and its checksum.
    pub header_bytes: usize,
    /// Bytes of the base mesh section and its checksum.
    pub base_bytes: usize,
    /// File length at the end of each bit-plane pass.
    pub pass_ends: Vec<usize>,
    /// Samples of the semi-regular mesh that was coded (its finest level's
    /// vertices).
    pub samples: usize,
    /// Its base quads.
    pub base_quads: usize,
    /// Its subdivision level.
    pub level: u32,
    /// For a remeshed input: what the remesher did.
    pub remeshed: Option<RemeshReport>,
    /// Where the colour sits at the remesh's samples: how well the samples
    /// can show the input's colour, as PSNR over 8-bit RGB (what they miss
    /// of it drawn over the mesh, measured on its surface); the colour
    /// stream ends within about 1 dB of it.
    pub colour_floor_db: Option<f64>,
}

/// Compresses any mesh: a quad mesh with subdivision connectivity is coded
/// as it is, anything else is remeshed first. The encoder's holds are
/// measured against `mesh` itself.
pub fn encode(mesh: &PolyMesh, options: &Options) -> Result<Encoded> {
    let prepared = prepare(mesh, &options.remesh)?;
    encode_prepared(&prepared, mesh, &options.encode)
}

/// Compresses a mesh with its look: the geometry as [`encode`] does, and,
/// when the asset has appearance ([`param::ColourSurface::has_appearance`]:
/// vertex colours, or a decoded base colour texture with texture
/// coordinates; read it with [`AssetOptions::with_images`]), the colour of
/// the input surface at each sample's closest point, coded progressively
/// with the geometry (`docs/appearance.md`). Without appearance the bytes
/// are [`encode`]'s. What the stream does not carry: [`not_carried`].
pub fn encode_asset(asset: &Asset, options: &Options) -> Result<Encoded> {
    let prepared = prepare_asset_reporting(asset, &options.remesh, &|_| {})?;
    encode_prepared_asset(&prepared, asset, &options.encode)
}

/// The second half of [`encode_asset`]: compresses `prepared`, made from
/// `asset`'s mesh by [`prepare`], with the asset's colours.
pub fn encode_prepared_asset(
    prepared: &Prepared,
    asset: &Asset,
    options: &EncodeOptions,
) -> Result<Encoded> {
    let Some(surface) = qm_param::ColourSurface::new(asset)? else {
        return encode_prepared(prepared, &asset.mesh, options);
    };
    let layout = prepared.mesh.layout();
    let texels = surface.texels();
    let sample = |finer: u32| -> Result<(Vec<[u8; 3]>, codec::qm_lift::Layout)> {
        let fine = prepared.mesh.refined(finer).map_err(codec::Error::from)?;
        let colours = surface.colours_at(fine.positions());
        Ok((colours, fine.into_parts().0))
    };
    let mut finer = finer_colour_levels(texels, layout);
    if finer == 0 {
        // Colour at the samples of a remesh: the stream goes as far as what
        // they miss of the surface's colour, measured, is worth. The
        // vertices of an input coded as it is are its own: exactly.
        let colours = surface.colours_at(prepared.mesh.positions());
        let mut given = codec::Colours::new(&colours);
        let missed = (prepared.remeshed.is_some())
            .then(|| colour_missed(&prepared.mesh, &colours, &surface));
        if let Some(missed) = missed {
            given = given.with_missed(missed);
        }
        let mut encoded = encode_with(prepared, &asset.mesh, Some(given), options)?;
        encoded.colour_floor_db = missed.map(|m| param::colour_psnr(m.sqrt()));
        return Ok(encoded);
    }
    let (mut colours, mut fine) = sample(finer)?;
    // A sharp texture: finer while what the samples miss of it stays
    // above the target, up to four samples a texel.
    while detail_psnr(&fine, &colours) < SHARP_TEXTURE_DB
        && finer_colour_fits(finer + 1, 4.0 * texels, layout)
    {
        finer += 1;
        (colours, fine) = sample(finer)?;
    }
    // A texture's detail: what its samples miss is estimated by the codec
    // (docs/decisions/037-texture-as-finer-colour.md).
    encode_with(
        prepared,
        &asset.mesh,
        Some(codec::Colours::new(&colours)),
        options,
    )
}

/// What `colours`, one per sample of `mesh`, drawn over the triangles of
/// its finest quads, miss of `surface`'s colour: the mean squared error
/// per 8-bit channel, area-weighted, at the points where the encoder
/// measures the geometry ([`codec::surface_points`]).
fn colour_missed(
    mesh: &SemiRegularMesh,
    colours: &[[u8; 3]],
    surface: &qm_param::ColourSurface,
) -> f64 {
    let scale = lift::unit_scale(mesh.positions());
    let points = codec::surface_points(mesh, scale);
    let at: Vec<_> = points.iter().map(|p| p.point / scale).collect();
    let (sum, weight) = (points.iter().zip(surface.colours_at(&at))).fold(
        (0.0, 0.0),
        |(sum, weight), (p, truth)| {
            let drawn = |k: usize| -> f64 {
                (p.corners.iter().zip(p.weights))
                    .map(|(&c, w)| w * f64::from(colours[c as usize][k]))
                    .sum()
            };
            let error: f64 = (0..3)
                .map(|k| (drawn(k) - f64::from(truth[k])).powi(2))
                .sum();
            (sum + p.weight * error / 3.0, weight + p.weight)
        },
    );
    if weight > 0.0 { sum / weight } else { 0.0 }
}

/// The colour PSNR, in dB, below which a texture's samples go one level
/// finer than the texel count asks ([`finer_colour_levels`]): issue 46's
/// target for lossless colour.
pub const SHARP_TEXTURE_DB: f64 = 30.0;

/// How well the colours of `layout`'s finest level follow from the level
/// below, as PSNR over 8-bit RGB: each sample that level adds against the
/// mean of its two (edge) or four (face) neighbours of the level below.
/// What sampling one level coarser would miss of the texture, and about
/// what this level misses of it where the texture is sharper still.
fn detail_psnr(layout: &codec::qm_lift::Layout, colours: &[[u8; 3]]) -> f64 {
    let n = layout.n();
    let (mut sum, mut count) = (0.0, 0u64);
    for f in 0..layout.face_count() {
        let c = |i: usize, j: usize| colours[layout.sample(f, i, j) as usize].map(f64::from);
        for j in 0..=n {
            for i in 0..=n {
                let mean = |ps: &[[f64; 3]]| -> [f64; 3] {
                    std::array::from_fn(|k| ps.iter().map(|p| p[k]).sum::<f64>() / ps.len() as f64)
                };
                let predicted = match (i % 2, j % 2) {
                    (0, 0) => continue,
                    (1, 0) => mean(&[c(i - 1, j), c(i + 1, j)]),
                    (0, 1) => mean(&[c(i, j - 1), c(i, j + 1)]),
                    _ => mean(&[
                        c(i - 1, j - 1),
                        c(i + 1, j - 1),
                        c(i - 1, j + 1),
                        c(i + 1, j + 1),
                    ]),
                };
                let v = c(i, j);
                sum += (0..3).map(|k| (v[k] - predicted[k]).powi(2)).sum::<f64>();
                count += 3;
            }
        }
    }
    if count == 0 {
        return f64::INFINITY;
    }
    param::colour_psnr((sum / count as f64).sqrt())
}

/// Most colour samples, in all, that a texture's detail earns at levels
/// finer than the geometry's (docs/appearance.md, "Texture detail").
pub const MAX_COLOUR_SAMPLES: u64 = 1 << 22;

/// The levels of colour beyond `layout`'s that a surface showing `texels`
/// texture texels ([`param::ColourSurface::texels`]) earns: the finest
/// level with no more samples than texels (none where the geometry's
/// samples are as many), at most [`codec::container::MAX_FINER_COLOUR`]
/// levels and [`MAX_COLOUR_SAMPLES`] colour samples, and no further than a
/// decoder's memory estimate of the file allows within
/// [`FINER_COLOUR_DECODE_MEMORY`].
pub fn finer_colour_levels(texels: f64, layout: &codec::qm_lift::Layout) -> u32 {
    let mut finer = 0;
    while finer_colour_fits(finer + 1, texels, layout) {
        finer += 1;
    }
    finer
}

/// Whether colour `finer` levels beyond `layout`'s has at most `most`
/// samples and stays within the caps of [`finer_colour_levels`].
fn finer_colour_fits(finer: u32, most: f64, layout: &codec::qm_lift::Layout) -> bool {
    let (base, level) = (layout.base(), layout.level());
    let samples = base.sample_count(level + finer) as f64;
    let (vertices, faces) = (base.vertex_count(), base.faces().len() as u32);
    let memory = codec::container::decode_memory_of(vertices, faces, level, Some(level + finer));
    finer <= codec::container::MAX_FINER_COLOUR as u32
        && samples <= MAX_COLOUR_SAMPLES as f64
        && samples <= most
        && memory <= FINER_COLOUR_DECODE_MEMORY
        && codec::qm_lift::Layout::check(base, level + finer).is_ok()
}

/// The most memory a decoder's estimate of a file may reach for its colour
/// to go finer than its geometry: the browser decoder's limit, 512 MiB (so
/// that every qm decoder with its default limit takes the file).
pub const FINER_COLOUR_DECODE_MEMORY: u64 = codec::container::BROWSER_DECODE_MEMORY;

/// A decoded `.qm` stream or prefix of one.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct Decoded {
    /// The mesh at the decoded level (quads).
    pub mesh: PolyMesh,
    /// Everything the decoder made: layout, quantized values, header, and
    /// how many bytes of each section were there.
    pub raw: Decompressed,
}

impl Decoded {
    /// The subdivision level of [`Decoded::mesh`] (0 is the base mesh).
    pub fn level(&self) -> u32 {
        self.raw.level
    }

    /// Bit-plane passes decoded.
    pub fn passes(&self) -> u32 {
        self.raw.passes
    }

    /// Whether the stream ended before its last pass.
    pub fn truncated(&self) -> bool {
        self.raw.truncated
    }

    /// Bytes of the input this mesh used: header, base mesh and the
    /// stream bytes decoded (fewer than given where the cut fell inside a
    /// hold or an error goal was met sooner), as
    /// [`LevelMesh::bytes_used`] counts them.
    pub fn bytes_used(&self) -> usize {
        self.raw.header_bytes + self.raw.base_bytes + self.raw.decoded_stream_bytes
    }

    /// The decoder's estimate of the RMS distance, in model units, of
    /// [`Decoded::mesh`] from the complete stream's finest mesh
    /// ([`codec::levels`]).
    pub fn error_estimate(&self) -> f64 {
        self.raw.estimate.error(self.raw.level)
    }

    /// [`Self::error_estimate`] as PSNR against the bounding-box diagonal,
    /// in dB.
    pub fn psnr_estimate(&self) -> f64 {
        self.raw.estimate.psnr_db(self.raw.level)
    }

    /// For a file with colours: one 8-bit sRGB colour per vertex of
    /// [`Decoded::mesh`].
    pub fn colours(&self) -> Option<&[[u8; 3]]> {
        self.raw.colours.as_deref()
    }

    /// For a file whose colours reached a finer level than
    /// [`Decoded::mesh`]'s: those colours as a texture atlas, one tile a
    /// base quad ([`codec::Atlas`]); the coordinates of the mesh's face
    /// corners are [`Decoded::corner_texcoords`].
    pub fn texture(&self) -> Option<&codec::Atlas> {
        self.raw.texture.as_ref()
    }

    /// With a [`Decoded::texture`]: the texture coordinates of each corner
    /// of [`Decoded::mesh`]'s faces, in order, `(0, 0)` at the image's
    /// top-left corner.
    pub fn corner_texcoords(&self) -> Option<Vec<[f32; 2]>> {
        let atlas = self.texture()?;
        Some(atlas.corner_texcoords(self.raw.layout.face_count(), self.raw.level))
    }

    /// This decode as an asset, with its look: with a [`Decoded::texture`],
    /// texture coordinates at every face corner and one material whose
    /// base colour texture is the atlas (decoded, no file behind it);
    /// otherwise its colours at the vertices, if any: what
    /// [`param::colour_distance`] compares with an input (as `cargo xtask
    /// appearance` does).
    pub fn to_asset(&self) -> Asset {
        let mut asset = Asset::default();
        asset.mesh = self.mesh.clone();
        if let (Some(atlas), Some(corners)) = (self.texture(), self.corner_texcoords()) {
            let rgba = (atlas.texels.iter())
                .flat_map(|&[r, g, b]| [r, g, b, 255])
                .collect();
            asset.tex_coords = Some(io::TexCoords {
                corners: (0..corners.len() as u32).collect(),
                values: corners,
            });
            asset.materials = vec![io::Material {
                name: "qm".into(),
                base_color: [1.0; 4],
                base_color_texture: Some(io::Texture {
                    source: io::ImageSource::Embedded {
                        mime_type: None,
                        bytes: Vec::new(),
                    },
                    image: Some(io::Image {
                        width: atlas.width,
                        height: atlas.height,
                        rgba,
                    }),
                }),
            }];
        } else if let Some(colours) = self.colours() {
            asset.colors = Some(
                (colours.iter())
                    .map(|c| [c[0], c[1], c[2], 255].map(|x| f32::from(x) / 255.0))
                    .collect(),
            );
        }
        asset
    }
}

/// Writes a decode with its look, atomically, by the path's extension:
/// GLB as [`gltf::decoded_glb`] makes it; OBJ with a [`Decoded::texture`]
/// with a material library and a PNG image beside it
/// ([`io::textured_files`]); PLY, or OBJ without a texture, with the
/// colours at the vertices where there are colours
/// ([`write_coloured_mesh`]); otherwise the mesh alone.
pub fn write_decoded(path: impl AsRef<Path>, decoded: &Decoded) -> Result<()> {
    let path = path.as_ref();
    let format = qm_io::Format::from_path(path);
    if format == Some(qm_io::Format::Glb) {
        return Ok(qm_io::write_bytes(path, &gltf::decoded_glb(decoded))?);
    }
    if format == Some(qm_io::Format::Obj)
        && let Some(atlas) = decoded.texture()
        && let Some(corners) = decoded.corner_texcoords()
    {
        let texture = qm_io::OutputTexture {
            width: atlas.width,
            height: atlas.height,
            texels: &atlas.texels,
            corners: &corners,
        };
        return Ok(qm_io::write_textured_mesh(path, &decoded.mesh, &texture)?);
    }
    match decoded.colours() {
        Some(colours) => write_coloured_mesh(path, &decoded.mesh, colours),
        None => write_mesh(path, &decoded.mesh),
    }
}

/// Decompresses `.qm` bytes; any cut after the base mesh is fine (a cut
/// inside the header or the base mesh is [`Error::is_truncated`]). By
/// default the mesh is at the level the bytes support
/// ([`LevelChoice::Auto`]); [`DecodeOptions`] choose another level, an
/// error goal or a triangle cap. For bytes that arrive in pieces, use a
/// [`StreamDecoder`].
pub fn decode(bytes: &[u8], options: &DecodeOptions) -> Result<Decoded> {
    let raw = qm_codec::decompress(bytes, options)?;
    let (positions, quads) = raw.level_mesh();
    Ok(Decoded {
        mesh: PolyMesh::from_faces(positions, &quads),
        raw,
    })
}

/// Finds subdivision connectivity in a quad mesh (no remeshing).
pub fn detect(mesh: &PolyMesh) -> Result<Detected> {
    Ok(qm_param::detect_subdivision(mesh)?)
}

/// Remeshes any mesh into a semi-regular quad mesh.
pub fn remesh(mesh: &PolyMesh, options: &RemeshOptions) -> Result<Remeshed> {
    Ok(qm_param::remesh(mesh, options)?)
}

/// An input mesh made semi-regular: the first half of [`encode`].
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct Prepared {
    /// The semi-regular mesh to compress.
    pub mesh: SemiRegularMesh,
    /// For a quad mesh taken as it is: the input vertex of each sample.
    pub source: Option<Vec<u32>>,
    /// For a remeshed input: what the remesher did.
    pub remeshed: Option<RemeshReport>,
}

/// Turns any input mesh into a semi-regular quad mesh: a quad mesh with
/// subdivision connectivity is taken as it is, anything else is remeshed.
/// Work that would take more than [`RemeshOptions::max_memory`] (as
/// [`param::remesh::encode_memory`] estimates it) is refused before it
/// starts.
pub fn prepare(mesh: &PolyMesh, options: &RemeshOptions) -> Result<Prepared> {
    prepare_reporting(mesh, options, &|_| {})
}

/// [`prepare`], announcing each step of a remesh ([`param::Step`]) to
/// `report` as it starts, for a progress display; it is called from the
/// remesher's threads.
pub fn prepare_reporting(
    mesh: &PolyMesh,
    options: &RemeshOptions,
    report: param::Reporter<'_>,
) -> Result<Prepared> {
    if mesh.all_faces_have(4) {
        match qm_param::detect_subdivision(mesh) {
            Ok(d) => {
                let samples = d.mesh.positions().len() as u64;
                qm_param::remesh::check_memory(0, 1, samples, false, options)?;
                return Ok(Prepared {
                    mesh: d.mesh,
                    source: Some(d.source),
                    remeshed: None,
                });
            }
            Err(qm_param::Error::NoSubdivisionConnectivity | qm_param::Error::InvalidMesh(_)) => {}
            Err(e) => return Err(e.into()),
        }
    }
    let r = qm_param::remesh_reporting(mesh, options, report)?;
    let remeshed = Prepared {
        mesh: r.mesh,
        source: None,
        remeshed: Some(r.report),
    };
    choice::by_rate(mesh, remeshed, options, report)
}

/// Bytes that `asset`'s appearance holds while its mesh is remeshed and
/// encoded beyond what the memory model charges the mesh: its decoded
/// texture images, and the colours sampled finer than the geometry where a
/// texture asks for them, at [`FINER_COLOUR_BYTES_PER_SAMPLE`]
/// ([`finer_colour_levels`] takes between a quarter of the texture's
/// texels, [`param::colour::texels`], and all of them, at most
/// [`MAX_COLOUR_SAMPLES`]: half of them is the estimate). Vertex
/// colours, and colours at the geometry's samples, stay below the remesh's
/// own peak (docs/appearance.md, "Memory").
pub fn appearance_bytes(asset: &Asset) -> u64 {
    let images: u64 = (asset.materials.iter())
        .filter_map(|m| m.base_color_texture.as_ref()?.image.as_ref())
        .map(|i| i.rgba.len() as u64)
        .sum();
    let samples = (qm_param::colour::texels(asset) / 2.0).min(MAX_COLOUR_SAMPLES as f64) as u64;
    images + samples * FINER_COLOUR_BYTES_PER_SAMPLE
}

/// Bytes each colour sample finer than the geometry takes while it is
/// sampled and coded: its position and colour, its lifting, trees and
/// coder (measured 74 and 117 on two textured controllers:
/// docs/appearance.md, "Memory and time").
pub const FINER_COLOUR_BYTES_PER_SAMPLE: u64 = 128;

/// [`prepare_reporting`] of `asset`'s mesh, with what its appearance holds
/// ([`appearance_bytes`]) counted against [`RemeshOptions::max_memory`]
/// beside the work ([`RemeshOptions::held`]): the work is refused where
/// the two together go over it.
pub fn prepare_asset_reporting(
    asset: &Asset,
    options: &RemeshOptions,
    report: param::Reporter<'_>,
) -> Result<Prepared> {
    let held = options.held.saturating_add(appearance_bytes(asset));
    prepare_reporting(&asset.mesh, &options.with_held(held), report)
}

/// The second half of [`encode`]: compresses `prepared`, made from `input`
/// by [`prepare`]; the holds are measured against `input`'s surface, the way
/// `qm distance` measures.
pub fn encode_prepared(
    prepared: &Prepared,
    input: &PolyMesh,
    options: &EncodeOptions,
) -> Result<Encoded> {
    encode_with(prepared, input, None, options)
}

/// [`encode_prepared`], with one colour per sample or not; the probes that
/// measure the stream (for the holds, and to share the bytes with the
/// colours) are on `input`'s surface.
fn encode_with(
    prepared: &Prepared,
    input: &PolyMesh,
    colours: Option<codec::Colours<'_>>,
    options: &EncodeOptions,
) -> Result<Encoded> {
    let mesh = &prepared.mesh;
    let compressed = if options.holds || colours.is_some() {
        let surface = qm_param::distance::Surface::new(input)?;
        let probes = qm_codec::Probes::new(mesh, |p| surface.closest(p));
        match colours {
            Some(colours) => qm_codec::compress_coloured(mesh, colours, options, Some(&probes))?,
            None => qm_codec::compress_probed(mesh, options, Some(&probes))?,
        }
    } else {
        qm_codec::compress(mesh, options)?
    };
    let layout = prepared.mesh.layout();
    Ok(Encoded {
        bytes: compressed.bytes,
        header_bytes: compressed.header_bytes,
        base_bytes: compressed.base_bytes,
        pass_ends: compressed.pass_ends,
        samples: layout.sample_count(),
        base_quads: layout.face_count(),
        level: layout.level(),
        remeshed: prepared.remeshed.clone(),
        colour_floor_db: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each message of an error's chain is shown once: no error repeats
    /// the message of its `source()`.
    fn chain_has_no_repeats(e: &Error) {
        let mut messages = vec![e.to_string()];
        let mut next = std::error::Error::source(e);
        while let Some(inner) = next {
            let text = inner.to_string();
            assert!(
                messages.iter().all(|m| !m.contains(&text)),
                "{text:?} repeats in {messages:?}"
            );
            messages.push(text);
            next = inner.source();
        }
    }

    /// The detail measure: infinite for flat colour, 0 dB where every
    /// sample of the finest level is 255 from the level below.
    #[test]
    fn detail_psnr_sees_what_the_level_below_misses() {
        let mesh = crate::lift::synthetic::bumpy_sphere(3);
        let layout = mesh.layout();
        let count = layout.sample_count();
        assert_eq!(
            detail_psnr(layout, &vec![[90, 30, 200]; count]),
            f64::INFINITY
        );
        // White where the finest level adds a sample, black where the level
        // below has one: every new sample misses by 255, 0 dB.
        let mut white = vec![[255u8; 3]; count];
        for s in layout.samples_at(layout.level() - 1) {
            white[s as usize] = [0; 3];
        }
        assert_eq!(detail_psnr(layout, &white), 0.0);
    }

    /// A bumpy sphere refined 3 times, and an asset of its finest quads,
    /// nothing beside.
    fn sphere_asset() -> (SemiRegularMesh, Asset) {
        let sphere = lift::synthetic::bumpy_sphere(3);
        let layout = sphere.layout();
        let mut asset = Asset::default();
        asset.mesh =
            PolyMesh::from_faces(sphere.positions().to_vec(), &layout.quads(layout.level()));
        (sphere, asset)
    }

    /// What colours drawn over a mesh miss of a surface's colour: as
    /// good as 8-bit rounding where they are the surface's own vertex
    /// colours over its own triangles, and their whole difference where
    /// they are flat grey. Such a surface, already semi-regular, is coded
    /// as it is, its colours exactly.
    #[test]
    fn colour_missed_measures_the_drawn_colour_against_the_surface() {
        let (sphere, mut asset) = sphere_asset();
        let layout = sphere.layout();
        let own: Vec<[u8; 3]> = (0..layout.sample_count() as u64)
            .map(|s| {
                let h = s.wrapping_mul(0x9e37_79b9_7f4a_7c15);
                [h >> 56, h >> 48, h >> 40].map(|x| x as u8)
            })
            .collect();
        asset.colors = Some(
            (own.iter())
                .map(|c| [c[0], c[1], c[2], 255].map(|x| f32::from(x) / 255.0))
                .collect(),
        );
        let surface = param::ColourSurface::new(&asset).unwrap().unwrap();
        let missed = colour_missed(&sphere, &own, &surface);
        assert!(missed < 0.2, "own colours: {missed}");
        // A semi-regular input is coded as it is: its colours come back
        // exactly, whatever the measure.
        let encoded = encode_asset(&asset, &Options::default()).unwrap();
        assert!(encoded.remeshed.is_none());
        let decoded = decode(&encoded.bytes, &DecodeOptions::FINEST).unwrap();
        assert_eq!(decoded.colours(), Some(&own[..]));
        let grey = vec![[128u8; 3]; own.len()];
        let missed = colour_missed(&sphere, &grey, &surface);
        // Random bytes against their middle: about 255^2 / 12 a channel,
        // less what interpolation inside each triangle averages out.
        assert!((1500.0..3500.0).contains(&missed), "grey: {missed}");
    }

    /// A textured decode as an asset looks as its written files do.
    #[test]
    fn a_textured_decode_is_an_asset_with_its_texture() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/textured_cube.qm"
        );
        let decoded = decode(&std::fs::read(path).unwrap(), &DecodeOptions::default()).unwrap();
        let asset = decoded.to_asset();
        assert!(decoded.texture().is_some() && asset.tex_coords.is_some());
        assert!(param::colour::texels(&asset) > 0.0);
        let dir = tempfile::tempdir().unwrap();
        for name in ["t.obj", "t.glb"] {
            write_decoded(dir.path().join(name), &decoded).unwrap();
            let options = AssetOptions::DEFAULT.with_images(true);
            let written = read_asset(dir.path().join(name), &options).unwrap();
            let options = param::distance::DistanceOptions::DEFAULT.with_samples(20_000);
            let report = param::colour_distance(&asset, &written, &options)
                .unwrap()
                .unwrap();
            assert!(report.psnr_db > 50.0, "{name}: {}", report.psnr_db);
        }
        let plain = decode(
            &encode(&asset.mesh, &Options::default()).unwrap().bytes,
            &DecodeOptions::default(),
        );
        assert!(plain.unwrap().to_asset().materials.is_empty());
    }

    #[test]
    fn what_the_stream_does_not_carry_is_listed() {
        let dir = std::env::temp_dir().join(format!("qm-not-carried-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("c.obj");
        let text = "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nvt 0 0\nvn 0 0 1\n\
                    mtllib gone.mtl\nusemtl a\nf 1/1/1 2/1/1 3/1/1\n";
        std::fs::write(&path, text).unwrap();
        let asset = read_asset(&path, &AssetOptions::DEFAULT).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        let kinds: Vec<io::AttributeKind> = not_carried(&asset).iter().map(|d| d.kind).collect();
        use io::AttributeKind as K;
        // The vertex colours are carried; the library is missing.
        assert_eq!(kinds, [K::TexCoords, K::Materials, K::Normals]);
        let materials = &not_carried(&asset)[1];
        assert!(materials.detail.contains("gone.mtl"), "{materials:?}");
        assert!(not_carried(&Asset::default()).is_empty());
    }

    #[test]
    fn errors_print_once() {
        let missing = read_mesh("no such file.obj").unwrap_err();
        assert!(
            missing.to_string().starts_with("no such file.obj: "),
            "{missing}"
        );
        let cut = decode(&[0x89, b'Q', b'M'], &DecodeOptions::default()).unwrap_err();
        assert!(cut.is_truncated());
        let flat = PolyMesh::from_faces(vec![glam(0.0); 3], &[[0, 1, 2]]);
        let nothing = encode(&flat, &Options::default()).unwrap_err();
        for e in [missing, cut, nothing] {
            chain_has_no_repeats(&e);
        }
    }

    /// The decoded texture images count against the memory limit: a limit
    /// that admits the mesh alone refuses it with its image, naming the
    /// whole estimate and the limit given.
    #[test]
    fn texture_images_count_against_the_memory_limit() {
        let (_, mut asset) = sphere_asset();
        let needed = |asset: &Asset, limit: u64| {
            let options = RemeshOptions::default().with_max_memory(limit);
            match prepare_asset_reporting(asset, &options, &|_| {}) {
                Err(Error::Param(param::Error::Memory {
                    needed, limit: l, ..
                })) => {
                    assert_eq!(l, limit);
                    Some(needed)
                }
                Err(e) => panic!("{e}"),
                Ok(_) => None,
            }
        };
        let alone = needed(&asset, 1).expect("a limit of a byte refuses");
        assert_eq!(needed(&asset, alone), None);
        let side = 1024;
        asset.materials.push(io::Material {
            name: "t".into(),
            base_color: [1.0; 4],
            base_color_texture: Some(io::Texture {
                source: io::ImageSource::File("t.png".into()),
                image: Some(io::Image {
                    width: side,
                    height: side,
                    rgba: vec![0; 4 * (side * side) as usize],
                }),
            }),
        });
        assert_eq!(appearance_bytes(&asset), 4 << 20);
        assert_eq!(needed(&asset, alone), Some(alone + (4 << 20)));
        assert_eq!(needed(&asset, alone + (4 << 20)), None);
    }

    fn glam(x: f64) -> qm_io::glam::DVec3 {
        qm_io::glam::DVec3::splat(x)
    }
}
