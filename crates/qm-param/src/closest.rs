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
        }
    }

    /// The corners of sorted triangle `t`.
    fn corners(&self, t: &[u32; 3]) -> [DVec3; 3] {
        t.map(|v| self.positions[v as usize])
    }

    /// The point of the triangles closest to `p` (moved by `-origin`, as the
    /// triangles are).
    pub(crate) fn project(&self, p: DVec3) -> DVec3 {
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
                    .map(|t| {
                        let (q, _) = closest_on_triangle(p, self.corners(t));
                        ((q - p).length_squared(), q)
                    })
                    .min_by(|x, y| x.0.total_cmp(&y.0))
            },
        );
        // The BVH is never empty: the callers give a triangle at least.
        found.map_or(p, |(_, (_, q))| q)
    }
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
