//! Normal placement: moving the samples so that the codec's details point
//! along its frame normals.
//!
//! The codec predicts each level's odd samples from the coarser ones and
//! codes the difference in a local frame, normal first (`qm_lift::frames`).
//! A detail's tangential part mostly slides its sample along the surface: it
//! costs bits and changes the shape little. Following the normal-mesh
//! construction (Guskov, Vidimče, Sweldens and Schröder, *Normal meshes*,
//! 2000; Khodakovsky and Guskov, *Compression of normal meshes*, 2003), the
//! fitted samples are placed again, coarse to fine: for level
//! `l = 1 ..= L`, each odd sample is predicted from the already placed
//! coarser samples with the codec's own stencils ([`Lifting::predict`]), a
//! ray is cast from the prediction along plus and minus the codec's frame
//! normal ([`frames::normals`]), and the sample moves to the nearest hit of
//! the input surface whose triangle faces the normal (cosine at least
//! [`FACING`]), unless that moves it too far:
//!
//! - the sample's detail, measured from where the parameterization put it,
//!   is at most [`RESOLVED`] local spacings long (`h`, half the shortest
//!   side of the coarser quads beside it): larger details mean the coarser
//!   level has not resolved the surface there yet, and a ray from its
//!   prediction lands somewhere unrelated;
//! - the hit lies within [`REACH`] times that detail's length of the
//!   prediction (plus `h / 4`);
//! - the move, tangential by construction, is at most [`DRIFT`] `h`.
//!
//! Samples that the charts' sampling put on a feature line (a crease or a
//! border along a base edge) never move: their frame normal is one side's,
//! taken from whichever base face owns the edge, and a ray along it slides
//! them off the line (docs/decisions/007-normal-placement.md).
//!
//! A sample that does not move keeps its detail: it goes where the
//! parameterization put it relative to its prediction, which follows its
//! coarser neighbours' moves, and back onto the surface along the normal
//! there. The fit (module `resample`) holds the samples slightly off the
//! surface, straddling it; every sample keeps its signed distance to the
//! surface, a moved one measured along its ray. Last, the samples are
//! fitted again (as many rounds as the first fit), each along its ray only
//! so that the details stay normal: the fit of the parameterized samples no
//! longer applies once they have slid.
//!
//! The placement asks for the closest surface points of the samples, of
//! four quadrature nodes per sample in every round of the fit, and for a
//! ray per odd sample. Module `surface` walks to most answers over the mesh
//! from a triangle nearby (each sample's own, recorded by `resample`: a
//! neighbour's may lie on the wrong sheet of a concave junction); kept
//! samples' closest points, long rays and rays that meet no triangle
//! nearby ask parry's hierarchy (docs/decisions/007-normal-placement.md).
//!
//! The bounds matter: with every ray hit accepted, samples drift far and
//! quads fold (docs/decisions/007-normal-placement.md;
//! `docs/normal-placement.md` has the measurements behind each bound).
//!
//! The predictions use integer coordinates on a 24-bit grid (a step of
//! `2^-24` of the box, far below any remesh error) and no update step: the
//! codec's update moves the coarser samples slightly, so its details are
//! nearly, not exactly, normal. Samples are shared between faces, so seams
//! stay closed.

use qm_lift::glam::DVec3;
use qm_lift::{Coord, Layout, Lifting, MAX_BITS, Quantizer, UpdateRule, frames};
use rayon::prelude::*;

use super::resample::quadrature_axis;
use super::surface::Surface;

/// Longest detail, in local spacings, whose sample is moved onto its ray.
const RESOLVED: f64 = 0.25;

/// A hit counts within this many times the detail's length of the
/// prediction (plus a quarter spacing).
const REACH: f64 = 2.0;

/// Longest move onto the ray, in local spacings.
const DRIFT: f64 = 0.5;

/// Least cosine between the hit triangle's normal and the frame normal.
const FACING: f64 = 0.9;

/// What [`place`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct Placed {
    /// Odd samples moved onto their ray.
    pub moved: usize,
    /// Odd samples that kept their detail.
    pub kept: usize,
}

/// Places the samples of `layout` again, coarse to fine, so that each odd
/// sample lies on the ray from its prediction along the codec's frame
/// normal where that is safe, then fits them along their rays in
/// `fit_rounds` rounds (see the module docs). `positions` are the samples,
/// indexed by sample id, `sampled` the surface triangle each was
/// sampled from before the fit moved it, and `pinned` the samples on
/// feature lines, which keep their details.
pub(super) fn place(
    layout: &Layout,
    positions: &mut [DVec3],
    sampled: &[u32],
    pinned: &[bool],
    surface: &Surface,
    fit_rounds: usize,
) -> Placed {
    let mut placed = Placed::default();
    let Some(quantizer) = grid(positions) else {
        return placed;
    };
    let original = positions.to_vec();
    let lifting = Lifting::new(layout, UpdateRule::None);
    // Where the fit put each sample, relative to the surface (signed
    // distance, positive on the side the closest triangle faces), and that
    // triangle: the walks of the queries below start there. Meanwhile, each
    // sample's prediction from the fitted coarser samples, all levels in
    // one grid: finest first, as predicting a level reads only the coarser
    // samples and overwrites only its odd ones.
    let ((offsets, mut triangles), before): ((Vec<f64>, Vec<u32>), Vec<Coord>) = rayon::join(
        || {
            original
                .par_iter()
                .zip(sampled)
                .map(|(&p, &t)| {
                    let foot = surface.closest_near(p, t);
                    let offset = (p - foot.point).dot(surface.normal(foot.triangle));
                    (offset, foot.triangle)
                })
                .unzip()
        },
        || {
            let mut before = quantizer.quantize_all(&original);
            for level in (1..=layout.level()).rev() {
                lifting.predict(level, &mut before);
            }
            before
        },
    );
    // The direction each sample is fitted along: its ray; the base vertices,
    // which have no ray, along the surface normal.
    let mut directions = vec![DVec3::ZERO; positions.len()];
    for v in 0..layout.base().vertex_count() as usize {
        directions[v] = surface.normal(triangles[v]);
    }
    let mut spacing = vec![0.0; positions.len()];
    // The samples on the grid as placed so far. Predicting a level
    // overwrites its odd samples only, with values from the coarser ones;
    // once they are placed, they are put in.
    let mut now = quantizer.quantize_all(positions);
    for level in 1..=layout.level() {
        lifting.predict(level, &mut now);
        let (normals, ()) = rayon::join(
            || frames::normals(layout, level, &now, frames::PARENTS_FROM),
            || spacings(layout, level, positions, &mut spacing),
        );
        let moves: Vec<(bool, DVec3, DVec3, u32)> = normals
            .par_iter()
            .map(|&(id, normal)| {
                let id = id as usize;
                let at = |data: &[Coord]| quantizer.dequantize(data[id].map(f64::from));
                let p = at(&now);
                // The sample with its detail kept: where the parameterization
                // put it relative to its prediction, back on its offset
                // surface along the normal there.
                let r = p + (original[id] - at(&before));
                let n = DVec3::from(normal.map(|c| c as f64)).normalize_or_zero();
                let keep = || {
                    // From the hierarchy: a walk from the sample's triangle
                    // mostly agrees, but where the closest point lies on an
                    // edge it may pick the other triangle, whose normal
                    // puts the sample back on its offset elsewhere, or end
                    // on a farther sheet (docs/decisions/007-normal-placement.md).
                    let foot = surface.closest(r);
                    let face = surface.normal(foot.triangle);
                    let y = r - ((r - foot.point).dot(face) - offsets[id]) * face;
                    (
                        false,
                        y,
                        if n == DVec3::ZERO { face } else { n },
                        foot.triangle,
                    )
                };
                let h = spacing[id];
                let detail = (r - p).length();
                if n == DVec3::ZERO || detail > RESOLVED * h || pinned[id] {
                    return keep();
                }
                let reach = REACH * detail + 0.25 * h;
                let Some((t, hit)) = surface.hit_near(p, n, reach, FACING, triangles[id]) else {
                    return keep();
                };
                let face = surface.normal(hit);
                // The fit's offset, along the ray.
                let along = offsets[id] / face.dot(n);
                let y = p + (t + along) * n;
                if y.distance(r) > DRIFT * h {
                    return keep();
                }
                (true, y, n, hit)
            })
            .collect();
        for (&(id, _), (moved, y, n, t)) in normals.iter().zip(moves) {
            now[id as usize] = quantizer.quantize(y);
            positions[id as usize] = y;
            directions[id as usize] = n;
            triangles[id as usize] = t;
            if moved {
                placed.moved += 1;
            } else {
                placed.kept += 1;
            }
        }
    }
    refit(
        layout,
        positions,
        &directions,
        &triangles,
        surface,
        fit_rounds,
    );
    placed
}

/// A 24-bit quantization grid over the samples, with a margin for the
/// predictions that reach beyond them.
fn grid(positions: &[DVec3]) -> Option<Quantizer> {
    let (lo, hi) = qm_lift::bounding_box(positions);
    let margin = DVec3::splat(0.25 * (hi - lo).max_element());
    Quantizer::fit(&[lo - margin, hi + margin], MAX_BITS).ok()
}

/// The local sample spacing at each odd sample of `level`: half the
/// shortest side of the coarser quads beside it (its quad for a face point,
/// the quads on both sides of its edge for an edge point), so that a thin
/// quad's short side sets the scale.
fn spacings(layout: &Layout, level: u32, positions: &[DVec3], spacing: &mut [f64]) {
    let s = 1usize << (layout.level() - level + 1);
    let h = s / 2;
    let m = layout.n() / s;
    for f in 0..layout.face_count() {
        for b in 0..=m {
            for a in 0..=m {
                if a < m {
                    spacing[layout.sample(f, a * s + h, b * s) as usize] = f64::INFINITY;
                }
                if b < m {
                    spacing[layout.sample(f, a * s, b * s + h) as usize] = f64::INFINITY;
                }
            }
        }
    }
    for f in 0..layout.face_count() {
        let at = |a: usize, b: usize| positions[layout.sample(f, a * s, b * s) as usize];
        for b in 0..m {
            for a in 0..m {
                let shortest = [
                    at(a, b).distance(at(a + 1, b)),
                    at(a + 1, b).distance(at(a + 1, b + 1)),
                    at(a + 1, b + 1).distance(at(a, b + 1)),
                    at(a, b + 1).distance(at(a, b)),
                ]
                .into_iter()
                .fold(f64::INFINITY, f64::min);
                let (i, j) = (a * s, b * s);
                spacing[layout.sample(f, i + h, j + h) as usize] = 0.5 * shortest;
                for (i, j) in [(i + h, j), (i + h, j + s), (i, j + h), (i + s, j + h)] {
                    let e = &mut spacing[layout.sample(f, i, j) as usize];
                    *e = e.min(0.5 * shortest);
                }
            }
        }
    }
}

/// Moves each sample along its direction (a unit vector) so that the
/// bilinear quads of the finest level fit the surface in the least-squares
/// sense, as the fit of the parameterized samples does (module `resample`),
/// with the parameterization's surface points replaced by the closest
/// surface points: the residuals are measured at the corners, edge
/// midpoints and centres of the quads (each base face's `(2n + 1)^2`
/// points, its border counted half since the face beside it counts it too)
/// and `rounds` Jacobi steps with the lumped mass move the samples. The
/// closest point of each node is walked to from `triangles` (the triangle
/// each sample was placed on) of its first corner.
fn refit(
    layout: &Layout,
    positions: &mut [DVec3],
    directions: &[DVec3],
    triangles: &[u32],
    surface: &Surface,
    rounds: usize,
) {
    let n = layout.n();
    let side = n + 1;
    let axis = |f: usize| quadrature_axis(n, f);
    let mut num = vec![0.0; positions.len()];
    let mut den = vec![0.0; positions.len()];
    // Per face and node, the triangle of its closest point in the last round.
    let mut found = vec![Vec::new(); layout.face_count()];
    for _ in 0..rounds {
        // Per face, the sums of its grid points.
        let sums: Vec<Vec<(f64, f64)>> = found
            .par_iter_mut()
            .enumerate()
            .map(|(f, found): (usize, &mut Vec<u32>)| {
                let grid = layout.face_grid(f);
                let first = found.is_empty();
                let mut local = vec![(0.0, 0.0); side * side];
                let mut node = 0;
                for fj in 0..=2 * n {
                    let (ys, wy, qy) = axis(fj);
                    for fi in 0..=2 * n {
                        let (xs, wx, qx) = axis(fi);
                        let mut corners = [(0usize, 0.0f64); 4];
                        let mut point = DVec3::ZERO;
                        for (c, corner) in corners.iter_mut().enumerate() {
                            let g = ys[c / 2] * side + xs[c % 2];
                            let w = wx[c % 2] * wy[c / 2];
                            *corner = (g, w);
                            point += positions[grid[g] as usize] * w;
                        }
                        // The samples move little between rounds, so the
                        // walk from the last round's triangle stays on the
                        // right sheet. The first round walks from the first
                        // corner's triangle; where that ends on a triangle
                        // not touching every corner's (the quad spans a gap
                        // or a crease), it walks from each corner's and
                        // keeps the closest.
                        let foot = if first {
                            let start = |c: &(usize, f64)| triangles[grid[c.0] as usize];
                            let foot = surface.closest_near(point, start(&corners[0]));
                            if corners
                                .iter()
                                .filter(|c| c.1 > 0.0)
                                .all(|c| surface.touching(foot.triangle, start(c)))
                            {
                                foot
                            } else {
                                corners
                                    .iter()
                                    .filter(|c| c.1 > 0.0)
                                    .map(|c| surface.closest_near(point, start(c)))
                                    .min_by(|a, b| {
                                        a.point
                                            .distance_squared(point)
                                            .total_cmp(&b.point.distance_squared(point))
                                    })
                                    .expect("a node has a corner of positive weight")
                            }
                        } else {
                            surface.closest_near(point, found[node])
                        };
                        if first {
                            found.push(foot.triangle);
                        } else {
                            found[node] = foot.triangle;
                        }
                        node += 1;
                        let residual = foot.point - point;
                        for (g, w) in corners {
                            if w > 0.0 {
                                let d = directions[grid[g] as usize];
                                let e = &mut local[g];
                                e.0 += w * qx * qy * residual.dot(d);
                                e.1 += w * qx * qy;
                            }
                        }
                    }
                }
                local
            })
            .collect();
        num.fill(0.0);
        den.fill(0.0);
        for (f, local) in sums.iter().enumerate() {
            for (&id, &(a, b)) in layout.face_grid(f).iter().zip(local) {
                num[id as usize] += a;
                den[id as usize] += b;
            }
        }
        for ((p, d), (&a, &b)) in positions
            .iter_mut()
            .zip(directions)
            .zip(num.iter().zip(&den))
        {
            if b > 0.0 {
                *p += *d * (a / b);
            }
        }
    }
}
