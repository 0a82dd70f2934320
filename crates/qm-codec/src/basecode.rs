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
//! Version 3 first says whether the faces are a split triangle mesh
//! ([`qm_lift::split_triangles`], the remesher's charts). Then it codes
//! the triangles alone, each as an edge shared with the triangles before it
//! (its place among the open edges, most recent first) and the vertex
//! opposite, or as three vertices; the decoder splits them again. Such a
//! base costs a few bits a triangle instead of about 40. Version 4 flags
//! the opposite vertex when it is the next one along the open edges beside
//! the attached edge, which version 3 named by its distance back.
//!
//! **Values** are coded in vertex order as the difference to a prediction
//! from the vertices before them: the parallelogram rule `b + d - c` over
//! every face whose three other corners are known (averaged when there are
//! several), else the mean of the known neighbours along face edges, else the
//! previous vertex. On a grid numbered row by row each vertex after the first
//! row and column has its parallelogram, and the residuals are about the size
//! of the surface's second differences instead of its coordinates. In a
//! version 3 split base the corners come first and have no such faces: a
//! corner is predicted over the triangles instead, by the parallelogram
//! across a known triangle's edge, else a known edge's midpoint; the
//! midpoints and centres that follow are predicted over the quads, as the
//! means of their edge's ends and of their triangle's corners.

use std::collections::HashMap;

use qm_ezw::{BitReader, BitWriter, Context};
use qm_lift::{split_triangles, unsplit};

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
    fn new<const N: usize>(faces: &[[u32; N]], vertices: usize) -> Self {
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

/// What the values' prediction knows of the base: the quads, and in a
/// version 3 split base its triangles.
struct Predictor<'a> {
    faces: &'a [[u32; 4]],
    incidence: Incidence,
    split: Option<Split<'a>>,
}

/// A split base's triangles, over corners `0..corners`.
struct Split<'a> {
    triangles: &'a [[u32; 3]],
    around: Incidence,
    /// The vertex opposite each directed edge `a b` in its triangle.
    opposite: HashMap<(u32, u32), u32>,
    /// The first centre's id: triangle `t`'s is `first_centre + t`.
    first_centre: usize,
}

/// Summed predictions and how many values they sum, for a floored mean.
#[derive(Default)]
struct Mean {
    sum: [i64; 3],
    count: i64,
}

impl Mean {
    /// Adds `x`, a sum of `count` values.
    fn add(&mut self, x: [i64; 3], count: i64) {
        (0..3).for_each(|i| self.sum[i] += x[i]);
        self.count += count;
    }

    fn get(&self) -> Option<[i64; 3]> {
        (self.count > 0).then(|| self.sum.map(|s| s.div_euclid(self.count)))
    }
}

impl<'a> Predictor<'a> {
    fn new(faces: &'a [[u32; 4]], vertices: usize, triangles: Option<&'a [[u32; 3]]>) -> Self {
        let split = triangles.map(|triangles| {
            let corners = triangles
                .iter()
                .flatten()
                .max()
                .map_or(0, |&v| v as usize + 1);
            let opposite = (triangles.iter())
                .flat_map(|t| (0..3).map(move |i| ((t[i], t[(i + 1) % 3]), t[(i + 2) % 3])))
                .collect();
            Split {
                triangles,
                around: Incidence::new(triangles, corners),
                opposite,
                first_centre: vertices - triangles.len(),
            }
        });
        Predictor {
            faces,
            incidence: Incidence::new(faces, vertices),
            split,
        }
    }

    /// Prediction of vertex `v`'s value from the values of vertices `0..v`.
    fn predict(&self, v: usize, values: &[[i32; 3]]) -> [i64; 3] {
        let over_triangles = self
            .split
            .as_ref()
            .and_then(|s| s.predict(v, self.faces, values));
        let predicted = over_triangles.or_else(|| self.over_quads(v, values));
        predicted.unwrap_or(match v {
            0 => [0; 3],
            _ => values[v - 1].map(i64::from),
        })
    }

    fn over_quads(&self, v: usize, values: &[[i32; 3]]) -> Option<[i64; 3]> {
        let known = |u: u32| (u as usize) < v;
        let value = |u: u32| values[u as usize].map(i64::from);
        // Parallelogram predictions, and the edge neighbours as a fallback (an
        // edge shared by two faces counts twice, which keeps the mean symmetric).
        let (mut parallelograms, mut neighbours) = (Mean::default(), Mean::default());
        for &f in self.incidence.around(v) {
            let face = self.faces[f as usize];
            let Some(k) = face.iter().position(|&u| u as usize == v) else {
                continue;
            };
            let (b, c, d) = (face[(k + 1) % 4], face[(k + 2) % 4], face[(k + 3) % 4]);
            if known(b) && known(c) && known(d) {
                let (b, c, d) = (value(b), value(c), value(d));
                parallelograms.add(std::array::from_fn(|i| b[i] + d[i] - c[i]), 1);
            }
            for u in [b, d].into_iter().filter(|&u| known(u)) {
                neighbours.add(value(u), 1);
            }
        }
        parallelograms.get().or(neighbours.get())
    }
}

impl Split<'_> {
    /// Vertex `v` over the triangles: a corner (below), or a centre, as the
    /// quadratic through its triangle's corners and midpoints takes it,
    /// `(4 (m_ab + m_bc + m_ca) - (a + b + c)) / 9`. A midpoint is left to
    /// the quads, which take the mean of its edge's ends.
    fn predict(&self, v: usize, faces: &[[u32; 4]], values: &[[i32; 3]]) -> Option<[i64; 3]> {
        let corners = self.around.start.len() - 1;
        if v < corners {
            return self.corner(v, values);
        }
        let t = v.checked_sub(self.first_centre)?;
        let value = |u: u32| values[u as usize].map(i64::from);
        let mut quadratic = Mean::default();
        for face in &faces[3 * t..3 * t + 3] {
            let (a, m) = (value(face[0]), value(face[1]));
            quadratic.add(std::array::from_fn(|i| 4 * m[i] - a[i]), 3);
        }
        quadratic.get()
    }

    /// Corner `v` over the triangles: the mean parallelogram across the
    /// edges opposite it whose triangle beyond is known, else the mean
    /// midpoint of the known edges opposite it, else its known neighbours.
    fn corner(&self, v: usize, values: &[[i32; 3]]) -> Option<[i64; 3]> {
        let known = |u: u32| (u as usize) < v;
        let value = |u: u32| values[u as usize].map(i64::from);
        let [mut parallelograms, mut midpoints, mut neighbours] = [(); 3].map(|_| Mean::default());
        for &t in self.around.around(v) {
            let t = self.triangles[t as usize];
            let Some(k) = t.iter().position(|&u| u as usize == v) else {
                continue;
            };
            let (a, b) = (t[(k + 1) % 3], t[(k + 2) % 3]);
            for u in [a, b].into_iter().filter(|&u| known(u)) {
                neighbours.add(value(u), 1);
            }
            if !(known(a) && known(b)) {
                continue;
            }
            let (va, vb) = (value(a), value(b));
            match self.opposite.get(&(b, a)).filter(|&&y| known(y)) {
                Some(&y) => {
                    let y = value(y);
                    parallelograms.add(std::array::from_fn(|i| va[i] + vb[i] - y[i]), 1);
                }
                None => midpoints.add(std::array::from_fn(|i| va[i] + vb[i]), 2),
            }
        }
        (parallelograms.get())
            .or(midpoints.get())
            .or(neighbours.get())
    }
}

/// How many of the vertices used last a face corner (version 2 on) or a
/// triangle's vertex (version 3, split) may name by its place among them.
const RECENT: usize = 32;

/// A place among the [`RECENT`] vertices, as a binary tree of contexts.
#[derive(Clone)]
struct PlaceTree([Context; RECENT]);

impl Default for PlaceTree {
    fn default() -> Self {
        PlaceTree([Context::default(); RECENT])
    }
}

impl PlaceTree {
    fn put(&mut self, w: &mut BitWriter, i: usize) {
        let mut node = 1;
        for d in (0..RECENT.trailing_zeros()).rev() {
            let bit = (i >> d) & 1 != 0;
            w.encode(&mut self.0[node], bit);
            node = 2 * node + usize::from(bit);
        }
    }

    fn get(&mut self, r: &mut BitReader) -> Result<usize, String> {
        let mut node = 1;
        for _ in 0..RECENT.trailing_zeros() {
            let bit = face_bit(r, &mut self.0[node])?;
            node = 2 * node + usize::from(bit);
        }
        Ok(node - RECENT)
    }
}

/// A flag of the faces (or triangles); the error is what a base section
/// too short for them says.
fn face_bit(r: &mut BitReader, c: &mut Context) -> Result<bool, String> {
    r.decode(c)
        .map_err(|_| "it ends before its last face".to_string())
}

/// The face coder's state, the same on both sides: version 1's difference
/// to the previous face's corner alone, or (versions 2 and 3, not split)
/// new and recent vertices before it.
struct FaceModel {
    /// Version 1: every corner a difference to the previous face's.
    version1: bool,
    /// Whether a corner is a vertex not used before, per corner.
    new: [Context; 4],
    /// A new vertex as the difference to the last new one, per corner.
    new_step: Vec<IntModel>,
    /// Whether a used vertex is among the recent ones, per corner.
    recent: [Context; 4],
    /// Its place there, per corner.
    place: Vec<PlaceTree>,
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
            place: vec![PlaceTree::default(); 4],
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
                    Some(i) => self.place[k].put(w, i),
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
        let vertices = self.used.len() as i64;
        let mut face = [0u32; 4];
        for (k, corner) in face.iter_mut().enumerate() {
            let (mut new, mut place) = (false, None);
            let v = if self.version1 {
                self.previous[k] as i64 + self.step[k].get(r)?
            } else if face_bit(r, &mut self.new[k])? {
                new = true;
                self.last_new[k] + self.new_step[k].get(r)?
            } else if face_bit(r, &mut self.recent[k])? {
                let i = self.place[k].get(r)?;
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

/// How many open edges a version 3 triangle may attach to, most recent
/// first: the front of a traversal, bounded so that coding stays linear.
const OPEN: usize = 256;

/// Versions 3 and 4's coder of a split base's triangles, the same on both
/// sides.
/// A triangle either attaches to an open edge (one used by one triangle so
/// far), by its place among them, the corner where the edge starts, and the
/// vertex opposite; or it is three vertices. A vertex is new (then it is
/// the next corner: corners are numbered in order of first use), else one
/// of the [`RECENT`] corners used last by its place, else named outright.
struct TriangleModel {
    attached: Context,
    place: IntModel,
    rotation: [Context; 2],
    /// Version 4: whether an attached triangle's vertex is the end of the
    /// open edge from the attached edge's end, or the start of the one
    /// into its start (a triangle that closes a gap in the boundary).
    beside: Option<[Context; 2]>,
    /// Whether a vertex is new, for an attached triangle's and the others'.
    new: [Context; 2],
    recent: Context,
    recent_place: PlaceTree,
    named: IntModel,
    /// Directed edges used once so far, most recent first.
    open: Vec<(u32, u32)>,
    /// The corners used last, most recent first.
    recents: Vec<u32>,
    /// Corners so far.
    corners: u32,
    /// Most corners the triangles may have.
    most: u32,
}

impl TriangleModel {
    fn new(most: u32, version: u8) -> Self {
        TriangleModel {
            attached: Context::default(),
            place: IntModel::new(),
            rotation: [Context::default(); 2],
            beside: (version >= 4).then_some([Context::default(); 2]),
            new: [Context::default(); 2],
            recent: Context::default(),
            recent_place: PlaceTree::default(),
            named: IntModel::new(),
            open: Vec::with_capacity(OPEN + 3),
            recents: Vec::with_capacity(RECENT + 3),
            corners: 0,
            most,
        }
    }

    fn put(&mut self, w: &mut BitWriter, t: &[u32; 3]) {
        let attach = self.open.iter().enumerate().find_map(|(place, &(a, b))| {
            (0..3)
                .find(|&i| t[i] == b && t[(i + 1) % 3] == a)
                .map(|i| (place, i))
        });
        w.encode(&mut self.attached, attach.is_some());
        match attach {
            Some((place, i)) => {
                self.place.put(w, place as i64);
                w.encode(&mut self.rotation[0], i == 0);
                if i != 0 {
                    w.encode(&mut self.rotation[1], i == 1);
                }
                let v = t[(i + 2) % 3];
                let (after, before) = self.beside(place);
                if let Some(beside) = &mut self.beside {
                    for (k, candidate) in [after, before].into_iter().enumerate() {
                        if let Some(c) = candidate {
                            w.encode(&mut beside[k], v == c);
                            if v == c {
                                self.used(t);
                                return;
                            }
                        }
                    }
                }
                self.put_vertex(w, v, 0);
            }
            None => t.iter().for_each(|&v| self.put_vertex(w, v, 1)),
        }
        self.used(t);
    }

    fn put_vertex(&mut self, w: &mut BitWriter, v: u32, kind: usize) {
        let new = v == self.corners;
        w.encode(&mut self.new[kind], new);
        if new {
            self.corners += 1;
            return;
        }
        let place = self.recents.iter().position(|&u| u == v);
        w.encode(&mut self.recent, place.is_some());
        match place {
            Some(i) => self.recent_place.put(w, i),
            None => self.named.put(w, (self.corners - 1 - v) as i64),
        }
    }

    /// Triangle `t`; the error says what is wrong with it.
    fn get(&mut self, r: &mut BitReader, t: usize) -> Result<[u32; 3], String> {
        let mut triangle = [0; 3];
        if face_bit(r, &mut self.attached)? {
            let place = self.place.get(r)?;
            let Some(&(a, b)) = usize::try_from(place).ok().and_then(|p| self.open.get(p)) else {
                let open = self.open.len();
                return Err(format!(
                    "triangle {t} attaches to open edge {place} of {open}"
                ));
            };
            let i = if face_bit(r, &mut self.rotation[0])? {
                0
            } else if face_bit(r, &mut self.rotation[1])? {
                1
            } else {
                2
            };
            triangle[i] = b;
            triangle[(i + 1) % 3] = a;
            let (after, before) = self.beside(place as usize);
            let mut beside = None;
            if let Some(contexts) = &mut self.beside {
                for (k, candidate) in [after, before].into_iter().enumerate() {
                    if let Some(c) = candidate
                        && beside.is_none()
                        && face_bit(r, &mut contexts[k])?
                    {
                        beside = Some(c);
                    }
                }
            }
            triangle[(i + 2) % 3] = match beside {
                Some(c) => c,
                None => self.get_vertex(r, t, 0)?,
            };
        } else {
            for v in &mut triangle {
                *v = self.get_vertex(r, t, 1)?;
            }
        }
        self.used(&triangle);
        Ok(triangle)
    }

    fn get_vertex(&mut self, r: &mut BitReader, t: usize, kind: usize) -> Result<u32, String> {
        if face_bit(r, &mut self.new[kind])? {
            if self.corners == self.most {
                return Err(format!("triangle {t} has more than {} corners", self.most));
            }
            self.corners += 1;
            return Ok(self.corners - 1);
        }
        if face_bit(r, &mut self.recent)? {
            let i = self.recent_place.get(r)?;
            return match self.recents.get(i) {
                Some(&u) => Ok(u),
                None => Err(format!(
                    "triangle {t} names recent corner {i} of {}",
                    self.recents.len()
                )),
            };
        }
        let back = self.named.get(r)?;
        match u32::try_from(back).ok().filter(|&b| b < self.corners) {
            Some(back) => Ok(self.corners - 1 - back),
            None => Err(format!(
                "triangle {t} names corner {back} back of {}",
                self.corners
            )),
        }
    }

    /// For a triangle attached to open edge `place`, `a b`: the end of the
    /// most recent open edge from `b` and the start of the most recent one
    /// into `a` (the second left out when it is the first), the vertices
    /// version 4 tries before the others.
    fn beside(&self, place: usize) -> (Option<u32>, Option<u32>) {
        if self.beside.is_none() {
            return (None, None);
        }
        let (a, b) = self.open[place];
        let after = self.open.iter().find(|e| e.0 == b && e.1 != a).map(|e| e.1);
        let before = (self.open.iter())
            .find(|e| e.1 == a && e.0 != b)
            .map(|e| e.0)
            .filter(|&x| Some(x) != after);
        (after, before)
    }

    /// After triangle `t`: its corners are the most recent, and its edges
    /// close the open edges they share or open anew.
    fn used(&mut self, t: &[u32; 3]) {
        for &v in t {
            if let Some(i) = self.recents.iter().position(|&u| u == v) {
                self.recents.remove(i);
            }
            self.recents.insert(0, v);
        }
        self.recents.truncate(RECENT);
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            match self.open.iter().position(|&e| e == (b, a)) {
                Some(p) => {
                    self.open.remove(p);
                }
                None => self.open.insert(0, (a, b)),
            }
        }
        self.open.truncate(OPEN);
    }
}

/// The triangles a version 3 base section sends instead of its faces, if
/// they are a split.
fn split_of(faces: &[[u32; 4]], vertices: usize, version: u8) -> Option<Vec<[u32; 3]>> {
    (version >= 3)
        .then(|| unsplit(faces, vertices as u32))
        .flatten()
}

/// The triangles `faces` over `vertices` are the split of, in this
/// build's version; `None` for a base that is no split.
pub(crate) fn split_triangles_of(faces: &[[u32; 4]], vertices: usize) -> Option<Vec<[u32; 3]>> {
    split_of(faces, vertices, crate::container::VERSION)
}

/// How many corners a split base of `triangles` has: its first vertices.
pub(crate) fn corner_count(triangles: &[[u32; 3]]) -> usize {
    triangles
        .iter()
        .flatten()
        .max()
        .map_or(0, |&c| c as usize + 1)
}

/// How far, in quantization steps, the encoder lets [`snap_split`] move a
/// value: rounding the corners and the points between them apart is a step
/// or so; a base whose midpoints and centres lie off the flat triangles (a
/// split base at level 0 made otherwise than from the input's own
/// triangles) is left alone.
pub(crate) const SNAP_STEPS: i64 = 2;

/// Sets the edge midpoints and centres of a split base (`faces`, the split
/// of `triangles`) to their predictions, so that they cost next to nothing,
/// unless one would move more than `most` steps in some coordinate (then
/// nothing changes); whether it did. For a mesh of level 0 alone, whose
/// base is all there is (the remesher's exact base, the input's own
/// triangles): its midpoints and centres lie on the flat triangles between
/// the corners, and their predictions are those points rounded from the
/// rounded corners. Elsewhere the base values are lifted, not samples, and
/// must stay as they are.
pub(crate) fn snap_split(
    faces: &[[u32; 4]],
    triangles: &[[u32; 3]],
    values: &mut [[i32; 3]],
    most: i64,
) -> bool {
    let corners = corner_count(triangles);
    let predictor = Predictor::new(faces, values.len(), Some(triangles));
    let mut snapped = values.to_vec();
    for v in corners..values.len() {
        let p = predictor.predict(v, &snapped);
        if (0..3).any(|i| (p[i] - values[v][i] as i64).abs() > most) {
            return false;
        }
        snapped[v] = p.map(|x| x.clamp(i32::MIN.into(), i32::MAX.into()) as i32);
    }
    values.copy_from_slice(&snapped);
    true
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
    let mut w = BitWriter::new();
    let split = split_of(faces, values.len(), version);
    if version >= 3 {
        w.encode(&mut Context::default(), split.is_some());
    }
    match &split {
        Some(triangles) => {
            let mut model = TriangleModel::new(values.len() as u32, version);
            triangles.iter().for_each(|t| model.put(&mut w, t));
        }
        None => {
            let mut model = FaceModel::new(values.len(), version);
            faces.iter().for_each(|face| model.put(&mut w, face));
        }
    }
    let predictor = Predictor::new(faces, values.len(), split.as_deref());
    let coded = coded_values(split.as_deref(), values.len(), implied);
    let mut coord = vec![IntModel::new(); 3];
    for (v, value) in values.iter().enumerate().take(coded) {
        let p = predictor.predict(v, values);
        for i in 0..3 {
            coord[i].put(&mut w, value[i] as i64 - p[i]);
        }
    }
    w.finish()
}

/// How many low bits of the `values` are noise to their prediction: the
/// bits below the leading one of the median residual, but one (which the
/// codes' contexts still predict a little), or, for a split base, all of
/// them ([`SPLIT_KEEPS`]). A stream that carries these bits instead of the
/// base section loses next to nothing on them, and a cut of it needs only
/// as many as its details can use.
pub(crate) fn noise_bits(
    faces: &[[u32; 4]],
    values: &[[i32; 3]],
    version: u8,
    implied: bool,
) -> u32 {
    let split = split_of(faces, values.len(), version);
    let predictor = Predictor::new(faces, values.len(), split.as_deref());
    let coded = coded_values(split.as_deref(), values.len(), implied);
    let keeps = if split.is_some() { SPLIT_KEEPS } else { KEEPS };
    median_residual_length(&predictor, &values[..coded]).saturating_sub(keeps)
}

/// The bit length of the median of `values`' prediction residuals, over
/// all coordinates (0 for no values).
fn median_residual_length(predictor: &Predictor, values: &[[i32; 3]]) -> u32 {
    let mut residuals: Vec<u64> = (0..values.len())
        .flat_map(|v| {
            let p = predictor.predict(v, values);
            (0..3).map(move |i| (values[v][i] as i64 - p[i]).unsigned_abs())
        })
        .collect();
    if residuals.is_empty() {
        return 0;
    }
    let middle = residuals.len() / 2;
    let median = *residuals.select_nth_unstable(middle).1;
    64 - median.leading_zeros()
}

/// Bits of the median residual that [`noise_bits`] leaves in the base
/// section: its leading one and the bit below it.
const KEEPS: u32 = 2;

/// [`KEEPS`] for a split base (the remesher's charts, or an input's own
/// triangles): its leading one alone. Such a base has hundreds to thousands
/// of triangles, and its section is most of what a cut below 65 dB holds;
/// the bit it no longer keeps arrives in the stream with the pass of its
/// weight. Bases of one square per part, at most a few hundred bytes, lost
/// PSNR with it, and keep [`KEEPS`] (docs/decisions/009-base-value-bits.md).
const SPLIT_KEEPS: u32 = 1;

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

/// How many of a base's `vertices` have their values coded: with
/// `implied` and a split base, its corners alone.
fn coded_values(split: Option<&[[u32; 3]]>, vertices: usize, implied: bool) -> usize {
    match split {
        Some(triangles) if implied => corner_count(triangles).min(vertices),
        _ => vertices,
    }
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
    let mut r = BitReader::new(bytes);
    let split = version >= 3 && face_bit(&mut r, &mut Context::default())?;
    let (faces, triangles) = if split {
        if face_count % 3 != 0 {
            return Err(format!(
                "{face_count} faces cannot be triangles split in three"
            ));
        }
        let mut model = TriangleModel::new(vertex_count.min(u32::MAX as usize) as u32, version);
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
    let predictor = Predictor::new(&faces, vertex_count, triangles.as_deref());
    let coded = coded_values(triangles.as_deref(), vertex_count, implied);
    let mut coord = vec![IntModel::new(); 3];
    let mut values = Vec::with_capacity(vertex_count.min(bytes.len()));
    for v in 0..coded {
        let p = predictor.predict(v, &values);
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
    values.resize(vertex_count, [0; 3]);
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

    type Triangles = Vec<[u32; 3]>;

    /// A `k x k` grid's squares, two triangles each, row by row.
    fn grid_triangles(k: u32) -> Triangles {
        let v = |x: u32, y: u32| y * (k + 1) + x;
        let mut triangles = Vec::new();
        for y in 0..k {
            for x in 0..k {
                triangles.push([v(x, y), v(x + 1, y), v(x + 1, y + 1)]);
                triangles.push([v(x, y), v(x + 1, y + 1), v(x, y + 1)]);
            }
        }
        triangles
    }

    /// The triangles of a wavy `k x k` grid, two to a square, row by row,
    /// split into quads: faces, values, triangles.
    fn split_grid(k: u32) -> (Vec<[u32; 4]>, Vec<[i32; 3]>, Triangles) {
        let triangles = grid_triangles(k);
        let split = split_triangles(&triangles);
        // Corners where the grid has them, the rest on the surface halfway.
        let at = |x: f64, y: f64| {
            let z = 3000.0 * (x * 0.7).sin() * (y * 0.4).cos();
            [(x * 4000.0) as i32, (y * 4000.0) as i32, z as i32]
        };
        let corner = |c: u32| ((c % (k + 1)) as f64, (c / (k + 1)) as f64);
        let mut places = vec![(0.0, 0.0); split.vertex_count as usize];
        for (i, &c) in split.corners.iter().enumerate() {
            places[i] = corner(c);
        }
        for (q, face) in split.faces.iter().enumerate() {
            let t = triangles[q / 3];
            let (a, b) = (corner(t[q % 3]), corner(t[(q + 1) % 3]));
            places[face[1] as usize] = ((a.0 + b.0) / 2.0, (a.1 + b.1) / 2.0);
            let centre = t.map(corner);
            places[face[2] as usize] = (
                centre.iter().map(|p| p.0).sum::<f64>() / 3.0,
                centre.iter().map(|p| p.1).sum::<f64>() / 3.0,
            );
        }
        let values = places.iter().map(|&(x, y)| at(x, y)).collect();
        let triangles = unsplit(&split.faces, split.vertex_count).unwrap();
        (split.faces, values, triangles)
    }

    /// Snapped to their predictions, a split base's midpoints and centres
    /// cost next to nothing, move by a step or two at most, and come back
    /// exactly; a base that is no split is none to snap.
    #[test]
    fn snapped_midpoints_and_centres_cost_next_to_nothing() {
        let (faces, values, triangles) = split_grid(16);
        let corners = corner_count(&triangles);
        // The grid's midpoints and centres off the flat triangles between
        // the corners by up to 1 in 4000: what snapping moves.
        let mut snapped = values.clone();
        assert!(snap_split(&faces, &triangles, &mut snapped, i64::MAX));
        assert_eq!(snapped[..corners], values[..corners]);
        let moved = (corners..values.len())
            .flat_map(|v| (0..3).map(move |i| (v, i)))
            .filter(|&(v, i)| snapped[v][i] != values[v][i])
            .count();
        assert!(moved > 0);
        let (before, after) = (
            encode(&faces, &values, 3, false),
            encode(&faces, &snapped, 3, false),
        );
        // Zero residuals: under a bit a value.
        assert!(
            8 * (before.len() - after.len()) > values.len() - corners,
            "{} against {}",
            after.len(),
            before.len()
        );
        let got = decode(&after, faces.len(), values.len(), 0, 3, false).unwrap();
        assert_eq!(got.values, snapped);
        let (quads, grid) = grid(4);
        assert!(split_triangles_of(&quads, grid.len()).is_none());
        // Implied, only the corners are coded; a base that is no split
        // cannot be implied.
        let corners_only = encode(&faces, &snapped, 3, true);
        assert!(corners_only.len() < after.len());
        let got = decode(&corners_only, faces.len(), values.len(), 0, 3, true).unwrap();
        assert_eq!(got.values[..corners], snapped[..corners]);
        assert!(got.values[corners..].iter().all(|v| *v == [0; 3]));
        let bytes = encode(&quads, &grid, 3, true);
        let err = decode(&bytes, quads.len(), grid.len(), 0, 3, true).unwrap_err();
        assert!(err.contains("no split"), "{err}");
    }

    /// `triangles` in the order the remesher gives them (depth first, each
    /// from the most recently opened edge it shares and turned to start
    /// there).
    fn depth_first(triangles: &[[u32; 3]]) -> Triangles {
        qm_lift::coding_order(triangles)
            .into_iter()
            .map(|(t, r)| std::array::from_fn(|i| triangles[t as usize][(r as usize + i) % 3]))
            .collect()
    }

    /// Version 4 flags a triangle's vertex when it is the next along the
    /// open edges beside the one the triangle attaches to, which version 3
    /// named by its distance back (4,416 of dragon_vrip_res4's 10,890
    /// triangles; 994 in version 4): here a 48 x 48 grid's triangles, depth
    /// first, cost a quarter less than in version 3 (1,780 bytes against
    /// 2,364), and come back.
    #[test]
    fn vertices_beside_their_edge_cost_less_in_version_4() {
        let triangles = depth_first(&grid_triangles(48));
        let split = split_triangles(&triangles);
        let none = vec![[0; 3]; split.vertex_count as usize];
        let (three, four) = (
            encode(&split.faces, &none, 3, false),
            encode(&split.faces, &none, 4, false),
        );
        assert!(
            5 * four.len() < 4 * three.len(),
            "version 3 {} bytes, version 4 {}",
            three.len(),
            four.len()
        );
        let got = decode(&four, split.faces.len(), none.len(), 0, 4, false).unwrap();
        assert_eq!(got.faces, split.faces);
    }

    /// Version 3 sends a split base's triangles and predicts its values
    /// over them: the faces cost under a fifth of version 2's bytes here
    /// (240 against 1,544), the whole section about half (1,820 against
    /// 3,597), and both come back exactly.
    #[test]
    fn split_bases_cost_less_in_version_3() {
        let (faces, values, triangles) = split_grid(16);
        let faces_alone = |version| {
            let none = vec![[0; 3]; values.len()];
            encode(&faces, &none, version, false).len()
        };
        let (two, three) = (faces_alone(2), faces_alone(3));
        assert!(
            5 * three < two,
            "faces: version 2 {two} bytes, version 3 {three}"
        );
        let (two, three) = (
            encode(&faces, &values, 2, false),
            encode(&faces, &values, 3, false),
        );
        assert!(
            3 * three.len() < 2 * two.len(),
            "{} against {}",
            three.len(),
            two.len()
        );
        let got = decode(&three, faces.len(), values.len(), 0, 3, false).unwrap();
        assert_eq!((got.faces, got.values), (faces.clone(), values.clone()));
        assert_eq!(split_of(&faces, values.len(), 3), Some(triangles));
        // A header that counts other vertices than the triangles make.
        let err = decode(&three, faces.len(), values.len() + 1, 0, 3, false).unwrap_err();
        assert!(err.contains("base vertices"), "{err}");
        assert!(decode(&three, faces.len() - 1, values.len(), 0, 3, false).is_err());
    }

    #[test]
    fn round_trip_and_size() {
        let (faces, values) = grid(9);
        for version in [1, 2, 3, 4] {
            let bytes = encode(&faces, &values, version, false);
            let got = decode(&bytes, faces.len(), values.len(), 0, version, false).unwrap();
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
    /// in a scrambled order and split as the remesher's charts split them:
    /// version 2 codes the faces in under three quarters of version 1's
    /// bytes (on the remesher's bases, whose order is less scrambled, the
    /// faces fell by about 42%).
    #[test]
    fn quads_of_scrambled_triangles_cost_less_in_version_2() {
        let mut triangles = grid_triangles(24);
        let mut x = 7u64;
        for i in (1..triangles.len()).rev() {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            triangles.swap(i, (x >> 33) as usize % (i + 1));
        }
        let faces = split_triangles(&triangles).faces;
        let vertices = faces.iter().flatten().max().map_or(0, |&v| v as usize + 1);
        let values = vec![[0; 3]; vertices];
        let size = |version| {
            let bytes = encode(&faces, &values, version, false);
            let got = decode(&bytes, faces.len(), values.len(), 0, version, false).unwrap();
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
        assert_eq!(noise_bits(&faces, &flat, 3, false), 0);
        let k = noise_bits(&faces, &values, 3, false);
        assert!(k > 0);
        let big: Vec<[i32; 3]> = values.iter().map(|v| v.map(|x| x * 32)).collect();
        assert_eq!(noise_bits(&faces, &big, 3, false), k + 5);
        let high: Vec<[i32; 3]> = values.iter().map(|v| v.map(|x| x >> k)).collect();
        assert!(encode(&faces, &high, 2, false).len() < encode(&faces, &values, 2, false).len());
    }

    /// The bit length of the median prediction residual of `values`, over
    /// `triangles` when they are given.
    fn median_length(
        faces: &[[u32; 4]],
        values: &[[i32; 3]],
        triangles: Option<&[[u32; 3]]>,
    ) -> u32 {
        median_residual_length(&Predictor::new(faces, values.len(), triangles), values)
    }

    /// A split base keeps the leading one of its median residual in the
    /// base section, a base of quads that bit and the next.
    #[test]
    fn a_split_base_keeps_one_bit_fewer() {
        // Every coordinate curved, as on a real surface.
        let curved = |values: Vec<[i32; 3]>| -> Vec<[i32; 3]> {
            let v = values.iter().map(|v| [v[0] + v[2], v[1] - v[2], v[2]]);
            v.collect()
        };
        let (faces, values) = grid(9);
        let values = curved(values);
        let quads = median_length(&faces, &values, None);
        assert!(quads > 2);
        assert_eq!(noise_bits(&faces, &values, 4, false), quads - KEEPS);
        let (faces, values, triangles) = split_grid(9);
        let values = curved(values);
        let split = median_length(&faces, &values, Some(&triangles));
        assert!(split > 2);
        assert_eq!(noise_bits(&faces, &values, 4, false), split - SPLIT_KEEPS);
        // Version 2 has no split bases.
        assert_eq!(
            noise_bits(&faces, &values, 2, false),
            median_length(&faces, &values, None) - KEEPS
        );
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
        for version in [1, 2, 3, 4] {
            let bytes = encode(&faces, &values, version, false);
            let got = decode(&bytes, 2, 4, 0, version, false).unwrap();
            assert_eq!((&got.faces, &got.values), (&faces, &values));
        }
    }

    #[test]
    fn damage_gives_errors_not_panics() {
        for version in [1, 2, 3, 4] {
            let (faces, values) = grid(4);
            damage(version, faces, values);
        }
        let (faces, values, _) = split_grid(3);
        damage(3, faces.clone(), values.clone());
        damage(4, faces, values);
    }

    fn damage(version: u8, faces: Vec<[u32; 4]>, values: Vec<[i32; 3]>) {
        let decode = |b: &[u8], f, v| decode(b, f, v, 0, version, false);
        let bytes = encode(&faces, &values, version, false);
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
