//! Writing a mesh with a texture: OBJ with its `.mtl` library and a PNG
//! image beside it, each file written whole or not at all.

use std::collections::HashMap;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use crate::{Format, MeshError, PolyMesh, Problem, check_writable, write_atomic};

/// A texture to write with a mesh: an 8-bit sRGB image and the texture
/// coordinates of every face corner.
#[derive(Clone, Copy, Debug)]
pub struct OutputTexture<'a> {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// `width * height` texels, row by row from the top.
    pub texels: &'a [[u8; 3]],
    /// The coordinates of each face corner, in the order of
    /// [`PolyMesh::faces`] with all faces concatenated: `(0, 0)` at the
    /// image's top-left corner, as glTF has them and the readers give them.
    pub corners: &'a [[f32; 2]],
}

/// The files [`write_textured_mesh`] writes for `path`: the mesh itself,
/// its material library and its image, beside one another (`NAME.obj`,
/// `NAME.mtl`, `NAME.png`).
pub fn textured_files(path: &Path) -> [PathBuf; 3] {
    [
        path.to_path_buf(),
        path.with_extension("mtl"),
        path.with_extension("png"),
    ]
}

/// Writes `mesh` with `texture` as OBJ (`vt` lines, one a distinct
/// coordinate, and each face fanned into `f v/vt` triangles from its first
/// corner, the diagonal a qm texture is sampled on), a material library naming the
/// image as `map_Kd`, and the image as PNG ([`textured_files`]); each file
/// is written whole or not at all, the image first and the mesh last, and
/// a failure removes those written before it.
/// Fails, naming the file, for another format than OBJ, a texel count
/// other than `width * height`, a corner count other than the mesh's, and
/// for everything [`write_mesh`](crate::write_mesh) refuses.
pub fn write_textured_mesh(
    path: &Path,
    mesh: &PolyMesh,
    texture: &OutputTexture,
) -> Result<(), MeshError> {
    let file = path.display().to_string();
    let format = Format::from_path(path).ok_or(MeshError::UnknownFormat { file: file.clone() })?;
    if format != Format::Obj {
        return Err(MeshError::UnsupportedOutput { file, format });
    }
    check_writable(mesh, format, &file)?;
    let invalid = |problem: String| MeshError::InvalidMesh {
        file: file.clone(),
        problem: Problem::Texture(problem),
    };
    let corners: usize = mesh.faces().map(<[u32]>::len).sum();
    if texture.corners.len() != corners {
        return Err(invalid(format!(
            "texture coordinates for {} corners, the faces have {corners}",
            texture.corners.len()
        )));
    }
    let texels = texture.width as u64 * texture.height as u64;
    if texture.texels.len() as u64 != texels || texels == 0 {
        return Err(invalid(format!(
            "{} texels for a {}x{} image",
            texture.texels.len(),
            texture.width,
            texture.height
        )));
    }
    let [_, mtl, png] = textured_files(path);
    let name = |p: &Path| p.file_name().map(|n| n.to_string_lossy().into_owned());
    let (mtl_name, png_name) = (
        name(&mtl).unwrap_or_default(),
        name(&png).unwrap_or_default(),
    );
    let io = |p: &Path| {
        let file = p.display().to_string();
        move |e: io::Error| MeshError::io(&file, e)
    };
    write_atomic(&png, |w| {
        w.write_all(&png_bytes(texture.width, texture.height, texture.texels))
    })
    .map_err(io(&png))?;
    // A failure after the image leaves none of the three files behind.
    let undo = |e: MeshError, written: &[&Path]| {
        for p in written {
            let _ = std::fs::remove_file(p);
        }
        e
    };
    write_atomic(&mtl, |w| {
        write!(
            w,
            "# written by qm\nnewmtl qm\nKd 1 1 1\nmap_Kd {png_name}\n"
        )
    })
    .map_err(|e| undo(io(&mtl)(e), &[&png]))?;
    write_atomic(path, |w| {
        let mut w = io::BufWriter::new(w);
        write_obj(&mut w, mesh, texture, &mtl_name)?;
        w.flush()
    })
    .map_err(|e| undo(io(path)(e), &[&png, &mtl]))
}

/// The OBJ text of [`write_textured_mesh`].
fn write_obj(
    w: &mut impl Write,
    mesh: &PolyMesh,
    texture: &OutputTexture,
    library: &str,
) -> io::Result<()> {
    writeln!(
        w,
        "# written by qm: {} vertices, {} faces, a {}x{} texture\nmtllib {library}",
        mesh.positions.len(),
        mesh.face_count(),
        texture.width,
        texture.height
    )?;
    for p in &mesh.positions {
        writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
    }
    // One `vt` a distinct coordinate; OBJ's v runs up the image.
    let mut index: HashMap<[u32; 2], usize> = HashMap::new();
    let mut corner_vt = Vec::with_capacity(texture.corners.len());
    for &[u, v] in texture.corners {
        let next = index.len() + 1;
        let k = *index
            .entry([u.to_bits(), v.to_bits()])
            .or_insert_with(|| next);
        if k == next {
            writeln!(w, "vt {} {}", u, 1.0 - v)?;
        }
        corner_vt.push(k);
    }
    w.write_all(b"usemtl qm\n")?;
    // Triangles, each face fanned from its first corner: the diagonal the
    // texture was sampled on, whatever an importer would choose for a quad.
    let mut first = 0;
    for face in mesh.faces() {
        for k in 1..face.len().saturating_sub(1) {
            w.write_all(b"f")?;
            for c in [0, k, k + 1] {
                write!(w, " {}/{}", u64::from(face[c]) + 1, corner_vt[first + c])?;
            }
            w.write_all(b"\n")?;
        }
        first += face.len();
    }
    Ok(())
}

/// An image of `width * height` 8-bit sRGB texels, rows from the top, as
/// PNG bytes.
///
/// # Panics
///
/// If `texels` is not `width * height` long or either side is 0.
pub fn png_bytes(width: u32, height: u32, texels: &[[u8; 3]]) -> Vec<u8> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(
            texels.as_flattened(),
            width,
            height,
            image::ExtendedColorType::Rgb8,
        )
        .expect("a PNG of valid dimensions into memory");
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{AssetOptions, read_asset};
    use glam::DVec3;

    #[test]
    fn a_textured_mesh_reads_back_with_its_texture() {
        let dir = tempfile::tempdir().unwrap();
        let mesh = PolyMesh::from_faces(
            vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y],
            &[[0u32, 1, 2, 3]],
        );
        let texels: Vec<[u8; 3]> = (0..6).map(|k| [k * 40, 255 - k * 40, 7]).collect();
        let corners = [[0.25, 0.25], [0.75, 0.25], [0.75, 0.75], [0.25, 0.75]];
        let texture = OutputTexture {
            width: 3,
            height: 2,
            texels: &texels,
            corners: &corners,
        };
        let path = dir.path().join("out.obj");
        write_textured_mesh(&path, &mesh, &texture).unwrap();
        let asset = read_asset(&path, &AssetOptions::DEFAULT.with_images(true)).unwrap();
        assert_eq!(asset.mesh.positions, mesh.positions);
        // Two triangles along the diagonal from the first corner.
        let faces: Vec<&[u32]> = asset.mesh.faces().collect();
        assert_eq!(faces, [&[0, 1, 2][..], &[0, 2, 3][..]]);
        let uv = asset.tex_coords.unwrap();
        let back: Vec<[f32; 2]> = (0..6).map(|c| uv.get(c).unwrap()).collect();
        let fanned = [0, 1, 2, 0, 2, 3].map(|c| corners[c]);
        assert_eq!(back, fanned);
        let image = asset.materials[0]
            .base_color_texture
            .as_ref()
            .unwrap()
            .image
            .as_ref()
            .unwrap();
        assert_eq!((image.width, image.height), (3, 2));
        let rgb: Vec<[u8; 3]> = image.rgba.chunks(4).map(|p| [p[0], p[1], p[2]]).collect();
        assert_eq!(rgb, texels);
        // Wrong counts and formats are refused, naming the file; nothing
        // is written for them.
        let short = OutputTexture {
            corners: &corners[..3],
            ..texture
        };
        let other = dir.path().join("other.obj");
        let e = write_textured_mesh(&other, &mesh, &short).unwrap_err();
        assert!(e.to_string().contains("other.obj"), "{e}");
        assert!(textured_files(&other).iter().all(|p| !p.exists()));
        let e = write_textured_mesh(&dir.path().join("x.ply"), &mesh, &texture).unwrap_err();
        assert!(e.to_string().contains("x.ply"), "{e}");
        // The mesh file cannot be written (a folder is in its place): the
        // image and the library written before it are gone too.
        let blocked = dir.path().join("blocked.obj");
        std::fs::create_dir(&blocked).unwrap();
        let e = write_textured_mesh(&blocked, &mesh, &texture).unwrap_err();
        assert!(e.to_string().contains("blocked.obj"), "{e}");
        let [_, mtl, png] = textured_files(&blocked);
        assert!(!mtl.exists() && !png.exists());
    }
}
