//! Untangling the map one vertex at a time ([`untangle_map`]).
//!
//! A vertex with a triangle turned over in a chart moves into the *kernel*
//! of its ring there: the points on the inner side of every edge `q r` of
//! its ring, `(r - q) x (x - q) > 0`, where all its triangles turn the
//! right way. [`kernel_point`] finds one by cyclic projection onto those
//! half-planes.

use qm_lift::glam::DVec2;

use super::map::{Map, place_in};
use super::star::{Domain, Stars};
use crate::TriMesh;
use crate::remesh::simplify::{Base, Location};

/// Untangles the map of the input onto `base` where it folds: an input
/// vertex (not a base vertex, not on a feature line) with a triangle turned
/// over in the chart of its nearest base vertex moves into the kernel of
/// its ring there (cyclic projection onto its edges' half-planes, from its
/// place and else from the mean of its neighbours), when that turns fewer
/// of its triangles over. Sweeps repeat, over the vertices still folded and
/// the neighbours of those moved, up to `rounds` times.
///
/// Nothing else moves: smoothing the whole map samples worse than the map
/// the simplification leaves (docs/decisions/004-chart-map-relaxation.md).
pub(crate) fn untangle_map(mesh: &TriMesh, base: &mut Base, domain: &Domain, rounds: usize) {
    let (stars, around) = (&domain.stars, &domain.around);
    let n = mesh.positions.len();
    let mut todo: Vec<u32> = (0..n as u32).collect();
    for _ in 0..rounds {
        let mut next = Vec::new();
        for &p in &todo {
            if let Some(moved) = untangle_vertex(mesh, base, stars, around, p) {
                if moved {
                    for &t in &around[p as usize] {
                        next.extend(mesh.triangles[t as usize]);
                    }
                } else {
                    next.push(p);
                }
            }
        }
        next.sort_unstable();
        next.dedup();
        if next.is_empty() {
            break;
        }
        todo = next;
    }
}

/// One untangling step of `p`: `None` if none of its triangles is turned
/// over (or it may not move), else whether it moved.
fn untangle_vertex(
    mesh: &TriMesh,
    base: &mut Base,
    stars: &Stars,
    around: &[Vec<u32>],
    p: u32,
) -> Option<bool> {
    let Location::Face(f, b) = base.location[p as usize] else {
        return None;
    };
    if base.feature[p as usize] {
        return None;
    }
    let tri = base.triangles[f as usize];
    // The charts of its base triangle's corners, nearest first: the first
    // that holds its ring decides whether it is folded.
    let mut corners = [0usize, 1, 2];
    corners.sort_by(|&i, &j| b[j].total_cmp(&b[i]));
    let mut tried = None;
    for c in corners {
        let a = tri[c];
        let star = &stars[&a];
        let place = |w: u32| place_in(star, a, w, Map::new(base), false);
        // Turned-over triangles, and their total area turned over: a move
        // that turns none back but less area over is progress too, the way
        // a knot of several vertices comes undone over the sweeps.
        let folds = |x: DVec2| -> Option<(usize, f64)> {
            let mut count = 0;
            let mut over = 0.0;
            for &t in &around[p as usize] {
                let tri = mesh.triangles[t as usize];
                let k = tri.iter().position(|&w| w == p)?;
                let (q, r) = (place(tri[(k + 1) % 3])?, place(tri[(k + 2) % 3])?);
                let area = (q - x).perp_dot(r - x);
                if area <= 0.0 {
                    count += 1;
                    over -= area;
                }
            }
            Some((count, over))
        };
        let Some(now) = place(p) else { continue };
        let Some(before) = folds(now) else { continue };
        if before.0 == 0 {
            return tried;
        }
        tried = Some(false);
        let mut mean = DVec2::ZERO;
        let mut count = 0.0f64;
        for &t in &around[p as usize] {
            for w in mesh.triangles[t as usize] {
                if w != p
                    && let Some(x) = place(w)
                {
                    mean += x;
                    count += 1.0;
                }
            }
        }
        let starts = [now, mean / count.max(1.0)];
        // And steps up the gradient of the turned-over area.
        let mut uphill = DVec2::ZERO;
        let mut reach = 0.0f64;
        for &t in &around[p as usize] {
            let tri = mesh.triangles[t as usize];
            let k = tri.iter().position(|&w| w == p)?;
            let (Some(q), Some(r)) = (place(tri[(k + 1) % 3]), place(tri[(k + 2) % 3])) else {
                continue;
            };
            reach = reach.max((r - q).length());
            if (q - now).perp_dot(r - now) <= 0.0 {
                let e = r - q;
                uphill += DVec2::new(-e.y, e.x);
            }
        }
        let steps = (uphill.length() > 0.0).then(|| uphill.normalize() * reach);
        let best = starts
            .iter()
            .filter_map(|&x0| untangle(mesh, &around[p as usize], p, x0, place))
            .chain(
                steps
                    .into_iter()
                    .flat_map(|d| [0.02, 0.05, 0.1, 0.2, 0.4].map(|f| now + d * f)),
            )
            .filter_map(|y| folds(y).map(|k| (k, y)))
            .min_by(|a, b| a.0.0.cmp(&b.0.0).then(a.0.1.total_cmp(&b.0.1)));
        let Some((after, x)) = best else { continue };
        if after.0 > before.0 || (after.0 == before.0 && after.1 >= 0.5 * before.1) {
            continue;
        }
        if let Some(l) = star.locate(x, false) {
            base.location[p as usize] = l;
            return Some(true);
        }
    }
    tried
}

/// A place for `p` inside the kernel of its ring in a chart (every one of
/// its triangles turned the right way), from `x` by cyclic projection onto
/// the half-planes of the ring's edges; `None` if it finds none.
fn untangle(
    mesh: &TriMesh,
    around: &[u32],
    p: u32,
    x: DVec2,
    place: impl Fn(u32) -> Option<DVec2>,
) -> Option<DVec2> {
    let mut edges = Vec::with_capacity(around.len());
    for &t in around {
        let tri = mesh.triangles[t as usize];
        let k = tri.iter().position(|&w| w == p)?;
        edges.push((place(tri[(k + 1) % 3])?, place(tri[(k + 2) % 3])?));
    }
    kernel_point(&edges, x)
}

/// A point in the kernel of a ring given by its edges, from `x` by cyclic
/// projection onto the edges' half-planes; `None` if it finds none.
pub(super) fn kernel_point(edges: &[(DVec2, DVec2)], mut x: DVec2) -> Option<DVec2> {
    let scale = edges
        .iter()
        .map(|&(q, r)| (r - q).length())
        .fold(0.0f64, f64::max);
    // From a wide margin to a thin one: a ring pinched against a feature
    // line has a thin kernel.
    let start = x;
    for margin in [1e-3 * scale, 1e-5 * scale, 1e-8 * scale] {
        x = start;
        for _ in 0..64 {
            let mut inside = true;
            for &(q, r) in edges {
                let e = r - q;
                let len = e.length();
                if len <= 0.0 {
                    return None;
                }
                let normal = DVec2::new(-e.y, e.x) / len;
                let d = (x - q).dot(normal);
                if d < margin {
                    inside = false;
                    x += normal * (2.0 * margin - d);
                }
            }
            if inside {
                return Some(x);
            }
        }
    }
    None
}
