//! Object File Format (OFF), text only.
//!
//! ```text
//! OFF                    header keyword, optional; may carry the counts too
//! 8 6 12                 vertices, faces, edges (edges ignored)
//! x y z [extra values]   one vertex a line
//! k i0 .. ik-1 [colour]  one face a line, 0-based indices
//! ```
//!
//! `#` starts a comment. The keyword variants `ST`, `C` and `N` (texture
//! coordinates, colours, normals, in that order before `OFF`) only append
//! values after the position, so they read like plain OFF. `4OFF`, `nOFF`
//! (other dimensions) and `OFF BINARY` are refused.

use super::{
    MAX_VERTICES, MeshBuilder, MeshError, Problem, numbered_lines, parse_f64, strip_comment,
};
use crate::PolyMesh;
use glam::DVec3;

/// The fewest bytes a vertex line takes (`0 0 0` and a line break) and a face
/// line (a count and a line break; shorter faces are refused later anyway).
const MIN_VERTEX_BYTES: u64 = 6;
const MIN_FACE_BYTES: u64 = 2;

/// Whether `token` is an OFF header keyword (`OFF`, `COFF`, `STCNOFF`, `4OFF`...).
pub(super) fn is_header_keyword(token: &str) -> bool {
    keyword_dimension(token).is_some()
}

/// For a header keyword, whether it declares 3D positions; `None` otherwise.
fn keyword_dimension(token: &str) -> Option<bool> {
    let mut rest = token.strip_suffix("OFF")?;
    for prefix in ["ST", "C", "N"] {
        rest = rest.strip_prefix(prefix).unwrap_or(rest);
    }
    match rest {
        "" => Some(true),
        "4" | "n" | "4n" => Some(false),
        _ => None,
    }
}

/// Lists what the header keyword's variants add after each position (`ST`
/// texture coordinates, `C` colours, `N` normals), which this reader skips.
pub(super) fn report_variant(bytes: &[u8], vertices: usize, dropped: &mut Vec<crate::Dropped>) {
    use crate::AttributeKind as Kind;
    let Some(keyword) = numbered_lines(bytes)
        .find_map(|(_, line)| tokens(line))
        .and_then(|t| std::str::from_utf8(t[0]).ok().map(str::to_owned))
    else {
        return;
    };
    let Some(mut rest) = keyword.strip_suffix("OFF") else {
        return;
    };
    let count = vertices as u64;
    for (prefix, kind, what) in [
        ("ST", Kind::TexCoords, "texture coordinates"),
        ("C", Kind::VertexColors, "colours"),
        ("N", Kind::Normals, "normals"),
    ] {
        if let Some(after) = rest.strip_prefix(prefix) {
            rest = after;
            let detail = format!("vertex {what} of {keyword} (not read from OFF)");
            crate::add_dropped(dropped, kind, count, detail);
        }
    }
}

/// A line's content (comment removed) split into tokens, or `None` for a
/// blank line.
fn tokens(line: &[u8]) -> Option<Vec<&[u8]>> {
    let tokens: Vec<&[u8]> = strip_comment(line)
        .split(u8::is_ascii_whitespace)
        .filter(|t| !t.is_empty())
        .collect();
    (!tokens.is_empty()).then_some(tokens)
}

fn text(token: &[u8]) -> String {
    String::from_utf8_lossy(token).into_owned()
}

fn parse<T: std::str::FromStr>(token: &[u8]) -> Option<T> {
    std::str::from_utf8(token).ok()?.parse().ok()
}

pub(super) fn read(bytes: &[u8], file: &str) -> Result<PolyMesh, MeshError> {
    let fail = |line, problem| MeshError::malformed(file, Some(line), problem);
    let mut lines = numbered_lines(bytes)
        .filter_map(|(number, line)| tokens(line).map(|tokens| (number, line, tokens)));
    // The number of the last line; a final line break ends a line, not starts one.
    let breaks = bytes.iter().filter(|&&b| b == b'\n').count();
    let last_line = if bytes.ends_with(b"\n") {
        breaks
    } else {
        breaks + 1
    };
    let truncated = |what: &str| {
        fail(
            last_line,
            Problem::Truncated {
                what: what.to_owned(),
            },
        )
    };

    let (mut number, mut counts_line, mut counts) =
        lines.next().ok_or_else(|| truncated("the OFF header"))?;
    let keyword = std::str::from_utf8(counts[0]).unwrap_or("");
    match keyword_dimension(keyword) {
        Some(true) => {
            if counts
                .get(1)
                .is_some_and(|t| t.eq_ignore_ascii_case(b"BINARY"))
            {
                return Err(fail(number, Problem::Unsupported("binary OFF".into())));
            }
            counts.remove(0);
            if counts.is_empty() {
                (number, counts_line, counts) =
                    lines.next().ok_or_else(|| truncated("the OFF counts"))?;
            }
        }
        Some(false) => {
            let what = format!("{keyword} (positions that are not 3D)");
            return Err(fail(number, Problem::Unsupported(what)));
        }
        // The header keyword is optional: a line of numbers is the counts line.
        None if parse::<u64>(counts[0]).is_some() => {}
        None => {
            let what = format!("expected an OFF header, found {:?}", text(counts[0]));
            return Err(fail(number, Problem::Syntax(what)));
        }
    }
    let (Some(vertex_count), Some(face_count)) = (
        counts.first().and_then(|t| parse::<u64>(t)),
        counts.get(1).and_then(|t| parse::<u64>(t)),
    ) else {
        let what = "expected the vertex and face counts".to_owned();
        return Err(fail(number, Problem::Syntax(what)));
    };
    if vertex_count > MAX_VERTICES {
        let problem = Problem::TooMany {
            what: "vertices",
            count: vertex_count,
            max: MAX_VERTICES,
        };
        return Err(fail(number, problem));
    }
    // Refuse counts that the rest of the file cannot hold before reserving for
    // them (the last line may lack its line break, hence the + 1).
    let counts_end = counts_line.as_ptr() as usize - bytes.as_ptr() as usize + counts_line.len();
    let remaining = bytes.len() - counts_end;
    let room = remaining as u64 + 1;
    let vertex_bytes = vertex_count.saturating_mul(MIN_VERTEX_BYTES);
    let exceeds = |what: &str, count| {
        fail(
            number,
            Problem::CountExceedsData {
                what: what.to_owned(),
                count,
                bytes: remaining,
            },
        )
    };
    if vertex_bytes > room {
        return Err(exceeds("vertices", vertex_count));
    }
    if vertex_bytes.saturating_add(face_count.saturating_mul(MIN_FACE_BYTES)) > room {
        return Err(exceeds("faces", face_count));
    }
    let counts_number = number;

    let mut builder = MeshBuilder::with_capacity(vertex_count as usize);
    for read in 0..vertex_count {
        let (number, _, tokens) = lines
            .next()
            .ok_or_else(|| truncated(&format!("the vertices ({read} of {vertex_count} read)")))?;
        if tokens.len() < 3 {
            let what = format!("vertex needs 3 coordinates, found {}", tokens.len());
            return Err(fail(number, Problem::Syntax(what)));
        }
        let mut xyz = [0.0; 3];
        for (value, token) in xyz.iter_mut().zip(&tokens) {
            *value = std::str::from_utf8(token)
                .ok()
                .and_then(parse_f64)
                .ok_or_else(|| {
                    fail(
                        number,
                        Problem::Syntax(format!("invalid coordinate {:?}", text(token))),
                    )
                })?;
        }
        builder
            .push_position(DVec3::from_array(xyz))
            .map_err(|p| fail(number, p))?;
    }

    let mut corners = Vec::new();
    for read in 0..face_count {
        let (number, _, tokens) = lines
            .next()
            .ok_or_else(|| truncated(&format!("the faces ({read} of {face_count} read)")))?;
        let Some(size) = parse::<u64>(tokens[0]) else {
            let what = format!("invalid corner count {:?}", text(tokens[0]));
            return Err(fail(number, Problem::Syntax(what)));
        };
        let listed = tokens.len() as u64 - 1;
        if size < 3 {
            let problem = Problem::TooFewCorners {
                corners: size as usize,
            };
            return Err(fail(number, problem));
        }
        if listed < size {
            let what = format!("face declares {size} corners but lists {listed}");
            return Err(fail(number, Problem::Syntax(what)));
        }
        corners.clear();
        // Values after the `size` indices are a colour.
        for token in &tokens[1..=size as usize] {
            let index: i64 = parse(token).ok_or_else(|| {
                fail(
                    number,
                    Problem::Syntax(format!("invalid vertex index {:?}", text(token))),
                )
            })?;
            if index < 0 || index as u64 >= vertex_count {
                let problem = Problem::IndexOutOfRange {
                    index,
                    vertices: vertex_count as usize,
                };
                return Err(fail(number, problem));
            }
            corners.push(index as u32);
        }
        builder.push_face(&corners).map_err(|p| fail(number, p))?;
    }
    builder.finish().map_err(|p| fail(counts_number, p))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Format, read_mesh_bytes};

    fn read_str(text: &str) -> Result<PolyMesh, MeshError> {
        read_mesh_bytes(text.as_bytes(), Format::Off, "t.off")
    }

    fn err(text: &str) -> MeshError {
        read_str(text).expect_err("malformed input must be refused")
    }

    const TETRA: &str = "OFF\n# a tetrahedron\n4 4 6\n\
        0 0 0\n1 0 0\n0 1 0\n0 0 1\n\
        3 0 2 1\n3 0 1 3\n3 1 2 3\n3 0 3 2\n";

    #[test]
    fn reads_plain_off() {
        let mesh = read_str(TETRA).unwrap();
        assert_eq!(mesh.positions.len(), 4);
        assert_eq!(mesh.positions[3], DVec3::Z);
        assert_eq!(mesh.face_count(), 4);
        assert_eq!(mesh.face(2), [1, 2, 3]);
    }

    #[test]
    fn reads_variants_counts_on_header_line_and_polygons() {
        let mesh = read_str(
            "COFF 5 2 0\r\n0 0 0 255 0 0 255\r\n1 0 0 0 255 0 255\r\n1 1 0 0 0 255 255\r\n\
             0 1 0 9 9 9 9\r\n0.5 0.5 1 1 1 1 1\r\n\
             4 0 1 2 3 0.5 0.5 0.5\r\n  3 2 3 4  # comment\r\n",
        )
        .unwrap();
        assert_eq!(mesh.positions[4], DVec3::new(0.5, 0.5, 1.0));
        assert_eq!(mesh.face(0), [0, 1, 2, 3]);
        assert_eq!(mesh.face(1), [2, 3, 4]);
        let headless = read_str("3 1\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").unwrap();
        assert_eq!(headless.face_count(), 1);
        let normals = read_str("NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n");
        assert_eq!(normals.unwrap().positions[1], DVec3::X);
    }

    #[test]
    fn huge_declared_count_fails_fast() {
        let e = err("OFF\n4000000000 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
        assert_eq!(
            e.to_string(),
            "t.off: line 2: header declares 4000000000 vertices but only 27 bytes follow"
        );
        assert!(e.is_truncated());
        let e = err("OFF\n3 18446744073709551615 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
        assert!(
            matches!(e.problem(), Some(Problem::CountExceedsData { .. })),
            "{e}"
        );
        let e = err("OFF\n99999999999 1 0\n");
        assert!(
            matches!(
                e.problem(),
                Some(Problem::TooMany {
                    what: "vertices",
                    ..
                })
            ),
            "{e}"
        );
    }

    #[test]
    fn truncated_vertex_and_face_lists() {
        let e = err("OFF\n3 1 0\n0 0 0\n1 0 0\n\n\n\n\n\n\n\n\n\n\n\n");
        assert_eq!(
            e.problem(),
            Some(&Problem::Truncated {
                what: "the vertices (2 of 3 read)".into()
            })
        );
        assert_eq!(e.line(), Some(15));
        let e = err("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n\n\n\n\n\n\n\n");
        assert_eq!(
            e.to_string(),
            "t.off: line 13: data ends in the middle of the faces (1 of 2 read)"
        );
    }

    #[test]
    fn bad_faces() {
        let e = err("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n");
        assert_eq!(
            e.to_string(),
            "t.off: line 6: face index 3 out of range (3 vertices)"
        );
        let e = err("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n");
        assert_eq!(
            e.problem(),
            Some(&Problem::IndexOutOfRange {
                index: -1,
                vertices: 3
            })
        );
        let e = err("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n");
        assert_eq!(
            e.to_string(),
            "t.off: line 6: face with 2 corners (at least 3 needed)"
        );
        let e = err("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n");
        assert_eq!(
            e.to_string(),
            "t.off: line 6: face declares 4000000000 corners but lists 3"
        );
    }

    #[test]
    fn bad_vertices() {
        let e = err("OFF\n3 1 0\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n");
        assert_eq!(
            e.to_string(),
            "t.off: line 4: vertex 1 has a NaN or infinite coordinate"
        );
        let e = err("OFF\n3 1 0\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n");
        assert_eq!(
            e.to_string(),
            "t.off: line 4: vertex needs 3 coordinates, found 2"
        );
    }

    #[test]
    fn bad_headers() {
        let e = err("OFF BINARY\n3 1 0\n");
        assert_eq!(
            e.problem(),
            Some(&Problem::Unsupported("binary OFF".into()))
        );
        let e = err("4OFF\n3 1 0\n0 0 0 0\n");
        assert_eq!(
            e.to_string(),
            "t.off: line 1: unsupported: 4OFF (positions that are not 3D)"
        );
        let e = err("MESH\n3 1 0\n");
        assert_eq!(
            e.to_string(),
            "t.off: line 1: expected an OFF header, found \"MESH\""
        );
        let e = err("OFF\n3\n");
        assert_eq!(
            e.to_string(),
            "t.off: line 2: expected the vertex and face counts"
        );
        let e = err("OFF\n# nothing else\n");
        assert!(e.is_truncated(), "{e}");
    }

    #[test]
    fn nothing_to_code() {
        let e = err("OFF\n0 0 0\n");
        assert_eq!(e.to_string(), "t.off: line 2: no vertices");
        let e = err("OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n");
        assert_eq!(e.to_string(), "t.off: line 2: no faces");
    }
}
