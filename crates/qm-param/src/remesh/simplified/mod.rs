//! Remeshing through a simplified base domain
//! ([`BaseDomain::Charts`](crate::remesh::BaseDomain::Charts), MAPS): each
//! part simplified to a coarse base of triangles, the input mapped onto it,
//! and the base's quads sampled.
//!
//! In order, after the clean-up: the level and each part's base for it
//! (module `bases`, simplification by module `simplify`); each part charted
//! onto its base, its map untangled, refolded and relaxed, then resampled
//! (module `sample`, through module `charts`); the patches joined and the
//! remesh measured (module `finish`). A remesh that measures below
//! [`RETRY_BELOW_DB`] is made again one level shallower, and the better
//! kept.

mod bases;
mod sample;

use bases::{Bases, simplify_to_bases};
use sample::sample_charts;

use super::options::{RemeshOptions, Remeshed};
use super::simplify;
use super::steps::{Reporter, Step};
use crate::clean::Cleaned;
use crate::{PolyMesh, Result};

/// A remesh through charts at the level chosen that measures below this
/// (or fails) is made again one level shallower, on four times as many
/// base triangles, and the better kept. On a coarse base the map squeezes
/// what stands out of it, and the relaxation of single vertices opens a
/// squeezed region only slowly (docs/decisions/003-level-and-base-size.md).
const RETRY_BELOW_DB: f64 = 75.0;

/// Remeshes through a simplified base domain (modules `simplify`, `charts`).
/// `mesh` is the input, for the remesh's measure; `cleaned` its clean-up.
pub(super) fn remesh_charts(
    mesh: &PolyMesh,
    cleaned: Cleaned,
    input_triangles: u64,
    options: &RemeshOptions,
    report: Reporter<'_>,
) -> Result<Remeshed> {
    // Simplification to a base: the level, and each part's base for it.
    report(Step::Simplifying);
    let Bases {
        bases,
        level,
        shallower,
        refold_goals,
        shares,
    } = simplify_to_bases(&cleaned, options)?;
    // Charting, untangling, relaxing, resampling and measuring at a level.
    let sample = |bases: Vec<simplify::Base>, level: u32, give_up: Option<usize>| {
        report(Step::MappingCharts);
        sample_charts(
            mesh,
            cleaned.clone(),
            bases,
            level,
            &refold_goals,
            give_up,
            input_triangles,
            options,
            report,
        )
    };
    // A remesh made to the end: only a part allowed to give up does.
    let whole = |bases: Vec<simplify::Base>, level: u32| {
        sample(bases, level, None).map(|r| r.expect("only a part allowed to give up does"))
    };
    let Some(shallower) = shallower else {
        return whole(bases, level);
    };
    // The part holding most of the surface, where a shallower level gives
    // it a larger base: where its base shows too coarse, the first try
    // gives up for the shallower level. Every part's base grows four times
    // there, which only the part deciding most of the error is worth
    // (docs/decisions/003-level-and-base-size.md).
    let decider = (0..bases.len())
        .find(|&c| shares[c] > 0.5 && shallower[c].triangles.len() > bases[c].triangles.len());
    // The bases again for a first try that gave up, should the shallower
    // level fail too.
    let kept = decider.map(|_| bases.clone());
    let first = sample(bases, level, decider).transpose();
    let poor = first.as_ref().is_none_or(|first| {
        first
            .as_ref()
            .map_or(true, |r| r.report.psnr.is_some_and(|p| p < RETRY_BELOW_DB))
    });
    if !poor {
        return first.expect("a first try that did not give up");
    }
    let second = whole(shallower, level - 1);
    let first = match (first, kept) {
        (Some(first), _) => first,
        (None, Some(bases)) if second.is_err() => whole(bases, level),
        _ => return second,
    };
    let psnr = |r: &Result<Remeshed>| {
        r.as_ref()
            .ok()
            .and_then(|r| r.report.psnr)
            .unwrap_or(f64::NEG_INFINITY)
    };
    if second.is_ok() && psnr(&second) > psnr(&first) {
        second
    } else {
        first
    }
}
