//! `auto`'s last choice, made by rate: where the remesher kept a remesh of
//! a small input (at most [`EXACT_MOST_TRIANGLES`] triangles, the size up
//! to which it sends an input as its own triangles at all), its own
//! triangles are compressed beside it, both streams are cut at their pass
//! ends and measured against the input, and the one that reaches 65 and 78
//! dB with fewer bytes is taken (docs/decisions/036-rate-choice.md).
//!
//! The remesher's own rule (docs/decisions/001-auto-base-domain.md) keeps
//! a remesh that measures 80 dB or better; on faceted CAD meshes such a
//! remesh needed two to six times Draco's bytes at 78 dB, the input's own
//! triangles a quarter to a half of that.

use qm_codec::EncodeOptions;
use qm_param::Step;
use qm_param::distance::{DistanceOptions, distance};
use qm_param::remesh::{BaseDomain, EXACT_MOST_TRIANGLES};

use crate::{DecodeOptions, PolyMesh, Prepared, RemeshOptions, Result, decode};

/// The PSNRs the two streams are compared at, in dB: the rates, a
/// first good picture and one close to the input.
const TARGETS_DB: [f64; 2] = [65.0, 78.0];

/// Samples per direction of the trial's distances: about 0.2 dB of noise,
/// enough to tell streams apart that differ by a few percent in bytes.
const SAMPLES: usize = 10_000;

/// `remeshed` (from `auto`), or the input's own triangles where they reach
/// [`TARGETS_DB`] with fewer bytes; the report of the one taken says why.
/// The trial is announced as [`Step::Measuring`].
pub(crate) fn by_rate(
    mesh: &PolyMesh,
    remeshed: Prepared,
    options: &RemeshOptions,
    announce: qm_param::Reporter<'_>,
) -> Result<Prepared> {
    let Some(report) = &remeshed.remeshed else {
        return Ok(remeshed);
    };
    let triangles: usize = mesh.faces().map(|f| f.len().saturating_sub(2)).sum();
    if options.domain != BaseDomain::Auto
        || options.level.is_some()
        || report.domain == "input"
        || triangles > EXACT_MOST_TRIANGLES
    {
        return Ok(remeshed);
    }
    announce(Step::Measuring);
    let Ok(exact) = qm_param::remesh(mesh, &options.with_domain(BaseDomain::Input)) else {
        return Ok(remeshed);
    };
    let mut exact = Prepared {
        mesh: exact.mesh,
        source: None,
        remeshed: Some(exact.report),
    };
    let Ok(theirs) = bytes_at(mesh, &exact, None) else {
        return Ok(remeshed);
    };
    let Ok(ours) = bytes_at(mesh, &remeshed, Some(&theirs)) else {
        return Ok(remeshed);
    };
    if !better(&theirs, &ours) {
        return Ok(remeshed);
    }
    if let Some(r) = &mut exact.remeshed {
        let say = |b: &[Option<f64>; 2]| {
            b.map(|x| x.map_or("more".to_string(), |x| format!("{x:.0} B")))
                .join(" / ")
        };
        r.fallback = Some(format!(
            "the input's own triangles reach 65 / 78 dB at {}, the remesh through {} at {}",
            say(&theirs),
            report.domain,
            say(&ours)
        ));
        r.memory = r.memory.max(report.memory);
    }
    Ok(exact)
}

/// Whether bytes `a` at [`TARGETS_DB`] beat `b`: more targets reached,
/// else fewer bytes by the geometric mean over them.
fn better(a: &[Option<f64>; 2], b: &[Option<f64>; 2]) -> bool {
    let reached = |x: &[Option<f64>; 2]| x.iter().flatten().count();
    let (ra, rb) = (reached(a), reached(b));
    if ra != rb {
        return ra > rb;
    }
    let log_sum = |x: &[Option<f64>; 2]| x.iter().flatten().map(|b| b.ln()).sum::<f64>();
    ra > 0 && log_sum(a) < log_sum(b)
}

/// The bytes `prepared`'s stream needs for each of [`TARGETS_DB`] against
/// `mesh`, interpolated in log bytes between the pass ends around it, found
/// by bisection over the passes (a stream's error does not grow with its
/// passes); `None` for a target it never reaches, or not measured where it
/// can no longer be [`better`] than `rival`'s.
fn bytes_at(
    mesh: &PolyMesh,
    prepared: &Prepared,
    rival: Option<&[Option<f64>; 2]>,
) -> Result<[Option<f64>; 2]> {
    let compressed = qm_codec::compress(&prepared.mesh, &EncodeOptions::DEFAULT.with_holds(false))?;
    let first = compressed.header_bytes + compressed.base_bytes;
    let cuts: Vec<usize> = std::iter::once(first)
        .chain(compressed.pass_ends.iter().copied())
        .collect();
    let options = DistanceOptions::DEFAULT.with_samples(SAMPLES);
    let mut measured: Vec<Option<f64>> = vec![None; cuts.len()];
    let mut psnr = |k: usize| -> Result<f64> {
        if let Some(p) = measured[k] {
            return Ok(p);
        }
        let decoded = decode(
            &compressed.bytes[..cuts[k]],
            &DecodeOptions::DEFAULT.with_passes(Some(k as u32)),
        )?;
        let p = distance(mesh, &decoded.mesh, &options)?.psnr_db;
        measured[k] = Some(p);
        Ok(p)
    };
    let mut found = [None; 2];
    let mut from = 0;
    for (t, &target) in TARGETS_DB.iter().enumerate() {
        // Where the rival reached both, a stream whose first target costs
        // this much can reach its second no sooner, and loses.
        if let (Some([Some(r65), Some(r78)]), Some(b65)) = (rival, found[0])
            && t == 1
            && 2.0 * f64::ln(b65) >= r65.ln() + r78.ln()
        {
            break;
        }
        // The first cut at or above the target, by bisection.
        let (mut lo, mut hi) = (from, cuts.len());
        while lo < hi {
            let mid = (lo + hi) / 2;
            if psnr(mid)? >= target {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        if lo == cuts.len() {
            break;
        }
        found[t] = Some(match lo.checked_sub(1) {
            Some(j) => crossing(
                &[(cuts[j] as f64, psnr(j)?), (cuts[lo] as f64, psnr(lo)?)],
                target,
            )
            .unwrap_or(cuts[lo] as f64),
            None => cuts[lo] as f64,
        });
        from = lo;
    }
    Ok(found)
}

/// The bytes at which `curve` (bytes, PSNR; bytes ascending) first reaches
/// `target`, linear in log bytes between the points around it.
fn crossing(curve: &[(f64, f64)], target: f64) -> Option<f64> {
    let k = curve.iter().position(|&(_, p)| p >= target)?;
    let Some(&(b0, p0)) = k.checked_sub(1).map(|j| &curve[j]) else {
        return Some(curve[k].0);
    };
    let (b1, p1) = curve[k];
    let t = ((target - p0) / (p1 - p0)).clamp(0.0, 1.0);
    Some((b0.ln() + t * (b1.ln() - b0.ln())).exp())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossings_interpolate_in_log_bytes() {
        let curve = [(100.0, 50.0), (400.0, 70.0), (800.0, 80.0)];
        assert_eq!(crossing(&curve, 40.0), Some(100.0));
        assert!((crossing(&curve, 60.0).unwrap() - 200.0).abs() < 1e-9);
        assert_eq!(crossing(&curve, 90.0), None);
    }

    #[test]
    fn more_targets_reached_wins_then_fewer_bytes() {
        let (a, b) = ([Some(10.0), None], [Some(100.0), Some(200.0)]);
        assert!(better(&b, &a) && !better(&a, &b));
        let (c, d) = ([Some(90.0), Some(190.0)], [Some(100.0), Some(180.0)]);
        assert!(better(&c, &d) && !better(&d, &c));
        assert!(!better(&[None, None], &[None, None]));
    }
}
