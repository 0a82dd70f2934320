//! Closest points on a triangle mesh: the crate's exact search
//! ([`Closest`]), and where each question about closest points is answered.
//!
//! For a point `p` and triangles `t`, the closest point is the `q_t` of
//! least `|p - q_t|`, with `q_t` the point of `t` closest to `p`, found by
//! the Voronoi regions of the triangle's corners, sides and face (Ericson,
//! *Real-Time Collision Detection*, 2005, section 5.1.5;
//! [`closest_on_triangle`]). [`Closest`] finds it exactly: a bounding
//! volume hierarchy over runs of nearby triangles is searched best first,
//! the squared distance to a box being a lower bound of those to the
//! triangles in it.
//!
//! Who asks what:
//!
//! - **Any mesh, from outside the crate:** `distance::Surface` (public),
//!   built on [`Closest`]: the feet the encoder's holds measure against.
//! - **Colours**: `colour::ColourSurface` and `colour_distance()` ask
//!   [`Closest::locate`], which also names the triangle and the barycentric
//!   coordinates of each answer.
//! - **[`distance()`](crate::distance())**, both ways and about a million
//!   samples each, and the remesher's own measure of its remesh (module
//!   `remesh::finish`): [`Closest`].
//! - **Normal placement** asks about points whose triangle is nearly known,
//!   and for ray hits, and needs the triangle of each answer: module
//!   `remesh::surface` walks over the mesh from a nearby triangle and asks
//!   parry's `TriMesh` where a walk cannot settle it.
//!
//! The two structures stay apart: the remesher's streams depend on parry's
//! own point-triangle arithmetic and on which of several equidistant
//! triangles its hierarchy returns, and parry's `TriMesh` over the
//! remesh's triangles costs the measure time and memory that the runs save
//! (docs/decisions/030-point-queries.md).

use parry3d_f64::bounding_volume::Aabb;
use parry3d_f64::math::Vector;
use parry3d_f64::partitioning::{Bvh, BvhBuildStrategy};
use qm_lift::glam::DVec3;
use rayon::prelude::*;

use crate::trimesh::closest_on_triangle;

/// Closest points on a set of triangles. The triangles are put in Morton
/// order of their centroids and cut into runs of [`RUN`]; the BVH holds one
/// leaf a run, so that its build, which dominated the remesher's measure of
/// a million-sample remesh, costs a few times less, at a few more triangle
/// tests a query. The triangles keep their corners' indices, into positions
/// numbered in the order the sorted triangles first use them, so that a
/// run's corners lie close in memory: a triangle takes 12 bytes and a vertex
/// 24, where its three corners took 72 (docs/decisions/030-point-queries.md).
pub(crate) struct Closest {
    /// The positions (less the origin), in the order of first use.
    positions: Vec<DVec3>,
    /// The triangles, in Morton order.
    triangles: Vec<[u32; 3]>,
    /// One leaf a run of [`RUN`] triangles.
    bvh: Bvh,
    /// For each sorted triangle, its index in the triangles given to
    /// [`Closest::indexed`]; empty when built by [`Closest::new`], whose
    /// callers ask for points alone.
    order: Vec<u32>,
}

/// Where [`Closest::locate`] found the closest point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Located {
    /// The point (moved by `-origin`, as the triangles are).
    pub point: DVec3,
    /// Its triangle, an index into the triangles given to
    /// [`Closest::indexed`].
    pub triangle: usize,
    /// Its barycentric coordinates in that triangle, in the order of the
    /// triangle's corners: non-negative, summing to 1.
    pub barycentric: [f64; 3],
}

/// Triangles a leaf of [`Closest`]'s BVH.
const RUN: usize = 4;

impl Closest {
    /// The triangles `triangles` of `points` (at least one), all within the
    /// box `[min, max]`, moved by `-origin` (parry works near the origin,
    /// where `f64` is densest).
    pub(crate) fn new(
        points: &[DVec3],
        triangles: &[[u32; 3]],
        [min, max]: [DVec3; 2],
        origin: DVec3,
    ) -> Closest {
        Closest::build(points, triangles, [min, max], origin, false)
    }

    /// [`Closest::new`], keeping which input triangle each sorted one is,
    /// for [`Closest::locate`] (4 bytes a triangle more).
    pub(crate) fn indexed(
        points: &[DVec3],
        triangles: &[[u32; 3]],
        [min, max]: [DVec3; 2],
        origin: DVec3,
    ) -> Closest {
        Closest::build(points, triangles, [min, max], origin, true)
    }

    fn build(
        points: &[DVec3],
        triangles: &[[u32; 3]],
        [min, max]: [DVec3; 2],
        origin: DVec3,
        keep_order: bool,
    ) -> Closest {
        let (min, max) = (min - origin, max - origin);
        // Each axis over its own extent: over the longest one, a needle's
        // centroids all fell in one column of cells, the runs took
        // triangles from all around it and every query tried every run.
        let top = ((1u64 << 21) - 1) as f64;
        let scale = top / (max - min).max(DVec3::splat(f64::MIN_POSITIVE));
        let mut keyed: Vec<(u64, u32)> = triangles
            .par_iter()
            .enumerate()
            .map(|(i, t)| {
                let [p, q, r] = t.map(|i| points[i as usize] - origin);
                let cell =
                    (((p + q + r) / 3.0 - min) * scale).clamp(DVec3::ZERO, DVec3::splat(top));
                let key =
                    morton(cell.x as u64) | morton(cell.y as u64) << 1 | morton(cell.z as u64) << 2;
                (key, i as u32)
            })
            .collect();
        keyed.par_sort_unstable_by_key(|&(key, _)| key);
        let mut number = vec![u32::MAX; points.len()];
        let mut positions = Vec::new();
        let sorted: Vec<[u32; 3]> = keyed
            .iter()
            .map(|&(_, t)| {
                triangles[t as usize].map(|v| {
                    let n = &mut number[v as usize];
                    if *n == u32::MAX {
                        *n = positions.len() as u32;
                        positions.push(points[v as usize] - origin);
                    }
                    *n
                })
            })
            .collect();
        let order = if keep_order {
            keyed.iter().map(|&(_, t)| t).collect()
        } else {
            Vec::new()
        };
        drop((keyed, number));
        let leaves: Vec<Aabb> = sorted
            .par_chunks(RUN)
            .map(|run| {
                let corners = run.iter().flat_map(|t| t.map(|v| positions[v as usize]));
                Aabb::from_points(corners.map(to_parry))
            })
            .collect();
        let bvh = Bvh::from_leaves(BvhBuildStrategy::Binned, &leaves);
        Closest {
            positions,
            triangles: sorted,
            bvh,
            order,
        }
    }

    /// The corners of sorted triangle `t`.
    fn corners(&self, t: &[u32; 3]) -> [DVec3; 3] {
        t.map(|v| self.positions[v as usize])
    }

    /// The point of the triangles closest to `p` (moved by `-origin`, as the
    /// triangles are).
    pub(crate) fn project(&self, p: DVec3) -> DVec3 {
        // The BVH is never empty: the callers give a triangle at least.
        self.nearest(p).map_or(p, |(q, _)| q)
    }

    /// [`Closest::project`] with the triangle and barycentric coordinates of
    /// the answer. Only for a search built by [`Closest::indexed`].
    pub(crate) fn locate(&self, p: DVec3) -> Located {
        let Some((point, sorted)) = self.nearest(p) else {
            unreachable!("the callers give a triangle at least")
        };
        Located {
            point,
            triangle: self.order[sorted] as usize,
            barycentric: barycentric(point, self.corners(&self.triangles[sorted])),
        }
    }

    /// The closest point and its sorted triangle.
    fn nearest(&self, p: DVec3) -> Option<(DVec3, usize)> {
        // Best first by squared distances, to the leaves' boxes and then to
        // their triangles.
        let query = to_parry(p);
        let found = self.bvh.find_best(
            f64::MAX,
            |node, _| {
                let outside = (node.mins() - query)
                    .max(query - node.maxs())
                    .max(Vector::ZERO);
                outside.length_squared()
            },
            |leaf, _| {
                let start = leaf as usize * RUN;
                let run = &self.triangles[start..(start + RUN).min(self.triangles.len())];
                run.iter()
                    .enumerate()
                    .map(|(k, t)| {
                        let (q, _) = closest_on_triangle(p, self.corners(t));
                        ((q - p).length_squared(), (q, start + k))
                    })
                    .min_by(|x, y| x.0.total_cmp(&y.0))
            },
        );
        found.map(|(_, (_, found))| found)
    }
}

/// The barycentric coordinates of `q`, a point of triangle `[a, b, c]`
/// (Ericson, *Real-Time Collision Detection*, 2005, section 3.4), clamped to
/// the triangle against rounding. A triangle without area gives its first
/// corner.
pub(crate) fn barycentric(q: DVec3, [a, b, c]: [DVec3; 3]) -> [f64; 3] {
    let (v0, v1, v2) = (b - a, c - a, q - a);
    let (d00, d01, d11) = (v0.dot(v0), v0.dot(v1), v1.dot(v1));
    let (d20, d21) = (v2.dot(v0), v2.dot(v1));
    let denominator = d00 * d11 - d01 * d01;
    if denominator.is_nan() || denominator <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let v = ((d11 * d20 - d01 * d21) / denominator).max(0.0);
    let w = ((d00 * d21 - d01 * d20) / denominator).max(0.0);
    let u = (1.0 - v - w).max(0.0);
    let sum = u + v + w;
    [u / sum, v / sum, w / sum]
}

/// The bits of `x` (21 of them) spread to every third bit.
fn morton(x: u64) -> u64 {
    let mut x = x & 0x1f_ffff;
    x = (x | x << 32) & 0x1f_0000_0000_ffff;
    x = (x | x << 16) & 0x1f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    (x | x << 2) & 0x1249_2492_4924_9249
}

/// `p` as parry's vector.
#[inline]
pub(crate) fn to_parry(p: DVec3) -> Vector {
    Vector::new(p.x, p.y, p.z)
}
