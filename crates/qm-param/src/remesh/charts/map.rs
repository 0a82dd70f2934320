//! The map of the input onto the base domain, and its places in the
//! charts.
//!
//! Main items: [`Map`] (the simplification's locations, perhaps with one
//! vertex moved to a trial location) and [`place_in`]. An input vertex at
//! barycentric coordinates `b` in base triangle `f` lies, in a chart whose
//! star draws `f` with corners `p0, p1, p2`, at `b0 p0 + b1 p1 + b2 p2`; a
//! base vertex lies at its corner's place.

use qm_lift::glam::DVec2;

use super::star::Star;
use crate::remesh::simplify::{Base, Location};

/// The map of the input onto the base domain, perhaps with one vertex
/// moved to a trial location (a relaxation's probe), so that vertices of
/// one colour can probe their moves side by side.
#[derive(Clone, Copy)]
pub(super) struct Map<'a> {
    pub(super) base: &'a Base,
    moved: u32,
    to: Location,
}

impl<'a> Map<'a> {
    pub(super) fn new(base: &'a Base) -> Map<'a> {
        Map {
            base,
            moved: u32::MAX,
            to: Location::Vertex,
        }
    }

    /// This map with input vertex `p` at `to`.
    pub(super) fn moving(self, p: u32, to: Location) -> Map<'a> {
        Map {
            moved: p,
            to,
            ..self
        }
    }

    pub(super) fn location(&self, v: u32) -> Location {
        if v == self.moved {
            self.to
        } else {
            self.base.location[v as usize]
        }
    }
}

/// The place of input vertex `v` in the chart of `star` (centred on `a`),
/// if the map puts it in the star's own triangles (or, `wide`, in those
/// unfolded around it too).
pub(super) fn place_in(star: &Star, a: u32, v: u32, map: Map, wide: bool) -> Option<DVec2> {
    let star = star.drawn(wide);
    match map.location(v) {
        Location::Vertex => {
            if v == a {
                return Some(DVec2::ZERO);
            }
            star.iter().find_map(|(t, place)| {
                let c = map.base.triangles[*t as usize]
                    .iter()
                    .position(|&w| w == v)?;
                Some(place[c])
            })
        }
        Location::Face(f, b) => {
            let (_, place) = star.iter().find(|(t, _)| *t == f)?;
            Some(place[0] * b[0] + place[1] * b[1] + place[2] * b[2])
        }
    }
}
