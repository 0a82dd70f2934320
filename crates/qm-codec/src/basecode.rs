//! The base section: base faces and level-0 values, predicted and
//! arithmetic-coded. The values are the high parts `value >> k` (the stream
//! carries the low `k` bits); the prediction works on those.
//!
//! Every number goes through the adaptive binary range coder of the stream
//! ([`qm_ezw::BitWriter`]) as a signed Exp-Golomb code whose bits all have
//! adaptive contexts: a zero flag, a sign, the bit length in unary, then the
//! bits below the leading one.
//!
//! **Faces** are coded corner by corner. Format version 1 codes each corner
//! as the difference to the same corner of the previous face: in the
//! grid-like base meshes of one square per part that difference is almost
//! always 1, but three quads to a base triangle in a simplifier's order cost
//! about 25 bits a quad. Version 2 first says whether the corner is a vertex
//! not used before, coded then as the difference to the last new vertex of
//! the same corner; else whether it is among the [`RECENT`] vertices used
//! last, coded then by its place there; else it is the version 1
//! difference. Faces that share vertices with the faces just before them
//! (a base triangle's three quads, a grid's rows) then cost a few bits a
//! corner (docs/format.md).
//!
//! **Values** are coded in vertex order as the difference to a prediction
//! from the vertices before them: the parallelogram rule `b + d - c` over
//! every face whose three other corners are known (averaged when there are
//! several), else the mean of the known neighbours along face edges, else the
//! previous vertex. On a grid numbered row by row each vertex after the first
//! row and column has its parallelogram, and the residuals are about the size
//! of the surface's second differences instead of its coordinates.

use qm_ezw::{BitReader, BitWriter, Context};

use crate::container::BaseSection;

/// Contexts of one kind of signed number.
#[derive(Clone)]
struct IntModel {
    zero: Context,
    sign: Context,
    /// Unary bit length, one context per position.
    length: [Context; 40],
    /// Bits below the leading one, one context per position.
    bits: [Context; 40],
}

impl IntModel {
    fn new() -> Self {
        IntModel {
            zero: Context::default(),
            sign: Context::default(),
            length: [Context::default(); 40],
            bits: [Context::default(); 40],
        }
    }

    fn put(&mut self, w: &mut BitWriter, v: i64) {
        w.encode(&mut self.zero, v == 0);
        if v == 0 {
            return;
        }
        w.encode(&mut self.sign, v < 0);
        let a = v.unsigned_abs();
        let n = 64 - a.leading_zeros() as usize;
        for i in 1..n {
            w.encode(&mut self.length[i], true);
        }
        if n < self.length.len() {
            w.encode(&mut self.length[n], false);
        }
        for i in (0..n - 1).rev() {
            w.encode(&mut self.bits[i], (a >> i) & 1 != 0);
        }
    }

    fn get(&mut self, r: &mut BitReader) -> Result<i64, String> {
        let bit = |r: &mut BitReader, c: &mut Context| {
            r.decode(c)
                .map_err(|_| "it ends before its last value".to_string())
        };
        if bit(r, &mut self.zero)? {
            return Ok(0);
        }
        let negative = bit(r, &mut self.sign)?;
        let mut n = 1;
        while n < self.length.len() && bit(r, &mut self.length[n])? {
            n += 1;
        }
        if n > 36 {
            return Err(format!("a value of {n} bits"));
        }
        let mut a = 1u64;
        for i in (0..n - 1).rev() {
            a = (a << 1) | bit(r, &mut self.bits[i])? as u64;
        }
        Ok(if negative { -(a as i64) } else { a as i64 })
    }
}

/// Faces around each vertex, as a compressed list.
struct Incidence {
    start: Vec<usize>,
    faces: Vec<u32>,
}

impl Incidence {
    fn new(faces: &[[u32; 4]], vertices: usize) -> Self {
        let mut start = vec![0usize; vertices + 1];
        for face in faces {
            for &v in face {
                start[v as usize + 1] += 1;
            }
        }
        for i in 0..vertices {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut list = vec![0u32; start[vertices]];
        for (f, face) in faces.iter().enumerate() {
            for &v in face {
                list[fill[v as usize]] = f as u32;
                fill[v as usize] += 1;
            }
        }
        Incidence { start, faces: list }
    }

    fn around(&self, v: usize) -> &[u32] {
        &self.faces[self.start[v]..self.start[v + 1]]
    }
}

/// Prediction of vertex `v`'s value from the values of vertices `0..v`.
fn predict(v: usize, faces: &[[u32; 4]], incidence: &Incidence, values: &[[i32; 3]]) -> [i64; 3] {
    let known = |u: u32| (u as usize) < v;
    let value = |u: u32| values[u as usize].map(i64::from);
    let add = |sum: &mut [i64; 3], x: [i64; 3]| (0..3).for_each(|i| sum[i] += x[i]);
    // Parallelogram predictions, and the edge neighbours as a fallback (an
    // edge shared by two faces counts twice, which keeps the mean symmetric).
    let (mut parallelogram, mut parallelograms) = ([0i64; 3], 0i64);
    let (mut neighbours, mut neighbour_count) = ([0i64; 3], 0i64);
    for &f in incidence.around(v) {
        let face = faces[f as usize];
        let Some(k) = face.iter().position(|&u| u as usize == v) else {
            continue;
        };
        let (b, c, d) = (face[(k + 1) % 4], face[(k + 2) % 4], face[(k + 3) % 4]);
        if known(b) && known(c) && known(d) {
            let (b, c, d) = (value(b), value(c), value(d));
            add(
                &mut parallelogram,
                std::array::from_fn(|i| b[i] + d[i] - c[i]),
            );
            parallelograms += 1;
        }
        for u in [b, d].into_iter().filter(|&u| known(u)) {
            add(&mut neighbours, value(u));
            neighbour_count += 1;
        }
    }
    let (sum, count) = if parallelograms > 0 {
        (parallelogram, parallelograms)
    } else {
        (neighbours, neighbour_count)
    };
    if count == 0 {
        return if v == 0 { [0; 3] } else { value(v as u32 - 1) };
    }
    sum.map(|s| s.div_euclid(count))
}

/// How many of the vertices used last a version 2 face corner may name by
/// its place among them.
const RECENT: usize = 32;

/// The face coder's state, the same on both sides: version 1's difference
/// to the previous face's corner alone, or version 2's new and recent
/// vertices before it.
struct FaceModel {
    /// Version 1: every corner a difference to the previous face's.
    version1: bool,
    /// Whether a corner is a vertex not used before, per corner.
    new: [Context; 4],
    /// A new vertex as the difference to the last new one, per corner.
    new_step: Vec<IntModel>,
    /// Whether a used vertex is among the recent ones, per corner.
    recent: [Context; 4],
    /// Its place there, a binary tree of contexts per corner.
    place: Vec<[Context; RECENT]>,
    /// Else the difference to the previous face's corner, per corner.
    step: Vec<IntModel>,
    used: Vec<bool>,
    last_new: [i64; 4],
    previous: [u32; 4],
    /// The vertices used last, most recent first.
    recents: Vec<u32>,
}

impl FaceModel {
    fn new(vertices: usize, version: u8) -> Self {
        FaceModel {
            version1: version == 1,
            new: [Context::default(); 4],
            new_step: vec![IntModel::new(); 4],
            recent: [Context::default(); 4],
            place: vec![[Context::default(); RECENT]; 4],
            step: vec![IntModel::new(); 4],
            used: vec![false; vertices],
            last_new: [-1; 4],
            previous: [0; 4],
            recents: Vec::with_capacity(RECENT + 1),
        }
    }

    fn put(&mut self, w: &mut BitWriter, face: &[u32; 4]) {
        for (k, &v) in face.iter().enumerate() {
            if self.version1 {
                self.step[k].put(w, v as i64 - self.previous[k] as i64);
                continue;
            }
            let new = !self.used[v as usize];
            w.encode(&mut self.new[k], new);
            let place = if new {
                self.new_step[k].put(w, v as i64 - self.last_new[k]);
                None
            } else {
                let place = self.recents.iter().position(|&u| u == v);
                w.encode(&mut self.recent[k], place.is_some());
                match place {
                    Some(i) => {
                        let mut node = 1;
                        for d in (0..RECENT.trailing_zeros()).rev() {
                            let bit = (i >> d) & 1 != 0;
                            w.encode(&mut self.place[k][node], bit);
                            node = 2 * node + usize::from(bit);
                        }
                    }
                    None => self.step[k].put(w, v as i64 - self.previous[k] as i64),
                }
                place
            };
            self.used_now(k, v, new, place);
        }
        self.previous = *face;
    }

    /// Face `f`; the error says what is wrong with it.
    fn get(&mut self, r: &mut BitReader, f: usize) -> Result<[u32; 4], String> {
        let bit = |r: &mut BitReader, c: &mut Context| {
            r.decode(c)
                .map_err(|_| "it ends before its last face".to_string())
        };
        let vertices = self.used.len() as i64;
        let mut face = [0u32; 4];
        for (k, corner) in face.iter_mut().enumerate() {
            let (mut new, mut place) = (false, None);
            let v = if self.version1 {
                self.previous[k] as i64 + self.step[k].get(r)?
            } else if bit(r, &mut self.new[k])? {
                new = true;
                self.last_new[k] + self.new_step[k].get(r)?
            } else if bit(r, &mut self.recent[k])? {
                let mut node = 1;
                for _ in 0..RECENT.trailing_zeros() {
                    node = 2 * node + usize::from(bit(r, &mut self.place[k][node])?);
                }
                let i = node - RECENT;
                let Some(&u) = self.recents.get(i) else {
                    let known = self.recents.len();
                    return Err(format!("face {f} names recent vertex {i} of {known}"));
                };
                place = Some(i);
                u as i64
            } else {
                self.previous[k] as i64 + self.step[k].get(r)?
            };
            if !(0..vertices).contains(&v) {
                return Err(format!(
                    "face {f} names vertex {v} of {vertices} base vertices"
                ));
            }
            *corner = v as u32;
            if !self.version1 {
                self.used_now(k, *corner, new, place);
            }
        }
        self.previous = face;
        Ok(face)
    }

    /// After corner `k` of a face named `v`, new or at `place` among the
    /// recent vertices (or, used but not recent, at neither).
    fn used_now(&mut self, k: usize, v: u32, new: bool, place: Option<usize>) {
        self.used[v as usize] = true;
        if new {
            self.last_new[k] = v as i64;
        }
        if let Some(i) = place {
            self.recents.remove(i);
        }
        self.recents.insert(0, v);
        self.recents.truncate(RECENT);
    }
}

/// Codes `faces` (corners below `values.len()`) and `values`, in format
/// version `version` (1 or 2).
pub(crate) fn encode(faces: &[[u32; 4]], values: &[[i32; 3]], version: u8) -> Vec<u8> {
    let mut w = BitWriter::new();
    let mut model = FaceModel::new(values.len(), version);
    for face in faces {
        model.put(&mut w, face);
    }
    let incidence = Incidence::new(faces, values.len());
    let mut coord = vec![IntModel::new(); 3];
    for (v, value) in values.iter().enumerate() {
        let p = predict(v, faces, &incidence, values);
        for i in 0..3 {
            coord[i].put(&mut w, value[i] as i64 - p[i]);
        }
    }
    w.finish()
}

/// How many low bits of the `values` are noise to their prediction: the
/// bits below the leading one of the median residual, but one (which the
/// codes' contexts still predict a little). A stream that carries these
/// bits instead of the base section loses next to nothing on them, and a
/// cut of it needs only as many as its details can use.
pub(crate) fn noise_bits(faces: &[[u32; 4]], values: &[[i32; 3]]) -> u32 {
    let incidence = Incidence::new(faces, values.len());
    let mut residuals: Vec<u64> = (0..values.len())
        .flat_map(|v| {
            let p = predict(v, faces, &incidence, values);
            (0..3).map(move |i| (values[v][i] as i64 - p[i]).unsigned_abs())
        })
        .collect();
    if residuals.is_empty() {
        return 0;
    }
    let middle = residuals.len() / 2;
    let median = *residuals.select_nth_unstable(middle).1;
    (64 - median.leading_zeros()).saturating_sub(2)
}

/// Decodes what [`encode`] wrote, given the counts from the header and the
/// number of low bits the stream holds of each value (so that a value with
/// them still fits 32 bits); the error says what is wrong.
pub(crate) fn decode(
    bytes: &[u8],
    face_count: usize,
    vertex_count: usize,
    low_bits: u32,
    version: u8,
) -> Result<BaseSection, String> {
    let range = (i32::MIN >> low_bits) as i64..=(i32::MAX >> low_bits) as i64;
    let mut r = BitReader::new(bytes);
    let mut faces = Vec::with_capacity(face_count.min(bytes.len()));
    let mut model = FaceModel::new(vertex_count, version);
    for f in 0..face_count {
        faces.push(model.get(&mut r, f)?);
    }
    let incidence = Incidence::new(&faces, vertex_count);
    let mut coord = vec![IntModel::new(); 3];
    let mut values = Vec::with_capacity(vertex_count.min(bytes.len()));
    for v in 0..vertex_count {
        let p = predict(v, &faces, &incidence, &values);
        let mut value = [0i32; 3];
        for i in 0..3 {
            let x = p[i] + coord[i].get(&mut r)?;
            if !range.contains(&x) {
                return Err(format!("base vertex {v} has a value out of range"));
            }
            value[i] = x as i32;
        }
        values.push(value);
    }
    Ok(BaseSection {
        faces,
        values,
        low_bits,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `k x k` grid of quads numbered row by row, on a wavy surface.
    fn grid(k: u32) -> (Vec<[u32; 4]>, Vec<[i32; 3]>) {
        let v = |x: u32, y: u32| y * (k + 1) + x;
        let mut faces = Vec::new();
        for y in 0..k {
            for x in 0..k {
                faces.push([v(x, y), v(x + 1, y), v(x + 1, y + 1), v(x, y + 1)]);
            }
        }
        let values = (0..(k + 1) * (k + 1))
            .map(|i| {
                let (x, y) = ((i % (k + 1)) as f64, (i / (k + 1)) as f64);
                [
                    (x * 4000.0) as i32,
                    (y * 4000.0) as i32,
                    (3000.0 * (x * 0.7).sin() * (y * 0.4).cos()) as i32,
                ]
            })
            .collect();
        (faces, values)
    }

    #[test]
    fn round_trip_and_size() {
        let (faces, values) = grid(9);
        for version in [1, 2] {
            let bytes = encode(&faces, &values, version);
            let got = decode(&bytes, faces.len(), values.len(), 0, version).unwrap();
            assert_eq!((got.faces, got.values), (faces.clone(), values.clone()));
            // The plain coding took one byte per corner and about three per
            // coordinate: 324 + 300 bytes here.
            assert!(
                bytes.len() < 300,
                "version {version}: {} bytes",
                bytes.len()
            );
        }
    }

    /// Three quads to each triangle of a triangulated grid, the triangles
    /// in a scrambled order and the corners numbered base vertices first,
    /// then edges, then triangles (as the remesher's charts number them):
    /// version 2 codes the faces in under three quarters of version 1's
    /// bytes (7,538 against 10,853 here; on the remesher's bases, whose
    /// order is less scrambled, the faces fell by about 42%).
    #[test]
    fn quads_of_scrambled_triangles_cost_less_in_version_2() {
        let k = 24u32;
        let v = |x: u32, y: u32| y * (k + 1) + x;
        let mut triangles = Vec::new();
        for y in 0..k {
            for x in 0..k {
                triangles.push([v(x, y), v(x + 1, y), v(x + 1, y + 1)]);
                triangles.push([v(x, y), v(x + 1, y + 1), v(x, y + 1)]);
            }
        }
        let mut x = 7u64;
        for i in (1..triangles.len()).rev() {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            triangles.swap(i, (x >> 33) as usize % (i + 1));
        }
        let corners = (k + 1) * (k + 1);
        let mut edges = std::collections::HashMap::new();
        for t in &triangles {
            for i in 0..3 {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                let next = corners + edges.len() as u32;
                edges.entry((a.min(b), a.max(b))).or_insert(next);
            }
        }
        let first_centre = corners + edges.len() as u32;
        let edge = |a: u32, b: u32| edges[&(a.min(b), a.max(b))];
        let mut faces = Vec::new();
        for (i, t) in triangles.iter().enumerate() {
            for c in 0..3 {
                let (a, b, d) = (t[c], t[(c + 1) % 3], t[(c + 2) % 3]);
                faces.push([a, edge(a, b), first_centre + i as u32, edge(d, a)]);
            }
        }
        let values = vec![[0; 3]; (first_centre as usize) + triangles.len()];
        let size = |version| {
            let bytes = encode(&faces, &values, version);
            let got = decode(&bytes, faces.len(), values.len(), 0, version).unwrap();
            assert_eq!(got.faces, faces, "version {version}");
            bytes.len()
        };
        let (one, two) = (size(1), size(2));
        assert!(
            4 * two < 3 * one,
            "version 1: {one} bytes, version 2: {two}"
        );
    }

    /// Noise bits follow the residuals: none on a plane (the parallelogram
    /// rule is exact there), five more when the values are 32 times
    /// larger, and the high parts left cost fewer bytes.
    #[test]
    fn noise_bits_follow_the_residuals() {
        let (faces, values) = grid(9);
        let flat: Vec<[i32; 3]> = values.iter().map(|v| [v[0], v[1], 0]).collect();
        // Every coordinate curved, as on a real surface.
        let values: Vec<[i32; 3]> = values
            .iter()
            .map(|v| [v[0] + v[2], v[1] - v[2], v[2]])
            .collect();
        assert_eq!(noise_bits(&faces, &flat), 0);
        let k = noise_bits(&faces, &values);
        assert!(k > 0);
        let big: Vec<[i32; 3]> = values.iter().map(|v| v.map(|x| x * 32)).collect();
        assert_eq!(noise_bits(&faces, &big), k + 5);
        let high: Vec<[i32; 3]> = values.iter().map(|v| v.map(|x| x >> k)).collect();
        assert!(encode(&faces, &high, 2).len() < encode(&faces, &values, 2).len());
    }

    #[test]
    fn extreme_values_round_trip() {
        let faces = vec![[0, 1, 2, 3], [3, 2, 1, 0]];
        let values = vec![
            [i32::MIN, i32::MAX, 0],
            [i32::MAX, i32::MIN, -1],
            [0; 3],
            [5, -5, 7],
        ];
        for version in [1, 2] {
            let bytes = encode(&faces, &values, version);
            let got = decode(&bytes, 2, 4, 0, version).unwrap();
            assert_eq!((&got.faces, &got.values), (&faces, &values));
        }
    }

    #[test]
    fn damage_gives_errors_not_panics() {
        for version in [1, 2] {
            damage(version);
        }
    }

    fn damage(version: u8) {
        let (faces, values) = grid(4);
        let decode = |b: &[u8], f, v| decode(b, f, v, 0, version);
        let bytes = encode(&faces, &values, version);
        // A cut either fails or, when the coder's last bytes were not
        // needed, still gives exactly the data.
        for cut in 0..bytes.len() {
            if let Ok(got) = decode(&bytes[..cut], faces.len(), values.len()) {
                assert_eq!(
                    (got.faces, got.values),
                    (faces.clone(), values.clone()),
                    "cut {cut}"
                );
            }
        }
        assert!(decode(&bytes[..bytes.len() / 2], faces.len(), values.len()).is_err());
        let mut x = 1u64;
        for _ in 0..2000 {
            let mut b = bytes.clone();
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
            let at = (x >> 33) as usize % b.len();
            b[at] ^= 1 << ((x >> 20) % 8);
            let _ = decode(&b, faces.len(), values.len());
        }
        assert!(decode(&bytes, faces.len(), values.len() - 1).is_err());
    }
}
