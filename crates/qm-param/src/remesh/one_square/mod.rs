//! One square per part ([`BaseDomain::Square`], the first design): each
//! part cut open into a disk and mapped onto a square of `K x K` base
//! quads, all parts sampled at one level `L`.
//!
//! In order, after the clean-up: a part of a few triangles is split at its
//! midpoints ([`SMALL_PART`]); each part is charted onto its smallest square
//! (module `chart`: cut, parametrization, extra cuts) aiming at a
//! curvature-driven density (module `density`); one level is chosen for all
//! parts and each square grows to its share there (module `level`); then
//! every part is resampled on its `(K 2^L + 1)^2` grid (module `resample`)
//! and the patches are joined (module `finish`).

mod chart;
mod density;
mod level;

use chart::{chart, grow_until_glued};
use level::Sizing;
pub(super) use level::square_samples;

use super::budget::{MAX_SAMPLES_PER_VERTEX, area_shares, target_samples};
use super::finish::{check_patch, finish, part};
use super::memory::{check_memory, encode_memory, largest_square_system, refuse_above};
use super::options::{BaseDomain, ComponentReport, RemeshOptions, Remeshed};
use super::steps::{Reporter, Step};
use super::{resample, square};
use crate::clean::Cleaned;
use crate::{Error, RemeshFailure, Result};

/// Components with fewer triangles are split at their edges' midpoints
/// (the same surface) until they have at least this many. A chart of a few
/// triangles cannot reach the square's corners, and its map folds
/// (docs/decisions/020-small-parts.md).
const SMALL_PART: usize = 64;

/// Squares larger than a component's share of the samples at this level are
/// not tried for it, neither as a larger size nor for an extra cut. A part
/// that small (a splinter, a button) is sampled beyond its share at any
/// level the rest of the mesh takes, and a larger square only adds samples
/// and base quads to it (docs/decisions/020-small-parts.md).
const PART_LEVEL: u32 = 3;

/// Remeshes each component onto one square (the first design).
pub(super) fn remesh_square(
    mut cleaned: Cleaned,
    input_triangles: u64,
    options: &RemeshOptions,
    report: Reporter<'_>,
) -> Result<Remeshed> {
    report(Step::MappingSquares);
    let input_vertices: usize = cleaned.components.iter().map(|c| c.positions.len()).sum();
    for c in &mut cleaned.components {
        while c.triangles.len() < SMALL_PART {
            *c = c.split_at_midpoints();
        }
    }
    let (total_area, shares) = area_shares(&cleaned.components)?;
    // Never more than MAX_SAMPLES_PER_VERTEX times the input's vertices.
    let target = target_samples(options, input_vertices);
    // Refused before charting where the largest part's system beside the
    // samples aimed for is over the limit.
    let parts = cleaned.components.len() as u64;
    let measured = options.domain == BaseDomain::Auto;
    let system = largest_square_system(&cleaned);
    let needed = |samples: u64| {
        encode_memory(input_triangles, parts, samples, measured).saturating_add(system)
    };
    refuse_above(
        needed(target as u64),
        options,
        input_triangles,
        target as u64,
    )?;
    let spacing = (total_area / target).sqrt();
    let sizing = Sizing {
        target,
        cap: MAX_SAMPLES_PER_VERTEX * input_vertices as f64,
        shares,
    };
    // Parameterize each component with the fewest base quads it needs, and
    // no more than its share affords at `PART_LEVEL`.
    let mut charts = Vec::new();
    for (c, component) in cleaned.components.iter().enumerate() {
        let k_max = (sizing.side(c) / f64::from(1u32 << PART_LEVEL)) as usize;
        let made = chart(component, 3, k_max.max(3), spacing, options);
        charts.push(made.map_err(|e| e.in_part(|| part(c, component)))?);
    }
    // One level for all, chosen by how many samples it gives the components
    // whose squares fit their share of the target there (small ones may be
    // oversampled instead, within bounds); then each square grows to its
    // share.
    let level = options.level.unwrap_or_else(|| sizing.level(&charts));
    if options.level.is_none() {
        let (_, taken, limit) = sizing.oversampled(&charts, level);
        let room = limit - taken;
        for (c, chart) in charts.iter_mut().enumerate() {
            let want = sizing.size(c, level, chart.map.k, room);
            if want > chart.map.k {
                let grown = square::parameterize_k(
                    &chart.disk,
                    &chart.density,
                    want,
                    options.stretch_iterations,
                    Some(&chart.map.divisor),
                )
                .and_then(|map| grow_until_glued(&chart.disk, &chart.density, map, options));
                let component = &cleaned.components[c];
                chart.map = grown.map_err(|e| e.in_part(|| part(c, component)))?;
            }
        }
    }
    // The level's samples, before any is made.
    let samples: f64 = charts.iter().map(|c| square_samples(c.map.k, level)).sum();
    check_memory(input_triangles, parts, samples as u64, measured, options)?;
    // A chart whose map folds would give a remesh that overlaps itself.
    for (c, (chart, component)) in charts.iter().zip(&cleaned.components).enumerate() {
        if chart.map.flipped > 0 && !options.accept_folds {
            let failure = RemeshFailure::Folds {
                folded: chart.map.flipped,
                triangles: component.triangles.len(),
            };
            return Err(Error::remesh(failure).in_part(|| part(c, component)));
        }
    }
    // Sample and stitch every component.
    report(Step::SamplingSquares);
    let mut patches = Vec::with_capacity(charts.len());
    for (c, (chart, component)) in charts.iter().zip(&cleaned.components).enumerate() {
        let map = &chart.map;
        let patch = resample::resample(&chart.disk, map, level, options.fit_rounds);
        check_patch(c, component, map.stretch, map.flipped, &patch.positions)?;
        let report = ComponentReport {
            vertices: component.positions.len(),
            triangles: component.triangles.len(),
            base_quads: map.k * map.k,
            extra_cuts: chart.cuts,
            stretch: map.stretch,
            flipped: map.flipped,
            uncovered: patch.uncovered,
        };
        patches.push((patch, report));
    }
    // The report's estimate: the systems' peak, past now, with the rest.
    let mut remeshed = finish(cleaned, patches, level, options, false)?;
    remeshed.report.memory = remeshed.report.memory.max(needed(samples as u64));
    Ok(remeshed)
}
