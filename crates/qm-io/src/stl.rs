//! STL, ASCII and binary, read through `stl_io`.
//!
//! STL stores each triangle with its own three corners; `stl_io` merges the
//! corners whose positions are bit-identical into shared vertices, which gives
//! the connectivity back. Only the first `solid` of an ASCII file is read.

use std::io::{self, Cursor};

use super::{MeshBuilder, MeshError, Problem};
use crate::PolyMesh;
use glam::DVec3;

/// Bytes of the binary header: 80 free bytes and a little-endian `u32` count.
const HEADER_BYTES: usize = 84;
/// Bytes a binary triangle takes: normal, 3 corners, attribute count.
const TRIANGLE_BYTES: u64 = 50;

fn declared_triangles(bytes: &[u8]) -> Option<u32> {
    let count = bytes.get(80..HEADER_BYTES)?;
    Some(u32::from_le_bytes(count.try_into().ok()?))
}

/// Whether the size is exactly that of a binary STL with the declared count,
/// the one test that ASCII text practically never passes.
pub(super) fn is_binary(bytes: &[u8]) -> bool {
    declared_triangles(bytes)
        .is_some_and(|n| HEADER_BYTES as u64 + TRIANGLE_BYTES * u64::from(n) == bytes.len() as u64)
}

pub(super) fn read(bytes: &[u8], file: &str) -> Result<PolyMesh, MeshError> {
    let fail = |problem| MeshError::malformed(file, None, problem);
    // The solid's name may be in any encoding (Latin-1 names are common):
    // only the keyword is looked at.
    let first_line = bytes.split(|&b| b == b'\n').next().unwrap_or_default();
    let ascii = !is_binary(bytes) && first_line.trim_ascii_start().starts_with(b"solid");
    let patched;
    let input = if ascii {
        // stl_io wants the first line to be exactly "solid " and a name in
        // UTF-8, which a bare "solid", leading blanks or a Latin-1 name
        // miss; the name is not needed.
        if bytes.starts_with(b"solid ") && std::str::from_utf8(first_line).is_ok() {
            bytes
        } else {
            let body = &bytes[first_line.len()..];
            patched = [&b"solid "[..], body].concat();
            &patched
        }
    } else {
        let Some(triangles) = declared_triangles(bytes) else {
            return Err(fail(Problem::Truncated {
                what: "the binary STL header".into(),
            }));
        };
        let available = bytes.len() - HEADER_BYTES;
        if TRIANGLE_BYTES * u64::from(triangles) > available as u64 {
            let what = "triangles".to_owned();
            return Err(fail(Problem::CountExceedsData {
                what,
                count: triangles.into(),
                bytes: available,
            }));
        }
        if bytes.starts_with(b"solid ") {
            // Hide the text-like header from stl_io's ASCII test; the header
            // carries nothing we use.
            let mut copy = bytes.to_vec();
            copy[..5].fill(b' ');
            patched = copy;
            &patched
        } else {
            bytes
        }
    };
    let stl = stl_io::read_stl(&mut Cursor::new(input)).map_err(|e| {
        fail(match e.kind() {
            io::ErrorKind::UnexpectedEof => Problem::Truncated {
                what: format!("the facets ({e})"),
            },
            _ => Problem::Syntax(format!("invalid STL: {e}")),
        })
    })?;

    let mut builder = MeshBuilder::with_capacity(stl.vertices.len());
    for vertex in &stl.vertices {
        let [x, y, z] = vertex.0;
        builder
            .push_position(DVec3::new(x.into(), y.into(), z.into()))
            .map_err(fail)?;
    }
    for face in &stl.faces {
        // push_position succeeded for every vertex, so every index fits u32.
        let corners = face.vertices.map(|i| i as u32);
        builder.push_face(&corners).map_err(fail)?;
    }
    builder.finish().map_err(fail)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Format, read_mesh_bytes};

    const ASCII: &str = "solid square\n\
        facet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 0 0\n  vertex 1 1 0\n endloop\nendfacet\n\
        facet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 1 0\n  vertex 0 1 0.5\n endloop\nendfacet\n\
        endsolid square\n";

    fn binary(header: &[u8], triangles: &[[[f32; 3]; 3]], declared: u32) -> Vec<u8> {
        let mut bytes = header.to_vec();
        bytes.resize(80, 0);
        bytes.extend_from_slice(&declared.to_le_bytes());
        for triangle in triangles {
            bytes.extend_from_slice(&[0; 12]);
            for corner in triangle {
                for c in corner {
                    bytes.extend_from_slice(&c.to_le_bytes());
                }
            }
            bytes.extend_from_slice(&[0; 2]);
        }
        bytes
    }

    const SQUARE: [[[f32; 3]; 3]; 2] = [
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]],
        [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.1]],
    ];

    #[test]
    fn ascii_merges_equal_corners() {
        let mesh = read_mesh_bytes(ASCII.as_bytes(), Format::Stl, "a.stl").unwrap();
        assert_eq!(mesh.positions.len(), 4);
        assert_eq!(mesh.face(0), [0, 1, 2]);
        assert_eq!(mesh.face(1), [0, 2, 3]);
        assert_eq!(mesh.positions[3], DVec3::new(0.0, 1.0, 0.5));
        let bare = ASCII.replacen("solid square", "  solid", 1);
        assert_eq!(
            read_mesh_bytes(bare.as_bytes(), Format::Stl, "a.stl").unwrap(),
            mesh
        );
    }

    #[test]
    fn an_ascii_name_in_latin_1_is_still_ascii() {
        let text = ASCII.replacen("solid square", "solid \u{e9}t\u{e9}", 1);
        let latin1: Vec<u8> = text.chars().map(|c| c as u32 as u8).collect();
        let mesh = read(&latin1, "latin1.stl").unwrap();
        assert_eq!(mesh.face_count(), 2);
    }

    #[test]
    fn binary_even_with_a_solid_header() {
        for header in [&b"exported by a CAD tool"[..], b"solid but binary"] {
            let bytes = binary(header, &SQUARE, 2);
            let mesh = read_mesh_bytes(&bytes, Format::Stl, "b.stl").unwrap();
            assert_eq!(mesh.positions.len(), 4);
            assert_eq!(mesh.face(1), [0, 2, 3]);
            assert_eq!(mesh.positions[3], DVec3::new(0.0, 1.0, f64::from(0.1f32)));
        }
    }

    #[test]
    fn binary_count_larger_than_the_file() {
        let bytes = binary(b"x", &SQUARE, 4_000_000_000);
        let e = read_mesh_bytes(&bytes, Format::Stl, "b.stl").unwrap_err();
        assert_eq!(
            e.to_string(),
            "b.stl: header declares 4000000000 triangles but only 100 bytes follow"
        );
        assert!(e.is_truncated());
        let e = read_mesh_bytes(b"\x00\x01binary but short", Format::Stl, "b.stl").unwrap_err();
        assert_eq!(
            e.to_string(),
            "b.stl: data ends in the middle of the binary STL header"
        );
    }

    #[test]
    fn binary_nan_corner() {
        let mut triangles = SQUARE;
        triangles[1][2][1] = f32::NAN;
        let bytes = binary(b"x", &triangles, 2);
        let e = read_mesh_bytes(&bytes, Format::Stl, "b.stl").unwrap_err();
        assert_eq!(
            e.problem(),
            Some(&Problem::NonFiniteCoordinate { vertex: 3 })
        );
    }

    #[test]
    fn binary_without_triangles() {
        let e = read_mesh_bytes(&binary(b"x", &[], 0), Format::Stl, "b.stl").unwrap_err();
        assert_eq!(e.problem(), Some(&Problem::NoVertices));
    }

    #[test]
    fn ascii_errors() {
        let broken = ASCII.replacen("facet normal 0 0 1", "facet normal 0 0", 1);
        let e = read_mesh_bytes(broken.as_bytes(), Format::Stl, "a.stl").unwrap_err();
        assert!(
            matches!(e.problem(), Some(Problem::Syntax(m)) if m.contains("invalid facet header")),
            "{e}"
        );
        let second_facet = ASCII.match_indices("  vertex 0 0 0\n").nth(1).unwrap().0;
        let cut = &ASCII[..second_facet + 15];
        let e = read_mesh_bytes(cut.as_bytes(), Format::Stl, "a.stl").unwrap_err();
        assert!(e.is_truncated(), "{e}");
        let nan = ASCII.replacen("vertex 1 0 0", "vertex 1 NaN 0", 1);
        let e = read_mesh_bytes(nan.as_bytes(), Format::Stl, "a.stl").unwrap_err();
        assert!(
            matches!(e.problem(), Some(Problem::Syntax(m)) if m.contains("finite")),
            "{e}"
        );
    }
}
