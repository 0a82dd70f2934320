//! Moving the map down an energy, vertex by vertex: untangling knots
//! ([`untangle_knots`]) and relaxing the stretch ([`relax_stretch`]).
//!
//! Main item: [`Knots`], Gauss-Seidel sweeps in which each free vertex
//! takes a few line-searched steps down the energy of its ring, the
//! vertices of one colour ([`colours`]) side by side. With `J` the map
//! from an input triangle (in its own 2D shape) to its drawing in a chart:
//!
//! - untangling: the conformal distortion `|J|^2 / h(det J)` with the
//!   regularized determinant `h(d) = (d + sqrt(d^2 + 4 delta^2)) / 2`, in
//!   the chart that draws the triangle best, plus a penalty for a fold;
//! - relaxing: the symmetric Dirichlet energy `A (|J|^2 + |J^-1|^2)`
//!   (`A` the input triangle's area, `J` against the part's median ratio of
//!   drawn to input area), in the chart that draws it worst, plus a
//!   penalty for a pleat, infinite for a fold.

use std::sync::atomic::{AtomicU64, Ordering};

use qm_lift::glam::{DMat2, DVec2};
use rayon::prelude::*;

use super::drawn::drawn_right;
use super::map::{Map, place_in};
use super::star::{Domain, Stars};
use super::untangle::kernel_point;
use crate::remesh::simplify::{Base, Location};
use crate::{TriMesh, triangle_area};

/// The knots single moves leave (rings whose kernel is empty in every
/// chart) come undone by moving their neighbourhoods together: Gauss-Seidel
/// sweeps over the free vertices within some rings of a folded one, each
/// moved down the energy of its triangles. A triangle's energy is its
/// conformal distortion (MIPS, `|J|^2 / det J`, J the map from the input
/// triangle to its drawing) with Escobar et al.'s regularized determinant
/// `(det + sqrt(det^2 + 4 delta^2)) / 2`, so that a turned-over triangle
/// has a finite energy that falls towards unfolding, taken in the chart
/// that draws it best, plus a large penalty where every chart draws it
/// turned over (a fold, as sampling counts it). Every triangle is thus
/// judged the same way whichever of its corners moves. The neighbourhood
/// widens while folds remain.
///
/// Returns the triangles still folded, early (after a sweep with the fold
/// penalty) where `hopeless` says of them that they are too many to be
/// worth going on for.
pub(crate) fn untangle_knots(
    mesh: &TriMesh,
    base: &mut Base,
    domain: &Domain,
    sweeps: usize,
    hopeless: &dyn Fn(&Base, &[u32]) -> bool,
) -> Vec<u32> {
    let mut knots = Knots::new(mesh, domain);
    let n = mesh.positions.len();
    let folded_now = |knots: &Knots, base: &Base| -> Vec<u32> {
        (0..mesh.triangles.len() as u32)
            .filter(|&t| knots.folded(Map::new(base), t))
            .collect()
    };
    let mut folded = folded_now(&knots, base);
    for reach in [2usize, 4, 8, 16] {
        if folded.is_empty() {
            break;
        }
        // The neighbourhood: `reach` rings around the folded triangles.
        let mut inside = vec![false; n];
        let mut front: Vec<u32> = folded
            .iter()
            .flat_map(|&t| mesh.triangles[t as usize])
            .collect();
        for &p in &front {
            inside[p as usize] = true;
        }
        for _ in 0..reach {
            let mut next = Vec::new();
            for &p in &front {
                for &t in &domain.around[p as usize] {
                    for w in mesh.triangles[t as usize] {
                        if !inside[w as usize] {
                            inside[w as usize] = true;
                            next.push(w);
                        }
                    }
                }
            }
            front = next;
        }
        let region: Vec<u32> = (0..n as u32)
            .filter(|&p| inside[p as usize] && knots.movable(base, p))
            .collect();
        // With the fold penalty first; where folds remain, the smooth
        // energy alone and then the penalty again, kept if it leaves fewer.
        knots.penalty = FOLD_PENALTY;
        knots.sweep(base, &region, &inside, sweeps);
        folded = folded_now(&knots, base);
        if hopeless(base, &folded) {
            break;
        }
        if !folded.is_empty() {
            let kept = base.location.clone();
            knots.penalty = 0.0;
            knots.sweep(base, &region, &inside, sweeps);
            knots.penalty = FOLD_PENALTY;
            knots.sweep(base, &region, &inside, sweeps);
            let after = folded_now(&knots, base);
            if after.len() < folded.len() {
                folded = after;
            } else {
                base.location = kept;
            }
        }
    }
    folded
}

/// Evens out the map's stretch, so that sampling density follows the
/// surface (PGC smooths its MAPS map for the same reason): Gauss-Seidel
/// sweeps over every free vertex, each moved down the symmetric Dirichlet
/// energy (`|J|^2 + |J^-1|^2`, times the input triangle's area) of its
/// triangles, J against the part's median ratio of drawn to input area, in
/// the chart that draws each worst. The energy is infinite for a triangle
/// turned over in every chart, so no move folds one, and a triangle turned
/// over in some charts but not all pays [`PLEAT_PENALTY`].
///
/// Any chart that draws a triangle may sample it, so each must draw it
/// well: with the best chart's energy alone the relaxation turned triangles
/// over in the charts that did not count. Unlike harmonic or mean-value
/// smoothing, this weighs compression and expansion alike: a protrusion the
/// simplification squeezed into a sliver of a base triangle, which sampling
/// all but skipped, opens up (docs/decisions/004-chart-map-relaxation.md).
pub(crate) fn relax_stretch(mesh: &TriMesh, base: &mut Base, domain: &Domain, sweeps: usize) {
    let mut knots = Knots::new(mesh, domain);
    let mut ratios: Vec<f64> = (0..mesh.triangles.len() as u32)
        .map(|t| knots.area_ratio(Map::new(base), t))
        .filter(|r| *r > 0.0)
        .collect();
    if ratios.is_empty() {
        return;
    }
    let middle = ratios.len() / 2;
    let median = *ratios.select_nth_unstable_by(middle, f64::total_cmp).1;
    let n = mesh.positions.len();
    let inside = vec![true; n];
    let region: Vec<u32> = (0..n as u32).filter(|&p| knots.movable(base, p)).collect();
    let area = mesh
        .triangles
        .iter()
        .map(|t| triangle_area(mesh.corners(t)))
        .collect();
    knots.stretch = Some((median, area));
    knots.sweep(base, &region, &inside, sweeps);
}

/// The penalty of a fold in [`untangle_knots`]' energy, against a
/// distortion of at least 2 per triangle.
const FOLD_PENALTY: f64 = 1e4;

/// The penalty, per unit of input area, of a triangle turned over in some
/// of the charts that draw it (a pleat) in [`relax_stretch`]' energy,
/// against at least 4 for an undistorted one. A finite penalty lets the
/// vertices around a pleat move to undo it; an infinite one froze them
/// (docs/decisions/004-chart-map-relaxation.md).
const PLEAT_PENALTY: f64 = 1000.0;

/// How many times its last step a vertex's line search starts from when
/// relaxing the stretch ([`Knots::relax`]): about half the ring energies
/// of starting from half the ring's size, at the same PSNR; a step that can
/// only shrink samples worse (docs/decisions/004-chart-map-relaxation.md).
const STEP_GROWTH: f64 = 2.0;

/// The regularization of the determinant in [`untangle_knots`]' energy,
/// relative to the input triangle's own area.
const UNTANGLE_DELTA: f64 = 1e-2;

/// What [`untangle_knots`] reads: the stars, the input's adjacency, and
/// each input triangle's own 2D shape (inverted).
pub(super) struct Knots<'a> {
    mesh: &'a TriMesh,
    domain: &'a Domain,
    shapes: Vec<DMat2>,
    /// The penalty of a fold now: none while the smooth energy alone
    /// untangles, [`FOLD_PENALTY`] after.
    penalty: f64,
    /// Where set, the energy is the stretch (symmetric Dirichlet, times
    /// the triangle's area) against this scale of the map's determinant,
    /// not the conformal distortion.
    stretch: Option<(f64, Vec<f64>)>,
    /// Per input vertex: the step its last move took (an `f64`'s bits), 0
    /// before any.
    steps: Vec<AtomicU64>,
    /// Per input vertex: a colour no neighbour has, so that the vertices of
    /// one colour move side by side.
    colours: Vec<u32>,
}

impl<'a> Knots<'a> {
    pub(super) fn new(mesh: &'a TriMesh, domain: &'a Domain) -> Knots<'a> {
        let shapes = mesh
            .triangles
            .iter()
            .map(|tri| {
                let [o, a, b] = mesh.corners(tri);
                let (u, v) = (a - o, b - o);
                let len = u.length();
                let cross = u.cross(v).length();
                // A degenerate input triangle takes the equilateral shape.
                let shape = if len > 0.0 && cross > 1e-12 * len * len.max(v.length()) {
                    DMat2::from_cols(
                        DVec2::new(len, 0.0),
                        DVec2::new(u.dot(v) / len, cross / len),
                    )
                } else {
                    DMat2::from_cols(DVec2::new(1.0, 0.0), DVec2::new(0.5, 0.75f64.sqrt()))
                };
                shape.inverse()
            })
            .collect();
        Knots {
            mesh,
            domain,
            shapes,
            penalty: FOLD_PENALTY,
            stretch: None,
            steps: (0..mesh.positions.len())
                .map(|_| AtomicU64::new(0))
                .collect(),
            colours: colours(mesh, &domain.around),
        }
    }

    /// Gauss-Seidel sweeps over `region` (the vertices marked `inside`),
    /// each after the first over the neighbours of those that moved. The
    /// vertices of one colour move in parallel (none is another's
    /// neighbour, so none reads what another writes), the colours in turn:
    /// the result does not depend on the threads.
    fn sweep(&self, base: &mut Base, region: &[u32], inside: &[bool], sweeps: usize) {
        let mut active = region.to_vec();
        let mut classes: Vec<Vec<u32>> = Vec::new();
        for _ in 0..sweeps {
            for class in &mut classes {
                class.clear();
            }
            for &p in &active {
                let c = self.colours[p as usize] as usize;
                if classes.len() <= c {
                    classes.resize_with(c + 1, Vec::new);
                }
                classes[c].push(p);
            }
            let mut next = Vec::new();
            for class in &classes {
                let moves: Vec<(u32, Location, bool)> = class
                    .par_iter()
                    .with_min_len(64)
                    .filter_map(|&p| self.relax(base, p).map(|(l, wake)| (p, l, wake)))
                    .collect();
                for (p, l, wake) in moves {
                    base.location[p as usize] = l;
                    if wake {
                        for &t in &self.domain.around[p as usize] {
                            next.extend(
                                self.mesh.triangles[t as usize]
                                    .into_iter()
                                    .filter(|&w| inside[w as usize] && self.movable(base, w)),
                            );
                        }
                    }
                }
            }
            next.sort_unstable();
            next.dedup();
            if next.is_empty() {
                break;
            }
            active = next;
        }
    }

    fn movable(&self, base: &Base, p: u32) -> bool {
        matches!(base.location[p as usize], Location::Face(..)) && !self.domain.held[p as usize]
    }

    /// The base vertices whose charts may draw triangle `t`: the corners
    /// of its corners' base triangles.
    fn charts(&self, map: Map, t: u32) -> impl Iterator<Item = u32> + use<> {
        let mut out = [u32::MAX; 9];
        let mut len = 0;
        for v in self.mesh.triangles[t as usize] {
            let corners = match map.location(v) {
                Location::Vertex => [v, v, v],
                Location::Face(f, _) => map.base.triangles[f as usize],
            };
            for a in corners {
                if !out[..len].contains(&a) {
                    out[len] = a;
                    len += 1;
                }
            }
        }
        out.into_iter().take(len)
    }

    /// Triangle `t`'s drawings, in every chart that draws it whole.
    pub(super) fn drawings(&self, map: Map, t: u32) -> impl Iterator<Item = [DVec2; 3]> {
        let tri = self.mesh.triangles[t as usize];
        self.charts(map, t).filter_map(move |a| {
            let star = &self.domain.stars[&a];
            Some([
                place_in(star, a, tri[0], map, true)?,
                place_in(star, a, tri[1], map, true)?,
                place_in(star, a, tri[2], map, true)?,
            ])
        })
    }

    /// Triangle `t`'s drawn area over its input area, in the chart that
    /// draws it largest (negative if every chart draws it turned over).
    pub(super) fn area_ratio(&self, map: Map, t: u32) -> f64 {
        self.drawings(map, t)
            .map(|[p, q, r]| {
                (DMat2::from_cols(q - p, r - p) * self.shapes[t as usize]).determinant()
            })
            .fold(f64::NEG_INFINITY, f64::max)
    }

    /// Whether every chart that draws `t` draws it turned over, as sampling
    /// counts a fold (triangles held between feature lines aside).
    pub(super) fn folded(&self, map: Map, t: u32) -> bool {
        if self.held(t) {
            return false;
        }
        let mut drawn = false;
        for [p, q, r] in self.drawings(map, t) {
            if drawn_right(p, q, r) {
                return false;
            }
            drawn = true;
        }
        drawn
    }

    /// Triangle `t`'s energy from its `drawings` (every chart's that
    /// draws it whole, in the order of [`Self::drawings`]):
    /// [`Self::stretch_energy`] when relaxing the stretch, else
    /// [`Self::untangle_energy`].
    fn energy(&self, t: u32, drawings: impl Iterator<Item = [DVec2; 3]>) -> f64 {
        match &self.stretch {
            Some((scale, area)) => self.stretch_energy(t, drawings, *scale, area[t as usize]),
            None => self.untangle_energy(t, drawings),
        }
    }

    /// Whether all of triangle `t`'s corners lie on feature lines, where
    /// its orientation does not count.
    fn held(&self, t: u32) -> bool {
        let tri = self.mesh.triangles[t as usize];
        tri.iter().all(|&v| self.domain.held[v as usize])
    }

    /// Triangle `t`'s least distortion over the charts that draw it, plus
    /// the penalty if it is folded (or drawn in none).
    fn untangle_energy(&self, t: u32, drawings: impl Iterator<Item = [DVec2; 3]>) -> f64 {
        let mut best = f64::INFINITY;
        let mut right = self.held(t);
        for [p, q, r] in drawings {
            right |= drawn_right(p, q, r);
            let j = DMat2::from_cols(q - p, r - p) * self.shapes[t as usize];
            let det = j.determinant();
            let norm = j.x_axis.length_squared() + j.y_axis.length_squared();
            let h = 0.5 * (det + (det * det + 4.0 * UNTANGLE_DELTA * UNTANGLE_DELTA).sqrt());
            if h > 0.0 {
                best = best.min(norm / h);
            }
        }
        if !best.is_finite() {
            return 2.0 * FOLD_PENALTY;
        }
        best + if right { 0.0 } else { self.penalty }
    }

    /// Triangle `t`'s symmetric Dirichlet energy (input area `area`,
    /// against the part's typical `scale`) in the chart that draws it
    /// worst, plus [`PLEAT_PENALTY`] if a chart draws it turned over.
    /// Infinite if every chart does, so relaxing never folds a triangle (nor
    /// lays one flat in every chart).
    fn stretch_energy(
        &self,
        t: u32,
        drawings: impl Iterator<Item = [DVec2; 3]>,
        scale: f64,
        area: f64,
    ) -> f64 {
        let held = self.held(t);
        let (mut right, mut pleat) = (held, false);
        let mut worst: Option<f64> = None;
        for [p, q, r] in drawings {
            let this_right = drawn_right(p, q, r);
            right |= this_right;
            pleat |= !this_right;
            let j = DMat2::from_cols(q - p, r - p) * self.shapes[t as usize];
            let det = j.determinant() / scale;
            let norm = (j.x_axis.length_squared() + j.y_axis.length_squared()) / scale;
            if det > 0.0 {
                let e = area * norm * (1.0 + 1.0 / (det * det));
                worst = Some(worst.map_or(e, |w| w.max(e)));
            }
        }
        match worst {
            Some(w) if right => {
                w + if pleat && !held {
                    PLEAT_PENALTY * area
                } else {
                    0.0
                }
            }
            _ => f64::INFINITY,
        }
    }

    /// One Gauss-Seidel step at `p`: a few line-searched steps down its
    /// triangles' energy, proposed in the chart of the nearest corner of
    /// its base triangle (with the triangles unfolded around it), and, where
    /// one of its triangles is folded, the kernel of its ring there. Returns
    /// its new location and whether the move is worth waking its
    /// neighbours for; reads the map and writes nothing but its step.
    fn relax(&self, base: &Base, p: u32) -> Option<(Location, bool)> {
        let Location::Face(f, b) = base.location[p as usize] else {
            return None;
        };
        let map = Map::new(base);
        let tri = base.triangles[f as usize];
        let c = (0..3).max_by(|&i, &j| b[i].total_cmp(&b[j])).unwrap_or(0);
        let a = tri[c];
        let star = &self.domain.stars[&a];
        let start = place_in(star, a, p, map, true)?;
        // The ring's size, for steps.
        let mut size = 0.0f64;
        for &t in &self.domain.around[p as usize] {
            for w in self.mesh.triangles[t as usize] {
                if let Some(x) = place_in(star, a, w, map, true) {
                    size = size.max((x - start).length());
                }
            }
        }
        if size <= 0.0 {
            return None;
        }
        let mut places = RingPlaces::new(self, p);
        let first = places.energy(self, map);
        let mut best = (start, first, base.location[p as usize]);
        // Relaxing the stretch starts from an unfolded map and keeps it so.
        let folded = self.stretch.is_none()
            && self.domain.around[p as usize]
                .iter()
                .any(|&t| self.folded(map, t));
        if folded
            && let Some(ring) =
                ring_chart(self.mesh, map, &self.domain.stars, &self.domain.around, p)
        {
            let edges = &ring.edges;
            let mean = edges.iter().map(|&(q, _)| q).sum::<DVec2>() / edges.len().max(1) as f64;
            let chart = &self.domain.stars[&ring.corner];
            for from in [ring.at, mean] {
                let Some(y) = kernel_point(edges, from) else {
                    continue;
                };
                let Some(l) = chart.locate(y, true) else {
                    continue;
                };
                let moved = map.moving(p, l);
                let e = places.energy(self, moved);
                if e < best.1 {
                    // Back in the proposing chart, where the steps go on.
                    if let Some(x) = place_in(star, a, p, moved, true) {
                        best = (x, e, l);
                    }
                }
            }
        }
        let mut at = |x: DVec2| -> Option<(f64, Location)> {
            let l = star.locate(x, true)?;
            Some((places.energy(self, map.moving(p, l)), l))
        };
        for _ in 0..3 {
            let (x, e) = (best.0, best.1);
            let h = 1e-5 * size;
            let mut g = DVec2::ZERO;
            for (k, d) in [DVec2::X, DVec2::Y].into_iter().enumerate() {
                let Some((plus, _)) = at(x + d * h) else {
                    g = DVec2::ZERO;
                    break;
                };
                g[k] = plus - e;
            }
            if !g.is_finite() || g.length() <= 0.0 {
                break;
            }
            let d = -g.normalize();
            // Relaxing the stretch starts from twice the vertex's last
            // step: the map moves little from sweep to sweep.
            let remembered = f64::from_bits(self.steps[p as usize].load(Ordering::Relaxed));
            let mut step = if self.stretch.is_some() && remembered > 0.0 {
                (STEP_GROWTH * remembered).min(0.5 * size)
            } else {
                0.5 * size
            };
            let mut found = None;
            while step > 1e-4 * size {
                let y = x + d * step;
                if let Some((ey, l)) = at(y)
                    && ey < e
                {
                    found = Some((y, ey, l));
                    self.steps[p as usize].store(step.to_bits(), Ordering::Relaxed);
                    break;
                }
                step *= 0.5;
            }
            let Some(next) = found else { break };
            best = next;
        }
        // Only a move that lowers the energy by a share worth sweeping for
        // wakes the neighbours.
        Some((best.2, best.1 < (1.0 - 1e-3) * first))
    }
}

/// Vertex `p`'s ring as its line search in [`Knots::relax`] reads it: per
/// triangle around `p`, the places of its other corners in each chart
/// asked for so far, which stay where they are while `p` alone moves, and
/// `p`'s places in the charts of the trial being measured. So a trial
/// places `p` once per chart and nothing else, and its energy is the one of
/// the triangles drawn afresh, bit for bit: the same places, summed in the
/// same order.
struct RingPlaces {
    p: u32,
    /// Per triangle around `p`, in order: per chart asked for, the places
    /// of its corners (`p`'s own slot unused).
    fixed: Vec<Vec<(u32, [Option<DVec2>; 3])>>,
    /// Per chart asked for in this trial: `p`'s place there.
    moving: Vec<(u32, Option<DVec2>)>,
}

impl RingPlaces {
    fn new(knots: &Knots, p: u32) -> RingPlaces {
        RingPlaces {
            p,
            fixed: vec![Vec::new(); knots.domain.around[p as usize].len()],
            moving: Vec::new(),
        }
    }

    /// The energy of `p`'s triangles under `map`, which may move `p` but
    /// no other vertex.
    fn energy(&mut self, knots: &Knots, map: Map) -> f64 {
        let p = self.p;
        self.moving.clear();
        let moving = &mut self.moving;
        knots.domain.around[p as usize]
            .iter()
            .zip(&mut self.fixed)
            .map(|(&t, fixed)| {
                let tri = knots.mesh.triangles[t as usize];
                // At most one drawing per chart, and at most nine charts.
                let mut drawn = [[DVec2::ZERO; 3]; 9];
                let mut len = 0;
                for a in knots.charts(map, t) {
                    let star = &knots.domain.stars[&a];
                    let places = match fixed.iter().find(|(b, _)| *b == a) {
                        Some(&(_, places)) => places,
                        None => {
                            let places =
                                tri.map(|w| (w != p).then(|| place_in(star, a, w, map, true))?);
                            fixed.push((a, places));
                            places
                        }
                    };
                    let here = match moving.iter().find(|(b, _)| *b == a) {
                        Some(&(_, x)) => x,
                        None => {
                            let x = place_in(star, a, p, map, true);
                            moving.push((a, x));
                            x
                        }
                    };
                    let corner = |c: usize| if tri[c] == p { here } else { places[c] };
                    if let (Some(x), Some(y), Some(z)) = (corner(0), corner(1), corner(2)) {
                        drawn[len] = [x, y, z];
                        len += 1;
                    }
                }
                knots.energy(t, drawn[..len].iter().copied())
            })
            .sum()
    }
}

/// A greedy colouring of the input's vertices (each the least colour none
/// of its neighbours before it has), from the triangles `around` each.
pub(super) fn colours(mesh: &TriMesh, around: &[Vec<u32>]) -> Vec<u32> {
    let mut colours = vec![u32::MAX; around.len()];
    let mut taken: Vec<bool> = Vec::new();
    for v in 0..around.len() {
        taken.clear();
        for &t in &around[v] {
            for w in mesh.triangles[t as usize] {
                let c = colours[w as usize];
                if c != u32::MAX {
                    if taken.len() <= c as usize {
                        taken.resize(c as usize + 1, false);
                    }
                    taken[c as usize] = true;
                }
            }
        }
        colours[v] = taken.iter().position(|&t| !t).unwrap_or(taken.len()) as u32;
    }
    colours
}

/// Vertex `p`'s ring drawn in the chart of the nearest corner of its base
/// triangle that holds it whole.
struct RingChart {
    corner: u32,
    at: DVec2,
    /// Per triangle: its other two corners' places, counter-clockwise.
    edges: Vec<(DVec2, DVec2)>,
}

fn ring_chart(
    mesh: &TriMesh,
    map: Map,
    stars: &Stars,
    around: &[Vec<u32>],
    p: u32,
) -> Option<RingChart> {
    let Location::Face(f, b) = map.location(p) else {
        return None;
    };
    let tri = map.base.triangles[f as usize];
    let mut corners = [0usize, 1, 2];
    corners.sort_by(|&i, &j| b[j].total_cmp(&b[i]));
    'corner: for (c, wide) in corners
        .iter()
        .map(|&c| (c, false))
        .chain(corners.iter().map(|&c| (c, true)))
    {
        let a = tri[c];
        let star = &stars[&a];
        let Some(at) = place_in(star, a, p, map, wide) else {
            continue;
        };
        let mut edges = Vec::with_capacity(around[p as usize].len());
        for &t in &around[p as usize] {
            let tri = mesh.triangles[t as usize];
            let Some(k) = tri.iter().position(|&w| w == p) else {
                continue 'corner;
            };
            let (Some(q), Some(r)) = (
                place_in(star, a, tri[(k + 1) % 3], map, wide),
                place_in(star, a, tri[(k + 2) % 3], map, wide),
            ) else {
                continue 'corner;
            };
            edges.push((q, r));
        }
        return Some(RingChart {
            corner: a,
            at,
            edges,
        });
    }
    None
}
