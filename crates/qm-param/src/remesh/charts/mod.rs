//! Sampling a component through its base domain (module `simplify`).
//!
//! Each base triangle becomes three quads, through its centroid and its
//! edges' midpoints; the quad at corner `A` is where `A`'s barycentric
//! coordinate is the largest. So every quad lies in the star of one base
//! vertex, and is sampled in that vertex's *chart*: its star laid flat
//! around it (edge lengths kept, angles scaled to a turn), the triangles
//! across its outer edges unfolded, each base triangle mapped linearly,
//! and every input triangle whose three vertices the map puts in the star
//! drawn there through their barycentric coordinates. A grid point of the
//! quad (its bilinear place in the base triangle) is looked up among the
//! drawn triangles and takes the surface point there. Grid points on an
//! edge or corner shared by several quads are one sample (the `Layout`'s
//! numbering), made once, so the remesh has no cracks.
//!
//! Before sampling, the map is mended where the simplification left it
//! folded or squeezed: single vertices move into the kernel of their ring
//! (`untangle_map`), knots come undone by moving their neighbourhoods down
//! a regularized conformal energy (`untangle_knots`), and then every free
//! vertex moves down the map's stretch (`relax_stretch`), never folding a
//! triangle, so that sampling density follows the surface.
//!
//! The modules, by step:
//!
//! - `quads`: the three quads of each base triangle ([`quads()`]);
//! - `star`: each base vertex's star laid flat, and the [`Domain`] of a
//!   component (every star, the input's adjacency);
//! - `map`: the map of the input onto the base domain, placed in a chart;
//! - `drawn`: triangles drawn in a chart, and the lookup of a point;
//! - `chart`: one chart for sampling, the input triangles drawn in it;
//! - `untangle`: single vertices into the kernel of their ring
//!   ([`untangle_map`]);
//! - `relax`: the energy descents, knots ([`untangle_knots`]) and stretch
//!   ([`relax_stretch`]);
//! - `sample`: the samples of every quad ([`resample`]).

mod chart;
mod drawn;
mod map;
mod quads;
mod relax;
mod sample;
mod star;
#[cfg(test)]
mod tests;
mod untangle;

pub(super) use quads::quads;
pub(super) use relax::{relax_stretch, untangle_knots};
pub(super) use sample::resample;
pub(super) use star::Domain;
pub(super) use untangle::untangle_map;
