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
//! With appearance ([`crate::read_asset`]): vertex colours `red green blue
//! [alpha]` (also `diffuse_red` ... and `r g b a`) of type `uchar` (/255),
//! `ushort` (/65535), `float` or `double` (0..1 as written; a value outside
//! drops the colours, not the mesh). Every other property and element the
//! header declares is listed as dropped: normals, texture coordinates (per
//! vertex or MeshLab's per-corner `texcoord` and `TextureFile` comment), face
//! colours, `edge` elements, the rest as properties.
//!
//! Written: binary little endian, `double` coordinates (exact) and faces as
//! `list uchar int vertex_indices`.

use std::io::{self, Write};

use ply_rs_bw::parser::{ParseError, Parser, Reader};
use ply_rs_bw::ply::{
    ElementDef, Encoding, Header, PropertyAccess, PropertyAccessResult, PropertyType, ScalarType,
};

use super::{MAX_VERTICES, MeshBuilder, MeshError, Problem, Source, numbered_lines};
use crate::asset::add_dropped;
use crate::{Asset, AttributeKind as Kind, Dropped, PolyMesh};
use glam::DVec3;

/// The most corners a written face may have (`uchar` list count).
pub(super) const MAX_WRITTEN_CORNERS: usize = u8::MAX as usize;
/// The most vertices a written mesh may have (`int` indices).
pub(super) const MAX_WRITTEN_VERTICES: usize = i32::MAX as usize;

/// Where an error is: the line of an ASCII record or header line, if known.
type Failure = (Option<usize>, Problem);

pub(super) fn read(bytes: &[u8], source: &Source) -> Result<Asset, MeshError> {
    read_inner(bytes, source.appearance.is_some())
        .map_err(|(line, problem)| MeshError::malformed(source.name, line, problem))
}

fn read_inner(bytes: &[u8], appearance: bool) -> Result<Asset, Failure> {
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

    let mut dropped = Vec::new();
    let colors = if appearance {
        describe(&header, &mut dropped)
    } else {
        None
    };
    let mut colors = colors.map(|alpha| Colors {
        alpha,
        values: Vec::with_capacity(vertices),
        problem: None,
    });
    let mut builder = MeshBuilder::with_capacity(vertices);
    let mut corners = Vec::new();
    for def in header.elements.values() {
        match role(def) {
            Role::Vertex => {
                let parser = Parser::<VertexRecord>::new();
                for k in 0..def.count {
                    let (line, record) = body.record(&parser, def, k)?;
                    builder
                        .push_position(DVec3::from_array(record.xyz))
                        .map_err(|p| (line, p))?;
                    if let Some(colors) = &mut colors {
                        colors.push(k, line, record.rgba);
                    }
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
    let mut asset = Asset::of(builder.finish().map_err(|p| (None, p))?);
    if let Some(colors) = colors {
        match colors.problem {
            None => asset.colors = Some(colors.values),
            Some(why) => {
                let detail = format!("vertex colours not read: {why}");
                add_dropped(&mut dropped, Kind::VertexColors, vertices as u64, detail);
            }
        }
    }
    asset.dropped = dropped;
    Ok(asset)
}

/// Vertex colours as they are read.
struct Colors {
    /// Whether the file has an alpha channel (else alpha is 1).
    alpha: bool,
    values: Vec<[f32; 4]>,
    /// The first value out of 0..1, which drops them all.
    problem: Option<String>,
}

impl Colors {
    fn push(&mut self, vertex: usize, line: Option<usize>, rgba: [f64; 4]) {
        if self.problem.is_some() {
            return;
        }
        let rgba = if self.alpha {
            rgba
        } else {
            [rgba[0], rgba[1], rgba[2], 1.0]
        };
        match rgba.iter().find(|v| !(0.0..=1.0).contains(*v)) {
            None => self.values.push(rgba.map(|v| v as f32)),
            Some(v) => {
                let at = line.map_or(String::new(), |l| format!(" (line {l})"));
                self.problem = Some(format!("vertex {vertex}{at} has value {v} outside 0..1"));
            }
        }
    }
}

/// Names of the colour channels: red, green, blue, alpha.
const COLOR_NAMES: [[&str; 4]; 3] = [
    ["red", "green", "blue", "alpha"],
    [
        "diffuse_red",
        "diffuse_green",
        "diffuse_blue",
        "diffuse_alpha",
    ],
    ["r", "g", "b", "a"],
];

/// The channel of a vertex colour property, if `name` is one.
fn color_channel(name: &str) -> Option<usize> {
    COLOR_NAMES
        .iter()
        .find_map(|names| names.iter().position(|&n| n == name))
}

/// Lists what the header declares beyond positions and faces into `dropped`;
/// returns whether vertex colours are read and, if so, whether with alpha.
fn describe(header: &Header, dropped: &mut Vec<Dropped>) -> Option<bool> {
    let mut colors = None;
    for comment in &header.comments {
        if let Some(name) = comment.trim().strip_prefix("TextureFile") {
            let detail = format!("texture {} (PLY textures are not read)", name.trim());
            add_dropped(dropped, Kind::Textures, 1, detail);
        }
    }
    for def in header.elements.values() {
        let count = def.count as u64;
        match role(def) {
            Role::Vertex => {
                let mut channels: [Option<&ScalarType>; 4] = [None; 4];
                let mut others: Vec<(Kind, &str)> = Vec::new();
                for p in def.properties.values() {
                    let name = p.name.as_str();
                    if let (Some(c), PropertyType::Scalar(t)) = (color_channel(name), &p.data_type)
                    {
                        channels[c] = Some(t);
                        continue;
                    }
                    let kind = match name {
                        "x" | "y" | "z" => continue,
                        "nx" | "ny" | "nz" => Kind::Normals,
                        "s" | "t" | "u" | "v" | "texture_u" | "texture_v" | "texture_s"
                        | "texture_t" => Kind::TexCoords,
                        _ => Kind::Properties,
                    };
                    others.push((kind, name));
                }
                for kind in [Kind::Normals, Kind::TexCoords, Kind::Properties] {
                    let names: Vec<&str> = others
                        .iter()
                        .filter(|(k, _)| *k == kind)
                        .map(|(_, n)| *n)
                        .collect();
                    if !names.is_empty() {
                        let detail = format!("vertex {}", names.join(" "));
                        add_dropped(dropped, kind, count, detail);
                    }
                }
                let usable = |t: &&ScalarType| {
                    matches!(
                        t,
                        ScalarType::UChar
                            | ScalarType::UShort
                            | ScalarType::Float
                            | ScalarType::Double
                    )
                };
                match channels {
                    [None, None, None, None] => {}
                    [Some(r), Some(g), Some(b), a]
                        if [r, g, b].iter().all(usable) && a.as_ref().is_none_or(usable) =>
                    {
                        colors = Some(a.is_some());
                    }
                    _ => {
                        let detail = format!(
                            "vertex colour channels {channels:?} (red, green and blue of \
                             uchar, ushort, float or double are read)"
                        );
                        add_dropped(dropped, Kind::VertexColors, count, detail);
                    }
                }
            }
            Role::Faces | Role::Strips => {
                let mut names: Vec<&str> = Vec::new();
                for p in def.properties.values() {
                    let name = p.name.as_str();
                    if is_index_list(name) {
                        continue;
                    }
                    let (kind, what) = match name {
                        _ if color_channel(name).is_some() => (Kind::FaceColors, "face colours"),
                        "texcoord" | "texnumber" => {
                            (Kind::TexCoords, "per-corner texture coordinates")
                        }
                        _ => {
                            names.push(name);
                            continue;
                        }
                    };
                    let detail = format!("{} {what} ({name})", def.name);
                    add_dropped(dropped, kind, count, detail);
                }
                if !names.is_empty() {
                    let detail = format!("{} {}", def.name, names.join(" "));
                    add_dropped(dropped, Kind::Properties, count, detail);
                }
            }
            Role::Skip => {
                let kind = if def.name == "edge" {
                    Kind::Lines
                } else {
                    Kind::Properties
                };
                let detail = format!("{} elements", def.name);
                add_dropped(dropped, kind, count, detail);
            }
        }
    }
    colors
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

/// A vertex record: the position and the colour channels (scaled to 0..1
/// by their type, so `uchar` 255 and `float` 1.0 are both 1).
#[derive(Default)]
struct VertexRecord {
    xyz: [f64; 3],
    rgba: [f64; 4],
}

impl VertexRecord {
    fn set(&mut self, name: &str, value: f64) -> PropertyAccessResult {
        let axis = match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            _ => return PropertyAccessResult::Ignored,
        };
        self.xyz[axis] = value;
        PropertyAccessResult::Set
    }

    /// A value that may be a position or a colour channel of `full` scale.
    fn set_either(&mut self, name: &str, value: f64, full: f64) -> PropertyAccessResult {
        match color_channel(name) {
            Some(c) => {
                self.rgba[c] = value / full;
                PropertyAccessResult::Set
            }
            None => self.set(name, value),
        }
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
        self.set_either(name, value.into(), 255.0)
    }
    fn set_short(&mut self, name: &str, value: i16) -> PropertyAccessResult {
        self.set(name, value.into())
    }
    fn set_ushort(&mut self, name: &str, value: u16) -> PropertyAccessResult {
        self.set_either(name, value.into(), 65535.0)
    }
    fn set_int(&mut self, name: &str, value: i32) -> PropertyAccessResult {
        self.set(name, value.into())
    }
    fn set_uint(&mut self, name: &str, value: u32) -> PropertyAccessResult {
        self.set(name, value.into())
    }
    fn set_float(&mut self, name: &str, value: f32) -> PropertyAccessResult {
        self.set_either(name, value.into(), 1.0)
    }
    fn set_double(&mut self, name: &str, value: f64) -> PropertyAccessResult {
        self.set_either(name, value, 1.0)
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

/// Writes binary little endian PLY, with `uchar red green blue` after each
/// vertex's position when `colours` are given (one a vertex). The caller has
/// checked face sizes and indices against [`MAX_WRITTEN_CORNERS`] and
/// [`MAX_WRITTEN_VERTICES`], and the colour count.
pub(super) fn write(
    w: &mut impl Write,
    mesh: &PolyMesh,
    colours: Option<&[[u8; 3]]>,
) -> io::Result<()> {
    let colour_properties = if colours.is_some() {
        "property uchar red\n\
         property uchar green\n\
         property uchar blue\n"
    } else {
        ""
    };
    write!(
        w,
        "ply\n\
         format binary_little_endian 1.0\n\
         comment written by qm\n\
         element vertex {}\n\
         property double x\n\
         property double y\n\
         property double z\n\
         {colour_properties}\
         element face {}\n\
         property list uchar int vertex_indices\n\
         end_header\n",
        mesh.positions.len(),
        mesh.face_count()
    )?;
    for (k, p) in mesh.positions.iter().enumerate() {
        for c in p.to_array() {
            w.write_all(&c.to_le_bytes())?;
        }
        if let Some(colours) = colours {
            w.write_all(&colours[k])?;
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
mod tests;
