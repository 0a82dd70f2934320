//! The base section: base faces and level-0 values, predicted and
//! arithmetic-coded ([`encode`], [`decode`], [`BaseSection`]). The values
//! are the high parts `value >> k` (the stream carries the low `k` bits);
//! the prediction works on those.
//!
//! Every number goes through the adaptive binary range coder of the stream
//! ([`qm_ezw::BitWriter`]) as a signed Exp-Golomb code whose bits all have
//! adaptive contexts ([`numbers`]). The section is the faces' corners, or a
//! split base's triangles ([`connectivity`]), then the values, each as the
//! difference to its prediction from the vertices before it ([`values`]).
//!
//! The format versions ([`OLDEST`] to [`VERSION`]) differ only in how this
//! section codes its faces ([`connectivity`]); the container writes
//! [`VERSION`] and reads them all.

mod connectivity;
mod front;
mod numbers;
#[cfg(test)]
mod tests;
mod values;

use qm_ezw::{BitReader, BitWriter, Context};
use qm_lift::split_triangles;

use connectivity::{FaceModel, TriangleModel, face_bit, split_of};
use values::{ChoiceModel, Corners, Predictor, ValueModels, coded_values};
pub(crate) use values::{SNAP_STEPS, corner_count, noise_bits, snap_split};

/// The format version this build writes; it reads this one and
/// every one back to [`OLDEST`] (`docs/format.md` specifies them). The
/// versions differ only in how the base section codes its faces
/// (this module): version 2 by new and recent vertices, version 3 also a
/// split triangle mesh by its triangles, version 4 those triangles' vertices
/// beside the edge they attach to by a flag, version 5 a split base's
/// corners by the parallelograms the encoder chose among those across
/// their known triangles, version 6 a split base's triangles with every
/// open edge kept and their flags in the context of the one or two
/// triangles before.
pub const VERSION: u8 = 6;

/// The oldest format version this build reads: the first published one.
pub const OLDEST: u8 = 1;

/// The base mesh as stored: corners of each face, then the level-0 scaling
/// value of each base vertex without its low bits.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BaseSection {
    /// Counter-clockwise corners of each base face.
    pub faces: Vec<[u32; 4]>,
    /// Quantized level-0 values, one per base vertex, shifted right
    /// (arithmetically) by `low_bits`.
    pub values: Vec<[i32; 3]>,
    /// Low bits of each value that are in the stream instead
    /// ([`qm_ezw::StreamParams::base_bits`]).
    pub low_bits: u32,
}

/// The triangles `faces` over `vertices` are the split of, in this
/// build's version; `None` for a base that is no split.
pub(crate) fn split_triangles_of(faces: &[[u32; 4]], vertices: usize) -> Option<Vec<[u32; 3]>> {
    split_of(faces, vertices, VERSION)
}

/// Codes `faces` (corners below `values.len()`) and `values`, in format
/// version `version`; with `implied` (a split base at level 0, header flag
/// [`crate::container::IMPLIED_SPLIT`]) the values of the corners alone, the
/// others being their predictions ([`snap_split`]).
pub(crate) fn encode(
    faces: &[[u32; 4]],
    values: &[[i32; 3]],
    version: u8,
    implied: bool,
) -> Vec<u8> {
    let split = split_of(faces, values.len(), version);
    let split = split.as_deref();
    let history = split.map_or(1, |triangles| history(triangles, values.len(), version));
    let coded = |corners| encode_choosing(faces, values, version, split, implied, corners, history);
    let plain = coded(Corners::Plain);
    // Version 5 on: a split base's corners predicted by the parallelograms
    // the encoder names, in vertex order or in the order that gives them
    // the most, where that is shorter.
    if version < 5 || split.is_none() {
        return plain;
    }
    [Corners::Chosen, Corners::ChosenInOrder]
        .into_iter()
        .map(coded)
        .fold(plain, |best, b| if b.len() < best.len() { b } else { best })
}

/// The slowest adaptation rate of the section's contexts in format
/// `version`, as a power of two: from version 6 on 1/32, not the stream's
/// 1/64. A base section is thousands of numbers, not millions: its
/// contexts gain more from learning fast than from settling (0.1 to 3%
/// off the base sections measured; the whole stream at 1/32 lost 0.2 to
/// 0.5%; docs/decisions/026-base-connectivity.md).
fn slowest_rate(version: u8) -> u32 {
    if version >= 6 {
        BASE_SLOWEST
    } else {
        qm_ezw::SLOWEST
    }
}

/// [`slowest_rate`] from version 6 on.
const BASE_SLOWEST: u32 = 5;

/// A writer of the section in format `version`.
fn writer(version: u8) -> BitWriter {
    BitWriter::new().with_slowest_rate(slowest_rate(version))
}

/// How many triangles before choose the contexts of a split base's
/// `triangles` over `vertices` (format version 6 on): two where that codes
/// them shorter, else one. Two learn a faceted part's patterns better (1
/// to 3% off its base section), one learns faster on the remesher's bases
/// of a thousand triangles (docs/decisions/026-base-connectivity.md).
fn history(triangles: &[[u32; 3]], vertices: usize, version: u8) -> u8 {
    if version < 6 {
        return 1;
    }
    let length = |history| {
        let mut w = writer(version);
        let mut model = TriangleModel::new(vertices as u32, version, history);
        triangles.iter().for_each(|t| model.put(&mut w, t));
        w.len_needed()
    };
    if length(2) < length(1) { 2 } else { 1 }
}

/// [`encode`] of a base that is the `split` of those triangles (or none),
/// with its corners predicted as `corners` says and its triangles' contexts
/// chosen by the `history` triangles before.
fn encode_choosing(
    faces: &[[u32; 4]],
    values: &[[i32; 3]],
    version: u8,
    split: Option<&[[u32; 3]]>,
    implied: bool,
    corners: Corners,
    history: u8,
) -> Vec<u8> {
    let mut w = writer(version);
    if version >= 3 {
        w.encode(&mut Context::default(), split.is_some());
    }
    if version >= 5 && split.is_some() {
        w.encode(&mut Context::default(), corners != Corners::Plain);
        if corners != Corners::Plain {
            w.encode(&mut Context::default(), corners == Corners::ChosenInOrder);
        }
    }
    if version >= 6 && split.is_some() {
        w.encode(&mut Context::default(), history == 2);
    }
    match split {
        Some(triangles) => {
            let mut model = TriangleModel::new(values.len() as u32, version, history);
            triangles.iter().for_each(|t| model.put(&mut w, t));
        }
        None => {
            let mut model = FaceModel::new(values.len(), version);
            faces.iter().for_each(|face| model.put(&mut w, face));
        }
    }
    let predictor = Predictor::new(faces, values.len(), split, corners);
    let coded = coded_values(split, values.len(), implied);
    let mut coord = ValueModels::new(version);
    let mut choice = ChoiceModel::default();
    for v in predictor.coding_order(coded) {
        let value = &values[v];
        let guess = predictor.guess(v, values);
        let mask = guess.best(value);
        choice.put(&mut w, &guess, mask);
        let p = guess.with(mask);
        let residual: [i64; 3] = std::array::from_fn(|i| value[i] as i64 - p[i]);
        coord.put(&mut w, &guess, residual);
    }
    w.finish()
}

/// How many of `base`'s vertices have their values coded (in the base
/// section, and their low bits in the stream): with `implied` (the
/// header's flag) and a split base, its corners alone.
pub fn coded_base_values(base: &qm_lift::BaseMesh, implied: bool) -> usize {
    let vertices = base.vertex_count() as usize;
    coded_values(
        split_triangles_of(base.faces(), vertices).as_deref(),
        vertices,
        implied,
    )
}

/// Decodes what [`encode`] wrote, given the counts from the header, the
/// number of low bits the stream holds of each value (so that a value with
/// them still fits 32 bits) and whether only the corners of a split base
/// are there (the others come back as 0, for the caller to predict); the
/// error says what is wrong.
pub(crate) fn decode(
    bytes: &[u8],
    face_count: usize,
    vertex_count: usize,
    low_bits: u32,
    version: u8,
    implied: bool,
) -> Result<BaseSection, String> {
    let range = (i32::MIN >> low_bits) as i64..=(i32::MAX >> low_bits) as i64;
    let mut r = BitReader::new(bytes).with_slowest_rate(slowest_rate(version));
    let split = version >= 3 && face_bit(&mut r, &mut Context::default())?;
    let corners = if version >= 5 && split && face_bit(&mut r, &mut Context::default())? {
        match face_bit(&mut r, &mut Context::default())? {
            true => Corners::ChosenInOrder,
            false => Corners::Chosen,
        }
    } else {
        Corners::Plain
    };
    let history = if version >= 6 && split && face_bit(&mut r, &mut Context::default())? {
        2
    } else {
        1
    };
    let (faces, triangles) = if split {
        if face_count % 3 != 0 {
            return Err(format!(
                "{face_count} faces cannot be triangles split in three"
            ));
        }
        let most = vertex_count.min(u32::MAX as usize) as u32;
        let mut model = TriangleModel::new(most, version, history);
        let mut triangles = Vec::with_capacity((face_count / 3).min(bytes.len()));
        for t in 0..face_count / 3 {
            triangles.push(model.get(&mut r, t)?);
        }
        let quads = split_triangles(&triangles);
        if quads.vertex_count as usize != vertex_count {
            return Err(format!(
                "its triangles make {} base vertices, not {vertex_count}",
                quads.vertex_count
            ));
        }
        (quads.faces, Some(triangles))
    } else {
        let mut model = FaceModel::new(vertex_count, version);
        let mut faces = Vec::with_capacity(face_count.min(bytes.len()));
        for f in 0..face_count {
            faces.push(model.get(&mut r, f)?);
        }
        (faces, None)
    };
    if implied && triangles.is_none() {
        return Err("its midpoints and centres are said to be implied, but it is no split".into());
    }
    let predictor = Predictor::new(&faces, vertex_count, triangles.as_deref(), corners);
    let coded = coded_values(triangles.as_deref(), vertex_count, implied);
    let mut coord = ValueModels::new(version);
    let mut choice = ChoiceModel::default();
    // The values not coded stay 0, for the caller to predict.
    let mut values = vec![[0i32; 3]; vertex_count];
    for v in predictor.coding_order(coded) {
        let guess = predictor.guess(v, &values);
        let p = guess.with(choice.get(&mut r, &guess)?);
        let residual = coord.get(&mut r, &guess)?;
        let mut value = [0i32; 3];
        for i in 0..3 {
            let x = p[i] + residual[i];
            if !range.contains(&x) {
                return Err(format!("base vertex {v} has a value out of range"));
            }
            value[i] = x as i32;
        }
        values[v] = value;
    }
    Ok(BaseSection {
        faces,
        values,
        low_bits,
    })
}
