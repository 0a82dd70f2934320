//! Tests of the PLY reader and writer.

use super::*;
use crate::tests::{assert_bit_exact, awkward_mesh};
use crate::{AttributeKind as Kind, Format, read_mesh_bytes, write_mesh_to};

fn read(bytes: &[u8]) -> Result<PolyMesh, MeshError> {
    read_mesh_bytes(bytes, Format::Ply, "t.ply")
}

fn err(bytes: &[u8]) -> MeshError {
    read(bytes).expect_err("malformed input must be refused")
}

/// A PLY file from a header (without `ply`, format and `end_header`
/// lines) and a body.
fn ply(format: &str, header: &str, body: &[u8]) -> Vec<u8> {
    let mut bytes = format!("ply\nformat {format} 1.0\n{header}end_header\n").into_bytes();
    bytes.extend_from_slice(body);
    bytes
}

/// Values in the byte order of a binary PLY.
struct Body {
    bytes: Vec<u8>,
    big: bool,
}

impl Body {
    fn put(&mut self, le: &[u8]) -> &mut Self {
        let start = self.bytes.len();
        self.bytes.extend_from_slice(le);
        if self.big {
            self.bytes[start..].reverse();
        }
        self
    }
    fn f32(&mut self, v: f32) -> &mut Self {
        self.put(&v.to_le_bytes())
    }
    fn f64(&mut self, v: f64) -> &mut Self {
        self.put(&v.to_le_bytes())
    }
    fn i16(&mut self, v: i16) -> &mut Self {
        self.put(&v.to_le_bytes())
    }
    fn u8(&mut self, v: u8) -> &mut Self {
        self.put(&[v])
    }
    fn i32(&mut self, v: i32) -> &mut Self {
        self.put(&v.to_le_bytes())
    }
    fn u32(&mut self, v: u32) -> &mut Self {
        self.put(&v.to_le_bytes())
    }
}

const MIXED_HEADER: &str = "comment mixed property types\n\
    element vertex 5\nproperty float x\nproperty double y\nproperty short z\nproperty uchar red\n\
    element face 2\nproperty list uchar uint vertex_index\nproperty float quality\n";

fn mixed_binary(big: bool) -> Vec<u8> {
    let mut body = Body {
        bytes: Vec::new(),
        big,
    };
    let points = [
        (0.0, 0.0, 0),
        (1.0, 0.0, 0),
        (1.0, 1.0, 0),
        (0.0, 1.0, 0),
        (0.5, 0.5, 1),
    ];
    for (k, (x, y, z)) in points.into_iter().enumerate() {
        body.f32(x).f64(y).i16(z).u8(k as u8);
    }
    body.u8(4).u32(0).u32(1).u32(2).u32(3).f32(0.5);
    body.u8(3).u32(2).u32(3).u32(4).f32(0.5);
    let format = if big {
        "binary_big_endian"
    } else {
        "binary_little_endian"
    };
    ply(format, MIXED_HEADER, &body.bytes)
}

fn mixed_expected() -> PolyMesh {
    let positions = vec![
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(0.0, 1.0, 0.0),
        DVec3::new(0.5, 0.5, 1.0),
    ];
    let mut mesh = PolyMesh::from_faces(positions, &[[0, 1, 2, 3]]);
    mesh.push_face(&[2, 3, 4]);
    mesh
}

#[test]
fn round_trip_is_bit_exact_and_keeps_polygons() {
    let mesh = awkward_mesh();
    let mut bytes = Vec::new();
    write_mesh_to(&mut bytes, Format::Ply, &mesh).unwrap();
    assert!(bytes.starts_with(b"ply\nformat binary_little_endian 1.0\ncomment written by qm\n"));
    let back = read(&bytes).unwrap();
    assert_bit_exact(&mesh, &back);
    let sizes: Vec<usize> = back.faces().map(<[u32]>::len).collect();
    assert_eq!(sizes, [3, 4, 5]);
}

#[test]
fn reads_ascii() {
    let bytes = ply(
        "ascii",
        &MIXED_HEADER.replace("short z", "float z"),
        b"0 0 0 9\n1 0 0 9\n1 1 0 9\n0 1 0 9\n0.5 0.5 1 9\n4 0 1 2 3 0.5\n3 2 3 4 0.5\n",
    );
    assert_eq!(read(&bytes).unwrap(), mixed_expected());
}

#[test]
fn an_element_declared_twice_is_refused_naming_both_lines() {
    let header = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
        element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
        element face 1\nproperty list uchar int vertex_indices\n";
    let bytes = ply(
        "ascii",
        header,
        b"0 0 0\n1 0 0\n0 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
    );
    let message = read(&bytes).unwrap_err().to_string();
    assert!(
        message.contains("'vertex' is declared twice (lines 3 and 7)"),
        "{message}"
    );
}

#[test]
fn reads_binary_little_and_big_endian() {
    assert_eq!(read(&mixed_binary(false)).unwrap(), mixed_expected());
    assert_eq!(read(&mixed_binary(true)).unwrap(), mixed_expected());
}

#[test]
fn tristrips_restart_alternate_and_drop_degenerate_triangles() {
    let header = "element vertex 9\nproperty float x\nproperty float y\nproperty float z\n\
        element tristrips 1\nproperty list int int vertex_indices\n";
    let strip = [0, 1, 2, 3, -1, 4, 5, 6, 6, 7, 8, -1, 2, -1];
    let mut body = Body {
        bytes: Vec::new(),
        big: false,
    };
    for k in 0..9 {
        body.f32(k as f32).f32(0.0).f32(0.0);
    }
    body.i32(strip.len() as i32);
    for i in strip {
        body.i32(i);
    }
    let mesh = read(&ply("binary_little_endian", header, &body.bytes)).unwrap();
    let faces: Vec<&[u32]> = mesh.faces().collect();
    // Strip 4 5 6 6 7 8: (4 5 6), (5 6 6) and (6 6 7) dropped, then odd k = 3
    // swaps the first two: (7 6 8).
    assert_eq!(faces, [&[0, 1, 2][..], &[2, 1, 3], &[4, 5, 6], &[7, 6, 8]]);

    let ascii = ply(
        "ascii",
        header,
        b"0 0 0\n1 0 0\n2 0 0\n3 0 0\n4 0 0\n5 0 0\n6 0 0\n7 0 0\n8 0 0\n5 0 1 2 3 4\n",
    );
    let mesh = read(&ascii).unwrap();
    let faces: Vec<&[u32]> = mesh.faces().collect();
    assert_eq!(faces, [&[0, 1, 2][..], &[2, 1, 3], &[2, 3, 4]]);
}

#[test]
fn tristrip_index_below_minus_one() {
    let header = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
        element tristrips 1\nproperty list uchar int vertex_indices\n";
    let e = err(&ply("ascii", header, b"0 0 0\n1 0 0\n0 1 0\n4 0 1 -2 2\n"));
    assert_eq!(
        e.to_string(),
        "t.ply: line 13: face index -2 out of range (3 vertices)"
    );
}

#[test]
fn huge_declared_counts_fail_before_allocating() {
    let header = "element vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\n\
        element face 1\nproperty list uchar int vertex_indices\n";
    let bytes = ply("binary_little_endian", header, &[0; 40]);
    let e = err(&bytes);
    assert_eq!(
        e.to_string(),
        "t.ply: line 3: header declares 4000000000 vertex elements but only 40 bytes follow"
    );
    assert!(e.is_truncated());
    // An element without properties takes no bytes yet costs a loop step.
    let header = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
        element nothing 18446744073709551615\nelement face 1\nproperty list uchar int vertex_indices\n";
    let e = err(&ply("binary_little_endian", header, &[0; 60]));
    assert!(
        matches!(
            e.problem(),
            Some(Problem::CountExceedsData {
                count: u64::MAX,
                ..
            })
        ),
        "{e}"
    );
}

#[test]
fn huge_list_length_in_small_file() {
    let header = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
        element face 1\nproperty list uint int vertex_indices\n";
    let mut body = Body {
        bytes: vec![0; 36],
        big: false,
    };
    body.u32(4_000_000_000).i32(0).i32(1);
    let e = err(&ply("binary_little_endian", header, &body.bytes));
    assert_eq!(
        e.to_string(),
        "t.ply: data ends in the middle of face 0 of 1"
    );
}

#[test]
fn truncated_binary_vertices() {
    let mut bytes = mixed_binary(false);
    let header_end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    bytes.truncate(header_end + 40);
    let e = err(&bytes);
    assert!(e.is_truncated(), "{e}");
    assert!(
        matches!(e.problem(), Some(Problem::CountExceedsData { .. })),
        "{e}"
    );
    // Enough bytes for the minimum, but a list runs past the end.
    let mut bytes = mixed_binary(true);
    bytes.truncate(bytes.len() - 6);
    let e = err(&bytes);
    assert_eq!(
        e.to_string(),
        "t.ply: data ends in the middle of face 1 of 2"
    );
}

#[test]
fn face_index_out_of_range_names_ascii_line() {
    let bytes = ply(
        "ascii",
        MIXED_HEADER,
        b"0 0 0 9\n1 0 0 9\n1 1 0 9\n0 1 0 9\n0.5 0.5 1 9\n4 0 1 2 3 0.5\n3 2 3 9001 0.5\n",
    );
    let e = err(&bytes);
    assert_eq!(
        e.to_string(),
        "t.ply: line 19: face index 9001 out of range (5 vertices)"
    );
}

#[test]
fn face_with_two_corners() {
    let bytes = ply(
        "ascii",
        MIXED_HEADER,
        b"0 0 0 9\n1 0 0 9\n1 1 0 9\n0 1 0 9\n0 0 1 9\n2 0 1 0\n",
    );
    let e = err(&bytes);
    assert_eq!(
        e.to_string(),
        "t.ply: line 18: face with 2 corners (at least 3 needed)"
    );
}

#[test]
fn nan_vertex_in_binary() {
    let header = "element vertex 3\nproperty double x\nproperty double y\nproperty double z\n\
        element face 1\nproperty list uchar int vertex_indices\n";
    let mut body = Body {
        bytes: Vec::new(),
        big: false,
    };
    body.f64(0.0)
        .f64(0.0)
        .f64(0.0)
        .f64(1.0)
        .f64(f64::INFINITY)
        .f64(0.0);
    body.f64(0.0).f64(1.0).f64(0.0).u8(3).i32(0).i32(1).i32(2);
    let e = err(&ply("binary_little_endian", header, &body.bytes));
    assert_eq!(
        e.to_string(),
        "t.ply: vertex 1 has a NaN or infinite coordinate"
    );
}

#[test]
fn bad_ascii_records() {
    let body = b"0 0 0 9\n1 0 0 9\n1 1 x 9\n0 1 0 9\n0 0 1 9\n3 0 1 2 0.5\n3 0 1 2 0.5\n";
    let e = err(&ply("ascii", MIXED_HEADER, body));
    assert_eq!(e.line(), Some(15));
    assert!(
        matches!(e.problem(), Some(Problem::Syntax(m)) if m.starts_with("invalid vertex record \"1 1 x 9\"")),
        "{e}"
    );
    let e = err(&ply("ascii", MIXED_HEADER, b"0 0 0 9\n1 0 0 9\n"));
    assert!(
        matches!(e.problem(), Some(Problem::CountExceedsData { .. })),
        "{e}"
    );
}

#[test]
fn missing_or_unusable_elements() {
    let e = err(&ply(
        "ascii",
        "element face 1\nproperty list uchar int vertex_indices\n",
        b"3 0 1 2\n",
    ));
    assert_eq!(e.to_string(), "t.ply: no vertices");
    let header = "element vertex 3\nproperty float x\nproperty float y\n";
    let e = err(&ply("ascii", header, b"0 0\n1 0\n0 1\n"));
    assert_eq!(
        e.to_string(),
        "t.ply: line 3: PLY vertex element has no 'z' property"
    );
    let header = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
    let e = err(&ply("ascii", header, b"0 0 0\n1 0 0\n0 1 0\n"));
    assert_eq!(e.to_string(), "t.ply: no faces");
    let header = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
        element face 1\nproperty list uchar float vertex_indices\n";
    let e = err(&ply("ascii", header, b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"));
    assert_eq!(
        e.to_string(),
        "t.ply: line 7: unsupported: face indices of type Float"
    );
}

#[test]
fn bad_headers() {
    let e = err(b"ply\nformat ascii 1.0\nelement vertex 3\n");
    assert_eq!(
        e.to_string(),
        "t.ply: line 4: data ends in the middle of the PLY header"
    );
    let e = err(b"ply\nformat ascii 1.0\nelemnt vertex 3\nend_header\n");
    assert_eq!(
        e.to_string(),
        "t.ply: line 3: invalid PLY header line \"elemnt vertex 3\""
    );
    let e = err(b"PK\x03\x04\x14\x00\x00\x00\x08\x00binary garbage\xff\xfe\n\n");
    assert!(matches!(e.problem(), Some(Problem::Syntax(_))), "{e}");
}

#[test]
fn mutated_files_never_panic() {
    let seeds = [mixed_binary(false), mixed_binary(true), {
        let mut b = Vec::new();
        write_mesh_to(&mut b, Format::Ply, &awkward_mesh()).unwrap();
        b
    }];
    let mut rng = crate::SplitMix64::new(0x9e37_79b9_7f4a_7c15);
    let mut next = move || rng.next_u64();
    for seed in &seeds {
        for _ in 0..300 {
            let mut bytes = seed.clone();
            for _ in 0..1 + next() % 4 {
                let at = (next() % bytes.len() as u64) as usize;
                bytes[at] = next() as u8;
            }
            if next() % 3 == 0 {
                bytes.truncate((next() % bytes.len() as u64) as usize);
            }
            let _ = read_mesh_bytes(&bytes, Format::Ply, "fuzz.ply");
        }
    }
}

fn read_asset(bytes: &[u8]) -> Asset {
    let options = crate::AssetOptions::DEFAULT;
    crate::read_asset_bytes(bytes, Format::Ply, "t.ply", &options).unwrap()
}

#[test]
fn vertex_colours_of_every_type_with_and_without_alpha() {
    let header = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
        property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n\
        property float nx\nproperty float ny\nproperty float nz\nproperty float quality\n\
        element face 1\nproperty list uchar int vertex_indices\nproperty uchar red\n\
        element edge 2\nproperty int vertex1\nproperty int vertex2\n";
    let body = "0 0 0 255 0 0 255 0 0 1 7\n1 0 0 0 255 0 128 0 0 1 7\n0 1 0 0 0 255 0 0 0 1 7\n\
        3 0 1 2 9\n0 1\n1 2\n";
    let asset = read_asset(&ply("ascii", header, body.as_bytes()));
    let colors = asset.colors.as_ref().unwrap();
    assert_eq!(colors[0], [1.0, 0.0, 0.0, 1.0]);
    assert_eq!(colors[1], [0.0, 1.0, 0.0, 128.0 / 255.0]);
    assert_eq!(colors[2][3], 0.0);
    let kinds: Vec<Kind> = asset.dropped.iter().map(|d| d.kind).collect();
    assert_eq!(
        kinds,
        [
            Kind::Normals,
            Kind::Properties,
            Kind::FaceColors,
            Kind::Lines
        ]
    );
    assert_eq!(asset.dropped[3].count, 2);
    let held: Vec<(Kind, u64)> = asset.held().iter().map(|d| (d.kind, d.count)).collect();
    assert_eq!(held, [(Kind::VertexColors, 3), (Kind::VertexAlpha, 2)]);
    assert_eq!(
        read(&ply("ascii", header, body.as_bytes())).unwrap(),
        asset.mesh
    );

    // Binary, float and ushort channels, diffuse_ names.
    for (kind, write) in [("float", 0), ("ushort", 1)] {
        let header = format!(
            "element vertex 3\nproperty double x\nproperty double y\nproperty double z\n\
             property {kind} diffuse_red\nproperty {kind} diffuse_green\nproperty {kind} diffuse_blue\n\
             element face 1\nproperty list uchar int vertex_indices\n"
        );
        let mut body = Body {
            bytes: Vec::new(),
            big: true,
        };
        for k in 0..3 {
            body.f64(k as f64).f64(f64::from(k == 1)).f64(0.0);
            for c in 0..3 {
                let on = c == k;
                match write {
                    0 => body.f32(if on { 0.5 } else { 0.0 }),
                    _ => body.put(&(if on { 65535u16 } else { 0 }).to_le_bytes()),
                };
            }
        }
        body.u8(3).i32(0).i32(1).i32(2);
        let asset = read_asset(&ply("binary_big_endian", &header, &body.bytes));
        let colors = asset.colors.unwrap();
        let full = if write == 0 { 0.5 } else { 1.0 };
        assert_eq!(colors[1], [0.0, full, 0.0, 1.0], "{kind}");
        assert!(asset.dropped.is_empty(), "{:?}", asset.dropped);
    }
}

#[test]
fn unusable_colours_are_reported_not_fatal() {
    let base = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
    let face = "element face 1\nproperty list uchar int vertex_indices\n";
    let cases = [
        (
            "property float red\nproperty float green\nproperty float blue\n",
            "0 0 0 1 1 1\n1 0 0 255 0 0\n0 1 0 0 0 0\n",
            "vertex 1 (line",
        ),
        (
            "property int red\nproperty int green\nproperty int blue\n",
            "0 0 0 1 1 1\n1 0 0 1 0 0\n0 1 0 0 0 0\n",
            "channels",
        ),
        (
            "property uchar red\nproperty uchar green\n",
            "0 0 0 1 1\n1 0 0 1 0\n0 1 0 0 0\n",
            "channels",
        ),
    ];
    for (props, vertices, fragment) in cases {
        let bytes = ply(
            "ascii",
            &format!("{base}{props}{face}"),
            format!("{vertices}3 0 1 2\n").as_bytes(),
        );
        let asset = read_asset(&bytes);
        assert!(asset.colors.is_none());
        assert_eq!(asset.dropped[0].kind, Kind::VertexColors);
        assert!(
            asset.dropped[0].detail.contains(fragment),
            "{:?}",
            asset.dropped
        );
    }
}
