//! The base section's values: each base vertex's level-0 value (its high
//! part `value >> k`; the stream carries the low `k` bits), coded in vertex
//! order as the difference to a [`Predictor`]'s prediction from the
//! vertices before it; and how many low bits are noise to that prediction
//! ([`noise_bits`]).
//!
//! **The prediction** is the parallelogram rule `b + d - c` over every face
//! whose three other corners are known (averaged when there are several),
//! else the mean of the known neighbours along face edges, else the
//! previous vertex. On a grid numbered row by row each vertex after the
//! first row and column has its parallelogram, and the residuals are about
//! the size of the surface's second differences instead of its
//! coordinates. In a version 3 split base the corners come first and have
//! no such faces: a corner is predicted over the triangles instead, by the
//! parallelogram across a known triangle's edge, else a known edge's
//! midpoint; the midpoints and centres that follow are predicted over the
//! quads, as the means of their edge's ends and of their triangle's
//! corners. Means are floored (`div_euclid`), so both sides agree.

use std::collections::HashMap;

use qm_ezw::{BitReader, BitWriter, Context};

use super::connectivity::split_of;
use super::numbers::IntModel;

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
pub(super) struct Predictor<'a> {
    faces: &'a [[u32; 4]],
    incidence: Incidence,
    split: Option<Split<'a>>,
    /// A split base's corner with several parallelograms is predicted by
    /// the ones the encoder chose ([`Guess::Among`]; format version 5 on,
    /// where the section's flag says so).
    choose: bool,
}

/// How a split base's corners are predicted (format version 5 on, where
/// the section's flags say so; the encoder keeps the shortest).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Corners {
    /// By the floored mean of their parallelograms (versions 3 and 4).
    Plain,
    /// By the parallelograms the encoder names ([`Guess::Among`]).
    Chosen,
    /// So, and coded in their [`prediction_order`].
    ChosenInOrder,
}

/// Most parallelograms a corner chooses among ([`Guess::Among`]); more are
/// left out, in triangle order.
pub(super) const MOST_CHOICES: usize = 4;

/// A vertex's prediction: one value, or (format version 5 on, a split
/// base's corner across two or more known triangles) the parallelograms
/// across them, of which the encoder names a subset whose floored mean is
/// the prediction (the constrained multi-parallelogram rule: on a faceted
/// mesh the parallelograms across a crease are far off, the ones on the
/// same flat face exact).
pub(super) enum Guess {
    One([i64; 3]),
    Among(Vec<[i64; 3]>),
}

impl Guess {
    /// The prediction for subset `mask` of the parallelograms (ignored
    /// for [`Guess::One`]).
    pub(super) fn with(&self, mask: u32) -> [i64; 3] {
        match self {
            Guess::One(p) => *p,
            Guess::Among(choices) => {
                let mut mean = Mean::default();
                for (i, c) in choices.iter().enumerate() {
                    if mask >> i & 1 != 0 {
                        mean.add(*c, 1);
                    }
                }
                mean.get().unwrap_or(choices[0])
            }
        }
    }

    /// The subset the encoder names for `value`: the one whose residual
    /// has the fewest significant bits over the three coordinates, then
    /// the smallest sum, the fuller first (0 for [`Guess::One`]).
    pub(super) fn best(&self, value: &[i32; 3]) -> u32 {
        let Guess::Among(choices) = self else {
            return 0;
        };
        let full = (1u32 << choices.len()) - 1;
        let cost = |mask: u32| {
            let p = self.with(mask);
            (0..3).fold((0u32, 0u64), |(bits, sum), i| {
                let r = (value[i] as i64 - p[i]).unsigned_abs();
                (bits + (64 - r.leading_zeros()), sum + r)
            })
        };
        // All of them where nothing is better.
        (1..=full).rev().min_by_key(|&m| cost(m)).unwrap_or(full)
    }
}

/// A split base's triangles, over corners `0..corners`.
struct Split<'a> {
    triangles: &'a [[u32; 3]],
    around: Incidence,
    /// The vertex opposite each directed edge `a b` in its triangle.
    opposite: HashMap<(u32, u32), u32>,
    /// The first centre's id: triangle `t`'s is `first_centre + t`.
    first_centre: usize,
    /// Where the corners choose their parallelograms: the order they are
    /// coded in ([`prediction_order`]) and each corner's place in it.
    order: Option<(Vec<u32>, Vec<u32>)>,
}

/// For each triangle around corner `v`, in triangle order: its other two
/// corners `a`, `b` (counter-clockwise from `v`) and the vertex across the
/// edge `a b` from it, if a triangle holds `b a`.
fn fan<'s>(
    around: &'s Incidence,
    triangles: &'s [[u32; 3]],
    opposite: &'s HashMap<(u32, u32), u32>,
    v: usize,
) -> impl Iterator<Item = (u32, u32, Option<u32>)> + 's {
    around.around(v).iter().filter_map(move |&t| {
        let t = triangles[t as usize];
        let k = t.iter().position(|&u| u as usize == v)?;
        let (a, b) = (t[(k + 1) % 3], t[(k + 2) % 3]);
        Some((a, b, opposite.get(&(b, a)).copied()))
    })
}

/// The order in which [`Corners::ChosenInOrder`] codes a split base's `corners`: next a
/// corner with the most parallelograms already known (up to 3), else the
/// most neighbours coded (up to 3), the one reached last among equals; from
/// corner 0 and then each part's first corner. In the order of first use
/// along the triangles a corner of a faceted part often has one
/// parallelogram known, across a crease; coded later, it has the one on
/// its own face too (Draco's prediction-degree traversal does the same).
fn prediction_order(
    around: &Incidence,
    triangles: &[[u32; 3]],
    opposite: &HashMap<(u32, u32), u32>,
    corners: usize,
) -> Vec<u32> {
    let mut coded = vec![false; corners];
    let mut waiting: [Vec<u32>; 8] = Default::default();
    let mut key = vec![0usize; corners];
    let mut order = Vec::with_capacity(corners);
    // Parallelograms known to `u`, and its neighbours coded.
    let score = |u: usize, coded: &[bool]| {
        let (mut parallelograms, mut neighbours) = (0, 0);
        for (a, b, across) in fan(around, triangles, opposite, u) {
            let (a, b) = (coded[a as usize], coded[b as usize]);
            neighbours += usize::from(a) + usize::from(b);
            if a && b && across.is_some_and(|y| coded[y as usize]) {
                parallelograms += 1;
            }
        }
        if parallelograms > 0 {
            4 + parallelograms.min(3)
        } else {
            neighbours.min(3)
        }
    };
    let mut seed = 0;
    loop {
        let mut next = None;
        for k in (1..waiting.len()).rev() {
            while let Some(u) = waiting[k].pop() {
                if !coded[u as usize] && key[u as usize] == k {
                    next = Some(u);
                    break;
                }
            }
            if next.is_some() {
                break;
            }
        }
        let v = match next {
            Some(v) => v,
            None => {
                while seed < corners && coded[seed] {
                    seed += 1;
                }
                if seed == corners {
                    break;
                }
                seed as u32
            }
        };
        coded[v as usize] = true;
        order.push(v);
        // Those whose parallelograms or neighbours `v` may complete: its
        // neighbours, and the vertices across the edges opposite it.
        for (a, b, across) in fan(around, triangles, opposite, v as usize) {
            for u in [Some(a), Some(b), across].into_iter().flatten() {
                let u = u as usize;
                if u < corners && !coded[u] {
                    let k = score(u, &coded);
                    if k != key[u] || k > 0 {
                        key[u] = k;
                        waiting[k].push(u as u32);
                    }
                }
            }
        }
    }
    order
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
    pub(super) fn new(
        faces: &'a [[u32; 4]],
        vertices: usize,
        triangles: Option<&'a [[u32; 3]]>,
        mode: Corners,
    ) -> Self {
        let choose = mode != Corners::Plain;
        let split = triangles.map(|triangles| {
            let corners = triangles
                .iter()
                .flatten()
                .max()
                .map_or(0, |&v| v as usize + 1);
            let opposite = (triangles.iter())
                .flat_map(|t| (0..3).map(move |i| ((t[i], t[(i + 1) % 3]), t[(i + 2) % 3])))
                .collect();
            let around = Incidence::new(triangles, corners);
            let order = (mode == Corners::ChosenInOrder).then(|| {
                let order = prediction_order(&around, triangles, &opposite, corners);
                let mut place = vec![0u32; corners];
                for (i, &c) in order.iter().enumerate() {
                    place[c as usize] = i as u32;
                }
                (order, place)
            });
            Split {
                triangles,
                around,
                opposite,
                first_centre: vertices - triangles.len(),
                order,
            }
        });
        Predictor {
            faces,
            incidence: Incidence::new(faces, vertices),
            split,
            choose,
        }
    }

    /// The order the values are coded in: a choosing split base's corners
    /// in their [`prediction_order`], then the others; else vertex order.
    pub(super) fn coding_order(&self, vertices: usize) -> Vec<usize> {
        match self.split.as_ref().and_then(|s| s.order.as_ref()) {
            Some((order, _)) => (order.iter().map(|&c| c as usize))
                .chain(order.len()..vertices)
                .collect(),
            None => (0..vertices).collect(),
        }
    }

    /// [`Self::predict`], or for a corner with several parallelograms
    /// (where it chooses) those to choose among.
    pub(super) fn guess(&self, v: usize, values: &[[i32; 3]]) -> Guess {
        if self.choose
            && let Some(split) = &self.split
            && v < split.around.start.len() - 1
        {
            let choices = split.parallelograms(v, values);
            if choices.len() >= 2 {
                return Guess::Among(choices);
            }
        }
        Guess::One(self.predict(v, values))
    }

    /// Prediction of vertex `v`'s value from the values of the vertices
    /// before it in the [`Self::coding_order`].
    pub(super) fn predict(&self, v: usize, values: &[[i32; 3]]) -> [i64; 3] {
        let over_triangles = self
            .split
            .as_ref()
            .and_then(|s| s.predict(v, self.faces, values));
        let predicted = over_triangles.or_else(|| self.over_quads(v, values));
        let previous = match self.split.as_ref().and_then(|s| s.order.as_ref()) {
            Some((order, place)) if v < order.len() => (place[v] as usize)
                .checked_sub(1)
                .map(|i| order[i] as usize),
            _ => v.checked_sub(1),
        };
        predicted.unwrap_or(match previous {
            None => [0; 3],
            Some(u) => values[u].map(i64::from),
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
    /// [`fan`] of corner `v`.
    fn fan(&self, v: usize) -> impl Iterator<Item = (u32, u32, Option<u32>)> + '_ {
        fan(&self.around, self.triangles, &self.opposite, v)
    }

    /// Whether corner `u` is coded before corner `v`.
    fn before(&self, u: usize, v: usize) -> bool {
        match &self.order {
            Some((_, place)) => place[u] < place[v],
            None => u < v,
        }
    }

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

    /// The parallelograms across the edges opposite corner `v` whose
    /// triangle beyond is known, at most [`MOST_CHOICES`], in the order of
    /// the triangles around `v`.
    fn parallelograms(&self, v: usize, values: &[[i32; 3]]) -> Vec<[i64; 3]> {
        let known = |u: u32| self.before(u as usize, v);
        let value = |u: u32| values[u as usize].map(i64::from);
        let mut found = Vec::new();
        for (a, b, across) in self.fan(v) {
            if let Some(y) = across.filter(|&y| known(a) && known(b) && known(y)) {
                let (va, vb, y) = (value(a), value(b), value(y));
                found.push(std::array::from_fn(|i| va[i] + vb[i] - y[i]));
                if found.len() == MOST_CHOICES {
                    break;
                }
            }
        }
        found
    }

    /// Corner `v` over the triangles: the mean parallelogram across the
    /// edges opposite it whose triangle beyond is known, else the mean
    /// midpoint of the known edges opposite it, else its known neighbours.
    fn corner(&self, v: usize, values: &[[i32; 3]]) -> Option<[i64; 3]> {
        let known = |u: u32| self.before(u as usize, v);
        let value = |u: u32| values[u as usize].map(i64::from);
        let [mut parallelograms, mut midpoints, mut neighbours] = [(); 3].map(|_| Mean::default());
        for (a, b, across) in self.fan(v) {
            for u in [a, b].into_iter().filter(|&u| known(u)) {
                neighbours.add(value(u), 1);
            }
            if !(known(a) && known(b)) {
                continue;
            }
            let (va, vb) = (value(a), value(b));
            match across.filter(|&y| known(y)) {
                Some(y) => {
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
    let predictor = Predictor::new(faces, values.len(), Some(triangles), Corners::Plain);
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
    // The parallelograms' means alone: the noise is the surface's.
    let predictor = Predictor::new(faces, values.len(), split.as_deref(), Corners::Plain);
    let coded = coded_values(split.as_deref(), values.len(), implied);
    let keeps = if split.is_some() { SPLIT_KEEPS } else { KEEPS };
    median_residual_length(&predictor, &values[..coded]).saturating_sub(keeps)
}

/// The bit length of the median of `values`' prediction residuals, over
/// all coordinates (0 for no values).
pub(super) fn median_residual_length(predictor: &Predictor, values: &[[i32; 3]]) -> u32 {
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
pub(super) const KEEPS: u32 = 2;

/// [`KEEPS`] for a split base (the remesher's charts, or an input's own
/// triangles): its leading one alone. Such a base has hundreds to thousands
/// of triangles, and its section is most of what a cut below 65 dB holds;
/// the bit it no longer keeps arrives in the stream with the pass of its
/// weight. Bases of one square per part, at most a few hundred bytes, lost
/// PSNR with it, and keep [`KEEPS`] (docs/decisions/009-base-value-bits.md).
pub(super) const SPLIT_KEEPS: u32 = 1;

/// How many of a base's `vertices` have their values coded: with
/// `implied` and a split base, its corners alone.
pub(super) fn coded_values(split: Option<&[[u32; 3]]>, vertices: usize, implied: bool) -> usize {
    match split {
        Some(triangles) if implied => corner_count(triangles).min(vertices),
        _ => vertices,
    }
}

/// The subsets a version 5 corner names ([`Guess::Among`]): a flag per
/// parallelogram, in context of how many there are and which one it is;
/// the last flag is left out where the others are all clear (a subset is
/// never empty).
#[derive(Default)]
pub(super) struct ChoiceModel {
    flags: [[Context; MOST_CHOICES]; MOST_CHOICES - 1],
}

impl ChoiceModel {
    pub(super) fn put(&mut self, w: &mut BitWriter, guess: &Guess, mask: u32) {
        let Guess::Among(choices) = guess else {
            return;
        };
        let n = choices.len();
        for i in 0..n {
            if i + 1 == n && mask & ((1 << i) - 1) == 0 {
                break;
            }
            w.encode(&mut self.flags[n - 2][i], mask >> i & 1 != 0);
        }
    }

    pub(super) fn get(&mut self, r: &mut BitReader, guess: &Guess) -> Result<u32, String> {
        let Guess::Among(choices) = guess else {
            return Ok(0);
        };
        let n = choices.len();
        let mut mask = 0;
        for i in 0..n {
            if i + 1 == n && mask == 0 {
                mask |= 1 << i;
                break;
            }
            if r.decode(&mut self.flags[n - 2][i])
                .map_err(|_| "it ends before its last value".to_string())?
            {
                mask |= 1 << i;
            }
        }
        Ok(mask)
    }
}

/// The models of the values' residuals: one per coordinate (versions 1 to
/// 4); from version 5 on also per kind of prediction (a choice among
/// parallelograms, or one value) and per whether the coordinate before in
/// the same vertex was exact. A chosen parallelogram on a flat face often
/// gives all three coordinates exactly, a single one across a crease
/// none: apart, each model learns its own spread (1 to 2% off a faceted
/// base section).
pub(super) struct ValueModels {
    models: Vec<IntModel>,
    /// Version 5 on: the models apart by kind and exactness.
    by_kind: bool,
}

impl ValueModels {
    pub(super) fn new(version: u8) -> Self {
        let by_kind = version >= 5;
        ValueModels {
            models: vec![IntModel::new(); if by_kind { 12 } else { 3 }],
            by_kind,
        }
    }

    /// The model of coordinate `i` after a predicted value of kind
    /// `guess`, the coordinate before exact or not.
    fn index(&self, guess: &Guess, i: usize, exact_before: bool) -> usize {
        if !self.by_kind {
            return i;
        }
        let among = usize::from(matches!(guess, Guess::Among(_)));
        (among * 3 + i) * 2 + usize::from(exact_before)
    }

    pub(super) fn put(&mut self, w: &mut BitWriter, guess: &Guess, residual: [i64; 3]) {
        let mut exact = false;
        for (i, &r) in residual.iter().enumerate() {
            let k = self.index(guess, i, exact);
            self.models[k].put(w, r);
            exact = r == 0;
        }
    }

    pub(super) fn get(&mut self, r: &mut BitReader, guess: &Guess) -> Result<[i64; 3], String> {
        let mut residual = [0i64; 3];
        let mut exact = false;
        for i in 0..3 {
            let k = self.index(guess, i, exact);
            residual[i] = self.models[k].get(r)?;
            exact = residual[i] == 0;
        }
        Ok(residual)
    }
}
