//! Remeshing any triangle mesh into a semi-regular quad mesh.
//!
//! Per connected component, after clean-up ([`crate::clean`]):
//! 1. cut it open into a disk (module `cut`): boundaries, `2g` loops for genus `g`
//!    and paths joining them, or one long path on a closed sphere;
//! 2. map the disk onto the unit square (module `square`): boundary by arc length
//!    with the two sides of every cut given equal lengths, interior by
//!    mean-value coordinates, then stretch-reweighted;
//! 3. add cuts from the points of highest stretch to the cut (Gu, Gortler
//!    and Hoppe's geometry images do the same) while that lowers the stretch;
//! 4. sample the square on a `(K 2^L + 1)^2` grid, `K x K` base quads, and
//!    glue the sides of each cut so that seam mates are one sample.
//!
//! Holes stay holes: real boundaries are laid on the square's perimeter
//! unglued, so no surface is added.

mod cut;
mod resample;
mod square;

use qm_lift::glam::DVec3;
use qm_lift::{BaseMesh, Layout, SemiRegularMesh};

use crate::clean::{CleanReport, clean};
use crate::{Error, PolyMesh, Result, TriMesh};

/// Below this L2 stretch no extra cut is tried.
const GOOD_STRETCH: f64 = 1.25;

/// The remesher never makes more samples than this many per input vertex.
pub const MAX_SAMPLES_PER_VERTEX: f64 = 32.0;

/// Remesher settings.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct RemeshOptions {
    /// Subdivision level `L`; `None` picks it from [`Self::samples_per_vertex`].
    pub level: Option<u32>,
    /// Samples to aim for per input vertex when choosing the level.
    pub samples_per_vertex: f64,
    /// Most samples to aim for, whatever the input's size (dense scans need
    /// far fewer samples per vertex than coarse models).
    pub max_samples: usize,
    /// Stretch-reweighting iterations of the parameterization.
    pub stretch_iterations: usize,
    /// Most extra cuts towards points of high stretch, per component.
    pub extra_cuts: usize,
}

impl RemeshOptions {
    /// Defaults: level for about 30 samples per input vertex but at most
    /// about a million samples, 7 stretch
    /// iterations, up to 2 extra cuts per component.
    pub const DEFAULT: RemeshOptions = RemeshOptions {
        level: None,
        samples_per_vertex: 30.0,
        max_samples: 1 << 20,
        stretch_iterations: 7,
        extra_cuts: 2,
    };

    /// Sets the level.
    pub const fn with_level(mut self, level: Option<u32>) -> Self {
        self.level = level;
        self
    }

    /// Sets the sample density target.
    pub const fn with_samples_per_vertex(mut self, ratio: f64) -> Self {
        self.samples_per_vertex = ratio;
        self
    }

    /// Sets the number of extra cuts.
    pub const fn with_extra_cuts(mut self, cuts: usize) -> Self {
        self.extra_cuts = cuts;
        self
    }

    /// Sets the stretch iterations.
    pub const fn with_stretch_iterations(mut self, iterations: usize) -> Self {
        self.stretch_iterations = iterations;
        self
    }
}

impl Default for RemeshOptions {
    fn default() -> Self {
        RemeshOptions::DEFAULT
    }
}

/// What the remesher did to one component.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ComponentReport {
    pub vertices: usize,
    pub triangles: usize,
    pub base_quads: usize,
    pub extra_cuts: usize,
    pub stretch: f64,
    pub flipped: usize,
    pub uncovered: usize,
}

/// A remeshed mesh.
#[derive(Clone, Debug)]
pub struct Remeshed {
    /// The semi-regular mesh.
    pub mesh: SemiRegularMesh,
    /// What the remesher did.
    pub report: RemeshReport,
}

/// What the remesher did: clean-up and each component's chart.
#[derive(Clone, Debug)]
pub struct RemeshReport {
    /// The clean-up summary.
    pub clean: CleanReport,
    /// Per component.
    pub components: Vec<ComponentReport>,
    /// The subdivision level chosen.
    pub level: u32,
}

/// Remeshes `mesh` into a semi-regular quad mesh.
pub fn remesh(mesh: &PolyMesh, options: &RemeshOptions) -> Result<Remeshed> {
    let cleaned = clean(mesh)?;
    let input_vertices: usize = cleaned.components.iter().map(|c| c.positions.len()).sum();
    let total_area: f64 = cleaned.components.iter().map(TriMesh::area).sum();
    if cleaned.components.is_empty() || total_area <= 0.0 {
        return Err(Error::Remesh(
            "nothing with area left after clean-up".into(),
        ));
    }
    // Parameterize each component with the fewest base quads it needs.
    let mut charts = Vec::new();
    for c in &cleaned.components {
        charts.push(chart(c, 3, options)?);
    }
    // One level for all, the highest at which every component's square still
    // fits its share of the target; then each square grows to its share.
    // Never more than MAX_SAMPLES_PER_VERTEX times the input's vertices.
    let target = (options.samples_per_vertex.min(MAX_SAMPLES_PER_VERTEX) * input_vertices as f64)
        .min(options.max_samples as f64);
    let shares: Vec<f64> = cleaned
        .components
        .iter()
        .map(|c| c.area() / total_area)
        .collect();
    let side = |c: usize| (target * shares[c]).sqrt();
    let level = match options.level {
        Some(l) => l,
        None => {
            // Rounding the level up when that overshoots by at most 15%
            // keeps the base mesh small (fewer, larger base quads).
            let fit = |slack: f64| {
                (0..charts.len())
                    .map(|c| (slack * side(c) / charts[c].1.k as f64).log2().floor())
                    .fold(f64::INFINITY, f64::min)
                    .clamp(1.0, qm_lift::MAX_LEVEL as f64) as u32
            };
            let samples = |level: u32| -> f64 {
                charts
                    .iter()
                    .map(|(_, m, _)| ((m.k << level) as f64 + 1.0).powi(2))
                    .sum()
            };
            let cap = MAX_SAMPLES_PER_VERTEX * input_vertices as f64;
            let loose = fit(1.15);
            if samples(loose) <= cap {
                loose
            } else {
                fit(1.0)
            }
        }
    };
    if options.level.is_none() {
        for (c, chart) in charts.iter_mut().enumerate() {
            // Nearest size to the share, unless rounding up breaks the cap.
            let exact = side(c) / (1u64 << level) as f64;
            let cap_side = (MAX_SAMPLES_PER_VERTEX * shares[c] * input_vertices as f64).sqrt();
            let want = if (exact.round() * (1u64 << level) as f64) < cap_side {
                exact.round()
            } else {
                exact.floor()
            } as usize;
            if want > chart.1.k {
                let map = square::parameterize_k(&chart.0, want, options.stretch_iterations)?;
                chart.1 = fit(&chart.0, map, options)?;
            }
        }
    }
    // Sample and stitch every component, then join them.
    let mut faces = Vec::new();
    let mut grids = Vec::new();
    let mut positions: Vec<DVec3> = Vec::new();
    let mut base_vertices = 0u32;
    let mut reports = Vec::new();
    for ((disk, map, cuts), component) in charts.iter().zip(&cleaned.components) {
        let patch = resample::resample(disk, map, level);
        let (bo, so) = (base_vertices, positions.len() as u32);
        faces.extend(patch.faces.iter().map(|f| f.map(|v| v + bo)));
        grids.extend(patch.grids.iter().map(|&s| s + so));
        positions.extend_from_slice(&patch.positions);
        base_vertices += patch.base_vertices;
        reports.push(ComponentReport {
            vertices: component.positions.len(),
            triangles: component.triangles.len(),
            base_quads: map.k * map.k,
            extra_cuts: *cuts,
            stretch: map.stretch,
            flipped: map.flipped,
            uncovered: patch.uncovered,
        });
    }
    let base = BaseMesh::new(base_vertices, faces)
        .map_err(|e| Error::Remesh(format!("the glued base mesh is invalid: {e}")))?;
    let layout = Layout::new(base, level)?;
    let (mesh, _) = SemiRegularMesh::from_face_grids(layout, &grids, &positions)?;
    Ok(Remeshed {
        mesh,
        report: RemeshReport {
            clean: cleaned.report,
            components: reports,
            level,
        },
    })
}

/// Gluing a small square can make two base edges share both ends without
/// being mates, which the base mesh would take for one edge: grow the square
/// until the glued layout is consistent (checked at level 1, where every base
/// edge has a midpoint sample).
fn fit(
    disk: &cut::Disk,
    mut map: square::SquareMap,
    options: &RemeshOptions,
) -> Result<square::SquareMap> {
    let first = map.k;
    loop {
        let probe = resample::resample(disk, &map, 1);
        let glued = BaseMesh::new(probe.base_vertices, probe.faces)
            .ok()
            .and_then(|base| Layout::new(base, 1).ok())
            .is_some_and(|layout| {
                SemiRegularMesh::from_face_grids(layout, &probe.grids, &probe.positions).is_ok()
            });
        if glued {
            return Ok(map);
        }
        if map.k > 4 * first.max(8) {
            return Err(Error::Remesh(
                "could not glue the cut into a valid base mesh".into(),
            ));
        }
        map = square::parameterize_k(disk, map.k + 1, options.stretch_iterations)?;
    }
}

/// Cuts and parameterizes one component with at least `k_min` base quads a
/// side, adding cuts towards high stretch while they help.
fn chart(
    mesh: &TriMesh,
    k_min: usize,
    options: &RemeshOptions,
) -> Result<(cut::Disk, square::SquareMap, usize)> {
    let topo = cut::Topology::new(mesh);
    let mut extra: Vec<Vec<u32>> = Vec::new();
    let mut disk = cut::cut_to_disk(mesh, &topo, &extra);
    let mut map = square::parameterize(&disk, k_min, options.stretch_iterations)?;
    for _ in 0..options.extra_cuts {
        // Sampling is already close to even: a cut would only add seams.
        if map.stretch < GOOD_STRETCH {
            break;
        }
        // The vertex of highest stretch, joined to the nearest cut vertex.
        let Some(worst) = (0..disk.positions.len())
            .max_by(|&a, &b| map.vertex_stretch[a].total_cmp(&map.vertex_stretch[b]))
        else {
            break;
        };
        let from = disk.origin[worst];
        let (dist, pred) = cut::shortest_paths(mesh, &topo, from);
        let Some(to) = disk
            .boundary
            .iter()
            .map(|&b| disk.origin[b as usize])
            .min_by(|&a, &b| dist[a as usize].total_cmp(&dist[b as usize]))
        else {
            break;
        };
        if to == from || !dist[to as usize].is_finite() {
            break;
        }
        let path = cut::path_to(&pred, to);
        let mut trial_extra = extra.clone();
        trial_extra.push(path);
        let trial_disk = cut::cut_to_disk(mesh, &topo, &trial_extra);
        let trial = square::parameterize(&trial_disk, k_min, options.stretch_iterations)?;
        if (trial.flipped, trial.stretch) >= (map.flipped, map.stretch) {
            break;
        }
        extra = trial_extra;
        disk = trial_disk;
        map = trial;
    }
    let map = fit(&disk, map, options)?;
    let cuts = extra.len();
    Ok((disk, map, cuts))
}
