//! Symmetric surface distance between two meshes, measured as Metro
//! (Cignoni, Rocchini and Scopigno, *Metro: measuring error on simplified
//! surfaces*, 1998) and MeshLab's Hausdorff filter measure it.
//!
//! Each surface is sampled area-uniformly and every sample is projected onto
//! the other surface; for samples `p` of `A` the one-sided distances are
//! `d(p, B) = min over q in B of |p - q|`, and
//!
//! - `rms(A -> B) = sqrt(mean of d(p, B)^2)`,
//! - `mean(A -> B) = mean of d(p, B)`,
//! - `max(A -> B) = max of d(p, B)` (a lower bound of the one-sided
//!   Hausdorff distance that tightens as the sample count grows).
//!
//! The symmetric values are the larger of the two directions, as Metro
//! reports them, and `psnr_db = 20 log10(diag / rms)` with `diag` the
//! bounding-box diagonal of `A` (the convention of Khodakovsky et al.,
//! *Progressive Geometry Compression*, 2000).
//!
//! Sampling: polygons are fanned into triangles; triangle `t` of area `a_t`
//! receives `floor(n a_t / area)` samples plus one more with probability
//! equal to the remainder, each uniform inside it (Turk's square-root
//! barycentrics). Every triangle draws from its own random stream seeded by
//! the seed and its index, so the result is the same however
//! the work is split across threads. Mesh vertices are not added as samples
//! (Metro adds them; with many samples they change nothing but bias small
//! sample counts towards vertices).
//!
//! Closest points come from module `closest`'s exact search, a
//! `parry3d-f64` BVH over runs of nearby triangles; [`Surface`] offers it
//! for any mesh. The `f64` build is used because qm quantizes up to 24 bits
//! per coordinate, an error of `2^-24` of the box, which `f32` projections
//! could not resolve. The remesher's normal placement asks its own
//! structure, which walks from nearby triangles and casts rays
//! (docs/decisions/030-point-queries.md).

use qm_io::SplitMix64;
use qm_lift::glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::closest::Closest;
use crate::{Error, PolyMesh, Result};

/// Which input of [`distance`] a problem is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Side {
    /// The first mesh, whose bounding box sets `diag`.
    A,
    /// The second mesh.
    B,
}

impl std::fmt::Display for Side {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Side::A => "A",
            Side::B => "B",
        })
    }
}

/// How [`distance`] samples the surfaces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub struct DistanceOptions {
    /// Samples per direction (about; the per-triangle remainders are random).
    /// Default [`DEFAULT_SAMPLES`].
    pub samples: usize,
    /// Seed of the sampling; the same seed gives the same report.
    /// Default [`DEFAULT_SEED`].
    pub seed: u64,
}

/// Default samples per direction: a million keeps the RMS estimate's
/// relative sampling error near `1/sqrt(n)`, a few hundredths of a dB of
/// PSNR, at about a second per direction and core on a 6,000-triangle mesh.
pub const DEFAULT_SAMPLES: usize = 1_000_000;

/// Default sampling seed.
pub const DEFAULT_SEED: u64 = 0x716d_6469_7374;

impl DistanceOptions {
    /// A million samples per direction, seed [`DEFAULT_SEED`].
    pub const DEFAULT: Self = DistanceOptions {
        samples: DEFAULT_SAMPLES,
        seed: DEFAULT_SEED,
    };

    /// Sets the number of samples per direction.
    pub const fn with_samples(mut self, samples: usize) -> Self {
        self.samples = samples;
        self
    }

    /// Sets the sampling seed.
    pub const fn with_seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }
}

impl Default for DistanceOptions {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Distances from the samples of one surface to the other.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct OneSided {
    /// Root mean square distance.
    pub rms: f64,
    /// Mean distance.
    pub mean: f64,
    /// Largest distance found.
    pub max: f64,
    /// Number of samples taken.
    pub samples: usize,
}

/// What [`distance`] measures. `psnr_db` is `f64::INFINITY` when the
/// surfaces coincide (serde_json writes it as `null`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DistanceReport {
    /// The larger of the two one-sided RMS distances.
    pub rms: f64,
    /// The larger of the two one-sided mean distances.
    pub mean: f64,
    /// The larger of the two one-sided maxima: the sampled Hausdorff distance.
    pub hausdorff: f64,
    /// `20 log10(diag / rms)`.
    pub psnr_db: f64,
    /// Bounding-box diagonal of `A`.
    pub diag: f64,
    /// Samples on `A`, distances to `B`.
    pub a_to_b: OneSided,
    /// Samples on `B`, distances to `A`.
    pub b_to_a: OneSided,
}

/// Measures the symmetric distance between the surfaces of `a` and `b`.
///
/// Fails if either mesh has no face of positive area, a face refers to a
/// missing vertex or a used vertex is not finite, or `options.samples` is 0.
pub fn distance(a: &PolyMesh, b: &PolyMesh, options: &DistanceOptions) -> Result<DistanceReport> {
    // Meshes in far units are measured at a power-of-two scale of A's box
    // (exact), where squared lengths and areas neither overflow nor vanish.
    let scale = qm_lift::unit_scale(&a.positions);
    if scale == 1.0 {
        return distance_at_scale(a, b, options);
    }
    let r = distance_at_scale(&scaled(a, scale), &scaled(b, scale), options)?;
    let back = |s: OneSided| OneSided {
        rms: s.rms / scale,
        mean: s.mean / scale,
        max: s.max / scale,
        ..s
    };
    Ok(DistanceReport {
        rms: r.rms / scale,
        mean: r.mean / scale,
        hausdorff: r.hausdorff / scale,
        diag: r.diag / scale,
        a_to_b: back(r.a_to_b),
        b_to_a: back(r.b_to_a),
        ..r
    })
}

/// `mesh` with its positions multiplied by `scale`.
pub(crate) fn scaled(mesh: &PolyMesh, scale: f64) -> PolyMesh {
    let mut mesh = mesh.clone();
    mesh.positions.iter_mut().for_each(|p| *p *= scale);
    mesh
}

fn distance_at_scale(
    a: &PolyMesh,
    b: &PolyMesh,
    options: &DistanceOptions,
) -> Result<DistanceReport> {
    if options.samples == 0 {
        return Err(Error::NoSamples);
    }
    let ta = Triangles::new(a, Side::A)?;
    let tb = Triangles::new(b, Side::B)?;
    let diag = ta.bbox_diagonal();

    let (a_to_b, b_to_a) = if a == b {
        // Every sample lies on the other surface exactly; projections would
        // only add rounding noise.
        let zero = OneSided {
            rms: 0.0,
            mean: 0.0,
            max: 0.0,
            samples: ta.sample_counts(options).into_iter().sum(),
        };
        (zero, zero)
    } else {
        // Both meshes are moved by the same offset, symmetric in A and B, so
        // that parry works near the origin, where `f64` is densest.
        let origin = 0.5 * (ta.bbox_center() + tb.bbox_center());
        let (mesh_a, mesh_b) = rayon::join(|| ta.closest(origin), || tb.closest(origin));
        let (a_to_b, b_to_a) = rayon::join(
            || one_sided(&ta, &mesh_b, origin, options),
            || one_sided(&tb, &mesh_a, origin, options),
        );
        (a_to_b, b_to_a)
    };
    let rms = a_to_b.rms.max(b_to_a.rms);
    let psnr_db = if rms > 0.0 {
        20.0 * (diag / rms).log10()
    } else {
        f64::INFINITY
    };
    Ok(DistanceReport {
        rms,
        mean: a_to_b.mean.max(b_to_a.mean),
        hausdorff: a_to_b.max.max(b_to_a.max),
        psnr_db,
        diag,
        a_to_b,
        b_to_a,
    })
}

/// Closest points on a mesh's surface, fanned into triangles as
/// [`distance`] fans it: the crate's answer to "which point of this mesh is
/// closest", exact, for any mesh.
pub struct Surface {
    mesh: Closest,
    origin: DVec3,
    /// The power of two the mesh is held at.
    scale: f64,
}

impl Surface {
    /// The surface of `mesh` (faces of positive area, finite vertices, as
    /// [`distance`] asks of mesh A), kept at its [`qm_lift::unit_scale`].
    pub fn new(mesh: &PolyMesh) -> Result<Self> {
        let scale = qm_lift::unit_scale(&mesh.positions);
        let mesh = if scale == 1.0 {
            std::borrow::Cow::Borrowed(mesh)
        } else {
            std::borrow::Cow::Owned(scaled(mesh, scale))
        };
        let triangles = Triangles::new(&mesh, Side::A)?;
        let origin = triangles.bbox_center();
        Ok(Surface {
            mesh: triangles.closest(origin),
            origin,
            scale,
        })
    }

    /// The point of the surface closest to `p`.
    pub fn closest(&self, p: DVec3) -> DVec3 {
        (self.mesh.project(p * self.scale - self.origin) + self.origin) / self.scale
    }
}

/// A mesh fanned into triangles of positive area.
pub(crate) struct Triangles<'a> {
    positions: &'a [DVec3],
    pub(crate) triangles: Vec<[u32; 3]>,
    /// Where each triangle comes from: its face, and `k` for the fan
    /// triangle of the face's corners `0, k + 1, k + 2`.
    pub(crate) fans: Vec<[u32; 2]>,
    /// Area of each triangle.
    areas: Vec<f64>,
    total_area: f64,
    min: DVec3,
    max: DVec3,
}

impl<'a> Triangles<'a> {
    pub(crate) fn new(mesh: &'a PolyMesh, side: Side) -> Result<Self> {
        if mesh.face_count() == 0 {
            return Err(Error::NoFaces { mesh: Some(side) });
        }
        let positions = &mesh.positions[..];
        let fanned = mesh.faces().map(|f| f.len().saturating_sub(2)).sum();
        let mut triangles = Vec::with_capacity(fanned);
        let mut areas = Vec::with_capacity(fanned);
        let mut fans = Vec::with_capacity(fanned);
        let mut min = DVec3::INFINITY;
        let mut max = DVec3::NEG_INFINITY;
        for (face, corners) in mesh.faces().enumerate() {
            for &index in corners {
                let Some(&p) = positions.get(index as usize) else {
                    return Err(Error::MissingVertex {
                        mesh: Some(side),
                        face,
                        vertex: index,
                    });
                };
                if !p.is_finite() {
                    return Err(Error::NonFinite {
                        mesh: Some(side),
                        vertex: index,
                    });
                }
                min = min.min(p);
                max = max.max(p);
            }
            // A fan from the first corner, as the mesh readers triangulate.
            for (k, pair) in corners.windows(2).skip(1).enumerate() {
                let t = [corners[0], pair[0], pair[1]];
                let [p, q, r] = t.map(|i| positions[i as usize]);
                let area = 0.5 * (q - p).cross(r - p).length();
                if area > 0.0 {
                    triangles.push(t);
                    areas.push(area);
                    fans.push([face as u32, k as u32]);
                }
            }
        }
        let total_area: f64 = areas.iter().sum();
        if !(total_area > 0.0 && total_area.is_finite()) {
            return Err(Error::ZeroArea { mesh: side });
        }
        Ok(Triangles {
            positions,
            triangles,
            fans,
            areas,
            total_area,
            min,
            max,
        })
    }

    pub(crate) fn bbox_diagonal(&self) -> f64 {
        (self.max - self.min).length()
    }

    pub(crate) fn bbox_center(&self) -> DVec3 {
        0.5 * (self.min + self.max)
    }

    /// The closest-point search over these triangles, moved by `-origin`.
    fn closest(&self, origin: DVec3) -> Closest {
        Closest::new(
            self.positions,
            &self.triangles,
            [self.min, self.max],
            origin,
        )
    }

    /// [`Self::closest`] that also tells the triangle of each answer.
    pub(crate) fn closest_indexed(&self, origin: DVec3) -> Closest {
        Closest::indexed(
            self.positions,
            &self.triangles,
            [self.min, self.max],
            origin,
        )
    }

    fn corners(&self, t: usize) -> [DVec3; 3] {
        self.triangles[t].map(|i| self.positions[i as usize])
    }

    /// How many samples each triangle receives, drawn as [`Self::samples`]
    /// draws them.
    pub(crate) fn sample_counts(&self, options: &DistanceOptions) -> Vec<usize> {
        (0..self.triangles.len())
            .map(|t| self.sample_count(t, &mut self.rng(t, options), options))
            .collect()
    }

    /// Triangle `t`'s random stream. It depends on nothing but the seed and
    /// `t`, so swapping `A` and `B` swaps the two directions exactly.
    fn rng(&self, t: usize, options: &DistanceOptions) -> SplitMix64 {
        SplitMix64::new(options.seed ^ SplitMix64::new(t as u64).next_u64())
    }

    fn sample_count(&self, t: usize, rng: &mut SplitMix64, options: &DistanceOptions) -> usize {
        let expected = options.samples as f64 * self.areas[t] / self.total_area;
        let whole = expected.floor();
        whole as usize + usize::from(rng.next_f64() < expected - whole)
    }
}

/// Triangles a partial sum of [`fold_samples`] covers.
const PARTIAL_RUN: usize = 1024;

/// One area-uniform sample of a [`Triangles`]: its triangle, its barycentric
/// coordinates there, and the point (moved by `-origin`).
pub(crate) struct Sample {
    pub triangle: usize,
    pub barycentric: [f64; 3],
    pub point: DVec3,
}

/// Folds `visit` over the area-uniform samples of `from`, the triangles'
/// points moved by `-origin`: partial folds over fixed runs of triangles,
/// merged in order, so that the result does not depend on how rayon splits
/// the work. Every caller sees the same samples for the same options.
pub(crate) fn fold_samples<P: Default + Send>(
    from: &Triangles,
    origin: DVec3,
    options: &DistanceOptions,
    visit: impl Fn(&mut P, Sample) + Sync,
    merge: impl Fn(P, P) -> P,
) -> P {
    let n = from.triangles.len();
    (0..n.div_ceil(PARTIAL_RUN))
        .into_par_iter()
        .map(|k| {
            let mut partial = P::default();
            for t in k * PARTIAL_RUN..(n.min((k + 1) * PARTIAL_RUN)) {
                let mut rng = from.rng(t, options);
                let count = from.sample_count(t, &mut rng, options);
                let [p, q, r] = from.corners(t).map(|c| c - origin);
                for _ in 0..count {
                    // Turk's square-root barycentrics are uniform in the
                    // triangle.
                    let s = rng.next_f64().sqrt();
                    let u = rng.next_f64();
                    let barycentric = [1.0 - s, s * (1.0 - u), s * u];
                    let point = p * barycentric[0] + q * barycentric[1] + r * barycentric[2];
                    let sample = Sample {
                        triangle: t,
                        barycentric,
                        point,
                    };
                    visit(&mut partial, sample);
                }
            }
            partial
        })
        .collect::<Vec<_>>()
        .into_iter()
        .fold(P::default(), merge)
}

/// Distances from area-uniform samples of `from` to the surface `to`.
fn one_sided(from: &Triangles, to: &Closest, origin: DVec3, options: &DistanceOptions) -> OneSided {
    let total = fold_samples(
        from,
        origin,
        options,
        |partial: &mut Partial, sample| {
            partial.add((to.project(sample.point) - sample.point).length());
        },
        |acc, p| acc.merge(&p),
    );
    if total.count == 0 {
        return OneSided {
            rms: 0.0,
            mean: 0.0,
            max: 0.0,
            samples: 0,
        };
    }
    let n = total.count as f64;
    OneSided {
        rms: (total.sum_squares / n).sqrt(),
        mean: total.sum / n,
        max: total.max,
        samples: total.count,
    }
}

#[derive(Default, Clone, Copy)]
struct Partial {
    count: usize,
    sum: f64,
    sum_squares: f64,
    max: f64,
}

impl Partial {
    fn add(&mut self, d: f64) {
        self.count += 1;
        self.sum += d;
        self.sum_squares += d * d;
        self.max = self.max.max(d);
    }

    fn merge(self, other: &Partial) -> Partial {
        Partial {
            count: self.count + other.count,
            sum: self.sum + other.sum,
            sum_squares: self.sum_squares + other.sum_squares,
            max: self.max.max(other.max),
        }
    }
}

#[cfg(test)]
mod tests {
    use qm_shapes::{poly, square, uv_sphere};

    use super::*;

    /// The BVH over runs finds the closest point every triangle tested one
    /// by one finds, for points near, on and far from a bumpy sphere.
    #[test]
    fn closest_points_match_a_search_of_every_triangle() {
        // Round, and a needle a thousand times longer than wide (each axis
        // has its own Morton scale).
        for stretch in [DVec3::ONE, DVec3::new(1e-3, 1e-3, 1.0)] {
            closest_points_match_on(stretch);
        }
    }

    fn closest_points_match_on(stretch: DVec3) {
        let mut mesh = uv_sphere(24, 40, 1.0);
        for (i, p) in mesh.positions.iter_mut().enumerate() {
            *p *= (1.0 + 0.05 * ((i * 7919) % 13) as f64 / 13.0) * stretch;
        }
        let triangles = Triangles::new(&mesh, Side::A).unwrap();
        let origin = DVec3::new(0.1, -0.2, 0.3) * stretch;
        let closest = triangles.closest(origin);
        let indexed = triangles.closest_indexed(origin);
        let mut rng = SplitMix64::new(7);
        for _ in 0..2000 {
            let p =
                (DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 4.0 - 2.0) * stretch;
            let q = p - origin;
            let found = (closest.project(q) - q).length();
            // The indexed search finds the same point, in the triangle and
            // at the barycentric coordinates it names.
            let located = indexed.locate(q);
            assert_eq!(located.point, closest.project(q));
            let corners =
                triangles.triangles[located.triangle].map(|i| mesh.positions[i as usize] - origin);
            let w = located.barycentric;
            let rebuilt = corners[0] * w[0] + corners[1] * w[1] + corners[2] * w[2];
            // (Needle triangles lose a few digits to the Gram determinant.)
            assert!(
                (rebuilt - located.point).length() <= 1e-10,
                "{rebuilt} against {located:?}"
            );
            let every = triangles
                .triangles
                .iter()
                .map(|t| {
                    let corners = t.map(|i| mesh.positions[i as usize] - origin);
                    (crate::trimesh::closest_on_triangle(q, corners).0 - q).length()
                })
                .fold(f64::INFINITY, f64::min);
            assert!(
                (found - every).abs() <= 1e-12,
                "{found} against {every} at {p}"
            );
        }
    }

    fn options(samples: usize) -> DistanceOptions {
        DistanceOptions::DEFAULT.with_samples(samples)
    }

    fn close(a: f64, b: f64, tolerance: f64) -> bool {
        (a - b).abs() <= tolerance * b.abs().max(1e-12)
    }

    #[test]
    fn identical_meshes_are_at_distance_zero() {
        let s = uv_sphere(8, 12, 1.0);
        let report = distance(&s, &s.clone(), &options(10_000)).unwrap();
        assert_eq!(report.rms, 0.0);
        assert_eq!(report.hausdorff, 0.0);
        assert_eq!(report.psnr_db, f64::INFINITY);
        assert!(close(report.diag, 2.0 * 3f64.sqrt(), 0.2));
        // Valid JSON: infinity is written as null.
        let json = serde_json::to_string(&report).unwrap();
        let value: serde_json::Value = serde_json::from_str(&json).unwrap();
        assert!(value["psnr_db"].is_null());
    }

    #[test]
    fn same_surface_different_triangulation_is_near_zero() {
        let a = poly(square(0.0));
        let mut b = PolyMesh::from_faces(a.positions.clone(), &[[1u32, 2, 3], [1, 3, 0]]);
        b.positions.push(DVec3::splat(5.0)); // unused, so no effect
        let report = distance(&a, &b, &options(10_000)).unwrap();
        assert!(report.hausdorff < 1e-12, "{report:?}");
        assert!(report.psnr_db > 200.0);
    }

    #[test]
    fn shifted_square_is_at_the_shift() {
        let d = 0.01;
        let report = distance(&poly(square(0.0)), &poly(square(d)), &options(20_000)).unwrap();
        for value in [report.rms, report.mean, report.hausdorff] {
            assert!(close(value, d, 1e-9), "{report:?}");
        }
        assert!(close(report.diag, 2f64.sqrt(), 1e-12));
        assert!(close(
            report.psnr_db,
            20.0 * (2f64.sqrt() / d).log10(),
            1e-9
        ));
        let n = report.a_to_b.samples as f64;
        assert!((n - 20_000.0).abs() < 100.0, "{n}");
    }

    #[test]
    fn scaled_sphere_is_at_about_the_radius_difference() {
        let a = uv_sphere(24, 48, 1.0);
        let b = uv_sphere(24, 48, 1.02);
        let report = distance(&a, &b, &options(50_000)).unwrap();
        // Same tessellation scaled about the centre: every point of A is at
        // most 0.02 from B; near the middle of faces a bit less.
        assert!(report.rms > 0.018 && report.rms < 0.0201, "{report:?}");
        assert!(report.hausdorff <= 0.0201, "{report:?}");
        assert!(report.mean <= report.rms && report.rms <= report.hausdorff);
    }

    #[test]
    fn swapping_the_meshes_swaps_the_directions() {
        let a = uv_sphere(10, 16, 1.0);
        let b = uv_sphere(7, 11, 1.05);
        let ab = distance(&a, &b, &options(20_000)).unwrap();
        let ba = distance(&b, &a, &options(20_000)).unwrap();
        assert_eq!(ab.a_to_b, ba.b_to_a);
        assert_eq!(ab.b_to_a, ba.a_to_b);
        assert_eq!(ab.rms, ba.rms);
        assert_eq!(ab.hausdorff, ba.hausdorff);
    }

    #[test]
    fn more_samples_give_a_stable_estimate() {
        let a = uv_sphere(10, 16, 1.0);
        let b = uv_sphere(7, 11, 1.0);
        let estimates: Vec<f64> = [40_000, 80_000, 160_000]
            .iter()
            .map(|&n| distance(&a, &b, &options(n)).unwrap().rms)
            .collect();
        for e in &estimates {
            assert!(close(*e, estimates[2], 0.01), "{estimates:?}");
        }
        let other_seed = distance(&a, &b, &options(160_000).with_seed(7)).unwrap();
        assert!(close(other_seed.rms, estimates[2], 0.01));
    }

    #[test]
    fn the_same_seed_gives_the_same_report() {
        let a = uv_sphere(10, 16, 1.0);
        let b = uv_sphere(7, 11, 1.0);
        let first = distance(&a, &b, &options(30_000)).unwrap();
        let second = distance(&a, &b, &options(30_000)).unwrap();
        assert_eq!(first, second);
    }

    #[test]
    fn degenerate_inputs_are_errors() {
        let good = poly(square(0.0));
        let empty = PolyMesh::new();
        assert_eq!(
            distance(&empty, &good, &options(10)),
            Err(Error::NoFaces {
                mesh: Some(Side::A)
            })
        );
        let flat = PolyMesh::from_faces(
            vec![DVec3::ZERO, DVec3::X, DVec3::splat(2.0) * DVec3::X],
            &[[0u32, 1, 2]],
        );
        assert_eq!(
            distance(&good, &flat, &options(10)),
            Err(Error::ZeroArea { mesh: Side::B })
        );
        let mut nan = poly(square(0.0));
        nan.positions[2].y = f64::NAN;
        assert_eq!(
            distance(&good, &nan, &options(10)),
            Err(Error::NonFinite {
                mesh: Some(Side::B),
                vertex: 2
            })
        );
        let missing = PolyMesh::from_faces(vec![DVec3::ZERO], &[[0u32, 1, 2]]);
        assert_eq!(
            distance(&missing, &good, &options(10)),
            Err(Error::MissingVertex {
                mesh: Some(Side::A),
                face: 0,
                vertex: 1
            })
        );
        assert_eq!(distance(&good, &good, &options(0)), Err(Error::NoSamples));
    }
}
