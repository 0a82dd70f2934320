//! Sampling through a simplified base domain: each part's input mapped
//! onto its base (module `charts`), the map untangled, refolded where it
//! still folds, its stretch relaxed; then every part resampled at the level,
//! the patches joined (module `finish`) and the remesh measured.
//!
//! A map folds where every chart that draws an input triangle draws it
//! turned over. The untangling moves single vertices into the kernels of
//! their rings, then widening neighbourhoods of what single moves leave
//! folded (knots); where the map still folds, the part is simplified again
//! with the folded triangles' corners kept as base vertices, which lays the
//! map out anew around them (a refold). A map that no longer folds has its
//! stretch relaxed (docs/decisions/004-chart-map-relaxation.md).

use rayon::prelude::*;

use super::bases::BASE_SLACK;
use crate::clean::Cleaned;
use crate::remesh::finish::{check_patch, finish, measure, part};
use crate::remesh::memory::check_memory;
use crate::remesh::options::{ComponentReport, RemeshOptions, Remeshed};
use crate::remesh::steps::{Reporter, Step};
use crate::remesh::{charts, simplify};
use crate::{Error, PolyMesh, RemeshFailure, Result, TriMesh};

/// Most untangling sweeps of the map onto the base domain
/// (`charts::untangle_map`).
const UNTANGLE_ROUNDS: usize = 50;

/// How many times the folds' estimated growth of a stuck part's refold
/// (see [`sample_charts`]) must exceed what [`BASE_SLACK`] allows for the
/// untangling of its knots to stop after its first neighbourhood: wider
/// ones untangle little more, at many times the time
/// (docs/decisions/004-chart-map-relaxation.md).
const KNOT_MARGIN: f64 = 2.0;

/// Most sweeps of the relaxation of the map's stretch
/// (`charts::relax_stretch`). Most inputs stop well before, with no move
/// left worth waking its neighbours for; the cap is for the few that do not
/// (docs/decisions/004-chart-map-relaxation.md).
const STRETCH_SWEEPS: usize = 200;

/// How many times a part whose map still folds is simplified again, its
/// folded triangles' corners kept as base vertices.
const REFOLD_TRIES: usize = 3;

/// Most sweeps of each widening of the untangling of what single moves
/// leave folded (`charts::untangle_knots`).
const UNTANGLE_SWEEPS: usize = 50;

/// Maps each part onto its base, relaxes the map and samples it at
/// `level` (remeshing again around folds towards `refold_goals`), then
/// measures the remesh.
///
/// With `give_up` (the part that would make a shallower level worth it),
/// returns `None` as soon as that part shows that its base is too coarse:
/// its map still folds after the refolds, or a refold needs (or,
/// for a part stuck over its goal, would need) more than [`BASE_SLACK`]
/// times its first base to hold its folded triangles: going on would spend
/// most of the time on a remesh the shallower level beats
/// (docs/decisions/003-level-and-base-size.md).
#[allow(clippy::too_many_arguments)]
pub(super) fn sample_charts(
    mesh: &PolyMesh,
    cleaned: Cleaned,
    mut bases: Vec<simplify::Base>,
    level: u32,
    refold_goals: &[usize],
    give_up: Option<usize>,
    input_triangles: u64,
    options: &RemeshOptions,
    report: Reporter<'_>,
) -> Result<Option<Remeshed>> {
    let check_memory = |bases: &[simplify::Base]| -> Result<()> {
        let quads: usize = bases.iter().map(|b| 3 * b.triangles.len()).sum();
        let samples = quads as f64 * ((1u64 << level) as f64 + 1.0).powi(2);
        let parts = bases.len() as u64;
        check_memory(input_triangles, parts, samples as u64, true, options)
    };
    check_memory(&bases)?;
    // Charting, untangling, refolding and relaxing, part by part (`None`:
    // the part gave up).
    let domains: Vec<Option<charts::Domain>> = bases
        .par_iter_mut()
        .zip(&cleaned.components)
        .enumerate()
        .map(|(c, (base, component))| {
            map_part(c, component, base, refold_goals[c], give_up == Some(c))
        })
        .collect::<Result<_>>()?;
    let Some(domains) = domains.into_iter().collect::<Option<Vec<_>>>() else {
        return Ok(None);
    };
    // Again for the bases sampled: a part simplified again around its folds
    // may have another.
    check_memory(&bases)?;
    let mut patches = Vec::with_capacity(bases.len());
    for (c, ((base, component), domain)) in bases
        .iter()
        .zip(&cleaned.components)
        .zip(&domains)
        .enumerate()
    {
        let (patch, folded) = charts::resample(component, base, domain, level, options.fit_rounds)
            .map_err(|e| e.in_part(|| part(c, component)))?;
        if folded > 0 && !options.accept_folds {
            let failure = RemeshFailure::Folds {
                folded,
                triangles: component.triangles.len(),
            };
            return Err(Error::remesh(failure).in_part(|| part(c, component)));
        }
        check_patch(c, component, 0.0, folded, &patch.positions)?;
        let report = ComponentReport {
            vertices: component.positions.len(),
            triangles: component.triangles.len(),
            base_quads: 3 * base.triangles.len(),
            extra_cuts: 0,
            stretch: 0.0,
            flipped: folded,
            uncovered: patch.uncovered,
        };
        patches.push((patch, report));
    }
    let mut remeshed = finish(cleaned, patches, level, options, true)?;
    remeshed.report.domain = "charts";
    report(Step::Measuring);
    let psnr = measure(mesh, &remeshed.mesh)?;
    remeshed.report.psnr = Some(psnr);
    if psnr < options.min_psnr {
        return Err(Error::remesh(RemeshFailure::TooFar {
            psnr,
            floor: options.min_psnr,
        }));
    }
    Ok(Some(remeshed))
}

/// Part `c`'s map onto its base: charted (`charts::Domain`), untangled,
/// simplified again around its folds while it still folds (towards
/// `refold_goal`), and relaxed where it no longer does. `None` where the
/// part `gives_up` (see [`sample_charts`]) and shows that its base is too
/// coarse.
fn map_part(
    c: usize,
    component: &TriMesh,
    base: &mut simplify::Base,
    refold_goal: usize,
    gives_up: bool,
) -> Result<Option<charts::Domain>> {
    let size = base.triangles.len();
    let too_coarse = |triangles: f64| gives_up && triangles > BASE_SLACK * size as f64;
    // A part stuck above its goal cannot trade other base vertices
    // for the folded triangles' corners: each corner kept adds about
    // two base triangles (Euler's formula), so the refold's size can
    // be estimated before it is made, a lower estimate
    // (docs/decisions/003-level-and-base-size.md).
    let stuck = gives_up && size as f64 > BASE_SLACK * refold_goal as f64;
    let estimate = |base: &simplify::Base, folded: &[u32]| -> f64 {
        let mut corners: Vec<u32> = folded
            .iter()
            .flat_map(|&t| component.triangles[t as usize])
            .filter(|&v| matches!(base.location[v as usize], simplify::Location::Face(..)))
            .collect();
        corners.sort_unstable();
        corners.dedup();
        (size + 2 * corners.len()) as f64
    };
    // The untangling stops early where even a fraction of the
    // folds it has left would make the refold too coarse.
    let hopeless = |base: &simplify::Base, folded: &[u32]| {
        stuck && too_coarse(size as f64 + KNOT_MARGIN * (estimate(base, folded) - size as f64))
    };
    let map = |base: &mut simplify::Base,
               hopeless: &dyn Fn(&simplify::Base, &[u32]) -> bool|
     -> Result<(charts::Domain, Vec<u32>)> {
        let domain =
            charts::Domain::new(component, base).map_err(|e| e.in_part(|| part(c, component)))?;
        charts::untangle_map(component, base, &domain, UNTANGLE_ROUNDS);
        let folded = charts::untangle_knots(component, base, &domain, UNTANGLE_SWEEPS, hopeless);
        Ok((domain, folded))
    };
    let (mut domain, mut folded) = map(base, &hopeless)?;
    // Where the map still folds, the folded triangles' corners stay
    // base vertices in a new simplification, which lays the map out
    // anew around them; the try with the fewest folds is kept.
    let mut keep = vec![false; component.positions.len()];
    let mark = |keep: &mut [bool], folds: &[u32]| {
        for &t in folds {
            for v in component.triangles[t as usize] {
                keep[v as usize] = true;
            }
        }
    };
    mark(&mut keep, &folded);
    if stuck && !folded.is_empty() && too_coarse(estimate(base, &folded)) {
        return Ok(None);
    }
    for _ in 0..REFOLD_TRIES {
        if folded.is_empty() {
            break;
        }
        // As many base triangles as the first try made: a part that
        // could not come down to its goal asks for no more.
        let mut again =
            simplify::simplify_keeping(component, refold_goal, size, &keep, base.noisy_creases);
        if too_coarse(again.triangles.len() as f64) {
            return Ok(None);
        }
        let (d, f) = map(&mut again, &|_, _| false)?;
        mark(&mut keep, &f);
        if f.len() <= folded.len() {
            (*base, domain, folded) = (again, d, f);
        }
    }
    if folded.is_empty() {
        charts::relax_stretch(component, base, &domain, STRETCH_SWEEPS);
    } else if gives_up {
        return Ok(None);
    }
    Ok(Some(domain))
}
