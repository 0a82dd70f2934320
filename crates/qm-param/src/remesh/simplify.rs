//! A coarse base triangle mesh of one component, with every input vertex
//! mapped onto it: the base domain of MAPS (Lee, Sweldens, Schröder, Cowsar
//! and Dobkin 1998), the one Progressive Geometry Compression coded on.
//!
//! Vertices are removed one at a time, cheapest first, by half-edge
//! collapse: vertex `v` goes and its 1-ring is re-triangulated as a fan from
//! a neighbour `u`. Before it goes, its 1-ring is flattened conformally
//! (MAPS's `z^a`: angles around `v` scaled to a full turn, or to a half turn
//! on a boundary, radii raised to the same power), and every input vertex
//! located in the ring's triangles, `v` among them, is located again in the
//! new fan in that flattening. A collapse whose fan folds in the flattening
//! is never made, so the map stays one to one. Composed over all removals,
//! each input vertex ends in one base triangle with barycentric coordinates:
//! the bijective map of the input onto the base mesh.
//!
//! Base vertices are input vertices (half-edge collapse moves nothing), so
//! the base mesh interpolates the input. Boundaries and sharp creases are
//! *feature lines*: a vertex on one goes only along it, and a vertex where
//! feature lines end or meet stays. So creases of CAD and low-poly models
//! become base edges and, after the split into quads, grid lines. Input
//! vertices on one side of a feature line stay on that side.
//!
//! The cost of a removal is the quadric error of the region merged into `u`
//! (Garland and Heckbert), plus [`AREA_WEIGHT`] times the area of `v`'s ring
//! (MAPS's area term, which keeps the base triangles of similar size on flat
//! parts), divided by the worst shape of the fan's triangles. A fan
//! triangle below [`MIN_QUALITY`] is not made; a simplification stuck at
//! more than [`STUCK`] times its target goes on with lower bounds where it
//! has removed nothing yet.

use std::cmp::Ordering;

use foldhash::fast::FixedState;
use priority_queue::PriorityQueue;

use qm_lift::glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::TriMesh;

/// Hash maps and sets of vertex and edge ids, with a fast fixed hasher
/// (the std one's SipHash showed in the profile of a large mesh).
type HashMap<K, V> = std::collections::HashMap<K, V, FixedState>;
type HashSet<K> = std::collections::HashSet<K, FixedState>;

/// Weight of the ring's area against the squared quadric error.
const AREA_WEIGHT: f64 = 0.02;

/// Dihedral angle, in degrees, above which an edge is a crease.
const CREASE_DEGREES: f64 = 50.0;

/// Crease chains (between corners, or closed) shorter than this many edges,
/// or than [`MIN_CREASE_LENGTH`] base edges, are dropped: scanner noise or
/// details below the base's size, not features it can follow.
const MIN_CREASE_EDGES: usize = 3;

/// The shortest crease chain kept, in expected base edge lengths.
const MIN_CREASE_LENGTH: f64 = 0.5;

/// Fan triangles thinner than this (twice the area over the sum of squared
/// edges, 1 for the equilateral, scaled by `2 / sqrt(3)`) are not made.
const MIN_QUALITY: f64 = 0.02;

/// A removal may make triangles down to this share of the quality of the
/// thinnest it removes, where that is under the shape bound.
const SLIVER_SLACK: f64 = 0.5;

/// How many times its target a simplification may stop at before it goes
/// on with lower shape bounds.
const STUCK: usize = 2;

/// The lower shape bounds a stuck simplification goes on with, in turn.
const LOWER_QUALITY: &[f64] = &[0.005, 0.001, 0.0002];

/// A turn of a crease line sharper than this (in degrees, 0 straight on)
/// ends it where a part's crease lines are taken for scanner noise (see
/// [`simplify_part`]). Such lines zigzag, where a machined crease runs
/// nearly straight (docs/decisions/005-noisy-creases.md).
const NOISE_TURN_DEGREES: f64 = 60.0;

/// Most neighbours of a vertex that may be removed. Its hole is
/// retriangulated by a dynamic programme cubic in the ring, and a removal
/// next to it plans it again, so a hub of hundreds takes minutes. Removals
/// around such a hub bring it under the bound; scans rarely have a vertex
/// of more than 16 (docs/decisions/006-high-valence-bounds.md).
const MAX_RING: usize = 32;

/// Crease lines other than clean ones (see [`CLEAN_CREASE_CV`]) may end at
/// no more distinct vertices than this share of the target's base
/// vertices: the longest lines are kept first. Each end holds a base
/// vertex, and many short lines hold a base of small triangles along them,
/// which take their samples from the rest of the part
/// (docs/decisions/005-noisy-creases.md).
const CREASE_END_SHARE: f64 = 0.05;

/// A crease line whose dihedral angle varies along it by less than this
/// (standard deviation over mean) is clean, a machined edge, and kept
/// whatever the budget of [`CREASE_END_SHARE`]
/// (docs/decisions/005-noisy-creases.md).
const CLEAN_CREASE_CV: f64 = 0.03;

/// Where an input vertex lies on the base mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Location {
    /// It is a base vertex.
    Vertex,
    /// In base triangle `.0` (an index of [`Base::triangles`]) at
    /// barycentric coordinates `.1` of its corners.
    Face(u32, [f64; 3]),
}

/// A base triangle mesh of a component and the map onto it.
#[derive(Clone, Debug)]
pub struct Base {
    /// Counter-clockwise base triangles on the component's vertex ids.
    pub triangles: Vec<[u32; 3]>,
    /// Per component vertex.
    pub location: Vec<Location>,
    /// Per component vertex: whether it lies on a feature line (a boundary
    /// or a crease), where the map keeps it.
    pub feature: Vec<bool>,
    /// Whether crease lines were ended at their sharp turns, as scanner
    /// noise (see [`simplify_part`]).
    pub noisy_creases: bool,
}

#[derive(Clone, Copy, Default)]
struct Quadric {
    a: [f64; 6],
    b: [f64; 3],
    c: f64,
    area: f64,
}

impl Quadric {
    fn plane(n: DVec3, p: DVec3, w: f64) -> Quadric {
        let d = -n.dot(p);
        Quadric {
            a: [
                w * n.x * n.x,
                w * n.x * n.y,
                w * n.x * n.z,
                w * n.y * n.y,
                w * n.y * n.z,
                w * n.z * n.z,
            ],
            b: [w * n.x * d, w * n.y * d, w * n.z * d],
            c: w * d * d,
            area: 0.0,
        }
    }

    fn add(&mut self, o: &Quadric) {
        for i in 0..6 {
            self.a[i] += o.a[i];
        }
        for i in 0..3 {
            self.b[i] += o.b[i];
        }
        self.c += o.c;
        self.area += o.area;
    }

    fn eval(&self, p: DVec3) -> f64 {
        let [xx, xy, xz, yy, yz, zz] = self.a;
        let quad = xx * p.x * p.x
            + 2.0 * xy * p.x * p.y
            + 2.0 * xz * p.x * p.z
            + yy * p.y * p.y
            + 2.0 * yz * p.y * p.z
            + zz * p.z * p.z;
        let lin = 2.0 * (self.b[0] * p.x + self.b[1] * p.y + self.b[2] * p.z);
        (quad + lin + self.c).max(0.0)
    }
}

fn edge_key(a: u32, b: u32) -> u64 {
    (u64::from(a.min(b)) << 32) | u64::from(a.max(b))
}

/// A vertex's 1-ring: `faces[i]` is `(v, verts[i], verts[i + 1])` (indices
/// taken cyclically when `closed`).
pub(super) struct Ring {
    pub verts: Vec<u32>,
    pub faces: Vec<u32>,
    pub closed: bool,
}

/// The 1-ring of `v` in a manifold triangle mesh, from `faces`, the indices
/// into `triangles` of its triangles (counter-clockwise): in order around
/// it, a boundary fan from its first boundary neighbour. `None` if they do
/// not make one fan.
pub(super) fn ring(v: u32, faces: &[u32], triangles: &[[u32; 3]]) -> Option<Ring> {
    if faces.is_empty() {
        return None;
    }
    // (x, y, face) per face: v, x, y counter-clockwise.
    let spokes: Vec<(u32, u32, u32)> = faces
        .iter()
        .map(|&f| {
            let t = triangles[f as usize];
            let c = t.iter().position(|&w| w == v).expect("face of its vertex");
            (t[(c + 1) % 3], t[(c + 2) % 3], f)
        })
        .collect();
    // Sorted lookups, so that a vertex of high valence costs k log k, not
    // k^2: (x, spoke) and the ys.
    let mut by_x: Vec<(u32, usize)> = spokes.iter().enumerate().map(|(i, s)| (s.0, i)).collect();
    by_x.sort_unstable();
    let mut ys: Vec<u32> = spokes.iter().map(|s| s.1).collect();
    ys.sort_unstable();
    let is_y = |x: u32| ys.binary_search(&x).is_ok();
    // The first spoke whose x is `y`.
    let from = |y: u32| {
        let i = by_x.partition_point(|e| e.0 < y);
        by_x.get(i).filter(|e| e.0 == y).map(|e| e.1)
    };
    // A boundary fan starts at the x that is no face's y.
    let start = spokes.iter().position(|s| !is_y(s.0)).unwrap_or(0);
    let closed = spokes.iter().all(|s| is_y(s.0));
    let mut verts = vec![spokes[start].0];
    let mut order = Vec::with_capacity(spokes.len());
    let mut at = start;
    for _ in 0..spokes.len() {
        let (_, y, f) = spokes[at];
        order.push(f);
        match from(y) {
            Some(next) if order.len() < spokes.len() => {
                verts.push(y);
                at = next;
            }
            _ => {
                if !closed {
                    verts.push(y);
                }
                break;
            }
        }
    }
    if order.len() != spokes.len() {
        return None;
    }
    let mut unique = verts.clone();
    unique.sort_unstable();
    unique.dedup();
    if unique.len() != verts.len() {
        return None;
    }
    Some(Ring {
        verts,
        faces: order,
        closed,
    })
}

/// A planned removal of `v` into `u`: a half-edge collapse, whose new
/// triangles are the fan from `u`, or the ring retriangulated (`u` then the
/// ring vertex nearest `v`, which takes its quadric).
struct Plan {
    u: u32,
    cost: f64,
    /// The new triangles (ring positions, counter-clockwise) where they are
    /// not the fan from `u`.
    triangles: Option<Vec<[usize; 3]>>,
}

/// A vertex's priority in the queue of removals: its planned cost.
#[derive(PartialEq)]
struct Cost {
    cost: f64,
    v: u32,
}

impl Eq for Cost {}

impl PartialOrd for Cost {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Cost {
    /// Cheapest first in a max-heap; ties by vertex, for determinism.
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .cost
            .total_cmp(&self.cost)
            .then_with(|| other.v.cmp(&self.v))
    }
}

struct Simplifier<'a> {
    positions: &'a [DVec3],
    faces: Vec<[u32; 3]>,
    alive: Vec<bool>,
    points: Vec<Vec<u32>>,
    vfaces: Vec<Vec<u32>>,
    removed: Vec<bool>,
    creases: HashSet<u64>,
    crease_degree: Vec<u8>,
    quadric: Vec<Quadric>,
    location: Vec<Location>,
    /// Per vertex: whether a run has planned it again since the first
    /// plans (its ring changed, or its plan was out of date).
    touched: Vec<bool>,
    alive_faces: usize,
    alive_vertices: usize,
    closed: bool,
    feature: Vec<bool>,
    /// Vertices never removed (empty: none).
    keep: &'a [bool],
    /// The least shape (1 equilateral) of a triangle a removal may make.
    min_quality: f64,
    /// Whether crease lines end at sharp turns.
    noisy_creases: bool,
    /// Triangle counts at which to keep the base passed through, largest
    /// first, those passed removed.
    checkpoints: Vec<usize>,
    /// The bases kept at checkpoints.
    passed: Vec<(usize, Base)>,
}

/// Simplifies `mesh` (one cleaned component) towards `target` base
/// triangles, fewer if no removal is left that keeps the map one to one
/// and the topology.
#[cfg(test)]
pub fn simplify(mesh: &TriMesh, target: usize) -> Base {
    simplify_keeping(mesh, target, target, &[], false)
}

/// Simplifies `mesh` (one cleaned component) towards `target` base
/// triangles, and where that is stuck at more than [`STUCK`] times
/// `target`, again with crease lines taken for scanner noise: ended at
/// their turns sharper than [`NOISE_TURN_DEGREES`], so that the short
/// zigzag pieces are dropped. The base with fewer triangles is kept.
///
/// A scan's creases are mostly noise, and they hold base vertices that the
/// simplification cannot remove along them (a side of one triangle, the
/// link condition), leaving few to cover the rest.
///
/// Where ending the lines at their turns leaves the same crease lines, the
/// second run would be the first again, and is not made
/// (docs/decisions/014-simplifier-runs.md).
///
/// With the base, the bases the kept run passed through on its way, one at
/// each of the `checkpoints` (triangle counts) above where it stopped: the
/// bases of shallower levels, for free.
pub fn simplify_part(mesh: &TriMesh, target: usize, checkpoints: &[usize]) -> Simplified {
    let run = |noisy: bool| {
        let mut s = Simplifier::for_target(mesh, target, noisy);
        s.checkpoints = checkpoints.to_vec();
        s.checkpoints.sort_unstable_by(|a, b| b.cmp(a));
        s
    };
    let mut plain = run(false);
    let creases = plain.creases.clone();
    plain.run(target.max(1), target.max(1));
    let plain = plain.finish_with_passed();
    if plain.base.triangles.len() <= STUCK * target.max(1) {
        return plain;
    }
    let mut noisy = run(true);
    if noisy.creases == creases {
        return plain;
    }
    noisy.run(target.max(1), target.max(1));
    let noisy = noisy.finish_with_passed();
    if noisy.base.triangles.len() < plain.base.triangles.len() {
        noisy
    } else {
        plain
    }
}

/// What [`simplify_part`] made: the base, and the bases passed through at
/// the checkpoints asked for (count asked, base), largest first.
pub struct Simplified {
    pub base: Base,
    pub passed: Vec<(usize, Base)>,
}

/// Simplifies `mesh` the way [`simplify_part`] does for `goal` base
/// triangles (crease lines pruned for it, lower shape bounds while over
/// [`STUCK`] times it), but only down to `stop` triangles (at least the
/// goal), and never removing the vertices marked in `keep` (a list as long
/// as the vertices, or empty): they stay base vertices. `noisy_creases`
/// ends crease lines at their sharp turns (see [`simplify_part`]).
///
/// So a part simplified again around its folds takes the path its first
/// base took: stuck against a goal of its own size instead, it ends at many
/// more triangles (docs/decisions/014-simplifier-runs.md).
pub fn simplify_keeping(
    mesh: &TriMesh,
    goal: usize,
    stop: usize,
    keep: &[bool],
    noisy_creases: bool,
) -> Base {
    let mut s = Simplifier::for_target(mesh, goal, noisy_creases);
    s.keep = keep;
    s.run(goal.max(1), stop.max(goal).max(1));
    s.base()
}

impl<'a> Simplifier<'a> {
    /// A simplifier of `mesh` whose crease lines are pruned for a base of
    /// `target` triangles.
    fn for_target(mesh: &'a TriMesh, target: usize, noisy_creases: bool) -> Self {
        // The edge of an equilateral base triangle of the target's mean area.
        let edge = (4.0 * mesh.area() / (3f64.sqrt() * target.max(1) as f64)).sqrt();
        let most_ends = CREASE_END_SHARE * target.max(1) as f64 / 2.0;
        Simplifier::new(mesh, MIN_CREASE_LENGTH * edge, most_ends, noisy_creases)
    }

    fn new(mesh: &'a TriMesh, min_crease: f64, most_ends: f64, noisy_creases: bool) -> Self {
        let n = mesh.positions.len();
        let mut vfaces = vec![Vec::new(); n];
        for (f, t) in mesh.triangles.iter().enumerate() {
            for &v in t {
                vfaces[v as usize].push(f as u32);
            }
        }
        let mut quadric = vec![Quadric::default(); n];
        let normal = |t: &[u32; 3]| {
            let [a, b, c] = mesh.corners(t);
            (b - a).cross(c - a)
        };
        for t in &mesh.triangles {
            let nn = normal(t);
            let area = 0.5 * nn.length();
            if area <= 0.0 {
                continue;
            }
            let mut q = Quadric::plane(nn.normalize(), mesh.positions[t[0] as usize], area);
            q.area = area / 3.0;
            for &v in t {
                quadric[v as usize].add(&q);
            }
        }
        // Edges with their faces, for boundaries and creases.
        let mut edge_faces: HashMap<u64, Vec<u32>> =
            HashMap::with_capacity_and_hasher(3 * mesh.triangles.len() / 2, FixedState::default());
        for (f, t) in mesh.triangles.iter().enumerate() {
            for i in 0..3 {
                edge_faces
                    .entry(edge_key(t[i], t[(i + 1) % 3]))
                    .or_default()
                    .push(f as u32);
            }
        }
        let cos_crease = CREASE_DEGREES.to_radians().cos();
        let mut creases = HashSet::default();
        let mut boundary_edges = 0usize;
        for (&key, fs) in &edge_faces {
            let sharp = match fs.as_slice() {
                [_] => {
                    boundary_edges += 1;
                    true
                }
                [f, g] => {
                    let (a, b) = (
                        normal(&mesh.triangles[*f as usize]),
                        normal(&mesh.triangles[*g as usize]),
                    );
                    a.normalize_or_zero().dot(b.normalize_or_zero()) < cos_crease
                }
                _ => true,
            };
            if sharp {
                creases.insert(key);
            }
        }
        let closed = boundary_edges == 0;
        let mut s = Simplifier {
            positions: &mesh.positions,
            faces: mesh.triangles.clone(),
            alive: vec![true; mesh.triangles.len()],
            points: vec![Vec::new(); mesh.triangles.len()],
            vfaces,
            removed: vec![false; n],
            creases,
            crease_degree: vec![0; n],
            quadric,
            location: vec![Location::Vertex; n],
            touched: vec![false; n],
            alive_faces: mesh.triangles.len(),
            alive_vertices: n,
            closed,
            feature: Vec::new(),
            keep: &[],
            min_quality: MIN_QUALITY,
            noisy_creases,
            checkpoints: Vec::new(),
            passed: Vec::new(),
        };
        s.prune_creases(&edge_faces, min_crease, most_ends);
        s.feature = s.crease_degree.iter().map(|&d| d > 0).collect();
        s
    }

    /// Drops short crease chains (keeping boundaries; with noisy creases,
    /// a chain ends where it turns by more than [`NOISE_TURN_DEGREES`]),
    /// and, clean lines aside, the shortest beyond `most_ends` distinct
    /// chain ends (see [`CREASE_END_SHARE`]), then counts each vertex's
    /// feature edges and adds the feature lines' quadrics.
    fn prune_creases(
        &mut self,
        edge_faces: &HashMap<u64, Vec<u32>>,
        min_length: f64,
        most_ends: f64,
    ) {
        let n = self.positions.len();
        let ends = |key: u64| ((key >> 32) as u32, key as u32);
        let mut degree = vec![0u32; n];
        for &key in &self.creases {
            let (a, b) = ends(key);
            degree[a as usize] += 1;
            degree[b as usize] += 1;
        }
        let mut adjacency: HashMap<u32, Vec<u32>> = HashMap::default();
        for &key in &self.creases {
            let (a, b) = ends(key);
            adjacency.entry(a).or_default().push(b);
            adjacency.entry(b).or_default().push(a);
        }
        // Interior crease vertices where a noisy line turns sharply.
        let cos_turn = NOISE_TURN_DEGREES.to_radians().cos();
        let interior = |a: u32, b: u32| edge_faces[&edge_key(a, b)].len() == 2;
        let turned: HashSet<u32> = adjacency
            .iter()
            .filter(|_| self.noisy_creases)
            .filter(|&(&at, ws)| {
                let &[a, b] = ws.as_slice() else {
                    return false;
                };
                let p = self.positions[at as usize];
                let (da, db) = (
                    self.positions[a as usize] - p,
                    self.positions[b as usize] - p,
                );
                // Straight on, the two edges point opposite ways.
                -da.normalize_or_zero().dot(db.normalize_or_zero()) < cos_turn
                    && interior(at, a)
                    && interior(at, b)
            })
            .map(|(&at, _)| at)
            .collect();
        // Walk chains between vertices of degree other than 2, and sharp
        // turns.
        let mut seen: HashSet<u64> = HashSet::default();
        let mut drop = Vec::new();
        let mut long: Vec<(f64, Vec<u64>)> = Vec::new();
        let mut keys: Vec<u64> = self.creases.iter().copied().collect();
        keys.sort_unstable();
        for &key in &keys {
            if seen.contains(&key) {
                continue;
            }
            let boundary = edge_faces[&key].len() == 1;
            let mut chain = vec![key];
            seen.insert(key);
            let (a, b) = ends(key);
            for start in [a, b] {
                let (mut prev, mut at) = (if start == a { b } else { a }, start);
                while degree[at as usize] == 2 && !turned.contains(&at) {
                    let next = adjacency[&at]
                        .iter()
                        .copied()
                        .find(|&w| w != prev)
                        .unwrap_or(prev);
                    let k = edge_key(at, next);
                    if !seen.insert(k) {
                        break;
                    }
                    chain.push(k);
                    prev = at;
                    at = next;
                }
            }
            let length: f64 = chain
                .iter()
                .map(|&k| {
                    let (a, b) = ends(k);
                    self.positions[a as usize].distance(self.positions[b as usize])
                })
                .sum();
            if boundary {
                continue;
            }
            if chain.len() < MIN_CREASE_EDGES || length < min_length {
                drop.extend(chain);
            } else {
                long.push((length, chain));
            }
        }
        // Longest first (stable: the chains came in key order).
        long.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut held: HashSet<u32> = HashSet::default();
        for (_, chain) in long {
            let mut touches = HashMap::<u32, u32>::default();
            for &k in &chain {
                let (a, b) = ends(k);
                *touches.entry(a).or_default() += 1;
                *touches.entry(b).or_default() += 1;
            }
            let chain_ends: Vec<u32> = touches
                .into_iter()
                .filter(|&(v, n)| n == 1 && !held.contains(&v))
                .map(|(v, _)| v)
                .collect();
            if !self.clean(&chain, edge_faces) && (held.len() + chain_ends.len()) as f64 > most_ends
            {
                drop.extend(chain);
            } else {
                held.extend(chain_ends);
            }
        }
        for key in drop {
            self.creases.remove(&key);
        }
        // A sharp turn between two lines kept stays, as their meeting does
        // (one more feature edge counted marks it).
        for &at in &turned {
            if adjacency[&at]
                .iter()
                .all(|&w| self.creases.contains(&edge_key(at, w)))
            {
                self.crease_degree[at as usize] = 1;
            }
        }
        // In a fixed order: the quadrics' sums, and so the base, must not
        // depend on the set's hashing.
        let mut kept: Vec<u64> = self.creases.iter().copied().collect();
        kept.sort_unstable();
        for key in kept {
            let (a, b) = ends(key);
            for v in [a, b] {
                self.crease_degree[v as usize] = self.crease_degree[v as usize].saturating_add(1);
            }
            // A plane through the edge, across its faces: keeps the line.
            let (pa, pb) = (self.positions[a as usize], self.positions[b as usize]);
            let e = pb - pa;
            for &f in &edge_faces[&key] {
                let fnormal = self.normal(f).normalize_or_zero();
                let across = e.cross(fnormal).normalize_or_zero();
                if across != DVec3::ZERO {
                    let q = Quadric::plane(across, pa, e.length_squared());
                    self.quadric[a as usize].add(&q);
                    self.quadric[b as usize].add(&q);
                }
            }
        }
    }

    /// Whether crease `chain`'s dihedral angle is nearly the same all along
    /// it ([`CLEAN_CREASE_CV`]).
    fn clean(&self, chain: &[u64], edge_faces: &HashMap<u64, Vec<u32>>) -> bool {
        let angles: Vec<f64> = chain
            .iter()
            .filter_map(|k| match edge_faces[k].as_slice() {
                &[f, g] => Some(self.normal(f).angle_between(self.normal(g))),
                _ => None,
            })
            .collect();
        if angles.is_empty() {
            return false;
        }
        let mean = angles.iter().sum::<f64>() / angles.len() as f64;
        let variance = angles.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / angles.len() as f64;
        mean > 0.0 && variance.sqrt() < CLEAN_CREASE_CV * mean
    }

    /// Face `f`'s normal, as long as twice its area.
    fn normal(&self, f: u32) -> DVec3 {
        let [x, y, z] = self.faces[f as usize].map(|v| self.positions[v as usize]);
        (y - x).cross(z - x)
    }

    fn ring(&self, v: u32) -> Option<Ring> {
        ring(v, &self.vfaces[v as usize], &self.faces)
    }

    /// MAPS's conformal flattening of `v`'s ring: `v` at the origin. On a
    /// feature line (a boundary, or `line`: the ring positions of an
    /// interior crease's two ends) each side of the line is opened to a half
    /// turn, radii kept, so that the line comes out straight through `v`
    /// and no point crosses it when `v` goes.
    fn flatten(&self, v: u32, ring: &Ring, line: Option<(usize, usize)>) -> Option<Vec<DVec2>> {
        let p = self.positions[v as usize];
        let k = ring.verts.len();
        let spokes: Vec<DVec3> = ring
            .verts
            .iter()
            .map(|&w| self.positions[w as usize] - p)
            .collect();
        let lengths: Vec<f64> = spokes.iter().map(|s| s.length()).collect();
        let longest = lengths.iter().copied().fold(0.0, f64::max);
        if longest.is_nan() || longest <= 0.0 || lengths.iter().any(|&l| l.is_nan() || l <= 0.0) {
            return None;
        }
        let angle = |i: usize, j: usize| spokes[i].angle_between(spokes[j]);
        let angles: Vec<f64> = (0..ring.faces.len())
            .map(|i| angle(i, (i + 1) % k))
            .collect();
        let total: f64 = angles.iter().sum();
        if total.is_nan() || total <= 1e-9 || angles.iter().any(|&a| a.is_nan() || a <= 0.0) {
            return None;
        }
        let mut out = vec![DVec2::ZERO; k];
        if let (Some((ui, bi)), true) = (line, ring.closed) {
            // Edge i runs from ring position i to i + 1; side 0 from u to b.
            let side0: f64 = (0..k)
                .filter(|&i| (i + k - ui) % k < (bi + k - ui) % k)
                .map(|i| angles[i])
                .sum();
            let side1 = total - side0;
            if side0 <= 1e-9 || side1 <= 1e-9 {
                return None;
            }
            let mut phi = 0.0f64;
            for step in 0..k {
                let i = (ui + step) % k;
                let r = (lengths[i] / longest).powf(std::f64::consts::TAU / total);
                out[i] = DVec2::new(r * phi.cos(), r * phi.sin());
                let scale = if step < (bi + k - ui) % k {
                    std::f64::consts::PI / side0
                } else {
                    std::f64::consts::PI / side1
                };
                phi += scale * angles[i];
            }
            return Some(out);
        }
        let turn = if ring.closed {
            std::f64::consts::TAU
        } else {
            std::f64::consts::PI
        };
        let a = turn / total;
        let mut phi = 0.0f64;
        for (i, slot) in out.iter_mut().enumerate() {
            let r = (lengths[i] / longest).powf(if ring.closed { a } else { 1.0 });
            *slot = DVec2::new(r * phi.cos(), r * phi.sin());
            if i < angles.len() {
                phi += a * angles[i];
            }
        }
        Some(out)
    }

    fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut out: Vec<u32> = self.vfaces[v as usize]
            .iter()
            .flat_map(|&f| self.faces[f as usize])
            .filter(|&w| w != v)
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Whether `u` and `w` share a live triangle (an edge).
    fn adjacent(&self, u: u32, w: u32) -> bool {
        self.vfaces[u as usize]
            .iter()
            .any(|&f| self.faces[f as usize].contains(&w))
    }

    /// The fan from ring position `ui`: per ring edge `i` not at `u`,
    /// `(i, [u, w_i, w_i+1])`.
    fn fan(ring: &Ring, ui: usize) -> Vec<(usize, [usize; 3])> {
        let k = ring.verts.len();
        (0..ring.faces.len())
            .filter_map(|i| {
                let j = (i + 1) % k;
                (i != ui && j != ui).then_some((i, [ui, i, j]))
            })
            .collect()
    }

    /// The side of ring edge `i` for a crease collapse into ring position
    /// `ui` with the other crease neighbour at `bi`: 0 from `u` to `b`, 1
    /// from `b` to `u`; all 0 without a crease.
    fn side(ring: &Ring, ui: usize, bi: Option<usize>, i: usize) -> u8 {
        let Some(bi) = bi else { return 0 };
        let k = ring.verts.len();
        let from_u = (i + k - ui) % k;
        let to_b = (bi + k - ui) % k;
        u8::from(from_u >= to_b)
    }

    /// The best removal of `v`, if any is allowed.
    fn plan(&self, v: u32) -> Option<Plan> {
        if self.removed[v as usize] || self.keep.get(v as usize) == Some(&true) {
            return None;
        }
        let degree = self.crease_degree[v as usize];
        if degree != 0 && degree != 2 {
            return None;
        }
        let min_faces = if self.closed { 4 } else { 1 };
        let ring = self.ring(v)?;
        if ring.verts.len() > MAX_RING {
            return None;
        }
        if self.alive_faces <= min_faces + 2 || self.alive_vertices <= 4 {
            return None;
        }
        // A boundary vertex lies on feature lines (its two boundary edges).
        if !ring.closed && degree != 2 {
            return None;
        }
        if !ring.closed && ring.faces.len() < 2 {
            return None;
        }
        let plain = self.flatten(v, &ring, None)?;
        // Most vertices lie on no feature line: no look-ups for them.
        let crease_ends: Vec<usize> = if degree == 0 {
            Vec::new()
        } else {
            (0..ring.verts.len())
                .filter(|&i| self.creases.contains(&edge_key(v, ring.verts[i])))
                .collect()
        };
        let candidates: Vec<usize> = if degree == 2 {
            crease_ends.clone()
        } else {
            (0..ring.verts.len()).collect()
        };
        let v_neighbours = self.neighbours(v);
        let ring_area: f64 = ring
            .faces
            .iter()
            .map(|&f| self.area3(self.faces[f as usize]))
            .sum();
        let ring_normal: DVec3 = ring
            .faces
            .iter()
            .map(|&f| self.normal3(self.faces[f as usize]))
            .sum::<DVec3>()
            .normalize_or_zero();
        // A removal may make triangles down to half as thin as the thinnest
        // it removes: a scan's slivers would otherwise hold every vertex
        // around them.
        let floor = ring
            .faces
            .iter()
            .map(|&f| SLIVER_SLACK * self.quality3(self.faces[f as usize]))
            .fold(self.min_quality, f64::min);
        // The cost of removing `v` into `u`, making triangles of `quality`.
        let cost = |u: u32, quality: f64| {
            let mut q = self.quadric[v as usize];
            q.add(&self.quadric[u as usize]);
            let err = q.eval(self.positions[u as usize]) / q.area.max(1e-300);
            (err + AREA_WEIGHT * ring_area) / quality.min(1.0)
        };
        let mut best: Option<Plan> = None;
        for ui in candidates {
            let u = ring.verts[ui];
            let bi = (degree == 2)
                .then(|| crease_ends.iter().copied().find(|&i| i != ui))
                .flatten();
            if let Some(bi) = bi
                && self.creases.contains(&edge_key(u, ring.verts[bi]))
            {
                continue;
            }
            // Each side of an interior crease keeps a triangle: a side of
            // one (`v, u, b`) would be squashed onto the line `u b`, and
            // its points with it.
            if let Some(bi) = bi
                && ring.closed
            {
                let k = ring.verts.len();
                let arc = (bi + k - ui) % k;
                if arc < 2 || k - arc < 2 {
                    continue;
                }
            }
            if !ring.closed && ui != 0 && ui != ring.verts.len() - 1 {
                continue;
            }
            let lined;
            let flat = match bi {
                Some(bi) if ring.closed => {
                    let Some(f) = self.flatten(v, &ring, Some((ui, bi))) else {
                        continue;
                    };
                    lined = f;
                    &lined
                }
                _ => &plain,
            };
            let quality = Self::fan(&ring, ui)
                .iter()
                .map(|&(_, t)| self.new_quality(&ring, flat, t, ring_normal))
                .try_fold(f64::INFINITY, |q, t| t.map(|t| q.min(t)));
            let Some(quality) = quality.filter(|&q| q >= floor) else {
                continue;
            };
            let cost = cost(u, quality);
            if best
                .as_ref()
                .is_some_and(|b| cost.partial_cmp(&b.cost) != Some(Ordering::Less))
            {
                continue;
            }
            // Link condition (checked last, for the one candidate that
            // would win): the common neighbours of u and v are the
            // vertices opposite their edge.
            let opposite = ring
                .faces
                .iter()
                .map(|&f| self.faces[f as usize])
                .filter(|t| t.contains(&u))
                .count();
            let common = v_neighbours
                .iter()
                .filter(|&&w| w != u && self.adjacent(u, w))
                .count();
            if common == opposite {
                best = Some(Plan {
                    u,
                    cost,
                    triangles: None,
                });
            }
        }
        // Where no fan is valid (a noisy scan's ring that no ring vertex
        // sees whole), MAPS's removal: the flattened ring retriangulated.
        if best.is_none()
            && degree == 0
            && ring.closed
            && let Some((quality, triangles)) = self.retriangulate(&ring, &plain, ring_normal)
            && quality >= floor
        {
            let p = self.positions[v as usize];
            let nearest = ring.verts.iter().copied().min_by(|&a, &b| {
                let d = |w: u32| self.positions[w as usize].distance_squared(p);
                d(a).total_cmp(&d(b))
            })?;
            best = Some(Plan {
                u: nearest,
                cost: cost(nearest, quality),
                triangles: Some(triangles),
            });
        }
        best
    }

    /// The triangulation of the closed ring's flattened polygon `flat` whose
    /// thinnest triangle is thickest (dynamic programming over the
    /// polygon's sub-chains), with every triangle turned the right way in
    /// the flattening and along `normal`, and no new edge that the mesh
    /// already has. Its least quality and triangles (ring positions,
    /// counter-clockwise), if there is one.
    fn retriangulate(
        &self,
        ring: &Ring,
        flat: &[DVec2],
        normal: DVec3,
    ) -> Option<(f64, Vec<[usize; 3]>)> {
        let k = ring.verts.len();
        // Whether positions i < j may be joined: a ring edge, or a new edge.
        let joinable = |i: usize, j: usize| {
            j == i + 1 || (i == 0 && j == k - 1) || !self.adjacent(ring.verts[i], ring.verts[j])
        };
        let score = |a: usize, b: usize, c: usize| {
            self.new_quality(ring, flat, [a, b, c], normal)
                .unwrap_or(f64::NEG_INFINITY)
        };
        // best[i][j]: the sub-chain i..=j closed by the edge i j.
        let mut best = vec![vec![(f64::NEG_INFINITY, usize::MAX); k]; k];
        for i in 0..k - 1 {
            best[i][i + 1] = (f64::INFINITY, usize::MAX);
        }
        for span in 2..k {
            for i in 0..k - span {
                let j = i + span;
                if !joinable(i, j) {
                    continue;
                }
                for m in i + 1..j {
                    let value = best[i][m].0.min(best[m][j].0).min(score(i, m, j));
                    if value > best[i][j].0 {
                        best[i][j] = (value, m);
                    }
                }
            }
        }
        let (quality, _) = best[0][k - 1];
        if !quality.is_finite() {
            return None;
        }
        let mut triangles = Vec::with_capacity(k - 2);
        let mut stack = vec![(0, k - 1)];
        while let Some((i, j)) = stack.pop() {
            if j > i + 1 {
                let m = best[i][j].1;
                triangles.push([i, m, j]);
                stack.push((i, m));
                stack.push((m, j));
            }
        }
        Some((quality, triangles))
    }

    /// The quality of a triangle a removal would make, on ring positions
    /// `[a, b, c]`: `None` if it is not turned the right way in the
    /// flattening `flat` and along `normal`.
    fn new_quality(
        &self,
        ring: &Ring,
        flat: &[DVec2],
        [a, b, c]: [usize; 3],
        normal: DVec3,
    ) -> Option<f64> {
        let (pa, pb, pc) = (flat[a], flat[b], flat[c]);
        let area2 = (pb - pa).perp_dot(pc - pa);
        let scale =
            (pb - pa).length_squared() + (pc - pb).length_squared() + (pa - pc).length_squared();
        let t = [ring.verts[a], ring.verts[b], ring.verts[c]];
        if area2.is_nan() || area2 <= 1e-12 * scale || self.normal3(t).dot(normal) <= 0.0 {
            return None;
        }
        Some(self.quality3(t))
    }

    fn area3(&self, t: [u32; 3]) -> f64 {
        0.5 * self.normal3_raw(t).length()
    }

    fn normal3_raw(&self, t: [u32; 3]) -> DVec3 {
        let [a, b, c] = t.map(|v| self.positions[v as usize]);
        (b - a).cross(c - a)
    }

    fn normal3(&self, t: [u32; 3]) -> DVec3 {
        self.normal3_raw(t).normalize_or_zero()
    }

    /// `4 sqrt(3) area / (sum of squared edges)`: 1 for the equilateral.
    fn quality3(&self, t: [u32; 3]) -> f64 {
        let [a, b, c] = t.map(|v| self.positions[v as usize]);
        let sum = (b - a).length_squared() + (c - b).length_squared() + (a - c).length_squared();
        if sum <= 0.0 {
            return 0.0;
        }
        2.0 * 3f64.sqrt() * (b - a).cross(c - a).length() / sum
    }

    /// Removes vertices, cheapest first, until `stop` triangles are left
    /// or no removal is. A part left at more than [`STUCK`] times its `goal`
    /// (a dense scan, whose every removal would make a sliver) goes on with
    /// the lower shape bounds of [`LOWER_QUALITY`] in turn, from the
    /// vertices no removal has touched yet (see [`Self::run_at`]).
    fn run(&mut self, goal: usize, stop: usize) {
        self.run_at(stop);
        for &bound in LOWER_QUALITY {
            if self.alive_faces <= STUCK * goal || self.alive_faces <= stop {
                break;
            }
            self.min_quality = bound;
            self.run_at(stop);
        }
    }

    fn run_at(&mut self, target: usize) {
        // The first plans, in parallel (the heap breaks ties by vertex, so
        // its order does not depend on the threads), of the vertices no run
        // before touched: a run under a lower shape bound reaches into the
        // regions where the usual one removed nothing, and leaves those it
        // simplified as they are: planning every vertex again made slivers
        // and a worse, slower remesh (docs/decisions/014-simplifier-runs.md).
        //
        // The queue holds each vertex once, its priority updated where its
        // ring changes, rather than every plan ever made.
        let first: Vec<(u32, Cost)> = (0..self.positions.len() as u32)
            .into_par_iter()
            .with_min_len(1024)
            .filter(|&v| !self.touched[v as usize])
            .filter_map(|v| self.plan(v).map(|p| (v, Cost { cost: p.cost, v })))
            .collect();
        let mut queue: PriorityQueue<u32, Cost, FixedState> = first.into_iter().collect();
        self.pass_checkpoints();
        while self.alive_faces > target {
            let Some((v, planned)) = queue.pop() else {
                break;
            };
            let Some(plan) = self.plan(v) else { continue };
            if plan.cost > planned.cost * (1.0 + 1e-9) + 1e-300 {
                self.touched[v as usize] = true;
                queue.push(v, Cost { cost: plan.cost, v });
                continue;
            }
            let touched = self.collapse(v, &plan);
            self.pass_checkpoints();
            for w in touched {
                self.touched[w as usize] = true;
                match self.plan(w) {
                    Some(p) => queue.push(w, Cost { cost: p.cost, v: w }),
                    None => queue.remove(&w).map(|(_, c)| c),
                };
            }
        }
    }

    /// Removes `v` as `plan` says; returns the vertices whose rings changed.
    fn collapse(&mut self, v: u32, plan: &Plan) -> Vec<u32> {
        let u = plan.u;
        let ring = self.ring(v).expect("planned ring");
        let k = ring.verts.len();
        let ui = ring.verts.iter().position(|&w| w == u).expect("u in ring");
        let bi = if self.crease_degree[v as usize] == 2 {
            (0..k).find(|&i| i != ui && self.creases.contains(&edge_key(v, ring.verts[i])))
        } else {
            None
        };
        let line = bi.filter(|_| ring.closed).map(|bi| (ui, bi));
        let flat = self.flatten(v, &ring, line).expect("planned flattening");
        let corner2d = |w: u32| -> DVec2 {
            if w == v {
                DVec2::ZERO
            } else {
                flat[ring
                    .verts
                    .iter()
                    .position(|&x| x == w)
                    .expect("ring vertex")]
            }
        };
        // The points of the old faces, in the flattening, with their side.
        let mut moving: Vec<(u32, DVec2, u8)> = Vec::new();
        for (i, &f) in ring.faces.iter().enumerate() {
            let side = Self::side(&ring, ui, bi, i);
            let t = self.faces[f as usize];
            let c = t.map(corner2d);
            for &p in &self.points[f as usize] {
                let Location::Face(_, b) = self.location[p as usize] else {
                    unreachable!("a located point")
                };
                moving.push((p, c[0] * b[0] + c[1] * b[1] + c[2] * b[2], side));
            }
            self.points[f as usize] = Vec::new();
            self.alive[f as usize] = false;
        }
        moving.push((v, DVec2::ZERO, if bi.is_some() { 2 } else { 0 }));
        // The new fan, or the ring retriangulated (no crease: one side).
        let fan = match &plan.triangles {
            Some(triangles) => triangles.iter().map(|&t| (0, t)).collect(),
            None => Self::fan(&ring, ui),
        };
        let mut made: Vec<(u32, [DVec2; 3], u8)> = Vec::with_capacity(fan.len());
        for &(i, [a, b, c]) in &fan {
            let t = [ring.verts[a], ring.verts[b], ring.verts[c]];
            let f = self.faces.len() as u32;
            self.faces.push(t);
            self.alive.push(true);
            self.points.push(Vec::new());
            made.push((f, [flat[a], flat[b], flat[c]], Self::side(&ring, ui, bi, i)));
        }
        for &w in &ring.verts {
            let fs = &mut self.vfaces[w as usize];
            fs.retain(|&f| self.alive[f as usize]);
        }
        for &(f, _, _) in &made {
            for w in self.faces[f as usize] {
                self.vfaces[w as usize].push(f);
            }
        }
        // Locate every moving point in a fan triangle of its side (`v`
        // itself, on a crease, lies on the line: either side).
        for (p, x, side) in moving {
            // A side may have no fan triangle left (its one triangle was
            // `v, u, b`): its points go onto the line `u b`.
            let sided = side != 2 && made.iter().any(|m| m.2 == side);
            let mut best: Option<(f64, u32, [f64; 3])> = None;
            for &(f, [a, b, c], s) in &made {
                if sided && s != side {
                    continue;
                }
                let area = (b - a).perp_dot(c - a);
                let l = [
                    (b - x).perp_dot(c - x) / area,
                    (c - x).perp_dot(a - x) / area,
                    (a - x).perp_dot(b - x) / area,
                ];
                let worst = l[0].min(l[1]).min(l[2]);
                if best.is_none_or(|b| worst > b.0) {
                    best = Some((worst, f, l));
                }
            }
            let (worst, f, mut l) = best.expect("a fan triangle");
            if worst < 0.0 {
                for x in &mut l {
                    *x = x.max(0.0);
                }
                let s: f64 = l.iter().sum();
                for x in &mut l {
                    *x /= s;
                }
            }
            self.location[p as usize] = Location::Face(f, l);
            self.points[f as usize].push(p);
        }
        // Bookkeeping.
        let qv = self.quadric[v as usize];
        self.quadric[u as usize].add(&qv);
        if let Some(bi) = bi {
            let b = ring.verts[bi];
            self.creases.remove(&edge_key(v, u));
            self.creases.remove(&edge_key(v, b));
            self.creases.insert(edge_key(u, b));
        }
        self.vfaces[v as usize].clear();
        self.removed[v as usize] = true;
        self.alive_vertices -= 1;
        self.alive_faces = self.alive_faces + made.len() - ring.faces.len();
        ring.verts
    }

    /// Keeps the base now at every checkpoint the count has come down to.
    fn pass_checkpoints(&mut self) {
        while let Some(&count) = self.checkpoints.first()
            && self.alive_faces <= count
        {
            self.checkpoints.remove(0);
            let base = self.base();
            self.passed.push((count, base));
        }
    }

    fn finish_with_passed(mut self) -> Simplified {
        let passed = std::mem::take(&mut self.passed);
        Simplified {
            base: self.base(),
            passed,
        }
    }

    fn base(&self) -> Base {
        let mut index = vec![u32::MAX; self.faces.len()];
        let mut triangles = Vec::with_capacity(self.alive_faces);
        for (f, t) in self.faces.iter().enumerate() {
            if self.alive[f] {
                index[f] = triangles.len() as u32;
                triangles.push(*t);
            }
        }
        let location = self
            .location
            .iter()
            .map(|l| match *l {
                Location::Face(f, b) => Location::Face(index[f as usize], b),
                Location::Vertex => Location::Vertex,
            })
            .collect();
        Base {
            triangles,
            location,
            feature: self.feature.clone(),
            noisy_creases: self.noisy_creases,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn euler(triangles: &[[u32; 3]]) -> i64 {
        let mut verts: Vec<u32> = triangles.iter().flatten().copied().collect();
        verts.sort_unstable();
        verts.dedup();
        let mut edges: Vec<u64> = triangles
            .iter()
            .flat_map(|t| (0..3).map(move |i| edge_key(t[i], t[(i + 1) % 3])))
            .collect();
        edges.sort_unstable();
        edges.dedup();
        verts.len() as i64 - edges.len() as i64 + triangles.len() as i64
    }

    /// A 24 x 24 grid folded at 70 degrees along a ridge: straight down
    /// the middle column, or zigzagging between it and the next at every
    /// row (a turn of 90 degrees). Heights fall with the distance from the
    /// ridge, so only its edges are creases.
    fn ridge(zigzag: bool) -> TriMesh {
        let n = 24u32;
        let column = |row: u32| f64::from(n / 2 + u32::from(zigzag) * (row % 2));
        let line: Vec<DVec2> = (0..=n)
            .map(|j| DVec2::new(column(j), f64::from(j)))
            .collect();
        let from_line = |p: DVec2| {
            line.windows(2)
                .map(|w| {
                    let (a, b) = (w[0], w[1]);
                    let t = ((p - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
                    p.distance(a + t * (b - a))
                })
                .fold(f64::INFINITY, f64::min)
        };
        let mut positions = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let p = DVec2::new(f64::from(i), f64::from(j));
                positions.push(DVec3::new(p.x, p.y, -0.7 * from_line(p)));
            }
        }
        let at = |i: u32, j: u32| j * (n + 1) + i;
        let mut triangles = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                // The diagonal follows the ridge where it crosses the cell.
                if f64::from(i + 1) == column(j) && f64::from(i) == column(j + 1) {
                    triangles.extend([[a, b, d], [b, c, d]]);
                } else {
                    triangles.extend([[a, b, c], [a, c, d]]);
                }
            }
        }
        TriMesh {
            positions,
            triangles,
        }
    }

    /// Crease lines taken for noise end at their sharp turns, and the short
    /// pieces are dropped: a zigzag ridge is then no feature line, while a
    /// straight one is one either way.
    #[test]
    fn noisy_creases_end_at_sharp_turns() {
        let inner_features = |mesh: &TriMesh, noisy: bool| {
            let base = simplify_keeping(mesh, 60, 60, &[], noisy);
            (0..mesh.positions.len())
                .filter(|&v| {
                    let p = mesh.positions[v];
                    let inner = |x: f64| x > 0.5 && x < 23.5;
                    base.feature[v] && inner(p.x) && inner(p.y)
                })
                .count()
        };
        let (straight, zigzag) = (ridge(false), ridge(true));
        let counts = [
            inner_features(&straight, false),
            inner_features(&straight, true),
            inner_features(&zigzag, false),
            inner_features(&zigzag, true),
        ];
        assert!(counts[..3].iter().all(|&c| c >= 20), "{counts:?}");
        assert_eq!(counts[3], 0, "{counts:?}");
    }

    /// Edges across the sheet of [`ridges`].
    const RIDGES_WIDTH: u32 = 66;

    /// A flat sheet with eight straight tent-shaped ridges of 4 to 25
    /// edges, 8 apart: each ridge's top is a crease line, its feet are not
    /// (under 42 degrees). The first, shortest ridge is clean (70 degrees
    /// all along); along the others the slope varies, and the crease with
    /// it (55 to 82 degrees).
    fn ridges() -> (TriMesh, Vec<(u32, std::ops::RangeInclusive<u32>)>) {
        let (w, h) = (RIDGES_WIDTH, 30u32);
        let ridges: Vec<(u32, std::ops::RangeInclusive<u32>)> =
            (0..8).map(|k| (5 + 8 * k, 2..=2 + 4 + 3 * k)).collect();
        let mut positions = Vec::new();
        for j in 0..=h {
            for i in 0..=w {
                let p = DVec2::new(f64::from(i), f64::from(j));
                let z = ridges
                    .iter()
                    .enumerate()
                    .map(|(k, (x, rows))| {
                        let y = p.y.clamp(f64::from(*rows.start()), f64::from(*rows.end()));
                        let d = p.distance(DVec2::new(f64::from(*x), y));
                        let wobble = if k == 0 {
                            0.0
                        } else {
                            (1.3 * y + k as f64).sin()
                        };
                        (2.1 - 0.7 * (1.0 + 0.25 * wobble) * d).max(0.0)
                    })
                    .fold(0.0, f64::max);
                positions.push(DVec3::new(p.x, p.y, z));
            }
        }
        let at = |i: u32, j: u32| j * (w + 1) + i;
        let mut triangles = Vec::new();
        for j in 0..h {
            for i in 0..w {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                triangles.extend([[a, b, c], [a, c, d]]);
            }
        }
        let mesh = TriMesh {
            positions,
            triangles,
        };
        (mesh, ridges)
    }

    /// Crease lines other than clean ones end at no more vertices than their
    /// share of the base: the longest are kept, the rest are dropped. A
    /// clean line stays, however short.
    #[test]
    fn crease_lines_hold_at_most_their_share_of_the_base() {
        let (mesh, ridges) = ridges();
        let target = 200;
        let base = simplify(&mesh, target);
        let kept: Vec<bool> = ridges
            .iter()
            .map(|(x, rows)| {
                let inner = *rows.start() + 1..*rows.end();
                inner
                    .filter(|&j| base.feature[(j * (RIDGES_WIDTH + 1) + x) as usize])
                    .count()
                    > 0
            })
            .collect();
        // 100 base vertices, 5% of them line ends: the clean ridge's two,
        // and the longest of the others (the ridges grow with k) as far as
        // the rest goes.
        assert!(kept[0], "{kept:?}");
        let noisy = kept[1..].iter().filter(|&&k| k).count();
        assert!((1..=2).contains(&noisy) && kept[7], "{kept:?}");
    }

    /// A vertex whose ring, flat, is a six-pointed star: no ring vertex
    /// sees the whole ring, so no half-edge collapse may remove it, but the
    /// ring retriangulated may; every point of the removed triangles lands
    /// in the new ones.
    #[test]
    fn a_ring_no_fan_fills_is_retriangulated() {
        let k = 12u32;
        let mut positions = vec![DVec3::ZERO];
        for i in 0..k {
            let r = if i % 2 == 0 { 1.0 } else { 0.3 };
            let phi = std::f64::consts::TAU * f64::from(i) / f64::from(k);
            positions.push(DVec3::new(r * phi.cos(), r * phi.sin(), 0.0));
        }
        let triangles = (0..k).map(|i| [0, 1 + i, 1 + (i + 1) % k]).collect();
        let mesh = TriMesh {
            positions,
            triangles,
        };
        let mut s = Simplifier::new(&mesh, 0.0, f64::INFINITY, false);
        let plan = s.plan(0).expect("a removal of the centre");
        let made = plan.triangles.as_ref().expect("the ring retriangulated");
        assert_eq!(made.len(), k as usize - 2);
        let ring = s.ring(0).unwrap();
        let flat = s.flatten(0, &ring, None).unwrap();
        for ui in 0..k as usize {
            let fan = Simplifier::fan(&ring, ui);
            let folds = fan
                .iter()
                .any(|&(_, [a, b, c])| (flat[b] - flat[a]).perp_dot(flat[c] - flat[a]) <= 0.0);
            assert!(folds, "the fan from {ui} fills the ring");
        }
        s.collapse(0, &plan);
        let base = s.base();
        assert_eq!(base.triangles.len(), k as usize - 2);
        assert!(matches!(base.location[0], Location::Face(..)));
        assert_mapped(&base);
    }

    #[test]
    fn a_sphere_simplifies_to_its_target_and_every_vertex_is_mapped() {
        let sphere = super::super::tests::sphere(32);
        let mesh = &crate::clean::clean(&sphere).unwrap().components[0];
        let base = simplify(mesh, 40);
        assert!(
            base.triangles.len() <= 40,
            "{} base triangles",
            base.triangles.len()
        );
        assert_eq!(euler(&base.triangles), 2, "genus kept");
        assert_mapped(&base);
    }

    /// Every vertex of `base`'s map is a base vertex or in a base triangle.
    fn assert_mapped(base: &Base) {
        for (v, l) in base.location.iter().enumerate() {
            match *l {
                Location::Vertex => {
                    assert!(base.triangles.iter().flatten().any(|&w| w == v as u32))
                }
                Location::Face(f, b) => {
                    assert!((f as usize) < base.triangles.len());
                    assert!(
                        b.iter().all(|&x| x >= 0.0) && (b.iter().sum::<f64>() - 1.0).abs() < 1e-9
                    );
                }
            }
        }
    }

    /// The bases a run passes through at its checkpoints are bases like
    /// its last: at their count or one collapse under it, genus kept,
    /// every vertex mapped. A checkpoint under where the run stops passes
    /// nothing.
    #[test]
    fn a_run_keeps_the_bases_it_passes_through() {
        let sphere = super::super::tests::sphere(32);
        let mesh = &crate::clean::clean(&sphere).unwrap().components[0];
        let simplified = simplify_part(mesh, 40, &[10, 400, 100]);
        let counts: Vec<usize> = simplified.passed.iter().map(|(c, _)| *c).collect();
        assert_eq!(counts, [400, 100]);
        for (count, base) in &simplified.passed {
            let n = base.triangles.len();
            assert!(n <= *count && n + 2 >= *count, "{n} triangles for {count}");
            assert_eq!(euler(&base.triangles), 2, "genus kept");
            assert_mapped(base);
        }
        assert!(simplified.base.triangles.len() <= 40);
    }
}
