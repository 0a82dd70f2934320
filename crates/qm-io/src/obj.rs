//! Wavefront OBJ: vertex positions (`v`) and faces (`f`, `fo`).
//!
//! A face corner is `v`, `v/vt`, `v//vn` or `v/vt/vn`; only `v` is used. It
//! counts from 1, and a negative value counts back from the last vertex read so
//! far (-1 is the latest). A positive index may refer to a vertex defined
//! further down; it is checked once the whole file is read. Groups, objects and
//! materials do not renumber vertices: all faces index one shared vertex list,
//! which is what keeps a surface connected across group borders. Lines (`l`),
//! points (`p`), texture coordinates, normals, curves and every other statement
//! are skipped. A `v` line may carry a fourth (weight) or further (colour)
//! values; they are ignored, as polygonal geometry has no use for them.

use std::io::{self, Write};

use super::{
    MAX_VERTICES, MeshBuilder, MeshError, Problem, numbered_lines, parse_f64, strip_comment,
};
use crate::PolyMesh;
use glam::DVec3;

pub(super) fn read(bytes: &[u8], file: &str) -> Result<PolyMesh, MeshError> {
    let fail = |line, problem| MeshError::malformed(file, Some(line), problem);
    let mut builder = MeshBuilder::with_capacity(0);
    let mut corners = Vec::new();
    // The largest index beyond the vertices read so far, with its line: legal
    // as long as the file defines that many vertices in the end.
    let mut forward: Option<(i64, usize)> = None;
    for (number, line) in numbered_lines(bytes) {
        let mut tokens = strip_comment(line)
            .split(u8::is_ascii_whitespace)
            .filter(|token| !token.is_empty());
        match tokens.next() {
            Some(b"v") => {
                let position = parse_position(&mut tokens).map_err(|p| fail(number, p))?;
                builder
                    .push_position(position)
                    .map_err(|p| fail(number, p))?;
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
                }
                builder.push_face(&corners).map_err(|p| fail(number, p))?;
            }
            _ => {}
        }
    }
    let vertices = builder.vertex_count();
    if let Some((index, number)) = forward {
        if index as usize > vertices {
            return Err(fail(number, Problem::IndexOutOfRange { index, vertices }));
        }
    }
    builder
        .finish()
        .map_err(|p| MeshError::malformed(file, None, p))
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
/// position reads back bit-exactly) and 1-based `f` lines, one polygon each.
pub(super) fn write(w: &mut impl Write, mesh: &PolyMesh) -> io::Result<()> {
    writeln!(
        w,
        "# written by qm: {} vertices, {} faces",
        mesh.positions.len(),
        mesh.face_count()
    )?;
    for p in &mesh.positions {
        writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
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
    use crate::{Format, read_mesh_bytes, write_mesh_to};

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
}
