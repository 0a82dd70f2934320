//! Mesh types and mesh files, the bottom of qm's ladder: [`PolyMesh`] and
//! [`Asset`], and readers and writers for OBJ, PLY, OFF, STL, glTF and GLB in,
//! OBJ and PLY out.
//!
//! [`read_mesh`] picks the format by extension ([`Format::from_path`]) and, for
//! an unknown extension, by content; [`read_mesh_bytes`] reads from memory (for
//! tests and fuzzing). [`write_mesh`] writes OBJ or PLY atomically (a temporary
//! file in the target's directory, then a rename), [`write_mesh_to`] writes to
//! any [`std::io::Write`]; [`write_coloured_mesh`] and
//! [`write_coloured_mesh_to`] add an 8-bit colour a vertex.
//!
//! What [`read_mesh`] keeps: vertex positions in file order (unreferenced
//! vertices too, except in glTF, see below) and faces as polygons with their
//! corner order (quads stay quads). Degenerate faces are kept as written;
//! only triangle strips drop the triangles with a repeated corner, as strips
//! use them as padding.
//!
//! [`read_asset`] (and [`read_asset_bytes`]) reads the same geometry and, beside
//! it, the appearance, in one convention for all formats (colours RGBA in
//! 0..1, sRGB-encoded; texture coordinates with (0, 0) at the image's
//! top-left corner, v downwards, so OBJ's v is flipped):
//! - OBJ: `v x y z r g b` colours, `vt` per face corner, `usemtl`, and the
//!   `mtllib` libraries' `Kd`, `d`/`Tr` and `map_Kd` (options skipped, paths
//!   relative to the library).
//! - PLY: vertex colours `red green blue [alpha]` (`uchar`, `ushort`, `float`,
//!   `double`; also `diffuse_red` ... and `r g b a`).
//! - glTF and GLB: `TEXCOORD_0`, `COLOR_0`, materials' `baseColorFactor` and
//!   `baseColorTexture`, over all primitives of the default scene with node
//!   transforms applied (`src/gltf_file/mod.rs` says how).
//! - OFF, STL: geometry only.
//!
//! Everything else a file declares is listed in [`Asset::dropped`], one
//! [`Dropped`] entry an [`AttributeKind`] with a count: normals (qm computes
//! them), further UV sets, tangents, skinning, morph targets, animations,
//! lines and points, other material maps, other PLY properties and elements,
//! unread glTF extensions. An appearance problem never fails the geometry: a
//! missing or unreadable `.mtl` or image, a bad texture index or a colour
//! out of range becomes an entry too. Images are decoded (PNG, JPEG, with
//! the `image` crate, under [`AssetOptions::max_image_bytes`]) only when
//! [`AssetOptions::images`] asks; otherwise they are only located.
//!
//! Input is treated as hostile: every reader returns a [`MeshError`] naming the
//! file and, for text formats, the line, and never panics. Counts declared in a
//! header are checked against the bytes that follow before anything is
//! allocated for them.
//!
//! Which code reads what:
//! - PLY: `ply-rs-bw` parses the header and decodes each record (ASCII, binary
//!   little and big endian); this module drives it record by record so that a
//!   bad face fails at once and a line number is known.
//! - STL: `stl_io` (ASCII and binary, merging bit-identical positions). It tells
//!   ASCII from binary by a leading `solid `, which binary files exported by
//!   some CAD tools also start with; the size check (84 + 50 bytes a triangle)
//!   decides first here.
//! - OFF: hand-written; no maintained crate reads it.
//! - glTF: the `gltf` crate (without its `import` and `utils` features)
//!   parses and validates the document and splits a GLB; buffers, accessors
//!   and images are read here, since the crate's reader panics on hostile
//!   accessors (`src/gltf_file/mod.rs` lists the cases).
//! - OBJ: hand-written, although `tobj` 4 was the plan, because for a mesh codec
//!   `tobj` changes the mesh: with `single_index: false` every object, group and
//!   material section is renumbered on its own in order of first use, so
//!   vertices shared between two groups are duplicated (a connected surface
//!   falls apart along group borders), unreferenced vertices vanish and vertex
//!   order changes; it parses `l` polylines as faces; it silently drops a face
//!   of two corners instead of reporting it; its errors carry no line number;
//!   it reads `f32` unless a feature is set; and a texture index far below zero
//!   (`f 1/-5000000000000000000 ...`) overflows its index arithmetic, a panic in
//!   debug builds. Positions and faces are the easy part of OBJ, so reading them
//!   directly costs less than repairing all of that.

mod asset;
mod error;
mod gltf_file;
mod mtl;
mod obj;
mod off;
mod ply;
mod polymesh;
mod rng;
mod stl;
mod textured;

use std::fmt;
use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::Path;

use glam::DVec3;

pub use asset::{
    Asset, AssetOptions, AttributeKind, Dropped, Image, ImageSource, Material, TexCoords, Texture,
    add_dropped,
};
pub use error::{MeshError, Problem};
pub use glam;
pub use polymesh::PolyMesh;
pub use rng::SplitMix64;
pub use textured::{OutputTexture, png_bytes, textured_files, write_textured_mesh};

/// A mesh file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Format {
    /// Wavefront OBJ (text).
    Obj,
    /// Stanford PLY (ASCII or binary).
    Ply,
    /// Object File Format (text).
    Off,
    /// Stereolithography (ASCII or binary); read only.
    Stl,
    /// glTF 2.0 as JSON, buffers in files beside it or in `data:` URIs; read
    /// only.
    Gltf,
    /// glTF 2.0 binary (GLB); read only.
    Glb,
}

impl Format {
    /// The format named by a path's extension, ignoring case.
    pub fn from_path(path: &Path) -> Option<Format> {
        let extension = path.extension()?.to_str()?.to_ascii_lowercase();
        match extension.as_str() {
            "obj" => Some(Format::Obj),
            "ply" => Some(Format::Ply),
            "off" => Some(Format::Off),
            "stl" => Some(Format::Stl),
            "gltf" => Some(Format::Gltf),
            "glb" => Some(Format::Glb),
            _ => None,
        }
    }

    /// Guesses the format from a file's first bytes, for files whose extension
    /// says nothing. `None` when the content looks like no mesh format.
    pub fn sniff(bytes: &[u8]) -> Option<Format> {
        if bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n") {
            return Some(Format::Ply);
        }
        if bytes.starts_with(b"glTF") {
            return Some(Format::Glb);
        }
        if gltf_file::looks_like_gltf_json(bytes) {
            return Some(Format::Gltf);
        }
        // The size test comes before the text tests because binary STL headers
        // may begin with "solid" too.
        if stl::is_binary(bytes) {
            return Some(Format::Stl);
        }
        // A first line that is not text (a Latin-1 comment, say) still may
        // start an OBJ file.
        let text = first_line_text(bytes).unwrap_or("");
        if off::is_header_keyword(text.split_ascii_whitespace().next().unwrap_or("")) {
            return Some(Format::Off);
        }
        if text.trim_start().starts_with("solid") {
            return Some(Format::Stl);
        }
        if obj::looks_like_obj(bytes) {
            return Some(Format::Obj);
        }
        None
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Format::Obj => "OBJ",
            Format::Ply => "PLY",
            Format::Off => "OFF",
            Format::Stl => "STL",
            Format::Gltf => "glTF",
            Format::Glb => "GLB",
        })
    }
}

/// Reads a mesh file, choosing the format by extension or, for an unknown
/// extension, by content. Only positions and faces are read; a glTF file's
/// external buffers are read from the file's folder.
pub fn read_mesh(path: &Path) -> Result<PolyMesh, MeshError> {
    read_file(path, None).map(|asset| asset.mesh)
}

/// Reads a mesh file with its appearance: what [`read_mesh`] reads, and
/// vertex colours, texture coordinates, materials and their base colour
/// textures where the format has them, with the list of what was not kept
/// ([`Asset::dropped`]). Files the mesh file names (`.mtl`, images, glTF
/// buffers) are resolved against its folder. A missing or unreadable
/// material library or image is not an error: it is listed as dropped. (A
/// missing glTF buffer is an error: the geometry is in it.)
pub fn read_asset(path: &Path, options: &AssetOptions) -> Result<Asset, MeshError> {
    read_file(path, Some(options))
}

fn read_file(path: &Path, appearance: Option<&AssetOptions>) -> Result<Asset, MeshError> {
    let file = path.display().to_string();
    let bytes = fs::read(path).map_err(|e| MeshError::io(&file, e))?;
    if bytes.is_empty() {
        return Err(MeshError::malformed(&file, None, Problem::Empty));
    }
    let format = match Format::from_path(path) {
        Some(format) => format,
        None => Format::sniff(&bytes).ok_or(MeshError::UnknownFormat { file: file.clone() })?,
    };
    let folder = match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    };
    let source = Source {
        name: &file,
        folder: Some(folder),
        appearance,
    };
    read_source(&bytes, format, &source)
}

/// Reads a mesh in `format` from memory; `name` stands for the file in errors.
/// A glTF file whose buffers are not inside it cannot be read this way.
pub fn read_mesh_bytes(bytes: &[u8], format: Format, name: &str) -> Result<PolyMesh, MeshError> {
    let source = Source {
        name,
        folder: None,
        appearance: None,
    };
    read_source(bytes, format, &source).map(|asset| asset.mesh)
}

/// [`read_asset`] from memory; `name` stands for the file in errors. Files
/// the mesh names (material libraries, images) cannot be found from memory
/// and are listed as dropped; images inside a GLB are read.
pub fn read_asset_bytes(
    bytes: &[u8],
    format: Format,
    name: &str,
    options: &AssetOptions,
) -> Result<Asset, MeshError> {
    let source = Source {
        name,
        folder: None,
        appearance: Some(options),
    };
    read_source(bytes, format, &source)
}

/// What a reader needs besides the bytes.
pub(crate) struct Source<'a> {
    /// The file name, for errors.
    name: &'a str,
    /// The folder that names in the file are relative to; `None` for bytes
    /// read from memory.
    folder: Option<&'a Path>,
    /// `None` to read geometry alone.
    appearance: Option<&'a AssetOptions>,
}

fn read_source(bytes: &[u8], format: Format, source: &Source) -> Result<Asset, MeshError> {
    let name = source.name;
    if bytes.is_empty() {
        return Err(MeshError::malformed(name, None, Problem::Empty));
    }
    match format {
        Format::Obj => obj::read(bytes, source),
        Format::Ply => ply::read(bytes, source),
        Format::Off => {
            let mut asset = Asset::of(off::read(bytes, name)?);
            if source.appearance.is_some() {
                off::report_variant(bytes, asset.mesh.positions.len(), &mut asset.dropped);
            }
            Ok(asset)
        }
        Format::Stl => {
            let mut asset = Asset::of(stl::read(bytes, name)?);
            if source.appearance.is_some() {
                let facets = asset.mesh.face_count() as u64;
                let detail = "facet normals (qm computes normals from the surface)".to_owned();
                add_dropped(&mut asset.dropped, AttributeKind::Normals, facets, detail);
            }
            Ok(asset)
        }
        Format::Gltf | Format::Glb => gltf_file::read(bytes, source),
    }
}

/// Writes `mesh` as OBJ or PLY (by extension) without ever leaving a partial
/// file: the data goes to a temporary file in the same directory, which then
/// replaces `path` by a rename. On any error `path` is untouched.
pub fn write_mesh(path: &Path, mesh: &PolyMesh) -> Result<(), MeshError> {
    let file = path.display().to_string();
    let format = Format::from_path(path).ok_or(MeshError::UnknownFormat { file: file.clone() })?;
    // Checked before touching the disk, so a refused mesh costs no temporary file.
    check_writable(mesh, format, &file)?;
    write_atomic(path, |w| write_unchecked(w, format, mesh, None))
        .map_err(|e| MeshError::io(&file, e))
}

/// [`write_mesh`] with an 8-bit sRGB colour for each vertex: PLY gets
/// `property uchar red`, `green`, `blue` after `x y z`, OBJ gets
/// `v x y z r g b` with `r g b` in 0..1 (six decimals, which read back to
/// the same 8-bit values). Fails, naming the file, when the colour count is
/// not the vertex count, and for everything [`write_mesh`] refuses.
pub fn write_coloured_mesh(
    path: &Path,
    mesh: &PolyMesh,
    colours: &[[u8; 3]],
) -> Result<(), MeshError> {
    let file = path.display().to_string();
    let format = Format::from_path(path).ok_or(MeshError::UnknownFormat { file: file.clone() })?;
    check_coloured(mesh, colours, format, &file)?;
    write_atomic(path, |w| write_unchecked(w, format, mesh, Some(colours)))
        .map_err(|e| MeshError::io(&file, e))
}

/// [`write_coloured_mesh`] to any writer, as [`write_mesh_to`].
pub fn write_coloured_mesh_to(
    w: &mut impl Write,
    format: Format,
    mesh: &PolyMesh,
    colours: &[[u8; 3]],
) -> Result<(), MeshError> {
    const NAME: &str = "<output>";
    check_coloured(mesh, colours, format, NAME)?;
    write_unchecked(w, format, mesh, Some(colours)).map_err(|e| MeshError::io(NAME, e))
}

/// [`check_writable`], and one colour a vertex.
fn check_coloured(
    mesh: &PolyMesh,
    colours: &[[u8; 3]],
    format: Format,
    file: &str,
) -> Result<(), MeshError> {
    check_writable(mesh, format, file)?;
    if colours.len() != mesh.positions.len() {
        return Err(MeshError::InvalidMesh {
            file: file.to_owned(),
            problem: Problem::ColourCount {
                colours: colours.len(),
                vertices: mesh.positions.len(),
            },
        });
    }
    Ok(())
}

/// Writes a file without ever leaving a partial one: `write` fills a
/// temporary file in the same directory, which is synced and then renamed
/// over `path`. The file gets the mode of the file it replaces, or the usual
/// mode of a new file. On any error `path` is untouched.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut fs::File) -> io::Result<()>,
) -> io::Result<()> {
    let dir = match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    builder.prefix(".qm-").suffix(".tmp");
    // tempfile creates files readable by the owner only.
    let permissions = match fs::metadata(path) {
        Ok(meta) => Some(meta.permissions()),
        Err(_) => default_permissions(),
    };
    if let Some(permissions) = permissions {
        builder.permissions(permissions);
    }
    let mut temp = builder.tempfile_in(dir)?;
    let _pending = Pending::register(temp.path());
    write(temp.as_file_mut())?;
    // Without the sync a crash soon after the rename could leave an empty file
    // where the old one was.
    temp.as_file().sync_all()?;
    temp.persist(path).map_err(|e| e.error)?;
    Ok(())
}

/// Writes `bytes` to `path` whole or not at all ([`write_atomic`]); a
/// failure names the file.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), MeshError> {
    write_atomic(path, |w| w.write_all(bytes))
        .map_err(|e| MeshError::io(&path.display().to_string(), e))
}

/// The temporary files of [`write_atomic`]s in progress.
static PENDING: std::sync::Mutex<Vec<std::path::PathBuf>> = std::sync::Mutex::new(Vec::new());

/// One temporary file listed in [`PENDING`] while it is written.
struct Pending(std::path::PathBuf);

impl Pending {
    fn register(path: &Path) -> Self {
        if let Ok(mut list) = PENDING.lock() {
            list.push(path.to_path_buf());
        }
        Pending(path.to_path_buf())
    }
}

impl Drop for Pending {
    fn drop(&mut self) {
        if let Ok(mut list) = PENDING.lock() {
            list.retain(|p| p != &self.0);
        }
    }
}

/// Removes the temporary files of the [`write_atomic`]s in progress: for a
/// program's interrupt and terminate handlers, which end the process
/// without running destructors. (A hard kill leaves them: hidden
/// `.qm-*.tmp` files beside the output.)
pub fn remove_partial_outputs() {
    remove_pending(|_| true);
}

/// Removes the temporary files in progress that `which` picks.
fn remove_pending(which: impl Fn(&Path) -> bool) {
    if let Ok(list) = PENDING.lock() {
        for path in list.iter().filter(|p| which(p)) {
            let _ = fs::remove_file(path);
        }
    }
}

/// Writes `mesh` as OBJ or PLY to `w`.
pub fn write_mesh_to(w: &mut impl Write, format: Format, mesh: &PolyMesh) -> Result<(), MeshError> {
    const NAME: &str = "<output>";
    check_writable(mesh, format, NAME)?;
    write_unchecked(w, format, mesh, None).map_err(|e| MeshError::io(NAME, e))
}

#[cfg(unix)]
fn default_permissions() -> Option<fs::Permissions> {
    use std::os::unix::fs::PermissionsExt;
    // The process umask still applies, as for any newly created file.
    Some(fs::Permissions::from_mode(0o666))
}

#[cfg(not(unix))]
fn default_permissions() -> Option<fs::Permissions> {
    None
}

fn write_unchecked(
    w: &mut impl Write,
    format: Format,
    mesh: &PolyMesh,
    colours: Option<&[[u8; 3]]>,
) -> io::Result<()> {
    let mut w = BufWriter::new(w);
    match format {
        Format::Obj => obj::write(&mut w, mesh, colours)?,
        Format::Ply => ply::write(&mut w, mesh, colours)?,
        Format::Off | Format::Stl | Format::Gltf | Format::Glb => {
            unreachable!("check_writable refuses {format}")
        }
    }
    w.flush()
}

/// Refuses what the readers would refuse, so every written file reads back.
fn check_writable(mesh: &PolyMesh, format: Format, file: &str) -> Result<(), MeshError> {
    let invalid = |problem| MeshError::InvalidMesh {
        file: file.to_owned(),
        problem,
    };
    let max_corners = match format {
        Format::Obj => usize::MAX,
        Format::Ply => ply::MAX_WRITTEN_CORNERS,
        Format::Off | Format::Stl | Format::Gltf | Format::Glb => {
            return Err(MeshError::UnsupportedOutput {
                file: file.to_owned(),
                format,
            });
        }
    };
    let vertices = mesh.positions.len();
    if vertices == 0 {
        return Err(invalid(Problem::NoVertices));
    }
    if mesh.face_count() == 0 {
        return Err(invalid(Problem::NoFaces));
    }
    let max_vertices = if format == Format::Ply {
        ply::MAX_WRITTEN_VERTICES as u64
    } else {
        MAX_VERTICES
    };
    if vertices as u64 > max_vertices {
        return Err(invalid(Problem::TooMany {
            what: "vertices",
            count: vertices as u64,
            max: max_vertices,
        }));
    }
    if let Some(vertex) = mesh.positions.iter().position(|p| !p.is_finite()) {
        return Err(invalid(Problem::NonFiniteCoordinate { vertex }));
    }
    for face in mesh.faces() {
        if face.len() < 3 {
            return Err(invalid(Problem::TooFewCorners {
                corners: face.len(),
            }));
        }
        if face.len() > max_corners {
            return Err(invalid(Problem::TooManyCorners {
                corners: face.len(),
                max: max_corners,
            }));
        }
        if let Some(&index) = face.iter().find(|&&i| i as usize >= vertices) {
            return Err(invalid(Problem::IndexOutOfRange {
                index: index.into(),
                vertices,
            }));
        }
    }
    Ok(())
}

/// The most vertices a mesh may have: indices are `u32`. (A `u64`, so that
/// the comparisons mean something on 32-bit targets too.)
const MAX_VERTICES: u64 = u32::MAX as u64;

/// Collects a mesh while enforcing the limits of [`PolyMesh`]'s `u32` indices
/// and offsets, and at the end that there is something to code.
struct MeshBuilder {
    mesh: PolyMesh,
    corners: usize,
}

impl MeshBuilder {
    /// `expected_vertices` must already be bounded by the input size.
    fn with_capacity(expected_vertices: usize) -> Self {
        let mut mesh = PolyMesh::new();
        mesh.positions.reserve(expected_vertices);
        MeshBuilder { mesh, corners: 0 }
    }

    fn vertex_count(&self) -> usize {
        self.mesh.positions.len()
    }

    fn push_position(&mut self, position: DVec3) -> Result<(), Problem> {
        if !position.is_finite() {
            return Err(Problem::NonFiniteCoordinate {
                vertex: self.mesh.positions.len(),
            });
        }
        if self.mesh.positions.len() as u64 >= MAX_VERTICES {
            return Err(Problem::TooMany {
                what: "vertices",
                count: self.mesh.positions.len() as u64 + 1,
                max: MAX_VERTICES,
            });
        }
        self.mesh.positions.push(position);
        Ok(())
    }

    /// Corner indices must already be checked against the vertex count.
    fn push_face(&mut self, corners: &[u32]) -> Result<(), Problem> {
        if corners.len() < 3 {
            return Err(Problem::TooFewCorners {
                corners: corners.len(),
            });
        }
        self.corners += corners.len();
        if self.corners > u32::MAX as usize {
            return Err(Problem::TooMany {
                what: "face corners",
                count: self.corners as u64,
                max: u32::MAX.into(),
            });
        }
        self.mesh.push_face(corners);
        Ok(())
    }

    fn finish(self) -> Result<PolyMesh, Problem> {
        if self.mesh.positions.is_empty() {
            Err(Problem::NoVertices)
        } else if self.mesh.face_count() == 0 {
            Err(Problem::NoFaces)
        } else {
            Ok(self.mesh)
        }
    }
}

/// The lines of a text file with their 1-based numbers, without `\n` or `\r\n`.
fn numbered_lines(bytes: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    bytes
        .split(|&b| b == b'\n')
        .map(|line| line.strip_suffix(b"\r").unwrap_or(line))
        .enumerate()
        .map(|(k, line)| (k + 1, line))
}

/// A line without its `#` comment.
fn strip_comment(line: &[u8]) -> &[u8] {
    match line.iter().position(|&b| b == b'#') {
        Some(end) => &line[..end],
        None => line,
    }
}

/// The first line as text, if the file starts with text at all.
fn first_line_text(bytes: &[u8]) -> Option<&str> {
    let line = numbered_lines(bytes)
        .next()
        .map_or(&[][..], |(_, line)| line);
    std::str::from_utf8(line).ok()
}

/// Parses a coordinate; `None` for anything that is not a number.
fn parse_f64(token: &str) -> Option<f64> {
    token.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_interrupted_write_leaves_no_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.qm");
        let names = || -> Vec<String> {
            let entries = fs::read_dir(dir.path()).unwrap();
            entries
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        };
        let result = write_atomic(&out, |file| {
            file.write_all(b"half")?;
            assert_eq!(names().len(), 1, "the temporary file");
            // What the interrupt handler does, to this folder's files
            // alone: other tests write beside it in the same process.
            remove_pending(|p| p.starts_with(dir.path()));
            assert_eq!(names(), Vec::<String>::new());
            Ok(())
        });
        assert!(result.is_err(), "nothing to rename");
        assert_eq!(names(), Vec::<String>::new());
        write_atomic(&out, |file| file.write_all(b"whole")).unwrap();
        remove_pending(|p| p.starts_with(dir.path()));
        assert_eq!(fs::read(&out).unwrap(), b"whole", "finished files stay");
    }

    fn quad_and_triangle() -> PolyMesh {
        let positions = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.5, 0.5, 1.0 / 3.0),
        ];
        let mut mesh = PolyMesh::from_faces(positions, &[[0, 1, 2, 3]]);
        mesh.push_face(&[1, 2, 4]);
        mesh
    }

    /// Positions whose decimal forms are long or unusual, in a triangle, a
    /// quad and a pentagon.
    pub(super) fn awkward_mesh() -> PolyMesh {
        let positions = vec![
            DVec3::new(0.1, 0.2, 0.3),
            DVec3::new(1.0 / 3.0, -2.0 / 7.0, std::f64::consts::PI),
            DVec3::new(-0.0, 5e-324, 1e-300),
            DVec3::new(f64::MAX, f64::MIN_POSITIVE, -1.797_693_134_862_315_7e308),
            DVec3::new(123_456_789.123_456_79, -9.999_999_999_999_999e-5, 2.5),
            DVec3::new(1e22, 0.300_000_000_000_000_04, 7.0),
        ];
        let mut mesh = PolyMesh::from_faces(positions, &[[0, 1, 2]]);
        mesh.push_face(&[0, 2, 3, 4]);
        mesh.push_face(&[1, 2, 3, 4, 5]);
        mesh
    }

    /// Equal meshes whose coordinates also agree bit for bit (`==` would take
    /// -0.0 for 0.0).
    pub(super) fn assert_bit_exact(a: &PolyMesh, b: &PolyMesh) {
        assert_eq!(a, b);
        for (p, q) in a.positions.iter().zip(&b.positions) {
            for k in 0..3 {
                assert_eq!(p[k].to_bits(), q[k].to_bits(), "{p} vs {q}");
            }
        }
    }

    /// Coloured PLY and OBJ files read back with the same geometry and the
    /// same 8-bit colours, through the atomic writer and the `_to` one.
    #[test]
    fn coloured_meshes_round_trip() {
        let mesh = awkward_mesh();
        let colours: Vec<[u8; 3]> = (0..mesh.positions.len() as u8)
            .map(|k| [k * 51, 255 - k * 37, k.wrapping_mul(89)])
            .collect();
        let dir = tempfile::tempdir().unwrap();
        for name in ["c.ply", "c.obj"] {
            let path = dir.path().join(name);
            write_coloured_mesh(&path, &mesh, &colours).unwrap();
            let asset = read_asset(&path, &AssetOptions::DEFAULT).unwrap();
            assert_bit_exact(&mesh, &asset.mesh);
            let back: Vec<[u8; 3]> = asset
                .colors
                .expect("colours read back")
                .iter()
                .map(|c| [0, 1, 2].map(|k| (c[k] * 255.0).round() as u8))
                .collect();
            assert_eq!(back, colours, "{name}");
            assert!(asset.dropped.is_empty(), "{name}: {:?}", asset.dropped);
            let mut bytes = Vec::new();
            let format = Format::from_path(&path).unwrap();
            write_coloured_mesh_to(&mut bytes, format, &mesh, &colours).unwrap();
            assert_eq!(bytes, fs::read(&path).unwrap(), "{name}");
        }
        // PLY `uchar` values are the bytes themselves.
        let asset = read_asset(&dir.path().join("c.ply"), &AssetOptions::DEFAULT).unwrap();
        let exact: Vec<[f32; 4]> = colours
            .iter()
            .map(|c| [c[0], c[1], c[2], 255].map(|x| (f64::from(x) / 255.0) as f32))
            .collect();
        assert_eq!(asset.colors, Some(exact));
    }

    #[test]
    fn a_colour_count_other_than_the_vertex_count_is_refused() {
        let mesh = quad_and_triangle();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("few.ply");
        let err = write_coloured_mesh(&path, &mesh, &[[0; 3]; 4]).unwrap_err();
        let text = err.to_string();
        assert!(
            text.contains("few.ply") && text.contains("4 colours for 5 vertices"),
            "{text}"
        );
        assert!(!path.exists());
        assert_eq!(
            fs::read_dir(dir.path()).unwrap().count(),
            0,
            "no temporary file"
        );
        let err = write_coloured_mesh_to(&mut Vec::new(), Format::Obj, &mesh, &[]).unwrap_err();
        assert!(
            err.to_string().contains("0 colours for 5 vertices"),
            "{err}"
        );
    }

    fn points(n: usize) -> PolyMesh {
        let mut mesh = PolyMesh::new();
        mesh.positions = vec![DVec3::ZERO; n];
        mesh
    }

    #[test]
    fn format_from_extension_ignores_case() {
        assert_eq!(Format::from_path(Path::new("a/b.OBJ")), Some(Format::Obj));
        assert_eq!(Format::from_path(Path::new("b.Ply")), Some(Format::Ply));
        assert_eq!(Format::from_path(Path::new("b.off")), Some(Format::Off));
        assert_eq!(Format::from_path(Path::new("b.stL")), Some(Format::Stl));
        assert_eq!(Format::from_path(Path::new("b.mesh")), None);
        assert_eq!(Format::from_path(Path::new("obj")), None);
    }

    #[test]
    fn sniffing_tells_formats_apart() {
        assert_eq!(Format::sniff(b"ply\nformat ascii 1.0\n"), Some(Format::Ply));
        assert_eq!(Format::sniff(b"OFF\n3 1 0\n"), Some(Format::Off));
        assert_eq!(Format::sniff(b"COFF\n3 1 0\n"), Some(Format::Off));
        assert_eq!(
            Format::sniff(b"solid x\nfacet normal 0 0 1\n"),
            Some(Format::Stl)
        );
        assert_eq!(Format::sniff(b"# cube\nv 0 0 0\n"), Some(Format::Obj));
        let mut binary_stl = b"solid but binary".to_vec();
        binary_stl.resize(80, 0);
        binary_stl.extend_from_slice(&1u32.to_le_bytes());
        binary_stl.resize(84 + 50, 0);
        assert_eq!(Format::sniff(&binary_stl), Some(Format::Stl));
        assert_eq!(Format::sniff(b"hello world\n"), None);
        assert_eq!(Format::sniff(&[0xff, 0xfe, 0x00, 0x12, 0x80]), None);
    }

    #[test]
    fn read_mesh_sniffs_unknown_extension_and_refuses_garbage() {
        let dir = tempfile::tempdir().unwrap();
        let off = dir.path().join("mesh.dat");
        fs::write(&off, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").unwrap();
        assert_eq!(read_mesh(&off).unwrap().face_count(), 1);

        let garbage = dir.path().join("noise.bin");
        fs::write(&garbage, [0x00u8, 0x9f, 0x13, 0xff, 0x42]).unwrap();
        let err = read_mesh(&garbage).unwrap_err();
        assert!(matches!(err, MeshError::UnknownFormat { .. }), "{err}");
        assert!(
            err.to_string().contains("noise.bin: unknown mesh format"),
            "{err}"
        );
    }

    #[test]
    fn missing_file_is_an_io_error_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("absent.obj");
        let err = read_mesh(&path).unwrap_err();
        let MeshError::Io { cause, .. } = &err else {
            panic!("{err:?}")
        };
        assert_eq!(cause.kind(), io::ErrorKind::NotFound);
        // Named once: the cause is in the message, not also the source.
        assert_eq!(err.to_string(), format!("{}: {cause}", path.display()));
        assert!(std::error::Error::source(&err).is_none());
    }

    #[test]
    fn empty_file_is_reported_for_every_format() {
        for format in [Format::Obj, Format::Ply, Format::Off, Format::Stl] {
            let err = read_mesh_bytes(b"", format, "e").unwrap_err();
            assert_eq!(err.problem(), Some(&Problem::Empty));
            assert_eq!(err.to_string(), "e: file is empty");
        }
    }

    #[test]
    fn write_mesh_round_trips_through_files() {
        let dir = tempfile::tempdir().unwrap();
        let mesh = quad_and_triangle();
        for name in ["m.obj", "m.PLY"] {
            let path = dir.path().join(name);
            write_mesh(&path, &mesh).unwrap();
            assert_eq!(read_mesh(&path).unwrap(), mesh, "{name}");
        }
        let left: Vec<_> = fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left.len(), 2, "no temporary files left: {left:?}");
    }

    #[cfg(unix)]
    #[test]
    fn written_files_get_the_mode_of_ordinary_new_files() {
        use std::os::unix::fs::PermissionsExt;
        let mode = |path: &Path| fs::metadata(path).unwrap().permissions().mode() & 0o777;
        let dir = tempfile::tempdir().unwrap();
        let reference = dir.path().join("plain.txt");
        fs::write(&reference, "x").unwrap();
        let path = dir.path().join("m.obj");
        write_mesh(&path, &quad_and_triangle()).unwrap();
        assert_eq!(mode(&path), mode(&reference));
        // Replacing a file keeps its mode.
        fs::set_permissions(&path, fs::Permissions::from_mode(0o640)).unwrap();
        write_mesh(&path, &quad_and_triangle()).unwrap();
        assert_eq!(mode(&path), 0o640);
    }

    #[test]
    fn failed_write_leaves_the_old_file_untouched() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("keep.obj");
        fs::write(&path, "old content").unwrap();
        let mut bad = quad_and_triangle();
        bad.positions[2].y = f64::NAN;
        let err = write_mesh(&path, &bad).unwrap_err();
        assert!(matches!(err, MeshError::InvalidMesh { .. }));
        assert_eq!(
            err.to_string(),
            format!(
                "{}: cannot write mesh: vertex 2 has a NaN or infinite coordinate",
                path.display()
            )
        );
        assert_eq!(fs::read_to_string(&path).unwrap(), "old content");
        assert_eq!(
            fs::read_dir(dir.path()).unwrap().count(),
            1,
            "no temporary file left"
        );
    }

    #[test]
    fn write_into_missing_directory_names_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("no/such/dir/m.ply");
        let err = write_mesh(&path, &quad_and_triangle()).unwrap_err();
        assert!(matches!(err, MeshError::Io { .. }));
        assert!(err.to_string().contains("m.ply"), "{err}");
    }

    #[test]
    fn off_and_stl_output_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["m.off", "m.stl"] {
            let err = write_mesh(&dir.path().join(name), &quad_and_triangle()).unwrap_err();
            assert!(matches!(err, MeshError::UnsupportedOutput { .. }));
            assert!(
                err.to_string().contains("unsupported output format"),
                "{err}"
            );
        }
        let err = write_mesh(&dir.path().join("m.xyz"), &quad_and_triangle()).unwrap_err();
        assert!(matches!(err, MeshError::UnknownFormat { .. }));
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn writers_refuse_meshes_the_readers_would_refuse() {
        let mut out = Vec::new();
        let cases: [(PolyMesh, Problem); 4] = [
            (PolyMesh::new(), Problem::NoVertices),
            (points(3), Problem::NoFaces),
            (
                PolyMesh::from_faces(vec![DVec3::ZERO; 3], &[[0, 1]]),
                Problem::TooFewCorners { corners: 2 },
            ),
            (
                PolyMesh::from_faces(vec![DVec3::ZERO; 3], &[[0, 1, 3]]),
                Problem::IndexOutOfRange {
                    index: 3,
                    vertices: 3,
                },
            ),
        ];
        for (mesh, problem) in cases {
            for format in [Format::Obj, Format::Ply] {
                let err = write_mesh_to(&mut out, format, &mesh).unwrap_err();
                assert_eq!(err.problem(), Some(&problem));
            }
        }
        assert!(out.is_empty());
        let big_face: Vec<u32> = (0..300).collect();
        let mut mesh = points(300);
        mesh.push_face(&big_face);
        let err = write_mesh_to(&mut out, Format::Ply, &mesh).unwrap_err();
        assert_eq!(
            err.problem(),
            Some(&Problem::TooManyCorners {
                corners: 300,
                max: 255
            })
        );
        write_mesh_to(&mut out, Format::Obj, &mesh).unwrap();
    }
}
