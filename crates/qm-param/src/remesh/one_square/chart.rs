//! Charting one part onto a square: the part cut open into a disk (module
//! `cut`), parametrized onto a square of base quads (module `square`),
//! further cuts towards the points of highest stretch while they clearly
//! help, and the square grown until its glued layout is consistent.

use qm_lift::{BaseMesh, Layout, SemiRegularMesh};

use super::density::density;
use crate::remesh::options::RemeshOptions;
use crate::remesh::resample;
use crate::remesh::{cut, square};
use crate::{Error, RemeshFailure, Result, TriMesh};

/// Below this L2 stretch no extra cut is tried.
const GOOD_STRETCH: f64 = 1.25;

/// One part charted onto a square.
pub(super) struct Chart {
    /// The part cut open into a disk.
    pub disk: cut::Disk,
    /// The disk's map onto the square.
    pub map: square::SquareMap,
    /// How many cuts were added towards high stretch.
    pub cuts: usize,
    /// Per triangle, the sample density aimed for (module `density`).
    pub density: Vec<f64>,
}

/// How far [`grow_until_glued`] grows the square past its first size, try
/// by try: one base quad at a time up to 8, then 16 and 32.
const GLUE_GROWTH: [usize; 11] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 16, 32];

/// Gluing a small square can make two base edges share both ends without
/// being mates, which the base mesh would take for one edge: grow the square
/// until the glued layout is consistent (checked at level 1, where every base
/// edge has a midpoint sample). From a first size `K` the sizes asked for
/// are `K, K + 1, ..., K + 8`, then `K + 16` and `K + 32` ([`GLUE_GROWTH`])
/// (each at least one more than the last size laid out), none above
/// `4 max(K, 8)`. A cut that a few more base quads do not mend is seldom
/// mended by many more (its shape is then the problem, not the square's
/// size), and each size costs a parameterization.
pub(super) fn grow_until_glued(
    disk: &cut::Disk,
    density: &[f64],
    mut map: square::SquareMap,
    options: &RemeshOptions,
) -> Result<square::SquareMap> {
    let first = map.k;
    let mut tried = Vec::new();
    loop {
        let probe = resample::resample(disk, &map, 1, 0);
        let problem = match BaseMesh::new(probe.base_vertices, probe.faces) {
            Err(e) => e.to_string(),
            Ok(base) => match Layout::new(base, 1).map(|layout| {
                SemiRegularMesh::from_face_grids(layout, &probe.grids, &probe.positions)
            }) {
                Err(e) | Ok(Err(e)) => e.to_string(),
                Ok(Ok(_)) => return Ok(map),
            },
        };
        tried.push(map.k);
        let next = (GLUE_GROWTH.get(tried.len()))
            .map(|grow| (first + grow).max(map.k + 1))
            .filter(|&k| k <= 4 * first.max(8));
        let Some(next) = next else {
            return Err(Error::remesh(RemeshFailure::DoesNotGlue {
                disk_vertices: disk.positions.len(),
                boundary_edges: disk.boundary.len(),
                sizes: tried,
                problem,
            }));
        };
        map = square::parameterize_k(
            disk,
            density,
            next,
            options.stretch_iterations,
            Some(&map.divisor),
        )?;
    }
}

/// Cuts and parameterizes one component with at least `k_min` base quads a
/// side (and no larger square than `k_max` where a smaller one will do),
/// adding cuts towards high stretch while they help; the samples aim
/// for the component's curvature-driven `density` (computed here at the
/// mean sample `spacing`, and returned with the chart).
pub(super) fn chart(
    mesh: &TriMesh,
    k_min: usize,
    k_max: usize,
    spacing: f64,
    options: &RemeshOptions,
) -> Result<Chart> {
    let topo = cut::Topology::new(mesh);
    let density = density(mesh, &topo, spacing);
    let mut extra: Vec<Vec<u32>> = Vec::new();
    let mut disk = cut::cut_to_disk(mesh, &topo, &extra);
    let mut map = square::parameterize(&disk, &density, k_min, k_max, options.stretch_iterations)?;
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
        let trial = square::parameterize(
            &trial_disk,
            &density,
            k_min,
            k_max,
            options.stretch_iterations,
        )?;
        // A cut adds seams and perimeter segments, and its square may need
        // many more base quads, so it must be clearly better; the first cut
        // that is not ends the search (docs/decisions/013-square-map.md).
        if !square::clearly_better(&trial, &map) || trial.k > map.k.max(k_max) {
            break;
        }
        extra = trial_extra;
        disk = trial_disk;
        map = trial;
    }
    let map = grow_until_glued(&disk, &density, map, options)?;
    let cuts = extra.len();
    Ok(Chart {
        disk,
        map,
        cuts,
        density,
    })
}
