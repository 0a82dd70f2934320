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
//! (Garland and Heckbert, module `quadric`), plus `AREA_WEIGHT` times the
//! area of `v`'s ring (MAPS's area term, which keeps the base triangles of
//! similar size on flat parts), divided by the worst shape of the fan's
//! triangles (module `plan`). A fan triangle below `MIN_QUALITY` is not
//! made; a simplification stuck at more than `STUCK` times its target goes
//! on with lower bounds where it has removed nothing yet (module `run`).
//!
//! The steps have modules: the simplifier's state (`simplifier`), its set-up
//! and feature lines (`creases`), a removal planned (`plan`) and made
//! (`collapse`), and the run of removals (`run`).

mod base;
mod collapse;
mod creases;
mod plan;
mod quadric;
mod queue;
mod ring;
mod run;
mod simplifier;
#[cfg(test)]
mod tests;

pub use base::{Base, Location, Simplified};
pub(super) use ring::{Ring, ring};
use run::STUCK;
use simplifier::Simplifier;

use crate::TriMesh;

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
/// their turns sharper than `NOISE_TURN_DEGREES` (module `creases`), so
/// that the short zigzag pieces are dropped. The base with fewer triangles
/// is kept.
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
