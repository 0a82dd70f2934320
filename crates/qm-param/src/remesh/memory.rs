//! The memory model of remeshing and encoding: how many bytes the work
//! takes, estimated before it is done, and the refusal of work over the
//! limit ([`RemeshOptions::max_memory`]).
//!
//! The estimate is linear: `FIXED_BYTES + BYTES_PER_TRIANGLE t +
//! BYTES_PER_PART p + (BYTES_PER_SAMPLE + MEASURE_BYTES_PER_SAMPLE) s` for
//! `t` input triangles in `p` parts remeshed into `s` samples (the measure's
//! term only where the remesh is measured against its input), fitted to the
//! peaks `cargo xtask memory` measures (docs/decisions/008-memory-model.md).

use super::budget::target_samples;
use super::options::{RemeshOptions, Remeshed};
use super::square::LU_BELOW;
use crate::clean::Cleaned;
use crate::{Error, Result};

/// Bytes that remeshing and then encoding hold whatever the mesh (the
/// process, thread stacks and pools, per-level tables). Fitted with the
/// terms below to peaks `cargo xtask memory` measures
/// (docs/decisions/008-memory-model.md).
pub const FIXED_BYTES: u64 = 24 << 20;

/// Bytes that remeshing and then encoding hold per input triangle (clean-up,
/// the simplifier or the parametrization, the surfaces of normal placement
/// and of the holds) (docs/decisions/008-memory-model.md).
pub const BYTES_PER_TRIANGLE: u64 = 800;

/// Bytes that remeshing and then encoding hold per sample
/// (docs/decisions/008-memory-model.md).
pub const BYTES_PER_SAMPLE: u64 = 280;

/// Bytes per sample that measuring a remesh against its input adds (the
/// distance's search structures over the remesh's triangles, while the
/// remesh is held) (docs/decisions/008-memory-model.md).
pub const MEASURE_BYTES_PER_SAMPLE: u64 = 180;

/// Bytes per part of the cleaned input (its domain, map and solver)
/// (docs/decisions/008-memory-model.md).
pub const BYTES_PER_PART: u64 = 20 << 10;

/// Bytes per unknown of one square map's sparse system solved by
/// Cholesky and BiCGSTAB (the weights twice, the mean-value operator, the
/// solver's vectors and scratch), beside its factor
/// (docs/decisions/008-memory-model.md).
pub const SYSTEM_BYTES_PER_UNKNOWN: u64 = 650;

/// Bytes of a square map's Cholesky factor per unknown and per doubling of
/// the unknowns: AMD on a mesh's planar pattern leaves about `4 n log2 n`
/// nonzeros of 8 bytes (docs/decisions/008-memory-model.md).
pub const FACTOR_BYTES_PER_UNKNOWN_LOG2: u64 = 32;

/// Bytes that one square map's sparse system of `unknowns` unknowns holds
/// while it is solved: nothing beyond [`BYTES_PER_TRIANGLE`] for the
/// systems a sparse LU solves (below `LU_BELOW` unknowns), else
/// [`SYSTEM_BYTES_PER_UNKNOWN`] and [`FACTOR_BYTES_PER_UNKNOWN_LOG2`] `log2
/// n` a unknown. The sizes a part tries are solved one after another at
/// that size, so one system is held at a time.
pub fn square_system_memory(unknowns: u64) -> u64 {
    if unknowns < LU_BELOW as u64 {
        return 0;
    }
    let log2 = u64::from(unknowns.ilog2()) + 1;
    unknowns.saturating_mul(SYSTEM_BYTES_PER_UNKNOWN + FACTOR_BYTES_PER_UNKNOWN_LOG2 * log2)
}

/// The largest [`square_system_memory`] of `cleaned`'s parts (each part's
/// vertices standing for its unknowns).
pub(super) fn largest_square_system(cleaned: &Cleaned) -> u64 {
    (cleaned.components.iter())
        .map(|c| square_system_memory(c.positions.len() as u64))
        .max()
        .unwrap_or(0)
}

/// Bytes that remeshing `triangles` in `parts` into `samples` and encoding
/// them take, estimated by [`FIXED_BYTES`], [`BYTES_PER_TRIANGLE`],
/// [`BYTES_PER_PART`] and [`BYTES_PER_SAMPLE`], and where the remesh is
/// `measured` against its input, [`MEASURE_BYTES_PER_SAMPLE`]: above every
/// peak `cargo xtask memory` measures, within 1.5 times most.
pub fn encode_memory(triangles: u64, parts: u64, samples: u64, measured: bool) -> u64 {
    let per_sample = BYTES_PER_SAMPLE
        + if measured {
            MEASURE_BYTES_PER_SAMPLE
        } else {
            0
        };
    FIXED_BYTES
        .saturating_add(triangles.saturating_mul(BYTES_PER_TRIANGLE))
        .saturating_add(parts.saturating_mul(BYTES_PER_PART))
        .saturating_add(samples.saturating_mul(per_sample))
}

/// Refuses work whose [`encode_memory`], with the bytes held beside it
/// ([`RemeshOptions::held`]), is above [`RemeshOptions::max_memory`].
pub fn check_memory(
    triangles: u64,
    parts: u64,
    samples: u64,
    measured: bool,
    options: &RemeshOptions,
) -> Result<()> {
    let needed = encode_memory(triangles, parts, samples, measured);
    refuse_above(needed, options, triangles, samples)
}

/// Refuses work that `needs` more than `options` admit
/// ([`RemeshOptions::admits`]); the error names the work and what is held
/// together.
pub(super) fn refuse_above(
    needed: u64,
    options: &RemeshOptions,
    triangles: u64,
    samples: u64,
) -> Result<()> {
    if !options.admits(needed) {
        return Err(Error::Memory {
            needed: needed.saturating_add(options.held),
            limit: options.max_memory,
            triangles,
            samples,
        });
    }
    Ok(())
}

/// `remeshed` with [`RemeshReport::memory`](super::RemeshReport::memory)
/// at least its own estimate.
pub(super) fn with_memory(mut remeshed: Remeshed, input_triangles: u64) -> Remeshed {
    let report = &mut remeshed.report;
    report.memory = report.memory.max(encode_memory(
        input_triangles,
        report.components.len() as u64,
        remeshed.mesh.positions().len() as u64,
        report.psnr.is_some(),
    ));
    remeshed
}

/// The memory estimate of both remeshes at once, [`both_at_once`] on
/// `cleaned` (`input_triangles` before clean-up) at the samples aimed for.
pub(super) fn both_memory(cleaned: &Cleaned, input_triangles: u64, options: &RemeshOptions) -> u64 {
    let vertices: usize = cleaned.components.iter().map(|c| c.positions.len()).sum();
    let samples = target_samples(options, vertices) as u64;
    both_at_once(
        input_triangles,
        cleaned.components.len() as u64,
        samples,
        largest_square_system(cleaned),
    )
}

/// Bytes that both remeshes made at once take, `triangles` in `parts`
/// into `samples` each, one square per part's largest system taking
/// `system`: each holds its own structures of the input, which peak
/// together (twice [`BYTES_PER_TRIANGLE`] and [`BYTES_PER_PART`]), and its
/// own samples, which seldom do (1.3 times the measured remesh's
/// [`BYTES_PER_SAMPLE`] and [`MEASURE_BYTES_PER_SAMPLE`]); never less than
/// one square per part alone with its system. Fitted to the peaks of `auto`
/// from the bunny to a scan of two million triangles
/// (docs/decisions/008-memory-model.md).
pub fn both_at_once(triangles: u64, parts: u64, samples: u64, system: u64) -> u64 {
    let input = encode_memory(triangles, parts, 0, false) - FIXED_BYTES;
    let per_sample = (BYTES_PER_SAMPLE + MEASURE_BYTES_PER_SAMPLE) * 13 / 10;
    let both = FIXED_BYTES
        .saturating_add(input.saturating_mul(2))
        .saturating_add(samples.saturating_mul(per_sample));
    both.max(encode_memory(triangles, parts, samples, true).saturating_add(system))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Estimate against peak: above it, and within 1.5 times a peak of 50 MB
    /// or more.
    fn bounds(what: &str, estimate: u64, peak_mb: f64) {
        let estimate = estimate as f64 / 1e6;
        assert!(
            estimate >= peak_mb,
            "{what}: {estimate:.0} MB for a peak of {peak_mb} MB"
        );
        assert!(
            peak_mb < 50.0 || estimate <= 1.5 * peak_mb,
            "{what}: {estimate:.0} MB for a peak of {peak_mb} MB"
        );
    }

    /// One square per part on the dense scans of `cargo xtask scale` (one
    /// part; peaks of `qm compress --base-domain square` with the sizes a
    /// part tries solved one after another), the Cholesky system's fill
    /// included; the same estimate without it falls below the 2M peak.
    #[test]
    fn the_square_systems_fill_is_in_the_estimate() {
        // (what, triangles, vertices, samples, peak in MB)
        let peaks = [
            ("scan of 0.5M, square", 499_392, 249_698, 1_048_578, 770.0),
            ("scan of 2M, square", 1_997_568, 998_786, 1_048_578, 2433.0),
        ];
        for (what, triangles, vertices, samples, peak) in peaks {
            let without = encode_memory(triangles, 1, samples, false);
            let with = without + square_system_memory(vertices);
            bounds(what, with, peak);
            assert!(square_system_memory(vertices) > 0, "{what}");
        }
        assert!(encode_memory(1_997_568, 1, 1_048_578, false) < 2_433_000_000);
        assert_eq!(square_system_memory(LU_BELOW as u64 - 1), 0);
    }

    /// Both remeshes at once under `auto` (peaks of `qm compress`).
    #[test]
    fn both_at_once_bounds_the_measured_peaks() {
        // (what, triangles, parts, vertices, samples, peak in MB)
        let peaks = [
            ("bunny", 69_451, 1, 35_947, 1_048_576, 663.0),
            (
                "10,000 separate triangles",
                10_000,
                10_000,
                3,
                900_000,
                756.0,
            ),
            ("scan of 0.5M", 499_392, 1, 249_698, 1_048_578, 1062.0),
            ("scan of 2M", 1_997_568, 1, 998_786, 1_048_578, 3569.0),
        ];
        for (what, triangles, parts, vertices, samples, peak) in peaks {
            let system = square_system_memory(vertices);
            bounds(what, both_at_once(triangles, parts, samples, system), peak);
        }
    }

    /// The model against the peaks it was fitted to (`cargo xtask memory`,
    /// docs/hostile-input.md): above each, and within 1.5 times each of
    /// 50 MB or more.
    #[test]
    fn the_memory_model_bounds_the_measured_peaks() {
        // (what, triangles, parts, samples, measured, peak in MB)
        let peaks: [(&str, u64, u64, u64, bool, f64); 11] = [
            ("fan of 1,000, charts", 4_000, 1, 59_906, true, 52.0),
            ("fan of 3,000, charts", 12_000, 1, 179_714, true, 109.0),
            ("plane, level 6, square", 722, 1, 37_249, false, 34.0),
            ("plane, level 8, square", 722, 1, 591_361, false, 184.0),
            ("plane, level 8, measured", 722, 1, 591_361, true, 258.0),
            ("plane, level 9, square", 722, 1, 2_362_369, false, 540.0),
            ("plane, level 9, measured", 722, 1, 2_362_369, true, 942.0),
            ("plane, level 10, square", 722, 1, 9_443_329, false, 1868.0),
            ("bunny, square", 69_451, 1, 1_049_277, false, 360.0),
            ("bunny, charts", 69_451, 1, 1_044_989, true, 509.0),
            ("dense scan, charts", 3_485_220, 1, 1_048_463, true, 2900.0),
        ];
        for (what, triangles, parts, samples, measured, peak) in peaks {
            bounds(
                what,
                encode_memory(triangles, parts, samples, measured),
                peak,
            );
        }
    }
}
