//! The base section's connectivity: the corners of the base faces, or the
//! triangles of a split base, coded on both sides by the same state
//! ([`FaceModel`], [`TriangleModel`]).
//!
//! **Faces** are coded corner by corner. Format version 1 codes each corner
//! as the difference to the same corner of the previous face: in the
//! grid-like base meshes of one square per part that difference is almost
//! always 1, but not in the three quads of each base triangle in a
//! simplifier's order. Version 2 first says whether the corner is a vertex
//! not used before, coded then as the difference to the last new vertex of
//! the same corner; else whether it is among the [`RECENT`] vertices used
//! last, coded then by its place there; else it is the version 1
//! difference. Faces that share vertices with the faces just before them
//! (a base triangle's three quads, a grid's rows) then cost a few bits a
//! corner (docs/format.md).
//!
//! **Triangles.** Version 3 first says whether the faces are a split
//! triangle mesh ([`qm_lift::split_triangles`], the remesher's charts,
//! [`split_of`]). Then it codes the triangles alone, each as an edge shared
//! with the triangles before it (its place among the [`OPEN`] edges, most
//! recent first) and the vertex opposite, or as three vertices; the decoder
//! splits them again. Such a base costs a few bits a triangle. Version 4
//! flags the opposite vertex when it is the next one along the open edges
//! beside the attached edge, which version 3 named by its distance back.
//! Version 6 keeps every open edge ([`OpenEdges`]), names a used vertex by
//! an open edge it ends, and learns each triangle's flags in the context of
//! what the triangle before did, or the two before (the encoder's choice).
//! What each version saved: docs/decisions/026-base-connectivity.md.

use qm_ezw::{BitReader, BitWriter, Context};
use qm_lift::unsplit;

use super::front::OpenEdges;
use super::numbers::IntModel;

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
pub(super) fn face_bit(r: &mut BitReader, c: &mut Context) -> Result<bool, String> {
    r.decode(c)
        .map_err(|_| "it ends before its last face".to_string())
}

/// The face coder's state, the same on both sides: version 1's difference
/// to the previous face's corner alone, or (versions 2 and 3, not split)
/// new and recent vertices before it.
pub(super) struct FaceModel {
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
    pub(super) fn new(vertices: usize, version: u8) -> Self {
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

    pub(super) fn put(&mut self, w: &mut BitWriter, face: &[u32; 4]) {
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
    pub(super) fn get(&mut self, r: &mut BitReader, f: usize) -> Result<[u32; 4], String> {
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

/// How many open edges a version 3 to 5 triangle may attach to, most
/// recent first: the front of a traversal, bounded so that coding stayed
/// linear before [`OpenEdges`] counted places in a logarithm. Version 6
/// keeps them all.
const OPEN: usize = 256;

/// Versions 3 to 6's coder of a split base's triangles, the same on both
/// sides.
/// A triangle either attaches to an open edge (one used by one triangle so
/// far), by its place among them, the corner where the edge starts, and the
/// vertex opposite; or it is three vertices. A vertex is new (then it is
/// the next corner: corners are numbered in order of first use), else one
/// of the [`RECENT`] corners used last by its place, else named outright.
pub(super) struct TriangleModel {
    attached: Context,
    /// The open edge's place, per outcome ([`OUTCOMES`]) of the triangle
    /// or two before (version 6 on; one model before).
    place: [IntModel; CONTEXTS],
    rotation: [Context; 2],
    /// Version 4 on: whether an attached triangle's vertex is the end of
    /// the open edge from the attached edge's end, or the start of the one
    /// into its start (a triangle that closes a gap in the boundary); per
    /// outcome ([`OUTCOMES`]) of the triangle or two before from version 6
    /// on.
    beside: Option<[[Context; 2]; CONTEXTS]>,
    /// Whether a vertex is new, for an attached triangle's and the
    /// others', per outcome ([`OUTCOMES`]) before from version 6 on.
    new: [[Context; 2]; CONTEXTS],
    /// Version 6 on: whether a used vertex is an end of an open edge, which
    /// one by the edge's place and a flag for its end.
    front: Option<FrontModel>,
    recent: Context,
    recent_place: PlaceTree,
    named: IntModel,
    /// Directed edges used once so far, most recent first.
    open: OpenEdges,
    /// The corners used last, most recent first.
    recents: Vec<u32>,
    /// Corners so far.
    corners: u32,
    /// Most corners the triangles may have.
    most: u32,
    /// What the triangle before did, or the two before ([`OTHER`] before
    /// the first; always 0 before version 6): the contexts' index.
    last: usize,
    /// How many triangles before choose the contexts: none before version
    /// 6, one or two (the encoder's choice, a flag) from version 6 on.
    history: u8,
}

/// What a triangle did, the context of the next one's flags, alone or
/// with the outcome before it (format version 6): its vertex was the one
/// [`TriangleModel`] tried first beside its edge, the second, a new one, or
/// anything else (a used vertex named, or three vertices). On a regular or
/// a revolved mesh the traversal repeats short patterns of these
/// (Edgebreaker's C and R), which the contexts learn.
const OUTCOMES: usize = 4;
/// Contexts of the outcomes of the two triangles before.
const CONTEXTS: usize = OUTCOMES * OUTCOMES;
const AFTER: usize = 0;
const BEFORE: usize = 1;
const NEW: usize = 2;
const OTHER: usize = 3;

/// Version 6's naming of a used vertex by an open edge it ends: a vertex
/// the triangles reach again lies on their front, mostly near the edge
/// they attach to, where [`TriangleModel::named`]'s distance back in first
/// use is long.
struct FrontModel {
    on: Context,
    place: IntModel,
    end: Context,
}

impl TriangleModel {
    /// The coder of a base of at most `most` corners in format `version`,
    /// its contexts chosen by the outcomes of the `history` triangles
    /// before (1 or 2; ignored before version 6).
    pub(super) fn new(most: u32, version: u8, history: u8) -> Self {
        let history = if version >= 6 { history.clamp(1, 2) } else { 0 };
        TriangleModel {
            attached: Context::default(),
            place: std::array::from_fn(|_| IntModel::new()),
            rotation: [Context::default(); 2],
            beside: (version >= 4).then_some([[Context::default(); 2]; CONTEXTS]),
            new: [[Context::default(); 2]; CONTEXTS],
            front: (version >= 6).then(|| FrontModel {
                on: Context::default(),
                place: IntModel::new(),
                end: Context::default(),
            }),
            recent: Context::default(),
            recent_place: PlaceTree::default(),
            named: IntModel::new(),
            open: OpenEdges::new((version < 6).then_some(OPEN)),
            recents: Vec::with_capacity(RECENT + 3),
            corners: 0,
            most,
            last: match history {
                0 => 0,
                1 => OTHER,
                _ => OTHER * OUTCOMES + OTHER,
            },
            history,
        }
    }

    pub(super) fn put(&mut self, w: &mut BitWriter, t: &[u32; 3]) {
        let attach = self.open.attach(t);
        let last = self.last;
        w.encode(&mut self.attached, attach.is_some());
        let outcome = match attach {
            Some((place, i)) => {
                self.place[last].put(w, place as i64);
                w.encode(&mut self.rotation[0], i == 0);
                if i != 0 {
                    w.encode(&mut self.rotation[1], i == 1);
                }
                let v = t[(i + 2) % 3];
                let (after, before) = self.beside(place);
                let mut outcome = None;
                if let Some(beside) = &mut self.beside {
                    for (k, candidate) in [(AFTER, after), (BEFORE, before)] {
                        if let Some(c) = candidate
                            && outcome.is_none()
                        {
                            w.encode(&mut beside[last][k], v == c);
                            outcome = (v == c).then_some(k);
                        }
                    }
                }
                outcome.unwrap_or_else(|| self.put_vertex(w, v, 0))
            }
            None => {
                for &v in t {
                    self.put_vertex(w, v, 1);
                }
                OTHER
            }
        };
        self.used(t, outcome);
    }

    /// Codes vertex `v` of an attached triangle (`kind` 0) or of one that
    /// is not (1); the outcome ([`OUTCOMES`]) it makes.
    fn put_vertex(&mut self, w: &mut BitWriter, v: u32, kind: usize) -> usize {
        let new = v == self.corners;
        w.encode(&mut self.new[self.last][kind], new);
        if new {
            self.corners += 1;
            return NEW;
        }
        if let Some(front) = &mut self.front {
            let on = self.open.touching(v);
            w.encode(&mut front.on, on.is_some());
            if let Some((place, end)) = on {
                front.place.put(w, place as i64);
                w.encode(&mut front.end, end);
                return OTHER;
            }
        }
        let place = self.recents.iter().position(|&u| u == v);
        w.encode(&mut self.recent, place.is_some());
        match place {
            Some(i) => self.recent_place.put(w, i),
            None => self.named.put(w, (self.corners - 1 - v) as i64),
        }
        OTHER
    }

    /// Triangle `t`; the error says what is wrong with it.
    pub(super) fn get(&mut self, r: &mut BitReader, t: usize) -> Result<[u32; 3], String> {
        let mut triangle = [0; 3];
        let last = self.last;
        let outcome = if face_bit(r, &mut self.attached)? {
            let place = self.place[last].get(r)?;
            let Some((a, b)) = usize::try_from(place).ok().and_then(|p| self.open.at(p)) else {
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
                for (k, candidate) in [(AFTER, after), (BEFORE, before)] {
                    if let Some(c) = candidate
                        && beside.is_none()
                        && face_bit(r, &mut contexts[last][k])?
                    {
                        beside = Some((c, k));
                    }
                }
            }
            let (v, outcome) = match beside {
                Some(found) => found,
                None => self.get_vertex(r, t, 0)?,
            };
            triangle[(i + 2) % 3] = v;
            outcome
        } else {
            for v in &mut triangle {
                *v = self.get_vertex(r, t, 1)?.0;
            }
            OTHER
        };
        self.used(&triangle, outcome);
        Ok(triangle)
    }

    /// A vertex of an attached triangle (`kind` 0) or of one that is not
    /// (1), and the outcome ([`OUTCOMES`]) it makes.
    fn get_vertex(
        &mut self,
        r: &mut BitReader,
        t: usize,
        kind: usize,
    ) -> Result<(u32, usize), String> {
        if face_bit(r, &mut self.new[self.last][kind])? {
            if self.corners == self.most {
                return Err(format!("triangle {t} has more than {} corners", self.most));
            }
            self.corners += 1;
            return Ok((self.corners - 1, NEW));
        }
        if let Some(front) = &mut self.front
            && face_bit(r, &mut front.on)?
        {
            let place = front.place.get(r)?;
            let end = face_bit(r, &mut front.end)?;
            return match usize::try_from(place).ok().and_then(|p| self.open.at(p)) {
                Some((a, b)) => Ok((if end { b } else { a }, OTHER)),
                None => Err(format!(
                    "triangle {t} names a vertex of open edge {place} of {}",
                    self.open.len()
                )),
            };
        }
        if face_bit(r, &mut self.recent)? {
            let i = self.recent_place.get(r)?;
            return match self.recents.get(i) {
                Some(&u) => Ok((u, OTHER)),
                None => Err(format!(
                    "triangle {t} names recent corner {i} of {}",
                    self.recents.len()
                )),
            };
        }
        let back = self.named.get(r)?;
        match u32::try_from(back).ok().filter(|&b| b < self.corners) {
            Some(back) => Ok((self.corners - 1 - back, OTHER)),
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
    fn beside(&mut self, place: usize) -> (Option<u32>, Option<u32>) {
        match (&self.beside, self.open.at(place)) {
            (Some(_), Some(edge)) => self.open.beside(edge),
            _ => (None, None),
        }
    }

    /// After triangle `t`, whose vertex made `outcome`: its corners are
    /// the most recent, and its edges close the open edges they share or
    /// open anew.
    fn used(&mut self, t: &[u32; 3], outcome: usize) {
        self.last = match self.history {
            0 => 0,
            1 => outcome,
            _ => (self.last % OUTCOMES) * OUTCOMES + outcome,
        };
        for &v in t {
            if let Some(i) = self.recents.iter().position(|&u| u == v) {
                self.recents.remove(i);
            }
            self.recents.insert(0, v);
        }
        self.recents.truncate(RECENT);
        for i in 0..3 {
            self.open.close_or_open(t[i], t[(i + 1) % 3]);
        }
        self.open.cut();
    }
}

/// The triangles a version 3 base section sends instead of its faces, if
/// they are a split.
pub(super) fn split_of(faces: &[[u32; 4]], vertices: usize, version: u8) -> Option<Vec<[u32; 3]>> {
    (version >= 3)
        .then(|| unsplit(faces, vertices as u32))
        .flatten()
}
