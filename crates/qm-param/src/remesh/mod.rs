//! Remeshing any triangle mesh into a semi-regular quad mesh.
//!
//! [`remesh`] takes the input at a unit scale, refuses it where the memory
//! it needs is over the limit (module `memory`), cleans it up into
//! manifold parts ([`crate::clean`]) and remeshes them through the base
//! domain asked for ([`BaseDomain`], module `options`):
//!
//! - one square per part (module `one_square`): each part cut open into a
//!   disk (module `cut`: boundaries, `2g` loops for genus `g` and paths
//!   joining them, or one long path on a closed sphere) and parametrized
//!   onto a square (module `square`: boundary by arc length with the two
//!   sides of every cut given equal lengths, interior by mean-value
//!   coordinates, stretch-reweighted towards a curvature-driven density),
//!   with extra cuts towards the points of highest stretch while they
//!   clearly help (as Gu, Gortler and Hoppe's geometry images do); the
//!   square sampled on a `(K 2^L + 1)^2` grid, `K x K` base quads, its cuts'
//!   sides glued so that seam mates are one sample;
//! - a simplified base domain (module `simplified`, MAPS): each part
//!   simplified to a coarse base of triangles (module `simplify`), the
//!   input charted onto it, the map untangled and its stretch relaxed
//!   (module `charts`), and the base's quads sampled through the map;
//! - both, measured, and the better (module `auto`); or the input's own
//!   triangles (module `input`).
//!
//! Either way the samples are fitted to the surface in the least-squares
//! sense (module `resample`), so that the quads straddle the surface rather
//! than cut under its bends. The parts' patches are joined into one mesh
//! (module `finish`) and, with [`RemeshOptions::normal`] (the default), the
//! samples are placed again, coarse to fine, where that is safe, on the ray
//! from the codec's prediction along its frame normal, so that their
//! details are normal (module `normal`, a normal mesh), and fitted again
//! along those rays. The report says what was done ([`RemeshReport`]).
//!
//! Holes stay holes: real boundaries are laid on the square's perimeter
//! unglued, so no surface is added.

mod charts;
mod cut;
mod exact;
mod lu;
mod normal;
mod resample;
mod simplify;
mod square;
mod surface;

mod auto;
mod budget;
mod finish;
mod input;
mod memory;
mod one_square;
mod options;
mod simplified;
mod steps;
#[cfg(test)]
mod tests;

use qm_io::PolyMesh;
use qm_lift::SemiRegularMesh;

pub use auto::EXACT_MOST_TRIANGLES;
pub use budget::{DENSE_SAMPLES_PER_VERTEX, MAX_SAMPLES_PER_VERTEX};
use memory::with_memory;
pub use memory::{
    BYTES_PER_PART, BYTES_PER_SAMPLE, BYTES_PER_TRIANGLE, FACTOR_BYTES_PER_UNKNOWN_LOG2,
    FIXED_BYTES, MEASURE_BYTES_PER_SAMPLE, SYSTEM_BYTES_PER_UNKNOWN, check_memory, encode_memory,
    square_system_memory,
};
pub use options::{
    BaseDomain, ComponentReport, DEFAULT_MAX_MEMORY, DEFAULT_MIN_PSNR, NormalReport, RemeshOptions,
    RemeshReport, Remeshed,
};
pub use steps::{Reporter, Step};

use crate::clean::clean;
use crate::error::Result;

/// Remeshes `mesh` into a semi-regular quad mesh.
///
/// With [`BaseDomain::Auto`] both base domains are tried and measured: the
/// simplified one is taken where one square per part fails or measures at
/// least [`CLEARLY_BETTER_DB`](auto::CLEARLY_BETTER_DB) worse, and the report
/// says why ([`RemeshReport::fallback`]); a small input whose remesh is not
/// faithful is taken as its own triangles ([`BaseDomain::Input`]).
///
/// A mesh of any unit is remeshed alike: one whose extent is far from 1
/// (light years, nanometres) is scaled by a power of two
/// ([`qm_lift::unit_scale`], exact both ways) for the work and scaled back.
pub fn remesh(mesh: &PolyMesh, options: &RemeshOptions) -> Result<Remeshed> {
    remesh_reporting(mesh, options, &|_| {})
}

/// [`remesh`], announcing each [`Step`] to `report` as it starts.
pub fn remesh_reporting(
    mesh: &PolyMesh,
    options: &RemeshOptions,
    report: Reporter<'_>,
) -> Result<Remeshed> {
    let scale = qm_lift::unit_scale(&mesh.positions);
    if scale == 1.0 {
        return remesh_at_scale(mesh, options, report);
    }
    let scaled = crate::distance::scaled(mesh, scale);
    let Remeshed { mesh, report } = remesh_at_scale(&scaled, options, report)?;
    let (layout, positions) = mesh.into_parts();
    let positions = positions.into_iter().map(|p| p / scale).collect();
    Ok(Remeshed {
        mesh: SemiRegularMesh::new(layout, positions)?,
        report,
    })
}

/// [`remesh`] at a unit scale, step by step.
fn remesh_at_scale(
    mesh: &PolyMesh,
    options: &RemeshOptions,
    report: Reporter<'_>,
) -> Result<Remeshed> {
    let clean = |mesh: &PolyMesh| {
        report(Step::Cleaning);
        clean(mesh)
    };
    // Refused before any work where the input alone is over the memory
    // limit; each pipeline checks again before it makes its samples.
    let input_triangles = mesh.faces().map(|f| f.len().saturating_sub(2) as u64).sum();
    check_memory(input_triangles, 0, 0, false, options)?;
    let remeshed = match options.domain {
        // The input's own triangles, zero-thickness sheets kept, at level 0.
        BaseDomain::Input => input::remesh_as_asked(mesh, options.level),
        // Clean-up; per part charting (a cut to a disk), parametrization
        // onto a square; one level; resampling.
        BaseDomain::Square => {
            one_square::remesh_square(clean(mesh)?, input_triangles, options, report)
        }
        // Clean-up; simplification to a base; charting onto it, untangling
        // and relaxing; resampling; the measure.
        BaseDomain::Charts => {
            simplified::remesh_charts(mesh, clean(mesh)?, input_triangles, options, report)
        }
        // Clean-up; both of the above, measured, and the better.
        BaseDomain::Auto => auto::remesh_auto(mesh, clean(mesh)?, input_triangles, options, report),
    };
    // Reporting: the memory estimate of the work done.
    remeshed.map(|r| with_memory(r, input_triangles))
}
