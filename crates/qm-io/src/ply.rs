//! Stanford PLY: ASCII, binary little endian and binary big endian.
//!
//! `ply-rs-bw` parses the header and decodes each record; this module walks
//! the elements itself, one record at a time, so that it can bound the work by
//! the input size, stop at the first bad face and name the line of an ASCII
//! record.
//!
//! Read: element `vertex` with scalar properties `x`, `y`, `z` of any numeric
//! type; element `face` with an integer list `vertex_indices` (or
//! `vertex_index`); element `tristrips` with an integer list `vertex_indices`,
//! where -1 ends a strip. Triangle `k` of a strip `s` is
//! `(s[k], s[k+1], s[k+2])` for even `k` and `(s[k+1], s[k], s[k+2])` for odd
//! `k`, which keeps the orientation of all triangles; triangles with a repeated
//! corner are how strips turn corners and are dropped. Every other element and
//! property is skipped.
//!
//! Written: binary little endian, `double` coordinates (exact) and faces as
//! `list uchar int vertex_indices`.

use std::io::{self, Write};

use ply_rs_bw::parser::{ParseError, Parser, Reader};
use ply_rs_bw::ply::{
    ElementDef, Encoding, Header, PropertyAccess, PropertyAccessResult, PropertyType, ScalarType,
};

use super::{MAX_VERTICES, MeshBuilder, MeshError, Problem, numbered_lines};
use crate::PolyMesh;
use glam::DVec3;

/// The most corners a written face may have (`uchar` list count).
pub(super) const MAX_WRITTEN_CORNERS: usize = u8::MAX as usize;
/// The most vertices a written mesh may have (`int` indices).
pub(super) const MAX_WRITTEN_VERTICES: usize = i32::MAX as usize;

/// Where an error is: the line of an ASCII record or header line, if known.
type Failure = (Option<usize>, Problem);

pub(super) fn read(bytes: &[u8], file: &str) -> Result<PolyMesh, MeshError> {
    read_inner(bytes).map_err(|(line, problem)| MeshError::malformed(file, line, problem))
}

fn read_inner(bytes: &[u8]) -> Result<PolyMesh, Failure> {
    let mut reader = Reader::new(bytes);
    let header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .map_err(|e| header_failure(bytes, &e))?;
    let mut body = Body {
        rest: reader.get_ref(),
        encoding: header.encoding,
        line: reader.line(),
    };
    let header_text = &bytes[..bytes.len() - body.rest.len()];
    let vertices = check_header(&header, header_text, body.rest.len())?;

    let mut builder = MeshBuilder::with_capacity(vertices);
    let mut corners = Vec::new();
    for def in header.elements.values() {
        match role(def) {
            Role::Vertex => {
                let parser = Parser::<VertexRecord>::new();
                for k in 0..def.count {
                    let (line, record) = body.record(&parser, def, k)?;
                    builder
                        .push_position(DVec3::from_array(record.0))
                        .map_err(|p| (line, p))?;
                }
            }
            Role::Faces => {
                let parser = Parser::<IndexList>::new();
                for k in 0..def.count {
                    let (line, record) = body.record(&parser, def, k)?;
                    corners.clear();
                    for &index in &record.0 {
                        corners.push(check_index(index, vertices).map_err(|p| (line, p))?);
                    }
                    builder.push_face(&corners).map_err(|p| (line, p))?;
                }
            }
            Role::Strips => {
                let parser = Parser::<IndexList>::new();
                for k in 0..def.count {
                    let (line, record) = body.record(&parser, def, k)?;
                    push_strips(&mut builder, &record.0, vertices).map_err(|p| (line, p))?;
                }
            }
            Role::Skip => {
                let parser = Parser::<Skip>::new();
                for k in 0..def.count {
                    body.record(&parser, def, k)?;
                }
            }
        }
    }
    builder.finish().map_err(|p| (None, p))
}

fn check_index(index: i64, vertices: usize) -> Result<u32, Problem> {
    match u32::try_from(index) {
        Ok(i) if (i as usize) < vertices => Ok(i),
        _ => Err(Problem::IndexOutOfRange { index, vertices }),
    }
}

/// Appends the triangles of the strips in `list` (separated by -1).
fn push_strips(builder: &mut MeshBuilder, list: &[i64], vertices: usize) -> Result<(), Problem> {
    for strip in list.split(|&i| i == -1) {
        let strip: Vec<u32> = strip
            .iter()
            .map(|&i| check_index(i, vertices))
            .collect::<Result<_, _>>()?;
        for (k, w) in strip.windows(3).enumerate() {
            let triangle = if k % 2 == 0 {
                [w[0], w[1], w[2]]
            } else {
                [w[1], w[0], w[2]]
            };
            if triangle[0] != triangle[1]
                && triangle[1] != triangle[2]
                && triangle[0] != triangle[2]
            {
                builder.push_face(&triangle)?;
            }
        }
    }
    Ok(())
}

fn header_failure(bytes: &[u8], e: &ParseError) -> Failure {
    let problem = if e.kind() == io::ErrorKind::UnexpectedEof {
        Problem::Truncated {
            what: "the PLY header".into(),
        }
    } else if let Some(text) = e
        .line()
        .and_then(|n| numbered_lines(bytes).nth(n.wrapping_sub(1)))
    {
        let text: String = String::from_utf8_lossy(text.1).chars().take(60).collect();
        Problem::Syntax(format!("invalid PLY header line {text:?}"))
    } else {
        Problem::Syntax(format!("invalid PLY header: {}", first_line(e)))
    };
    (e.line(), problem)
}

/// The first line of a `ply-rs-bw` message, whose further lines repeat the input.
fn first_line(e: &ParseError) -> String {
    e.to_string().lines().next().unwrap_or_default().to_owned()
}

/// What each element is read for.
enum Role {
    Vertex,
    Faces,
    Strips,
    Skip,
}

fn role(def: &ElementDef) -> Role {
    match def.name.as_str() {
        "vertex" => Role::Vertex,
        "face" => Role::Faces,
        "tristrips" => Role::Strips,
        _ => Role::Skip,
    }
}

/// Checks that the elements that matter have the properties needed and that
/// the declared counts fit in the bytes after the header; returns the number
/// of vertices.
fn check_header(header: &Header, header_text: &[u8], body_bytes: usize) -> Result<usize, Failure> {
    let ascii = header.encoding == Encoding::Ascii;
    // The header parser keeps one definition per name; a second one would
    // leave the body read against the wrong layout.
    let mut declared: Vec<(&str, usize)> = Vec::new();
    for (number, line) in numbered_lines(header_text) {
        let mut words = std::str::from_utf8(line)
            .unwrap_or("")
            .split_ascii_whitespace();
        if let (Some("element"), Some(name)) = (words.next(), words.next()) {
            if let Some(&(_, first)) = declared.iter().find(|(n, _)| *n == name) {
                let what =
                    format!("PLY element '{name}' is declared twice (lines {first} and {number})");
                return Err((Some(number), Problem::Syntax(what)));
            }
            declared.push((name, number));
        }
    }
    let mut needed = 0u64;
    let mut vertices = None;
    for def in header.elements.values() {
        let fail = |problem| (element_line(header_text, &def.name), problem);
        match role(def) {
            Role::Vertex => {
                for axis in ["x", "y", "z"] {
                    match def.properties.get(axis).map(|p| &p.data_type) {
                        Some(PropertyType::Scalar(_)) => {}
                        Some(PropertyType::List(..)) => {
                            let what = format!("PLY vertex property '{axis}' is a list");
                            return Err(fail(Problem::Syntax(what)));
                        }
                        None => {
                            let what = format!("PLY vertex element has no '{axis}' property");
                            return Err(fail(Problem::Syntax(what)));
                        }
                    }
                }
                if def.count as u64 > MAX_VERTICES {
                    let problem = Problem::TooMany {
                        what: "vertices",
                        count: def.count as u64,
                        max: MAX_VERTICES,
                    };
                    return Err(fail(problem));
                }
                vertices = Some(def.count);
            }
            Role::Faces | Role::Strips => {
                let list = def.properties.values().find(|p| is_index_list(&p.name));
                match list.map(|p| &p.data_type) {
                    Some(PropertyType::List(_, item)) if is_integer(item) => {}
                    Some(PropertyType::List(_, item)) => {
                        let what = format!("{} indices of type {item:?}", def.name);
                        return Err(fail(Problem::Unsupported(what)));
                    }
                    _ => {
                        let what = format!("PLY {} element has no 'vertex_indices' list", def.name);
                        return Err(fail(Problem::Syntax(what)));
                    }
                }
            }
            Role::Skip => {}
        }
        // Checking before reading bounds both time and memory by the input
        // size, whatever the header claims; a record of no bytes still costs a
        // loop step, so it counts as one byte.
        let record = min_record_bytes(def, ascii).max(1);
        needed = needed.saturating_add(record.saturating_mul(def.count as u64));
        // An ASCII file may lack its last line break.
        if needed > body_bytes as u64 + u64::from(ascii) {
            let problem = Problem::CountExceedsData {
                what: format!("{} elements", def.name),
                count: def.count as u64,
                bytes: body_bytes,
            };
            return Err(fail(problem));
        }
    }
    vertices.ok_or((None, Problem::NoVertices))
}

/// The header line that declares element `name`.
fn element_line(header_text: &[u8], name: &str) -> Option<usize> {
    numbered_lines(header_text).find_map(|(number, line)| {
        let mut words = std::str::from_utf8(line).ok()?.split_ascii_whitespace();
        (words.next() == Some("element") && words.next() == Some(name)).then_some(number)
    })
}

fn is_index_list(name: &str) -> bool {
    name == "vertex_indices" || name == "vertex_index"
}

fn is_integer(t: &ScalarType) -> bool {
    !matches!(t, ScalarType::Float | ScalarType::Double)
}

fn scalar_bytes(t: &ScalarType) -> u64 {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// The fewest bytes one record of `def` can take: lists may be empty, and an
/// ASCII value takes at least a digit and a separator.
fn min_record_bytes(def: &ElementDef, ascii: bool) -> u64 {
    def.properties
        .values()
        .map(|p| match (&p.data_type, ascii) {
            (_, true) => 2,
            (PropertyType::Scalar(t), false) => scalar_bytes(t),
            (PropertyType::List(count, _), false) => scalar_bytes(count),
        })
        .sum()
}

/// The unread data after the header.
struct Body<'a> {
    rest: &'a [u8],
    encoding: Encoding,
    /// The line of the next ASCII record.
    line: usize,
}

impl Body<'_> {
    /// Decodes record `k` of `def`, with its line for ASCII.
    fn record<E: PropertyAccess>(
        &mut self,
        parser: &Parser<E>,
        def: &ElementDef,
        k: usize,
    ) -> Result<(Option<usize>, E), Failure> {
        let truncated = || Problem::Truncated {
            what: format!("{} {k} of {}", def.name, def.count),
        };
        if self.encoding == Encoding::Ascii {
            let line = self.line;
            if self.rest.is_empty() {
                return Err((Some(line), truncated()));
            }
            let end = self
                .rest
                .iter()
                .position(|&b| b == b'\n')
                .map_or(self.rest.len(), |e| e + 1);
            let (text, rest) = self.rest.split_at(end);
            self.rest = rest;
            self.line += 1;
            let text = std::str::from_utf8(text).map_err(|_| {
                (
                    Some(line),
                    Problem::Syntax(format!("{} {k} is not text", def.name)),
                )
            })?;
            let record = parser.read_ascii_element(text, def).map_err(|e| {
                let what = format!(
                    "invalid {} record {:?}: {}",
                    def.name,
                    text.trim(),
                    first_line(&e)
                );
                (Some(line), Problem::Syntax(what))
            })?;
            Ok((Some(line), record))
        } else {
            let decoded = if self.encoding == Encoding::BinaryLittleEndian {
                parser.read_little_endian_element(&mut self.rest, def)
            } else {
                parser.read_big_endian_element(&mut self.rest, def)
            };
            let record = decoded.map_err(|e| {
                let problem = if e.kind() == io::ErrorKind::UnexpectedEof {
                    truncated()
                } else {
                    Problem::Syntax(format!("{} {k}: {}", def.name, first_line(&e)))
                };
                (None, problem)
            })?;
            Ok((None, record))
        }
    }
}

/// A vertex record: only the position.
#[derive(Default)]
struct VertexRecord([f64; 3]);

impl VertexRecord {
    fn set(&mut self, name: &str, value: f64) -> PropertyAccessResult {
        let axis = match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            _ => return PropertyAccessResult::Ignored,
        };
        self.0[axis] = value;
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for VertexRecord {
    fn new() -> Self {
        VertexRecord::default()
    }
    fn set_char(&mut self, name: &str, value: i8) -> PropertyAccessResult {
        self.set(name, value.into())
    }
    fn set_uchar(&mut self, name: &str, value: u8) -> PropertyAccessResult {
        self.set(name, value.into())
    }
    fn set_short(&mut self, name: &str, value: i16) -> PropertyAccessResult {
        self.set(name, value.into())
    }
    fn set_ushort(&mut self, name: &str, value: u16) -> PropertyAccessResult {
        self.set(name, value.into())
    }
    fn set_int(&mut self, name: &str, value: i32) -> PropertyAccessResult {
        self.set(name, value.into())
    }
    fn set_uint(&mut self, name: &str, value: u32) -> PropertyAccessResult {
        self.set(name, value.into())
    }
    fn set_float(&mut self, name: &str, value: f32) -> PropertyAccessResult {
        self.set(name, value.into())
    }
    fn set_double(&mut self, name: &str, value: f64) -> PropertyAccessResult {
        self.set(name, value)
    }
}

/// A face or strip record: only the vertex index list.
#[derive(Default)]
struct IndexList(Vec<i64>);

impl IndexList {
    fn set<T: Into<i64>>(&mut self, name: &str, values: Vec<T>) -> PropertyAccessResult {
        if !is_index_list(name) {
            return PropertyAccessResult::Ignored;
        }
        self.0.clear();
        self.0.extend(values.into_iter().map(Into::into));
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for IndexList {
    fn new() -> Self {
        IndexList::default()
    }
    fn set_list_char(&mut self, name: &str, values: Vec<i8>) -> PropertyAccessResult {
        self.set(name, values)
    }
    fn set_list_uchar(&mut self, name: &str, values: Vec<u8>) -> PropertyAccessResult {
        self.set(name, values)
    }
    fn set_list_short(&mut self, name: &str, values: Vec<i16>) -> PropertyAccessResult {
        self.set(name, values)
    }
    fn set_list_ushort(&mut self, name: &str, values: Vec<u16>) -> PropertyAccessResult {
        self.set(name, values)
    }
    fn set_list_int(&mut self, name: &str, values: Vec<i32>) -> PropertyAccessResult {
        self.set(name, values)
    }
    fn set_list_uint(&mut self, name: &str, values: Vec<u32>) -> PropertyAccessResult {
        self.set(name, values)
    }
}

/// A record of an element nobody reads; the parser still decodes it to skip it.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

/// Writes binary little endian PLY. The caller has checked face sizes and
/// indices against [`MAX_WRITTEN_CORNERS`] and [`MAX_WRITTEN_VERTICES`].
pub(super) fn write(w: &mut impl Write, mesh: &PolyMesh) -> io::Result<()> {
    write!(
        w,
        "ply\n\
         format binary_little_endian 1.0\n\
         comment written by qm\n\
         element vertex {}\n\
         property double x\n\
         property double y\n\
         property double z\n\
         element face {}\n\
         property list uchar int vertex_indices\n\
         end_header\n",
        mesh.positions.len(),
        mesh.face_count()
    )?;
    for p in &mesh.positions {
        for c in p.to_array() {
            w.write_all(&c.to_le_bytes())?;
        }
    }
    for face in mesh.faces() {
        w.write_all(&[face.len() as u8])?;
        for &index in face {
            w.write_all(&(index as i32).to_le_bytes())?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tests::{assert_bit_exact, awkward_mesh};
    use crate::{Format, read_mesh_bytes, write_mesh_to};

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
        assert!(
            bytes.starts_with(b"ply\nformat binary_little_endian 1.0\ncomment written by qm\n")
        );
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
}
