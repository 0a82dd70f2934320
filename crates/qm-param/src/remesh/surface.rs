//! The input surface for normal placement: closest points and ray hits,
//! found by walking the mesh from a nearby triangle, and from parry's
//! bounding volume hierarchy where a walk cannot settle them.
//!
//! Normal placement asks a few million questions about points near the
//! surface whose triangle is nearly known: the closest points of the
//! samples (from the triangle each was sampled on, before the fit moved it
//! a fraction of a sample spacing), of about four quadrature nodes per
//! sample in each of the second fit's three rounds (from a corner sample's
//! triangle, then from the node's own of the last round), and a ray from
//! each odd sample's prediction. The hierarchy answers each from its root;
//! a walk answers most at once.
//!
//! - **Closest points** ([`Surface::closest_near`]): a descent of the
//!   distance. From the foot of the point on the current triangle it tries,
//!   when the foot lies on an edge, the triangles around both ends of that
//!   edge (the one across first); on a corner, the triangles around it;
//!   inside, the three triangles beside it, but only those across an edge
//!   the point lies beyond as seen in their own plane (elsewhere their
//!   closest point is on the shared edge, no nearer); and it moves while
//!   that comes closer, at most [`WALK`] steps. Most walks end where they
//!   start, which costs a projection (barycentric coordinates from each
//!   triangle's inverse Gram matrix) and three dot products. A walk ends at
//!   a local minimum, which is the closest point for points nearer the
//!   surface than its triangles are wide, unless another sheet of the
//!   surface comes as near (a narrow gap, a concave crease): callers start
//!   from the right sheet, or from several triangles.
//! - **Rays** ([`Surface::hit_near`]): the triangles joined to the closest
//!   point of the ray's origin within the ray's reach, tested as the
//!   hierarchy tests them; the hierarchy answers long rays and rays that
//!   meet none of those. On the six development models every ray, checked
//!   one by one, had the hierarchy's answer.
//!
//! A walk answers a sample's own closest point several times faster than
//! the hierarchy, at the same remesh PSNR
//! (docs/decisions/007-normal-placement.md).
//!
//! Elsewhere the crate asks module `closest` (the distance, the remesher's
//! measure, the holds' feet). This surface keeps parry's hierarchy: its
//! answers, the foot's triangle included, set the samples, and that search
//! computes the feet with other arithmetic and may pick another of several
//! equidistant triangles (docs/decisions/030-point-queries.md).

use parry3d_f64::math::Vector;
use parry3d_f64::query::{PointQueryWithLocation, Ray, RayCast};
use parry3d_f64::shape::TriMesh as ParryMesh;
use qm_lift::glam::DVec3;

use crate::closest::to_parry;
use crate::trimesh::{Feature, closest_on_triangle};
use crate::{Error, RemeshFailure, Result, TriMesh};

/// Longest walk (a walk that long ends where it is).
const WALK: usize = 32;

/// Most triangles a step of a walk tries (around a corner, or the two ends
/// of an edge); beyond, the closest point comes from the hierarchy
/// (docs/decisions/006-high-valence-bounds.md).
const MAX_FAN: usize = 64;

/// Longest reach, in longest sides of the triangle nearest the origin, of
/// the rays that [`Surface::hit_near`] answers from the triangles around
/// their origin (longer ones ask the hierarchy).
const LOCAL_REACH: f64 = 0.25;

/// Most triangles [`Surface::hit_near`] tests before it asks the hierarchy.
const LOCAL: usize = 48;

/// No triangle (across a border edge).
const NONE: u32 = u32::MAX;

/// A point of the surface and the triangle it lies on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Foot {
    pub point: DVec3,
    pub triangle: u32,
}

/// A triangle's first corner, its unit normal (zero if degenerate), its two
/// sides from that corner, the inverse of their Gram matrix
/// (`[g11, -g01, g00] / det`, zero if degenerate) and its longest side.
/// Two cache lines, the plane in the first.
#[repr(C, align(64))]
struct Plane {
    a: DVec3,
    normal: DVec3,
    ab: DVec3,
    ac: DVec3,
    inverse: [f64; 3],
    /// The length of the longest side.
    longest: f64,
}

impl Plane {
    /// The projection of `a + ap` onto the plane where it lies inside the
    /// triangle (not on its border).
    #[inline]
    fn inner(&self, ap: DVec3) -> Option<DVec3> {
        let (d1, d2) = (self.ab.dot(ap), self.ac.dot(ap));
        let [i00, i01, i11] = self.inverse;
        let (s, u) = (i00 * d1 + i01 * d2, i01 * d1 + i11 * d2);
        (s > 0.0 && u > 0.0 && s + u < 1.0).then(|| self.a + self.ab * s + self.ac * u)
    }
}

/// The input surface, ready for rays and closest points.
pub(super) struct Surface {
    mesh: ParryMesh,
    /// Subtracted from every position in `mesh` (parry works near the
    /// origin).
    origin: DVec3,
    points: Vec<DVec3>,
    /// `points` less `origin`, as `mesh` holds them.
    shifted: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    /// Per triangle, what finds an inner closest point at once.
    planes: Vec<Plane>,
    /// The triangle across the edge opposite each corner, or [`NONE`].
    across: Vec<[u32; 3]>,
    /// Per triangle and edge (opposite each corner), `(w, c)` such that a
    /// point `p` lies beyond the edge as seen in the plane of the triangle
    /// across it where `(p - a) . w > c` (`a` the first corner; never
    /// across a border): `w` is the triangle across's normal crossed with
    /// the edge, pointing into that triangle.
    folds: Vec<[(DVec3, f64); 3]>,
    /// The triangles around each vertex: `fan[fan_start[v]..fan_start[v + 1]]`.
    fan_start: Vec<u32>,
    fan: Vec<u32>,
}

impl Surface {
    /// The surface of the cleaned components.
    pub(super) fn new(components: &[TriMesh]) -> Result<Surface> {
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for p in components.iter().flat_map(|c| &c.positions) {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let origin = 0.5 * (lo + hi);
        let mut points = Vec::new();
        let mut triangles = Vec::new();
        for c in components {
            let first = points.len() as u32;
            points.extend_from_slice(&c.positions);
            triangles.extend(c.triangles.iter().map(|t| t.map(|v| v + first)));
        }
        let planes: Vec<Plane> = triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| points[v as usize]);
                let (ab, ac) = (b - a, c - a);
                let (g00, g01, g11) = (ab.dot(ab), ab.dot(ac), ac.dot(ac));
                let det = g00 * g11 - g01 * g01;
                // Degenerate: no inner point, every foot by the regions.
                let inverse = if det > 1e-12 * g00 * g11 {
                    [g11 / det, -g01 / det, g00 / det]
                } else {
                    [0.0; 3]
                };
                Plane {
                    a,
                    normal: ab.cross(ac).normalize_or_zero(),
                    ab,
                    ac,
                    inverse,
                    longest: g00.max(g11).max((c - b).length_squared()).sqrt(),
                }
            })
            .collect();
        let shifted: Vec<DVec3> = points.iter().map(|&p| p - origin).collect();
        let mesh = ParryMesh::new(
            shifted.iter().map(|&p| to_parry(p)).collect(),
            triangles.clone(),
        )
        .map_err(|e| {
            Error::remesh(RemeshFailure::Step(format!(
                "the surface for normal placement: {e:?}"
            )))
        })?;
        // Edge neighbours: each directed edge meets its reverse (the cleaned
        // components are manifold and consistently oriented).
        let mut edges = std::collections::HashMap::with_capacity(3 * triangles.len());
        for (t, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                edges.insert((tri[(k + 1) % 3], tri[(k + 2) % 3]), t as u32);
            }
        }
        let across: Vec<[u32; 3]> = triangles
            .iter()
            .map(|tri| {
                std::array::from_fn(|k| {
                    edges
                        .get(&(tri[(k + 2) % 3], tri[(k + 1) % 3]))
                        .copied()
                        .unwrap_or(NONE)
                })
            })
            .collect();
        let folds = triangles
            .iter()
            .zip(&across)
            .map(|(tri, across): (&[u32; 3], &[u32; 3])| {
                let a = points[tri[0] as usize];
                std::array::from_fn(|k| {
                    let u = across[k];
                    if u == NONE {
                        return (DVec3::ZERO, 0.0);
                    }
                    let (v1, v2) = (
                        points[tri[(k + 1) % 3] as usize],
                        points[tri[(k + 2) % 3] as usize],
                    );
                    // The triangle across runs the edge from v2 to v1.
                    let w = planes[u as usize].normal.cross(v1 - v2);
                    (w, (v1 - a).dot(w))
                })
            })
            .collect();
        let mut fan_start = vec![0u32; points.len() + 1];
        for &v in triangles.iter().flatten() {
            fan_start[v as usize + 1] += 1;
        }
        for v in 0..points.len() {
            fan_start[v + 1] += fan_start[v];
        }
        let mut fill = fan_start.clone();
        let mut fan = vec![0u32; 3 * triangles.len()];
        for (t, tri) in triangles.iter().enumerate() {
            for &v in tri {
                fan[fill[v as usize] as usize] = t as u32;
                fill[v as usize] += 1;
            }
        }
        Ok(Surface {
            mesh,
            origin,
            points,
            shifted,
            triangles,
            planes,
            across,
            folds,
            fan_start,
            fan,
        })
    }

    /// Unit normal of `triangle` (zero if it is degenerate).
    pub(super) fn normal(&self, triangle: u32) -> DVec3 {
        self.planes[triangle as usize].normal
    }

    /// The closest point of the surface to `p`, from the hierarchy.
    pub(super) fn closest(&self, p: DVec3) -> Foot {
        let (projection, (triangle, _)) = self
            .mesh
            .project_local_point_and_get_location(to_parry(p - self.origin), false);
        Foot {
            point: from_parry(projection.point) + self.origin,
            triangle,
        }
    }

    /// The closest point of the surface to `p` near `start`: the end of a
    /// descent of the distance from `start` over neighbouring triangles, a
    /// local minimum. It is the closest point when `p` is nearer the surface
    /// there than the triangles are wide and no other sheet of the surface
    /// comes that near (a narrow gap, a concave crease); the caller has to
    /// start near the answer, or from several triangles.
    pub(super) fn closest_near(&self, p: DVec3, start: u32) -> Foot {
        // Most walks end where they start, on an inner foot that no
        // triangle across an edge can beat (the walk below would find
        // that too, after more work).
        let plane = &self.planes[start as usize];
        let ap = p - plane.a;
        if let Some(q) = plane.inner(ap)
            && self.folds[start as usize]
                .iter()
                .all(|&(w, c)| ap.dot(w) <= c)
        {
            return Foot {
                point: q,
                triangle: start,
            };
        }
        let (mut t, (mut q, mut feature)) = (start, self.foot(p, start));
        let mut d = p.distance_squared(q);
        for _ in 0..WALK {
            let corners = self.triangles[t as usize];
            let fan = |k: usize| {
                let v = corners[k] as usize;
                &self.fan[self.fan_start[v] as usize..self.fan_start[v + 1] as usize]
            };
            let across = &self.across[t as usize];
            let (candidates, skip): ([&[u32]; 3], u32) = match feature {
                // Where the surface folds towards the point, a triangle
                // beside may be closer than an inner foot.
                Feature::Inside => ([across, &[], &[]], NONE),
                // The triangles around both ends: the one across may be no
                // closer where the foot moves on to one of its corners. The
                // one across first, as it is the likeliest to be closer.
                Feature::Edge(k) => (
                    [
                        std::slice::from_ref(&across[k]),
                        fan((k + 1) % 3),
                        fan((k + 2) % 3),
                    ],
                    across[k],
                ),
                Feature::Corner(k) => ([fan(k), &[], &[]], NONE),
            };
            if candidates.iter().map(|c| c.len()).sum::<usize>() > MAX_FAN {
                // A hub (a fan's, an n-gon's): trying its every triangle
                // for every point near it made time quadratic in its
                // valence; the hierarchy answers in logarithmic time.
                return self.closest(p);
            }
            let mut best: Option<(u32, DVec3, Feature, f64)> = None;
            for (j, &u) in candidates.into_iter().flatten().enumerate() {
                // From an inner foot, the triangle across an edge comes
                // closer only where the point lies beyond that edge as seen
                // in the triangle's own plane: elsewhere its closest point
                // is on the shared edge, no closer than the inner foot.
                if feature == Feature::Inside {
                    let (w, c) = self.folds[t as usize][j];
                    if (p - self.planes[t as usize].a).dot(w) <= c {
                        continue;
                    }
                }
                // The distance to a triangle's plane is a lower bound of that
                // to the triangle, and costs a dot product.
                let bound = best.map_or(d, |b| b.3);
                if u == NONE
                    || u == t
                    || (j > 0 && u == skip)
                    || self.plane_distance_squared(p, u) >= bound
                {
                    continue;
                }
                let (qu, fu) = self.foot(p, u);
                let du = p.distance_squared(qu);
                if du < d && best.is_none_or(|(_, _, _, db)| du < db) {
                    best = Some((u, qu, fu, du));
                }
            }
            match best {
                Some((u, qu, fu, du)) => (t, q, feature, d) = (u, qu, fu, du),
                None => break,
            }
        }
        Foot {
            point: q,
            triangle: t,
        }
    }

    /// The nearest hit of the line `from + s dir`, `|s| <= reach`, whose
    /// triangle faces `dir` (cosine at least `facing`): `(s, triangle)`,
    /// from the hierarchy. Only the first hit each way is looked at.
    pub(super) fn hit(
        &self,
        from: DVec3,
        dir: DVec3,
        reach: f64,
        facing: f64,
    ) -> Option<(f64, u32)> {
        let origin = to_parry(from - self.origin);
        let mut best: Option<(f64, u32)> = None;
        for sign in [1.0, -1.0] {
            let ray = Ray::new(origin, to_parry(dir * sign));
            let limit = best.map_or(reach, |b| b.0.abs());
            let Some(hit) = self.mesh.cast_local_ray_and_get_normal(&ray, limit, false) else {
                continue;
            };
            if self.normal(hit.subshape).dot(dir) >= facing {
                best = Some((sign * hit.time_of_impact, hit.subshape));
            }
        }
        best
    }

    /// [`Surface::hit`], answered from the triangles around `from` where
    /// they settle it: the closest point of `from` is walked to from
    /// `start`, and the surface within `reach` of `from` is gone through
    /// from there, triangle to triangle across edges within `reach`; every
    /// triangle reached is tested as the hierarchy tests it (the same
    /// operations, so the same answer unless the line passes through an
    /// edge of two). The hierarchy answers when no triangle reached is hit,
    /// when more than [`LOCAL`] are reached, when the walk ends further
    /// than `reach` from `from`, or when `reach` is more than
    /// [`LOCAL_REACH`] of the longest side of the triangle it ends on. The
    /// answers differ only where another sheet of the surface, not joined
    /// to this one within `reach`, comes within `reach` of `from`: across a
    /// gap narrower than twice `reach`, so than half the longest side of
    /// the triangle nearest `from`.
    pub(super) fn hit_near(
        &self,
        from: DVec3,
        dir: DVec3,
        reach: f64,
        facing: f64,
        start: u32,
    ) -> Option<(f64, u32)> {
        let foot = self.closest_near(from, start);
        let reach2 = reach * reach;
        if from.distance_squared(foot.point) >= reach2
            || reach > LOCAL_REACH * self.planes[foot.triangle as usize].longest
        {
            return self.hit(from, dir, reach, facing);
        }
        let origin = from - self.origin;
        let mut seen = [NONE; LOCAL];
        let mut count = 0;
        seen[0] = foot.triangle;
        count += 1;
        let mut next = 0;
        // Per direction (plus, minus), the nearest hit.
        let mut first: [Option<(f64, u32)>; 2] = [None, None];
        while next < count {
            let t = seen[next];
            next += 1;
            let corners = self.triangles[t as usize].map(|v| self.shifted[v as usize]);
            let [a, b, c] = corners;
            for (k, sign) in [1.0, -1.0].into_iter().enumerate() {
                if let Some(toi) = ray_triangle(a, b, c, origin, dir * sign)
                    && toi < first[k].map_or(reach, |f| f.0)
                {
                    first[k] = Some((toi, t));
                }
            }
            for (k, u) in self.across[t as usize].into_iter().enumerate() {
                // The surface in the ball crosses into `u` through their
                // shared edge, in the ball.
                if u == NONE
                    || seen[..count].contains(&u)
                    || segment_distance_squared(origin, corners[(k + 1) % 3], corners[(k + 2) % 3])
                        >= reach2
                {
                    continue;
                }
                if count == LOCAL {
                    return self.hit(from, dir, reach, facing);
                }
                seen[count] = u;
                count += 1;
            }
        }
        if first == [None, None] {
            return self.hit(from, dir, reach, facing);
        }
        // As the hierarchy's two casts: the first hit each way counts if it
        // faces `dir`, the minus one only nearer than the plus one.
        let mut best: Option<(f64, u32)> = None;
        for (k, sign) in [1.0, -1.0].into_iter().enumerate() {
            let Some((toi, t)) = first[k] else { continue };
            if best.is_some_and(|b| toi >= b.0.abs()) {
                continue;
            }
            if self.normal(t).dot(dir) >= facing {
                best = Some((sign * toi, t));
            }
        }
        best
    }

    /// Whether triangles `a` and `b` are one or share a corner.
    pub(super) fn touching(&self, a: u32, b: u32) -> bool {
        if a == b {
            return true;
        }
        let (a, b) = (self.triangles[a as usize], self.triangles[b as usize]);
        a.iter().any(|v| b.contains(v))
    }

    /// The squared distance of `p` to the plane of triangle `t` (zero if it
    /// is degenerate, so that the triangle is looked at).
    #[inline]
    fn plane_distance_squared(&self, p: DVec3, t: u32) -> f64 {
        let plane = &self.planes[t as usize];
        let h = (p - plane.a).dot(plane.normal);
        h * h
    }

    /// The closest point of triangle `t` to `p` and where on the triangle it
    /// lies (by regions of the corners' and edges' Voronoi cells).
    fn foot(&self, p: DVec3, t: u32) -> (DVec3, Feature) {
        // Most feet lie inside: the barycentric coordinates of the point's
        // projection settle those.
        let plane = &self.planes[t as usize];
        if let Some(q) = plane.inner(p - plane.a) {
            return (q, Feature::Inside);
        }
        closest_on_triangle(
            p,
            self.triangles[t as usize].map(|v| self.points[v as usize]),
        )
    }
}

/// The squared distance of `p` to the segment from `a` to `b`.
fn segment_distance_squared(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let (ab, ap) = (b - a, p - a);
    let length = ab.length_squared();
    let s = if length > 0.0 {
        (ap.dot(ab) / length).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (ap - ab * s).length_squared()
}

/// Where the ray from `origin` along `dir` meets triangle `abc`, as parry
/// computes it (`local_ray_intersection_with_triangle`, the same operations
/// in the same order, so the same time of impact).
fn ray_triangle(a: DVec3, b: DVec3, c: DVec3, origin: DVec3, dir: DVec3) -> Option<f64> {
    let ab = b - a;
    let ac = c - a;
    let n = ab.cross(ac);
    let d = n.dot(dir);
    if d == 0.0 {
        return None;
    }
    let ap = origin - a;
    let t = ap.dot(n);
    if (t < 0.0 && d < 0.0) || (t > 0.0 && d > 0.0) {
        return None;
    }
    let d = d.abs();
    let e = -dir.cross(ap);
    let (v, w) = if t < 0.0 {
        (-ac.dot(e), ab.dot(e))
    } else {
        (ac.dot(e), -ab.dot(e))
    };
    if v < 0.0 || v > d || w < 0.0 || v + w > d {
        return None;
    }
    let invd = 1.0 / d;
    Some(if t < 0.0 { -t * invd } else { t * invd })
}

fn from_parry(p: Vector) -> DVec3 {
    DVec3::new(p.x, p.y, p.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed surface: a sphere of `n` rings and `2n` meridians, its
    /// radius `radius(theta, phi)`.
    fn radial(n: u32, radius: impl Fn(f64, f64) -> f64) -> TriMesh {
        let (positions, triangles) = qm_shapes::uv_sphere_radial(n, 2 * n, radius);
        TriMesh {
            positions,
            triangles,
        }
    }

    /// A bumpy closed surface: a sphere of `n` rings, its radius rippled.
    fn bumpy(n: u32) -> TriMesh {
        radial(n, |theta, phi| {
            1.0 + 0.1 * (3.0 * phi).sin() * (2.0 * theta).sin()
        })
    }

    /// A sphere with a groove `depth` deep and about `2 width` wide (in
    /// radians) around its equator: two walls meeting in a concave bottom,
    /// as a model's ear meets its head.
    fn grooved(width: f64, depth: f64) -> TriMesh {
        radial(128, |theta, _| {
            let x = (theta - std::f64::consts::FRAC_PI_2) / width;
            1.0 - depth * (-x * x).exp()
        })
    }

    /// Deterministic pseudo-random numbers in `[-1, 1)`.
    fn noise(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*state >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }

    /// For points near the surface (within a tenth of a triangle's size, as
    /// the samples are), walks from a triangle up to half a triangle from
    /// the answer find the hierarchy's closest points.
    #[test]
    fn walks_find_the_closest_points_near_them() {
        let surface = Surface::new(&[bumpy(24)]).unwrap();
        let mut state = 7;
        let mut moved = 0;
        for _ in 0..2000 {
            let dir = DVec3::new(noise(&mut state), noise(&mut state), noise(&mut state));
            let on = surface.closest(dir.normalize());
            let p = on.point + 0.01 * noise(&mut state) * surface.normal(on.triangle);
            let truth = surface.closest(p);
            let q = truth.point
                + 0.04 * DVec3::new(noise(&mut state), noise(&mut state), noise(&mut state));
            let start = surface.closest(q).triangle;
            let walked = surface.closest_near(p, start);
            assert!(
                (walked.point.distance(p) - truth.point.distance(p)).abs() < 1e-12,
                "{p:?} from triangle {start}: walked to {walked:?}, the hierarchy says {truth:?}"
            );
            moved += usize::from(start != truth.triangle);
        }
        // The walks did walk.
        assert!(moved > 500, "{moved}");
    }

    /// A point near the surface, as a fitted sample or a prediction is: on a
    /// random triangle (half of them within 0.1 of the equator, in the
    /// groove of [`grooved`]), then moved up to `along` times the
    /// triangle's size along it and `off` times off it. With that triangle.
    fn near(surface: &Surface, state: &mut u64, along: f64, off: f64) -> (DVec3, u32) {
        let count = surface.triangles.len();
        let groove = noise(state) > 0.0;
        loop {
            let t = ((noise(state) + 1.0) * 0.5 * count as f64) as usize % count;
            let [a, b, c] = surface.triangles[t].map(|v| surface.points[v as usize]);
            if groove && (a + b + c).z.abs() > 0.3 {
                continue;
            }
            let (u, v) = ((noise(state) + 1.0) * 0.5, (noise(state) + 1.0) * 0.5);
            let (u, v) = if u + v > 1.0 {
                (1.0 - u, 1.0 - v)
            } else {
                (u, v)
            };
            let size = a.distance(b).max(a.distance(c));
            let normal = surface.normal(t as u32);
            let slide = DVec3::new(noise(state), noise(state), noise(state)).reject_from(normal);
            let p = a
                + (b - a) * u
                + (c - a) * v
                + along * size * slide
                + off * size * noise(state) * normal;
            return (p, t as u32);
        }
    }

    /// Walks from the triangle a point was sampled on, before it moved as
    /// the fit moves the samples, find the hierarchy's closest points, also
    /// on the walls and the bottom of a narrow concave groove (normal
    /// placement walks the samples' own closest points so).
    #[test]
    fn walks_from_the_sampled_triangle_find_the_closest_points() {
        // A deep, narrow groove: walls about three triangles apart.
        for mesh in [bumpy(24), grooved(0.05, 0.4)] {
            let surface = Surface::new(&[mesh]).unwrap();
            let mut state = 11;
            let mut moved = 0;
            for _ in 0..3000 {
                let (p, start) = near(&surface, &mut state, 0.05, 0.01);
                let truth = surface.closest(p);
                let walked = surface.closest_near(p, start);
                assert!(
                    (walked.point.distance(p) - truth.point.distance(p)).abs() < 1e-12,
                    "{p:?} from triangle {start}: walked to {walked:?}, the hierarchy says {truth:?}"
                );
                moved += usize::from(walked.triangle != start);
            }
            assert!(moved > 300, "{moved}");
        }
    }

    /// Rays from near the surface (as the predictions are) give the
    /// hierarchy's answers, also in a groove, from one wall across its
    /// concave bottom to the other, whether the triangles around them
    /// answer or, for long rays, the hierarchy. (Across a gap narrower than
    /// twice the reach, not joined within the reach, they may differ: see
    /// [`Surface::hit_near`].)
    #[test]
    fn rays_near_the_surface_hit_what_the_hierarchy_hits() {
        let surface = Surface::new(&[grooved(0.1, 0.2)]).unwrap();
        let height = |t: u32| {
            let [a, b, c] = surface.triangles[t as usize].map(|v| surface.points[v as usize]);
            (a + b + c).z / 3.0
        };
        let mut state = 5;
        let (mut short, mut beside, mut across) = (0, 0, 0);
        for _ in 0..3000 {
            let (p, start) = near(&surface, &mut state, 0.2, 0.3);
            let dir = (surface.normal(start)
                + 0.2 * DVec3::new(noise(&mut state), noise(&mut state), noise(&mut state)))
            .normalize();
            let longest = surface.planes[start as usize].longest;
            let reach = 0.3 * longest * (noise(&mut state) + 1.0) * 0.5;
            // Normal placement's facing cosine, and any hit.
            for facing in [0.9, -1.0] {
                let truth = surface.hit(p, dir, reach, facing);
                assert_eq!(
                    surface.hit_near(p, dir, reach, facing, start),
                    truth,
                    "{p:?} along {dir:?} within {reach} from triangle {start}"
                );
                if let Some((_, t)) = truth
                    && reach <= LOCAL_REACH * longest
                {
                    short += 1;
                    beside += usize::from(t != start);
                    across += usize::from(height(t) * height(start) < 0.0);
                }
            }
        }
        // Most short rays hit, many of them on a triangle beside the one
        // they started from, some on the other wall.
        assert!(
            short > 2000 && beside > 300 && across >= 10,
            "{short} hits, {beside} beside, {across} across"
        );
    }
}
