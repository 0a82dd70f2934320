//! One base vertex's chart, for sampling: the input triangles the map puts
//! in its star, drawn there.
//!
//! Main items: [`build_chart`], which draws them, its [`Built`] (the
//! [`Chart`] and every drawn triangle's signed area, for counting folds)
//! and [`Chart::locate`], which finds the input triangle and barycentric
//! coordinates of a chart point. Each input vertex is drawn where the map
//! puts it (see module `map`), in the star's own triangles first; an input
//! triangle whose three vertices are drawn is drawn straight between them.

use std::collections::HashMap;

use qm_lift::glam::DVec2;

use super::drawn::{Drawn, barycentric, drawn_right};
use super::star::Star;
use crate::TriMesh;
use crate::remesh::simplify::{Base, Location};

/// One base vertex's chart.
pub(super) struct Chart {
    /// Per star triangle (index into the base triangles), the 2D places of
    /// its corners.
    pub(super) star: HashMap<u32, [DVec2; 3]>,
    /// The input triangles drawn in the star's own triangles.
    drawn: Drawn,
    /// Input triangles that reach into the unfolded triangles around the
    /// star, looked up in where none of the star's own holds a point.
    outer: Drawn,
}

/// Where a lookup landed: input triangle, barycentric coordinates, and
/// whether it was inside (not the nearest outside).
#[derive(Clone, Copy)]
pub(super) struct Hit {
    /// The smallest barycentric coordinate before clamping.
    pub(super) worst: f64,
    /// On one of the star's own triangles, not an outer one.
    pub(super) own: bool,
    pub(super) triangle: u32,
    pub(super) bary: [f64; 3],
    pub(super) inside: bool,
}

impl Chart {
    pub(super) fn locate(&self, x: DVec2) -> Option<Hit> {
        let mut best = self.drawn.nearest(x);
        let mut own = true;
        if best.is_none_or(|b| b.0 < -1e-9)
            && let Some(outer) = self.outer.nearest(x)
            && best.is_none_or(|b| outer.0 > b.0)
        {
            best = Some(outer);
            own = false;
        }
        if best.is_none() {
            for (t, q) in &self.drawn.triangles {
                let l = barycentric(q, x);
                let worst = l[0].min(l[1]).min(l[2]);
                if best.is_none_or(|b| worst > b.0) {
                    best = Some((worst, *t, l));
                }
            }
        }
        let (worst, triangle, mut l) = best?;
        if worst < 0.0 {
            for v in &mut l {
                *v = v.max(0.0);
            }
            let s: f64 = l.iter().sum();
            for v in &mut l {
                *v /= s;
            }
        }
        Some(Hit {
            worst,
            own,
            triangle,
            bary: l,
            inside: worst >= -1e-9,
        })
    }
}

/// Drawn input triangles of a chart: turned over, and turned the right way.
pub(super) type Orientations = (Vec<u32>, Vec<u32>);

pub(super) struct Built {
    pub(super) chart: Chart,
    /// Every drawn triangle, folded or not, and its signed area.
    all: Vec<(u32, [DVec2; 3])>,
    areas: Vec<f64>,
    /// The triangles drawn the right way partly in the unfolded ones.
    outer_right: Vec<u32>,
}

impl Built {
    /// The drawn triangles, split into those turned over in this chart and
    /// those turned the right way.
    ///
    /// A triangle whose three corners lie on feature lines, or are held
    /// between them, is neither: the map lays feature lines straight along
    /// base edges, so an ear of a ragged boundary (two boundary edges) has
    /// no area there, nor has a vertex whose neighbours all lie on one.
    pub(super) fn orientations(&self, mesh: &TriMesh, held: &[bool]) -> Orientations {
        let (mut folded, mut right) = (Vec::new(), self.outer_right.clone());
        for ((t, _), &area) in self.all.iter().zip(&self.areas) {
            let on_lines = mesh.triangles[*t as usize]
                .iter()
                .all(|&v| held[v as usize]);
            if area > 0.0 {
                right.push(*t);
            } else if !on_lines {
                folded.push(*t);
            }
        }
        (folded, right)
    }
}

pub(super) fn build_chart(
    a: u32,
    places: &Star,
    mesh: &TriMesh,
    base: &Base,
    in_face: &[Vec<u32>],
    vertex_triangles: &[Vec<u32>],
) -> Built {
    // 2D places of the input vertices: in the star's own triangles first,
    // then (where not already placed) in the unfolded ones.
    let mut coords: HashMap<u32, (DVec2, bool)> = HashMap::new();
    coords.insert(a, (DVec2::ZERO, true));
    for (k, (t, place)) in places.places.iter().enumerate() {
        let own = k < places.proper;
        for (c, &w) in base.triangles[*t as usize].iter().enumerate() {
            coords.entry(w).or_insert((place[c], own));
        }
        for &v in &in_face[*t as usize] {
            if let Location::Face(_, b) = base.location[v as usize] {
                coords.insert(
                    v,
                    (place[0] * b[0] + place[1] * b[1] + place[2] * b[2], own),
                );
            }
        }
    }
    let mut seen = std::collections::HashSet::new();
    let mut all = Vec::new();
    let mut areas = Vec::new();
    let mut own = Vec::new();
    let mut outer = Vec::new();
    let mut outer_right = Vec::new();
    let mut keys: Vec<u32> = coords.keys().copied().collect();
    keys.sort_unstable();
    for v in keys {
        for &t in &vertex_triangles[v as usize] {
            if !seen.insert(t) {
                continue;
            }
            let tri = mesh.triangles[t as usize];
            let (Some(&(p, op)), Some(&(q, oq)), Some(&(r, or))) = (
                coords.get(&tri[0]),
                coords.get(&tri[1]),
                coords.get(&tri[2]),
            ) else {
                continue;
            };
            // Nearly collinear (an ear laid along a feature line) counts as
            // no area: its barycentric coordinates would be noise.
            let area = if drawn_right(p, q, r) || (q - p).perp_dot(r - p) < 0.0 {
                (q - p).perp_dot(r - p)
            } else {
                0.0
            };
            if op && oq && or {
                areas.push(area);
                all.push((t, [p, q, r]));
                if area > 0.0 {
                    own.push((t, [p, q, r]));
                }
            } else if area > 0.0 {
                outer.push((t, [p, q, r]));
                outer_right.push(t);
            }
        }
    }
    Built {
        chart: Chart {
            star: places.places.iter().copied().collect(),
            drawn: Drawn::new(own),
            outer: Drawn::new(outer),
        },
        all,
        areas,
        outer_right,
    }
}
