//! [`BaseDomain::Auto`]: both base domains made, measured, and the better
//! taken; a small input whose remesh is not faithful goes as its own
//! triangles.
//!
//! One square per part (module `one_square`) and the simplified base domain
//! (module `simplified`) are made at once where the memory limit holds both,
//! else in turn; the simplified one is taken where one square per part
//! fails or measures [`CLEARLY_BETTER_DB`] worse, and alone where a part
//! has [`MOST_CUT_LOOPS`] or more loops to cut. An input of at most
//! [`EXACT_MOST_TRIANGLES`] triangles whose remesh fails or measures below
//! [`FAITHFUL_DB`] is sent as its own triangles (module `input`) where they
//! measure clearly better (docs/decisions/001-auto-base-domain.md).

use super::finish::measure;
use super::input::remesh_input;
use super::memory::{both_memory, with_memory};
use super::one_square::remesh_square;
#[cfg(doc)]
use super::options::BaseDomain;
use super::options::{RemeshOptions, Remeshed};
use super::simplified::remesh_charts;
use super::steps::{Reporter, Step};
use crate::clean::Cleaned;
use crate::{Error, PolyMesh, RemeshFailure, Result};

/// The loops that cutting a part into a disk takes (`2 genus + holes - 1`)
/// from which [`BaseDomain::Auto`] does not try one square per part: its
/// cut grows with them, and the map stretches along it without bound
/// (docs/decisions/001-auto-base-domain.md).
pub(super) const MOST_CUT_LOOPS: i64 = 16;

/// How much better, in dB, the simplified base domain must measure for
/// [`BaseDomain::Auto`] to take it over one square per part: its base
/// section is larger, which a small gain does not pay for at low rates
/// (docs/decisions/001-auto-base-domain.md).
pub(super) const CLEARLY_BETTER_DB: f64 = 2.0;

/// The most input triangles [`BaseDomain::Auto`] takes as the base itself
/// ([`BaseDomain::Input`]) where the remesh is not faithful: such a base is
/// sent whole before anything shows (docs/decisions/001-auto-base-domain.md).
/// The facade weighs a kept remesh against the input's own triangles up to
/// the same size (docs/decisions/036-rate-choice.md).
pub const EXACT_MOST_TRIANGLES: usize = 20_000;

/// Below this PSNR [`BaseDomain::Auto`] takes a small input's own triangles
/// as the base instead of its remesh ([`EXACT_MOST_TRIANGLES`]), where they
/// measure [`CLEARLY_BETTER_DB`] better.
const FAITHFUL_DB: f64 = 80.0;

/// [`BaseDomain::Auto`] on `cleaned`, the clean-up of `mesh`
/// (`input_triangles` before clean-up): both remeshes and the choice
/// between them, or for a small input its own triangles.
pub(super) fn remesh_auto(
    mesh: &PolyMesh,
    cleaned: Cleaned,
    input_triangles: u64,
    options: &RemeshOptions,
    report: Reporter<'_>,
) -> Result<Remeshed> {
    let triangles: usize = cleaned.components.iter().map(|c| c.triangles.len()).sum();
    let remeshed = remesh_both(mesh, cleaned, input_triangles, options, report);
    // A level asked for is a remesh asked for.
    if triangles > EXACT_MOST_TRIANGLES || options.level.is_some() {
        return remeshed;
    }
    remesh_or_input(mesh, remeshed, triangles, input_triangles)
}

/// Both remeshes, at once where the memory limit holds both, and the
/// choice between them.
fn remesh_both(
    mesh: &PolyMesh,
    cleaned: Cleaned,
    input_triangles: u64,
    options: &RemeshOptions,
    report: Reporter<'_>,
) -> Result<Remeshed> {
    let square = |cleaned: Cleaned| -> Result<Remeshed> {
        let mut square = remesh_square(cleaned, input_triangles, options, report)?;
        report(Step::Measuring);
        square.report.psnr = Some(measure(mesh, &square.mesh)?);
        Ok(square)
    };
    let charts = |cleaned: Cleaned| remesh_charts(mesh, cleaned, input_triangles, options, report);
    if let Some(loops) = too_many_loops(&cleaned) {
        // Charts alone; one square per part only where they fail.
        return match charts(cleaned.clone()) {
            Ok(mut charts) => {
                charts.report.fallback =
                    Some(format!("one square per part was not tried: {loops}"));
                Ok(charts)
            }
            Err(e) => {
                let mut square = square(cleaned).map_err(|_| e.clone())?;
                square.report.fallback = Some(format!("the simplified base domain failed: {e}"));
                Ok(square)
            }
        };
    }
    // The charts remesh made beside the square's, or the clean-up it is to
    // be made from if it is needed.
    // A level asked for makes as many samples as its base quads take, which
    // neither remesh knows before its base is made: then one at a time.
    let both = both_memory(&cleaned, input_triangles, options);
    let (square, made) = if options.level.is_none() && options.admits(both) {
        let copy = cleaned.clone();
        let (s, c) = rayon::join(|| square(copy), || charts(cleaned));
        let at_once = |mut r: Remeshed| {
            r.report.memory = both;
            r
        };
        (s.map(at_once), Ok(c.map(at_once)))
    } else {
        (square(cleaned.clone()), Err(cleaned))
    };
    let charts = move || made.unwrap_or_else(charts);
    match square {
        Ok(square) => {
            let psnr = square.report.psnr.unwrap_or(f64::NEG_INFINITY);
            // The simplified base domain where it measures clearly better
            // (a shape of many handles, a bunny's ears).
            match charts() {
                Ok(mut charts)
                    if charts
                        .report
                        .psnr
                        .is_some_and(|p| p > psnr + CLEARLY_BETTER_DB) =>
                {
                    charts.report.fallback =
                        Some(format!("one square per part measured {psnr:.1} dB"));
                    Ok(charts)
                }
                _ => Ok(square),
            }
        }
        Err(
            e @ Error::Remesh {
                failure:
                    RemeshFailure::DoesNotMap { .. }
                    | RemeshFailure::DoesNotGlue { .. }
                    | RemeshFailure::TooManySegments
                    | RemeshFailure::Folds { .. },
                ..
            },
        ) => {
            // Where neither works: the charts' folds, distance or memory if
            // that is why (the flags that override them apply there), else
            // the square's failure.
            let mut remeshed = charts().map_err(|c| match c {
                Error::Remesh {
                    failure: RemeshFailure::Folds { .. } | RemeshFailure::TooFar { .. },
                    ..
                }
                | Error::Memory { .. } => c,
                _ => e.clone(),
            })?;
            remeshed.report.fallback = Some(format!("one square per part failed: {e}"));
            Ok(remeshed)
        }
        // Over the memory limit where the charts may not be: they alone.
        Err(e @ Error::Memory { .. }) => {
            let mut remeshed = charts()?;
            remeshed.report.fallback = Some(format!("one square per part was not tried: {e}"));
            Ok(remeshed)
        }
        Err(e) => Err(e),
    }
}

/// Which part needs [`MOST_CUT_LOOPS`] or more, said for the report.
fn too_many_loops(cleaned: &Cleaned) -> Option<String> {
    cleaned
        .components
        .iter()
        .enumerate()
        .map(|(c, component)| (c, crate::clean::topology(component)))
        .map(|(c, t)| (c, 2 * t.genus + t.boundary_loops as i64 - 1, t))
        .filter(|&(_, loops, _)| loops >= MOST_CUT_LOOPS)
        .max_by_key(|&(_, loops, _)| loops)
        .map(|(c, loops, t)| {
            format!(
                "part {c} has {loops} loops to cut (genus {}, {} holes)",
                t.genus, t.boundary_loops
            )
        })
}

/// `auto`'s remesh of a small input (`triangles` after clean-up), or the
/// input's own triangles where the remesh failed (not for memory), measures
/// below [`FAITHFUL_DB`] and [`CLEARLY_BETTER_DB`] below them, or took them
/// as its base anyway; its report carries the memory of the remesh tried
/// (`input_triangles` before clean-up).
fn remesh_or_input(
    mesh: &PolyMesh,
    remeshed: Result<Remeshed>,
    triangles: usize,
    input_triangles: u64,
) -> Result<Remeshed> {
    let (psnr, why) = match &remeshed {
        // A base of as many quads as the input's own triangles make is
        // those triangles, and levels over them only add samples of the
        // same flat faces (docs/decisions/001-auto-base-domain.md).
        Ok(r)
            if r.report
                .components
                .iter()
                .map(|c| c.base_quads)
                .sum::<usize>()
                >= 3 * triangles =>
        {
            (
                f64::NEG_INFINITY,
                format!(
                    "the remesh through {} took the input's own triangles as its base",
                    r.report.domain
                ),
            )
        }
        Ok(r) => match r.report.psnr {
            Some(psnr) if psnr < FAITHFUL_DB => (
                psnr,
                format!(
                    "the remesh through {} measured {psnr:.1} dB",
                    r.report.domain
                ),
            ),
            _ => return remeshed,
        },
        // Refused for memory: the user's limit stands.
        Err(Error::Memory { .. }) => return remeshed,
        Err(e) => (f64::NEG_INFINITY, format!("remeshing failed: {e}")),
    };
    // Where the input's triangles make no base either (no area left, say),
    // the remesh's own failure is the one to report.
    let Ok(mut exact) = remesh_input(mesh) else {
        return remeshed;
    };
    // Not clearly better: the remesh streams, and costs less.
    if remeshed.is_ok()
        && exact
            .report
            .psnr
            .is_none_or(|e| e < psnr + CLEARLY_BETTER_DB)
    {
        return remeshed;
    }
    exact.report.fallback = Some(why);
    // The work done is the remesh's and then the input's.
    if let Ok(r) = remeshed {
        exact.report.memory = with_memory(r, input_triangles).report.memory;
    }
    Ok(exact)
}
