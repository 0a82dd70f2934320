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

/// Refuses work whose [`encode_memory`] is above `limit`.
pub fn check_memory(
    triangles: u64,
    parts: u64,
    samples: u64,
    measured: bool,
    limit: u64,
) -> Result<()> {
    let needed = encode_memory(triangles, parts, samples, measured);
    if needed > limit {
        return Err(Error::Memory {
            needed,
            limit,
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

/// The memory estimate of both remeshes at once: each holds its own
/// structures of the input and its own samples, but they seldom peak
/// together: 1.6 times one remesh's share beyond [`FIXED_BYTES`]
/// (docs/decisions/008-memory-model.md).
pub(super) fn both_memory(cleaned: &Cleaned, input_triangles: u64, options: &RemeshOptions) -> u64 {
    let vertices: usize = cleaned.components.iter().map(|c| c.positions.len()).sum();
    let samples = target_samples(options, vertices) as u64;
    let one = encode_memory(
        input_triangles,
        cleaned.components.len() as u64,
        samples,
        true,
    );
    FIXED_BYTES.saturating_add((one - FIXED_BYTES).saturating_mul(8) / 5)
}

#[cfg(test)]
mod tests {
    use super::*;

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
            let estimate = encode_memory(triangles, parts, samples, measured) as f64 / 1e6;
            assert!(
                estimate >= peak,
                "{what}: {estimate:.0} MB for a peak of {peak} MB"
            );
            assert!(
                peak < 50.0 || estimate <= 1.5 * peak,
                "{what}: {estimate:.0} MB for a peak of {peak} MB"
            );
        }
    }
}
