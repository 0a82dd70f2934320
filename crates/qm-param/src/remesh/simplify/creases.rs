//! A simplifier set up for a part: the quadrics of its faces, and its
//! feature lines.
//!
//! Boundaries, and edges whose dihedral angle is above [`CREASE_DEGREES`],
//! are feature lines. Crease chains (between their ends, or closed) too
//! short for the base are dropped as noise; where a part's creases are taken
//! for scanner noise, a chain also ends at its sharp turns
//! ([`NOISE_TURN_DEGREES`]); and, clean lines aside ([`CLEAN_CREASE_CV`]),
//! the chains may end at no more vertices than their share of the base
//! ([`CREASE_END_SHARE`]), longest first. Each edge of a kept line adds to
//! the quadrics of its ends those of planes through it, across each of its
//! faces, which keep the line (docs/decisions/005-noisy-creases.md).

use foldhash::fast::FixedState;
use qm_lift::glam::DVec3;

use super::base::Location;
use super::quadric::Quadric;
use super::ring::edge_key;
use super::simplifier::{HashMap, HashSet, MIN_QUALITY, Simplifier};
use crate::TriMesh;

/// Dihedral angle, in degrees, above which an edge is a crease.
const CREASE_DEGREES: f64 = 50.0;

/// Crease chains (between corners, or closed) shorter than this many edges,
/// or than [`MIN_CREASE_LENGTH`] base edges, are dropped: scanner noise or
/// details below the base's size, not features it can follow.
const MIN_CREASE_EDGES: usize = 3;

/// The shortest crease chain kept, in expected base edge lengths.
const MIN_CREASE_LENGTH: f64 = 0.5;

/// A turn of a crease line sharper than this (in degrees, 0 straight on)
/// ends it where a part's crease lines are taken for scanner noise (see
/// [`simplify_part`](super::simplify_part)). Such lines zigzag, where a
/// machined crease runs nearly straight (docs/decisions/005-noisy-creases.md).
const NOISE_TURN_DEGREES: f64 = 60.0;

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

impl<'a> Simplifier<'a> {
    /// A simplifier of `mesh` whose crease lines are pruned for a base of
    /// `target` triangles.
    pub(super) fn for_target(mesh: &'a TriMesh, target: usize, noisy_creases: bool) -> Self {
        // The edge of an equilateral base triangle of the target's mean area.
        let edge = (4.0 * mesh.area() / (3f64.sqrt() * target.max(1) as f64)).sqrt();
        let most_ends = CREASE_END_SHARE * target.max(1) as f64 / 2.0;
        Simplifier::new(mesh, MIN_CREASE_LENGTH * edge, most_ends, noisy_creases)
    }

    pub(super) fn new(
        mesh: &'a TriMesh,
        min_crease: f64,
        most_ends: f64,
        noisy_creases: bool,
    ) -> Self {
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
}
