//! Wavefront OBJ: vertex positions (`v`) and faces (`f`, `fo`).
//!
//! A face corner is `v`, `v/vt`, `v//vn` or `v/vt/vn`. Each index counts
//! from 1, and a negative value counts back from the last vertex read so
//! far (-1 is the latest). A positive index may refer to a vertex defined
//! further down; it is checked once the whole file is read. Groups, objects and
//! materials do not renumber vertices: all faces index one shared vertex list,
//! which is what keeps a surface connected across group borders. Lines (`l`),
//! points (`p`), texture coordinates, normals, curves and every other statement
//! are skipped for the geometry. A `v` line may carry a fourth (weight) or
//! three further (colour) values.
//!
//! With appearance ([`crate::read_asset`]): `v x y z r g b` colours (0..1,
//! every vertex or none), `vt u [v]` and the corners' texture indices (a bad
//! index drops the texture coordinates, not the mesh), `usemtl`, and the
//! `mtllib` libraries ([`crate::mtl`]) beside the file; `vn`, `l` and `p` are
//! counted as dropped.

use std::collections::HashMap;
use std::io::{self, Write};

use super::{
    MAX_VERTICES, MeshBuilder, MeshError, Problem, Source, numbered_lines, parse_f64, strip_comment,
};
use crate::asset::{self, add_dropped};
use crate::{Asset, AttributeKind as Kind, Material, PolyMesh, TexCoords};
use glam::DVec3;

pub(super) fn read(bytes: &[u8], source: &Source) -> Result<Asset, MeshError> {
    let file = source.name;
    let fail = |line, problem| MeshError::malformed(file, Some(line), problem);
    let mut builder = MeshBuilder::with_capacity(0);
    let mut corners = Vec::new();
    let mut look = source.appearance.map(|_| Look::default());
    // The largest index beyond the vertices read so far, with its line: legal
    // as long as the file defines that many vertices in the end.
    let mut forward: Option<(i64, usize)> = None;
    for (number, line) in numbered_lines(bytes) {
        let content = strip_comment(line);
        let mut tokens = content
            .split(u8::is_ascii_whitespace)
            .filter(|token| !token.is_empty());
        let keyword = tokens.next();
        match keyword {
            Some(b"v") => {
                let position = parse_position(&mut tokens).map_err(|p| fail(number, p))?;
                builder
                    .push_position(position)
                    .map_err(|p| fail(number, p))?;
                if let Some(look) = &mut look {
                    look.vertex_extras(number, tokens);
                }
            }
            Some(b"f" | b"fo") => {
                corners.clear();
                let vertices = builder.vertex_count();
                for token in tokens {
                    let index = parse_corner(token).map_err(|p| fail(number, p))?;
                    let resolved = resolve(index, vertices).map_err(|p| fail(number, p))?;
                    if resolved as usize >= vertices && forward.is_none_or(|(max, _)| index > max) {
                        forward = Some((index, number));
                    }
                    corners.push(resolved);
                    if let Some(look) = &mut look {
                        look.corner(number, token);
                    }
                }
                builder.push_face(&corners).map_err(|p| fail(number, p))?;
                if let Some(look) = &mut look {
                    look.face_done();
                }
            }
            Some(other) => {
                if let Some(look) = &mut look {
                    look.statement(number, other, content, tokens);
                }
            }
            None => {}
        }
    }
    let vertices = builder.vertex_count();
    if let Some((index, number)) = forward {
        if index as usize > vertices {
            return Err(fail(number, Problem::IndexOutOfRange { index, vertices }));
        }
    }
    let mesh = builder
        .finish()
        .map_err(|p| MeshError::malformed(file, None, p))?;
    let mut asset = Asset::of(mesh);
    if let (Some(look), Some(options)) = (look, source.appearance) {
        look.finish(&mut asset, source, options);
    }
    Ok(asset)
}

/// What an OBJ file says beyond positions and faces, collected while reading
/// for [`crate::read_asset`].
#[derive(Default)]
struct Look {
    /// Vertex colours (`v x y z r g b`), one per vertex while every vertex so
    /// far had one.
    colors: Vec<[f32; 4]>,
    /// Vertices with three values after the position.
    colored: usize,
    /// Vertices without.
    plain: usize,
    /// Why the colours cannot be used, if they cannot.
    color_problem: Option<String>,
    /// `vt` values, v already flipped.
    tex_values: Vec<[f32; 2]>,
    /// Texture index per corner read so far (or [`TexCoords::NONE`]).
    tex_corners: Vec<u32>,
    /// Whether any corner has a texture index.
    textured: bool,
    /// The largest texture index beyond the `vt` read so far, with its line.
    tex_forward: Option<(i64, usize)>,
    /// Why the texture coordinates cannot be used, if they cannot.
    tex_problem: Option<String>,
    /// Material names in order of first `usemtl`.
    material_names: Vec<String>,
    material_index: HashMap<String, u32>,
    /// The current material (`None` before any `usemtl`).
    current: Option<u32>,
    /// The material of each face.
    face_materials: Vec<Option<u32>>,
    /// `mtllib` arguments with their lines.
    libraries: Vec<(usize, String)>,
    normals: u64,
    lines: u64,
    points: u64,
}

impl Look {
    fn vertex_extras<'a>(&mut self, number: usize, extras: impl Iterator<Item = &'a [u8]>) {
        let extras: Vec<&[u8]> = extras.collect();
        // A fourth value alone is a weight, not a colour.
        if extras.len() != 3 {
            self.plain += 1;
            return;
        }
        self.colored += 1;
        let mut rgba = [1.0f32; 4];
        for (k, token) in extras.iter().enumerate() {
            let value = std::str::from_utf8(token)
                .ok()
                .and_then(|t| t.parse::<f32>().ok());
            match value {
                Some(v) if (0.0..=1.0).contains(&v) => rgba[k] = v,
                _ => {
                    self.color_problem.get_or_insert_with(|| {
                        format!(
                            "line {number}: colour value {:?} is not in 0..1",
                            String::from_utf8_lossy(token)
                        )
                    });
                }
            }
        }
        if self.color_problem.is_none() {
            self.colors.push(rgba);
        }
    }

    /// The texture part of a face corner (`v/vt`, `v/vt/vn`).
    fn corner(&mut self, number: usize, token: &[u8]) {
        let mut parts = token.split(|&b| b == b'/');
        parts.next();
        let index = match parts.next() {
            Some(t) if !t.is_empty() => t,
            _ => {
                self.tex_corners.push(TexCoords::NONE);
                return;
            }
        };
        self.textured = true;
        let written = std::str::from_utf8(index)
            .ok()
            .and_then(|t| t.parse::<i64>().ok());
        let count = self.tex_values.len();
        match written.map(|i| (i, resolve(i, count))) {
            Some((i, Ok(resolved))) => {
                if resolved as usize >= count && self.tex_forward.is_none_or(|(max, _)| i > max) {
                    self.tex_forward = Some((i, number));
                }
                self.tex_corners.push(resolved);
            }
            _ => {
                self.tex_corners.push(TexCoords::NONE);
                self.tex_problem.get_or_insert_with(|| {
                    format!(
                        "line {number}: texture index {:?} out of range ({count} vt)",
                        String::from_utf8_lossy(index)
                    )
                });
            }
        }
    }

    fn face_done(&mut self) {
        self.face_materials.push(self.current);
    }

    fn statement<'a>(
        &mut self,
        number: usize,
        keyword: &[u8],
        content: &[u8],
        mut tokens: impl Iterator<Item = &'a [u8]>,
    ) {
        // The rest of the line after the keyword: names may hold spaces.
        let rest = || {
            let text = String::from_utf8_lossy(content);
            let text = text.trim_start();
            text[keyword.len().min(text.len())..].trim().to_owned()
        };
        match keyword {
            b"vt" => {
                let mut uv = [0.0f32; 2];
                for (k, value) in uv.iter_mut().enumerate() {
                    let token = tokens.next();
                    let parsed = token
                        .and_then(|t| std::str::from_utf8(t).ok())
                        .and_then(|t| t.parse::<f32>().ok())
                        .filter(|v| v.is_finite());
                    match (parsed, token) {
                        (Some(v), _) => *value = v,
                        // `vt u` alone: v is 0.
                        (None, None) if k == 1 => {}
                        _ => {
                            self.tex_problem.get_or_insert_with(|| {
                                format!("line {number}: invalid texture coordinate")
                            });
                        }
                    }
                }
                self.tex_values.push([uv[0], 1.0 - uv[1]]);
            }
            b"vn" => self.normals += 1,
            b"l" => self.lines += 1,
            b"p" => self.points += 1,
            b"usemtl" => {
                let name = rest();
                let next = self.material_names.len() as u32;
                let index = *self.material_index.entry(name.clone()).or_insert(next);
                if index == next {
                    self.material_names.push(name);
                }
                self.current = Some(index);
            }
            b"mtllib" => self.libraries.push((number, rest())),
            _ => {}
        }
    }

    fn finish(self, asset: &mut Asset, source: &Source, options: &crate::AssetOptions) {
        let vertices = asset.mesh.positions.len();
        let dropped = &mut asset.dropped;
        if self.colored > 0 {
            let problem = self.color_problem.or_else(|| {
                (self.plain > 0)
                    .then(|| format!("only {} of {vertices} vertices have colours", self.colored))
            });
            match problem {
                None => asset.colors = Some(self.colors),
                Some(why) => {
                    let detail = format!("vertex colours (v x y z r g b) not read: {why}");
                    add_dropped(dropped, Kind::VertexColors, self.colored as u64, detail);
                }
            }
        }
        if self.textured {
            let count = self.tex_values.len();
            let forward = self
                .tex_forward
                .filter(|&(index, _)| index as usize > count)
                .map(|(index, number)| {
                    format!("line {number}: texture index {index} out of range ({count} vt)")
                });
            match self.tex_problem.or(forward) {
                None => {
                    asset.tex_coords = Some(TexCoords {
                        values: self.tex_values,
                        corners: self.tex_corners,
                    });
                }
                Some(why) => {
                    let corners = self.tex_corners.len() as u64;
                    let detail = format!("texture coordinates not read: {why}");
                    add_dropped(dropped, Kind::TexCoords, corners, detail);
                }
            }
        }
        for (count, kind, what) in [
            (
                self.normals,
                Kind::Normals,
                "vn lines (qm computes normals from the surface)",
            ),
            (self.lines, Kind::Lines, "l elements"),
            (self.points, Kind::Points, "p elements"),
        ] {
            if count > 0 {
                add_dropped(dropped, kind, count, what.to_owned());
            }
        }
        if self.material_names.is_empty() {
            return;
        }
        let defined = load_libraries(&self.libraries, source, dropped);
        let mut materials: Vec<Material> = self
            .material_names
            .iter()
            .map(
                |name| match defined.iter().rev().find(|(m, _)| &m.name == name) {
                    Some((m, folder)) => to_material(m, folder.as_deref(), options, dropped),
                    None => {
                        let detail = format!("material {name:?} is defined in no material library");
                        add_dropped(dropped, Kind::Materials, 1, detail);
                        Material::named(name)
                    }
                },
            )
            .collect();
        let unassigned = self.face_materials.iter().any(Option::is_none);
        if unassigned {
            materials.push(Material::named(""));
        }
        let fallback = materials.len() as u32 - 1;
        let faces: Vec<u32> = self
            .face_materials
            .iter()
            .map(|m| m.unwrap_or(fallback))
            .collect();
        if materials.len() > 1 {
            asset.face_materials = Some(faces);
        }
        asset.materials = materials;
    }
}

/// Reads the material libraries `mtllib` names, each with the folder its
/// maps are relative to. A library that cannot be read is reported.
fn load_libraries(
    libraries: &[(usize, String)],
    source: &Source,
    dropped: &mut Vec<crate::Dropped>,
) -> Vec<(crate::mtl::MtlMaterial, Option<std::path::PathBuf>)> {
    let mut found = Vec::new();
    for (number, names) in libraries {
        let Some(folder) = source.folder else {
            let detail =
                format!("line {number}: {names}: not read (the mesh was read from memory)");
            add_dropped(dropped, Kind::Materials, 0, detail);
            continue;
        };
        // `mtllib a.mtl b.mtl` names several; a single name may hold spaces.
        let whole = asset::resolve(folder, names);
        let paths = if whole.is_file() {
            vec![whole]
        } else {
            names
                .split_ascii_whitespace()
                .map(|n| asset::resolve(folder, n))
                .collect()
        };
        for path in paths {
            match std::fs::read(&path) {
                Ok(bytes) => {
                    let label = path.display().to_string();
                    let folder = path.parent().map(std::path::Path::to_path_buf);
                    for material in crate::mtl::parse(&bytes, &label, dropped) {
                        found.push((material, folder.clone()));
                    }
                }
                Err(e) => {
                    let detail = format!("{}: {e}", path.display());
                    add_dropped(dropped, Kind::Materials, 0, detail);
                }
            }
        }
    }
    found
}

fn to_material(
    m: &crate::mtl::MtlMaterial,
    folder: Option<&std::path::Path>,
    options: &crate::AssetOptions,
    dropped: &mut Vec<crate::Dropped>,
) -> Material {
    let [r, g, b] = m.diffuse.unwrap_or([1.0; 3]);
    let texture = match (&m.map, folder) {
        (Some(name), Some(folder)) => {
            let path = asset::resolve(folder, name);
            asset::load_texture(crate::ImageSource::File(path), options, dropped)
        }
        _ => None,
    };
    Material {
        name: m.name.clone(),
        base_color: [r, g, b, m.alpha.unwrap_or(1.0)],
        base_color_texture: texture,
    }
}

fn parse_position<'a>(tokens: &mut impl Iterator<Item = &'a [u8]>) -> Result<DVec3, Problem> {
    let mut xyz = [0.0; 3];
    for (k, value) in xyz.iter_mut().enumerate() {
        let token = tokens
            .next()
            .ok_or_else(|| Problem::Syntax(format!("vertex needs 3 coordinates, found {k}")))?;
        *value = std::str::from_utf8(token)
            .ok()
            .and_then(parse_f64)
            .ok_or_else(|| {
                Problem::Syntax(format!(
                    "invalid coordinate {:?}",
                    String::from_utf8_lossy(token)
                ))
            })?;
    }
    Ok(DVec3::from_array(xyz))
}

/// The vertex index of a corner token, as written (1-based or negative).
fn parse_corner(token: &[u8]) -> Result<i64, Problem> {
    let vertex = token.split(|&b| b == b'/').next().unwrap_or_default();
    std::str::from_utf8(vertex)
        .ok()
        .and_then(|v| v.parse().ok())
        .ok_or_else(|| {
            Problem::Syntax(format!(
                "invalid face corner {:?}",
                String::from_utf8_lossy(token)
            ))
        })
}

/// The 0-based vertex of a written index, given the vertices read so far.
/// Positive indices beyond them are returned for the caller to check later.
fn resolve(index: i64, vertices: usize) -> Result<u32, Problem> {
    let out_of_range = Problem::IndexOutOfRange { index, vertices };
    let resolved = if index > 0 {
        index - 1
    } else if index < 0 {
        // `vertices` is at most MAX_VERTICES, so this cannot overflow.
        vertices as i64 + index
    } else {
        return Err(out_of_range);
    };
    if resolved < 0 || resolved >= MAX_VERTICES as i64 {
        return Err(out_of_range);
    }
    Ok(resolved as u32)
}

/// Whether text content (no NUL bytes) has a vertex statement.
pub(super) fn looks_like_obj(bytes: &[u8]) -> bool {
    !bytes.contains(&0)
        && numbered_lines(bytes).any(|(_, line)| {
            line.split(u8::is_ascii_whitespace).find(|t| !t.is_empty()) == Some(b"v")
        })
}

/// Writes `v x y z` lines with Rust's shortest round-trip formatting (so every
/// position reads back bit-exactly), followed by ` r g b` in 0..1 with six
/// decimals when `colours` are given (one a vertex; each 8-bit value reads
/// back exactly), and 1-based `f` lines, one polygon each.
pub(super) fn write(
    w: &mut impl Write,
    mesh: &PolyMesh,
    colours: Option<&[[u8; 3]]>,
) -> io::Result<()> {
    writeln!(
        w,
        "# written by qm: {} vertices, {} faces",
        mesh.positions.len(),
        mesh.face_count()
    )?;
    for (k, p) in mesh.positions.iter().enumerate() {
        write!(w, "v {} {} {}", p.x, p.y, p.z)?;
        if let Some(colours) = colours {
            let [r, g, b] = colours[k].map(|c| f64::from(c) / 255.0);
            write!(w, " {r:.6} {g:.6} {b:.6}")?;
        }
        w.write_all(b"\n")?;
    }
    for face in mesh.faces() {
        w.write_all(b"f")?;
        for &index in face {
            write!(w, " {}", u64::from(index) + 1)?;
        }
        w.write_all(b"\n")?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tests::{assert_bit_exact, awkward_mesh};
    use crate::{AttributeKind as Kind, Format, read_mesh_bytes, write_mesh_to};

    fn read_str(text: &str) -> Result<PolyMesh, MeshError> {
        read_mesh_bytes(text.as_bytes(), Format::Obj, "t.obj")
    }

    fn err(text: &str) -> MeshError {
        read_str(text).expect_err("malformed input must be refused")
    }

    #[test]
    fn round_trip_is_bit_exact_and_keeps_polygons() {
        let mesh = awkward_mesh();
        let mut text = Vec::new();
        write_mesh_to(&mut text, Format::Obj, &mesh).unwrap();
        let back = read_mesh_bytes(&text, Format::Obj, "mem.obj").unwrap();
        assert_bit_exact(&mesh, &back);
        let sizes: Vec<usize> = back.faces().map(<[u32]>::len).collect();
        assert_eq!(sizes, [3, 4, 5]);
        let text = String::from_utf8(text).unwrap();
        assert!(text.contains("\nf 1 3 4 5\n"), "{text}");
    }

    #[test]
    fn corner_syntax_negative_indices_and_groups() {
        let mesh = read_str(
            "# two groups sharing an edge\r\n\
             mtllib a.mtl\r\n\
             v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nv 1 1 0 1.0\r\nv 5 5 5 0.1 0.2 0.3\r\n\
             vt 0 0\r\nvn 0 0 1\r\n\
             o thing\r\ng a\r\nusemtl red\r\n\
             f 1/1/1 2/1/1 3/1/1\r\n\
             g b\r\ns 1\r\n\
             f -4//1 -2//1 -3//1  # comment after a face\r\n\
             l 1 2 3 4\r\np 1\r\n",
        )
        .unwrap();
        assert_eq!(mesh.positions.len(), 5, "unreferenced vertex 5 kept");
        assert_eq!(mesh.positions[4], DVec3::splat(5.0));
        assert_eq!(mesh.face_count(), 2, "lines and points are not faces");
        assert_eq!(mesh.face(0), [0, 1, 2]);
        assert_eq!(mesh.face(1), [1, 3, 2], "groups share vertices");
    }

    #[test]
    fn forward_references_are_allowed() {
        let mesh = read_str("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n").unwrap();
        assert_eq!(mesh.face(0), [0, 1, 2]);
    }

    #[test]
    fn index_out_of_range_names_line_and_count() {
        let e = err("v 0 0 0\nv 1 0 0\n\nv 0 1 0\nf 1 2 9001\nf 1 2 3\n");
        assert_eq!(
            e.to_string(),
            "t.obj: line 5: face index 9001 out of range (3 vertices)"
        );
        assert_eq!(e.line(), Some(5));
        assert_eq!(
            e.problem(),
            Some(&Problem::IndexOutOfRange {
                index: 9001,
                vertices: 3
            })
        );
    }

    #[test]
    fn negative_index_before_the_first_vertex() {
        let e = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n");
        assert_eq!(
            e.problem(),
            Some(&Problem::IndexOutOfRange {
                index: -4,
                vertices: 3
            })
        );
        assert_eq!(e.line(), Some(4));
        let e = err(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/-5000000000000000000 2 3\nf 1 2 -9223372036854775808\n",
        );
        assert_eq!(
            e.line(),
            Some(5),
            "texture indices are not checked, vertex indices are"
        );
    }

    #[test]
    fn index_zero_is_out_of_range() {
        let e = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
        assert_eq!(
            e.problem(),
            Some(&Problem::IndexOutOfRange {
                index: 0,
                vertices: 3
            })
        );
    }

    #[test]
    fn face_with_two_corners() {
        let e = err("v 0 0 0\nv 1 0 0\nf 1 2\n");
        assert_eq!(
            e.to_string(),
            "t.obj: line 3: face with 2 corners (at least 3 needed)"
        );
        assert_eq!(
            err("v 0 0 0\nf\n").problem(),
            Some(&Problem::TooFewCorners { corners: 0 })
        );
    }

    #[test]
    fn nan_and_infinite_coordinates() {
        let e = err("v 0 0 0\nv 1 NaN 0\n");
        assert_eq!(
            e.to_string(),
            "t.obj: line 2: vertex 1 has a NaN or infinite coordinate"
        );
        let e = err("v 0 0 0\nv 1 0 0\nv 0 0 -inf\n");
        assert_eq!(
            e.problem(),
            Some(&Problem::NonFiniteCoordinate { vertex: 2 })
        );
        let e = err("v 1e999 0 0\n");
        assert_eq!(
            e.problem(),
            Some(&Problem::NonFiniteCoordinate { vertex: 0 })
        );
    }

    #[test]
    fn bad_tokens() {
        let e = err("v 0 0\n");
        assert_eq!(
            e.to_string(),
            "t.obj: line 1: vertex needs 3 coordinates, found 2"
        );
        let e = err("v 0 0 zero\n");
        assert_eq!(e.to_string(), "t.obj: line 1: invalid coordinate \"zero\"");
        let e = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x/1\n");
        assert_eq!(e.to_string(), "t.obj: line 4: invalid face corner \"x/1\"");
        let e = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 /1/1\n");
        assert!(matches!(e.problem(), Some(Problem::Syntax(_))), "{e}");
    }

    #[test]
    fn nothing_to_code() {
        let e = err("# just a comment\n\n");
        assert_eq!(e.to_string(), "t.obj: no vertices");
        let e = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\n");
        assert_eq!(e.to_string(), "t.obj: no faces");
    }

    #[test]
    fn forward_reference_never_satisfied() {
        let e = err("f 1 2 3\nf 1 2 7\nv 0 0 0\nv 1 0 0\nv 0 1 0\n");
        assert_eq!(
            e.to_string(),
            "t.obj: line 2: face index 7 out of range (3 vertices)"
        );
    }

    #[test]
    fn binary_garbage_does_not_panic() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut garbage = Vec::new();
        for _ in 0..4096 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            garbage.push(state as u8);
        }
        let e = read_mesh_bytes(&garbage, Format::Obj, "g.obj").unwrap_err();
        assert!(matches!(e, MeshError::Malformed { .. }), "{e}");
        // Garbage shaped like statements, including invalid UTF-8 inside them.
        let e = err("v 0 0 0\nv \u{fffd}1 0 0\n");
        assert!(matches!(e.problem(), Some(Problem::Syntax(_))), "{e}");
        let bytes = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 \xff\n";
        let e = read_mesh_bytes(bytes, Format::Obj, "t.obj").unwrap_err();
        assert_eq!(
            e.to_string(),
            "t.obj: line 4: invalid face corner \"\u{fffd}\""
        );
    }

    /// A textured OBJ, its library and image in `dir`: two quads sharing an
    /// edge, a seam in texture space along it, two materials, `map_Kd` with
    /// options and a relative path, a missing image for the second.
    pub(crate) fn write_textured(dir: &std::path::Path) -> std::path::PathBuf {
        std::fs::create_dir_all(dir.join("maps")).unwrap();
        std::fs::write(
            dir.join("maps/wood.png"),
            crate::gltf_file::tests::png(2, 2),
        )
        .unwrap();
        std::fs::write(
            dir.join("two.mtl"),
            "newmtl wood\nKd 0.8 0.6 0.4\nmap_Kd -s 1 1 1 -bm 0.5 maps/wood.png\n\
             newmtl stone\nKd 0.5 0.5 0.5\nd 0.25\nmap_Kd maps/stone.png\nmap_Bump maps/n.png\n",
        )
        .unwrap();
        let obj = dir.join("two.obj");
        std::fs::write(
            &obj,
            "mtllib two.mtl\n\
             v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 2 0 0 0 0 1\nv 0 1 0 1 1 1\nv 1 1 0 0.5 0.5 0.5\nv 2 1 0 0 0 0\n\
             vt 0 0\nvt 0.5 0\nvt 0.5 1\nvt 0 1\nvt 0.75 0.25\nvn 0 0 1\n\
             usemtl wood\nf 1/1/1 2/2/1 5/3/1 4/4/1\n\
             usemtl stone\nf 2/5/1 3/-4/1 6/-3/1 5/-2/1\nl 1 2\n",
        )
        .unwrap();
        obj
    }

    #[test]
    fn textured_obj_with_colours_materials_and_a_missing_image() {
        let dir = tempfile::tempdir().unwrap();
        let obj = write_textured(dir.path());
        let options = crate::AssetOptions::DEFAULT.with_images(true);
        let asset = crate::read_asset(&obj, &options).unwrap();
        assert_eq!(asset.mesh, crate::read_mesh(&obj).unwrap());
        let colors = asset.colors.as_ref().unwrap();
        assert_eq!(colors.len(), 6);
        assert_eq!(colors[4], [0.5, 0.5, 0.5, 1.0]);
        let uv = asset.tex_coords.as_ref().unwrap();
        assert_eq!(uv.values.len(), 5);
        // vt 0.5 1 read with v down: (0.5, 0).
        assert_eq!(uv.get(2), Some([0.5, 0.0]));
        // Relative indices: -4 of 5 is vt 2.
        assert_eq!(uv.corners[4..], [4, 1, 2, 3]);
        assert_eq!(asset.materials.len(), 2);
        assert_eq!(asset.face_materials, Some(vec![0, 1]));
        let wood = &asset.materials[0];
        assert_eq!(wood.base_color, [0.8, 0.6, 0.4, 1.0]);
        let texture = wood.base_color_texture.as_ref().unwrap();
        assert_eq!(
            texture.source,
            crate::ImageSource::File(dir.path().join("maps/wood.png"))
        );
        assert_eq!(texture.image.as_ref().unwrap().rgba.len(), 16);
        let stone = &asset.materials[1];
        assert_eq!(stone.base_color[3], 0.25);
        assert_eq!(stone.base_color_texture, None);
        let find = |kind| asset.dropped.iter().find(|d| d.kind == kind).unwrap();
        assert!(
            find(Kind::Textures).detail.contains("stone.png"),
            "{:?}",
            asset.dropped
        );
        assert!(
            find(Kind::Properties)
                .detail
                .contains("map_Kd options -s not applied")
        );
        assert_eq!(find(Kind::Normals).count, 1);
        assert_eq!(find(Kind::Lines).count, 1);
        assert_eq!(find(Kind::OtherMaps).count, 1);
        let held: Vec<Kind> = asset.held().iter().map(|d| d.kind).collect();
        assert_eq!(
            held,
            [
                Kind::VertexColors,
                Kind::TexCoords,
                Kind::Textures,
                Kind::Materials
            ]
        );
    }

    #[test]
    fn appearance_problems_never_fail_the_geometry() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.obj");
        let options = crate::AssetOptions::DEFAULT;
        let cases = [
            (
                "mtllib nowhere.mtl\nusemtl x\nf 1 2 3\n",
                Kind::Materials,
                "nowhere.mtl",
            ),
            (
                "vt 0 0\nf 1/1 2/7 3/1\n",
                Kind::TexCoords,
                "texture index 7 out of range",
            ),
            (
                "vt 0 x\nf 1/1 2/1 3/1\n",
                Kind::TexCoords,
                "invalid texture coordinate",
            ),
            (
                "f 1/0 2/1 3/1\nvt 0 0\n",
                Kind::TexCoords,
                "texture index \"0\"",
            ),
            (
                "v 9 9 9 2 0 0\nf 1 2 3\n",
                Kind::VertexColors,
                "not in 0..1",
            ),
            (
                "v 9 9 9 1 0 0\nf 1 2 3\n",
                Kind::VertexColors,
                "only 1 of 4 vertices",
            ),
        ];
        for (extra, kind, fragment) in cases {
            std::fs::write(&path, format!("v 0 0 0\nv 1 0 0\nv 0 1 0\n{extra}")).unwrap();
            let asset = crate::read_asset(&path, &options).unwrap();
            assert_eq!(asset.mesh.face_count(), 1, "{extra}");
            let entry = asset.dropped.iter().find(|d| d.kind == kind);
            assert!(
                entry.is_some_and(|d| d.detail.contains(fragment)),
                "{extra:?}: {:?}",
                asset.dropped
            );
            assert!(asset.tex_coords.is_none() && asset.colors.is_none());
        }
        // From memory the library cannot be found; that is said too.
        let bytes = b"mtllib a.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        let asset = crate::read_asset_bytes(bytes, Format::Obj, "m.obj", &options).unwrap();
        assert!(
            asset.dropped[0].detail.contains("read from memory"),
            "{:?}",
            asset.dropped
        );
        assert_eq!(asset.materials[0].name, "m");
    }
}
