//! The simplifier's state: a part's mesh as vertices are removed from it,
//! with every input vertex located in a live face, and the questions asked
//! of it (rings, neighbours, normals and shapes of triangles).
//!
//! It is built and its feature lines found in module `creases`; removals are
//! planned in module `plan`, made in module `collapse`, and run cheapest
//! first in module `run`.

use foldhash::fast::FixedState;
use qm_lift::glam::DVec3;

use super::base::{Base, Location};
use super::quadric::Quadric;
use super::ring::{Ring, ring};

/// Hash maps and sets of vertex and edge ids, with a fast fixed hasher
/// (docs/decisions/014-simplifier-runs.md).
pub(super) type HashMap<K, V> = std::collections::HashMap<K, V, FixedState>;
pub(super) type HashSet<K> = std::collections::HashSet<K, FixedState>;

/// Fan triangles thinner than this (twice the area over the sum of squared
/// edges, 1 for the equilateral, scaled by `2 / sqrt(3)`) are not made.
pub(super) const MIN_QUALITY: f64 = 0.02;

/// A part as it is simplified: its live faces, the points located in
/// each, the quadrics and feature lines of its vertices, and the run's
/// bounds and checkpoints.
pub(super) struct Simplifier<'a> {
    pub(super) positions: &'a [DVec3],
    pub(super) faces: Vec<[u32; 3]>,
    pub(super) alive: Vec<bool>,
    pub(super) points: Vec<Vec<u32>>,
    pub(super) vfaces: Vec<Vec<u32>>,
    pub(super) removed: Vec<bool>,
    pub(super) creases: HashSet<u64>,
    pub(super) crease_degree: Vec<u8>,
    pub(super) quadric: Vec<Quadric>,
    pub(super) location: Vec<Location>,
    /// Per vertex: whether a run has planned it again since the first
    /// plans (its ring changed, or its plan was out of date).
    pub(super) touched: Vec<bool>,
    pub(super) alive_faces: usize,
    pub(super) alive_vertices: usize,
    pub(super) closed: bool,
    pub(super) feature: Vec<bool>,
    /// Vertices never removed (empty: none).
    pub(super) keep: &'a [bool],
    /// The least shape (1 equilateral) of a triangle a removal may make.
    pub(super) min_quality: f64,
    /// Whether crease lines end at sharp turns.
    pub(super) noisy_creases: bool,
    /// Triangle counts at which to keep the base passed through, largest
    /// first, those passed removed.
    pub(super) checkpoints: Vec<usize>,
    /// The bases kept at checkpoints.
    pub(super) passed: Vec<(usize, Base)>,
}

impl Simplifier<'_> {
    /// Face `f`'s normal, as long as twice its area.
    pub(super) fn normal(&self, f: u32) -> DVec3 {
        let [x, y, z] = self.faces[f as usize].map(|v| self.positions[v as usize]);
        (y - x).cross(z - x)
    }

    pub(super) fn ring(&self, v: u32) -> Option<Ring> {
        ring(v, &self.vfaces[v as usize], &self.faces)
    }

    /// Whether `u` and `w` share a live triangle (an edge).
    pub(super) fn adjacent(&self, u: u32, w: u32) -> bool {
        self.vfaces[u as usize]
            .iter()
            .any(|&f| self.faces[f as usize].contains(&w))
    }

    pub(super) fn area3(&self, t: [u32; 3]) -> f64 {
        0.5 * self.normal3_raw(t).length()
    }

    fn normal3_raw(&self, t: [u32; 3]) -> DVec3 {
        let [a, b, c] = t.map(|v| self.positions[v as usize]);
        (b - a).cross(c - a)
    }

    pub(super) fn normal3(&self, t: [u32; 3]) -> DVec3 {
        self.normal3_raw(t).normalize_or_zero()
    }

    /// `4 sqrt(3) area / (sum of squared edges)`: 1 for the equilateral.
    pub(super) fn quality3(&self, t: [u32; 3]) -> f64 {
        let [a, b, c] = t.map(|v| self.positions[v as usize]);
        let sum = (b - a).length_squared() + (c - b).length_squared() + (a - c).length_squared();
        if sum <= 0.0 {
            return 0.0;
        }
        2.0 * 3f64.sqrt() * (b - a).cross(c - a).length() / sum
    }

    /// The base now: the live faces, renumbered, and every vertex's
    /// location on them.
    pub(super) fn base(&self) -> Base {
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
