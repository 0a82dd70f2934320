//! `ab`: two encoder (and remesher) settings on the same models, compared at
//! equal bytes.
//!
//! Each model is prepared (remeshed unless it has subdivision connectivity),
//! once if A and B remesh alike and once per side if not (`remesh=`), and
//! compressed losslessly with settings A and B; each stream is decoded at
//! the same log-spaced byte budgets (25, or `--cuts N`) and measured against
//! the input with the surface distance of `rd-curve`. The table gives, at the
//! sizes where A reaches 60, 65, 70 and 78 dB, the PSNR B reaches with the
//! same bytes (the gain) and the bytes B needs for the same PSNR (the ratio),
//! and B's mean gain over the whole stretch in which A rises from 60 to 78
//! dB ([`mean_gain`]). A single point moves by a few tenths of a dB with
//! where the cuts fall against the passes; the mean is steadier.

use std::fmt::Write as _;
use std::path::PathBuf;

use indicatif::{ProgressBar, ProgressStyle};
use qm::{DecodeOptions, EncodeOptions, Frames, RemeshOptions, UpdateRule, Weighting};

use crate::rd::{self, AtPsnr, bytes_at};

/// PSNR levels at which A and B are compared.
const TARGETS_DB: [f64; 4] = [60.0, 65.0, 70.0, 78.0];

/// The PSNR range over which [`mean_gain`] averages.
const MEAN_RANGE_DB: (f64, f64) = (60.0, 78.0);

/// Byte budgets per stream (log-spaced from the base mesh to the whole
/// file, as in `rd-curve`), unless `--cuts` says otherwise.
const BUDGETS: usize = 25;

/// The cuts `--cuts` takes (the interpolation needs a few; each costs a
/// decode and a surface distance).
const CUTS: std::ops::RangeInclusive<usize> = 5..=1000;

const USAGE: &str = "usage: cargo xtask ab [--models FILE|DIR ...] [--a SPEC] [--b SPEC] [--cuts N] [--out FILE]\n  \
    SPEC: comma-separated frames=auto|off|LEVEL, normal=BITS, weight=BITS, update=none|paper|mean,\n  \
    remesh=normal|plain (with or without the remesher's normal placement),\n  \
    level=L (remesh level), spv=N (remesh samples per input vertex),\n  \
    holds=on|off\n  \
    (A defaults to frames=off,normal=0, world axes; B to the defaults)";

/// Parses a setting list into encoder and remesher options.
fn options(spec: &str) -> Result<(EncodeOptions, RemeshOptions), String> {
    let mut o = EncodeOptions::DEFAULT;
    let mut r = RemeshOptions::DEFAULT;
    for item in spec.split(',').filter(|s| !s.is_empty()) {
        let (key, value) = item
            .split_once('=')
            .ok_or_else(|| format!("{item}: expected KEY=VALUE\n{USAGE}"))?;
        let number = || {
            value
                .parse::<u32>()
                .map_err(|_| format!("{item}: not a number"))
        };
        o = match key {
            "frames" => o.with_frame_source(match value {
                "on" | "auto" => Frames::Auto,
                "off" => Frames::Off,
                _ => Frames::ParentsFrom(
                    number().map_err(|_| format!("{item}: on, auto, off or a level"))?,
                ),
            }),
            "normal" => o.with_weighting(o.weighting.with_normal_bits(number()?)),
            "weight" => o.with_weighting(Weighting {
                bits_per_level: number()?,
                ..o.weighting
            }),
            "update" => o.with_update(match value {
                "none" => UpdateRule::None,
                "paper" => UpdateRule::Paper,
                "mean" => UpdateRule::MeanPreserving,
                _ => return Err(format!("{item}: none, paper or mean")),
            }),
            "remesh" => {
                r = r.with_normal(match value {
                    "normal" => true,
                    "plain" => false,
                    _ => return Err(format!("{item}: normal or plain")),
                });
                o
            }
            "level" => {
                r = r.with_level(Some(number()?));
                o
            }
            "spv" => {
                r = r.with_samples_per_vertex(f64::from(number()?));
                o
            }
            "holds" => o.with_holds(match value {
                "on" => true,
                "off" => false,
                _ => return Err(format!("{item}: on or off")),
            }),
            _ => return Err(format!("{item}: unknown setting\n{USAGE}")),
        };
    }
    Ok((o, r))
}

pub fn run(args: &[String]) -> Result<(), String> {
    let mut models = Vec::new();
    let mut a = "frames=off,normal=0".to_string();
    let mut b = String::new();
    let mut out = None;
    let mut cuts = BUDGETS;
    let mut i = 0;
    while i < args.len() {
        let value = || args.get(i + 1).cloned().ok_or(USAGE.to_string());
        match args[i].as_str() {
            "--models" => {
                i += 1;
                while i < args.len() && !args[i].starts_with("--") {
                    models.push(PathBuf::from(&args[i]));
                    i += 1;
                }
                continue;
            }
            "--a" => a = value()?,
            "--b" => b = value()?,
            "--out" => out = Some(PathBuf::from(value()?)),
            "--cuts" => {
                cuts = value()?
                    .parse()
                    .ok()
                    .filter(|n| CUTS.contains(n))
                    .ok_or(format!(
                        "--cuts: a number from {} to {}\n{USAGE}",
                        CUTS.start(),
                        CUTS.end()
                    ))?
            }
            _ => return Err(USAGE.to_string()),
        }
        i += 2;
    }
    let mut files = Vec::new();
    if models.is_empty() {
        models.push(crate::workspace().join("assets/spot.obj"));
        models.push(crate::workspace().join("assets/quad"));
    }
    for m in models {
        if m.is_dir() {
            files.extend(rd::mesh_files(&m)?);
        } else {
            files.push(m);
        }
    }
    let ((oa, ra), (ob, rb)) = (options(&a)?, options(&b)?);
    let bar = ProgressBar::new((files.len() * 2 * cuts) as u64);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} {msg}")
            .map_err(|e| e.to_string())?
            .progress_chars("=> "),
    );
    let mut table = String::new();
    let head: Vec<String> = TARGETS_DB.iter().map(|t| format!("{t:.0} dB")).collect();
    let _ = writeln!(
        table,
        "A = `{a}`, B = `{}`. Per cell: PSNR gain of B at A's bytes; B's bytes / A's bytes at equal PSNR.\n",
        if b.is_empty() { "defaults" } else { &b }
    );
    let _ = writeln!(
        table,
        "| model | lossless A / B | remesh PSNR A / B | {} | mean {:.0} to {:.0} dB |\n|---|---|---|{}",
        head.join(" | "),
        MEAN_RANGE_DB.0,
        MEAN_RANGE_DB.1,
        "---|".repeat(TARGETS_DB.len() + 1)
    );
    for file in &files {
        let name = rd::file_name(file);
        let at = |e: String| format!("{}: {e}", file.display());
        bar.set_message(format!("{name}: prepare"));
        let input = qm::read_mesh(file).map_err(|e| at(e.to_string()))?;
        let prepared_a = qm::prepare(&input, &ra).map_err(|e| at(e.to_string()))?;
        let prepared_b = if rb == ra {
            None
        } else {
            bar.set_message(format!("{name}: prepare B"));
            Some(qm::prepare(&input, &rb).map_err(|e| at(e.to_string()))?)
        };
        let mut curves = Vec::new();
        let mut sizes = Vec::new();
        let mut floors = Vec::new();
        let mut streams = Vec::new();
        for (o, prepared) in [
            (&oa, &prepared_a),
            (&ob, prepared_b.as_ref().unwrap_or(&prepared_a)),
        ] {
            streams.push(qm::encode_prepared(prepared, &input, o).map_err(|e| at(e.to_string()))?);
            // How far the semi-regular mesh itself is from the input.
            let layout = prepared.mesh.layout();
            let remeshed = qm::PolyMesh::from_faces(
                prepared.mesh.positions().to_vec(),
                &layout.quads(layout.level()),
            );
            floors.push(rd::measure(&input, &remeshed).map_err(at)?.psnr_db);
        }
        // One grid of budgets for both streams, so that interpolating
        // between its points errs alike on both curves.
        let first = |c: &qm::Encoded| c.header_bytes + c.base_bytes;
        let grid = rd::budgets(
            streams.iter().map(first).min().unwrap_or(0),
            streams.iter().map(|c| c.bytes.len()).max().unwrap_or(0),
            cuts,
        );
        for (label, c) in ["A", "B"].iter().zip(&streams) {
            let mut curve = Vec::new();
            let budgets = grid
                .iter()
                .copied()
                .filter(|&b| b >= first(c) && b < c.bytes.len())
                .chain([c.bytes.len()]);
            for bytes in budgets {
                bar.set_message(format!("{name}: {label} {bytes} B"));
                let d = qm::decode(&c.bytes, &DecodeOptions::FINEST.with_max_bytes(Some(bytes)))
                    .map_err(|e| at(e.to_string()))?;
                let report = rd::measure(&input, &d.mesh).map_err(at)?;
                curve.push((bytes, report.psnr_db));
                bar.inc(1);
            }
            sizes.push(c.bytes.len());
            curves.push(curve);
        }
        let mut cells = Vec::new();
        for t in TARGETS_DB {
            let cell = match (bytes_at(&curves[0], t), bytes_at(&curves[1], t)) {
                (AtPsnr::Bytes(x), bb) => {
                    let gain = psnr_at(&curves[1], x) - t;
                    let ratio = match bb {
                        AtPsnr::Bytes(y) | AtPsnr::AtMost(y) => format!("{:.2}", y / x),
                        AtPsnr::NotReached => "n/a".into(),
                    };
                    format!("{gain:+.2} dB, {ratio}")
                }
                _ => "n/a".into(),
            };
            cells.push(cell);
        }
        cells.push(
            mean_gain(&curves[0], &curves[1], MEAN_RANGE_DB)
                .map_or("n/a".into(), |g| format!("{g:+.2} dB")),
        );
        let _ = writeln!(
            table,
            "| {name} | {} / {} B | {:.2} / {:.2} dB | {} |",
            sizes[0],
            sizes[1],
            floors[0],
            floors[1],
            cells.join(" | ")
        );
        for (label, curve) in ["A", "B"].iter().zip(&curves) {
            let points: Vec<String> = curve
                .iter()
                .map(|(b, p)| format!("{b} B {p:.2} dB"))
                .collect();
            bar.suspend(|| eprintln!("{name} {label}: {}", points.join(", ")));
        }
    }
    bar.finish_and_clear();
    println!("{table}");
    if let Some(out) = out {
        std::fs::write(&out, &table).map_err(|e| format!("{}: {e}", out.display()))?;
    }
    Ok(())
}

/// Mean PSNR gain of curve `b` over curve `a` across the bytes in which `a`
/// rises from `range.0` to `range.1` dB: the area between the two curves
/// (each interpolated as [`psnr_at`] does) over that stretch of log-bytes,
/// divided by its width. This is in the manner of Bjøntegaard's delta PSNR
/// (G. Bjøntegaard, *Calculation of average PSNR differences between
/// RD-curves*, VCEG-M33, 2001), which averages over the byte range both
/// curves share, on fitted polynomials; here the range is `a`'s stretch and
/// the curves are the measured points. `None` if `a` does not cross both
/// ends, or if `b` has no point as short as the stretch's start (a larger
/// base mesh: nothing of `b` decodes there).
fn mean_gain(a: &[(usize, f64)], b: &[(usize, f64)], range: (f64, f64)) -> Option<f64> {
    let (AtPsnr::Bytes(lo), AtPsnr::Bytes(hi)) = (bytes_at(a, range.0), bytes_at(a, range.1))
    else {
        return None;
    };
    if b.first().is_none_or(|&(bytes, _)| bytes as f64 > lo) {
        return None;
    }
    let (lo, hi) = (lo.ln(), hi.ln());
    if hi <= lo {
        return None;
    }
    // The midpoint rule on piecewise linear curves; 1024 steps put its
    // error far below the curves' own.
    const STEPS: usize = 1024;
    let (a, b) = (running_best(a), running_best(b));
    let sum: f64 = (0..STEPS)
        .map(|i| {
            let x = lo + (hi - lo) * (i as f64 + 0.5) / STEPS as f64;
            psnr_on(&b, x) - psnr_on(&a, x)
        })
        .sum();
    Some(sum / STEPS as f64)
}

/// PSNR of a curve (sorted by bytes) at `bytes`, interpolated in log-bytes
/// over its running best (a longer prefix is never worse than a shorter one
/// that was already decoded).
fn psnr_at(curve: &[(usize, f64)], bytes: f64) -> f64 {
    psnr_on(&running_best(curve), bytes.ln())
}

/// A curve as `(ln bytes, best PSNR so far)`, infinite PSNR clamped to 200.
fn running_best(curve: &[(usize, f64)]) -> Vec<(f64, f64)> {
    let mut best = f64::NEG_INFINITY;
    curve
        .iter()
        .map(|&(b, p)| {
            best = best.max(p);
            ((b as f64).ln(), best.min(200.0))
        })
        .collect()
}

/// [`psnr_at`] on a [`running_best`] curve, at `x` = ln bytes.
fn psnr_on(front: &[(f64, f64)], x: f64) -> f64 {
    match front.iter().position(|&(b, _)| b >= x) {
        None => front.last().map_or(f64::NAN, |p| p.1),
        Some(0) => front[0].1,
        Some(k) => {
            let ((x0, y0), (x1, y1)) = (front[k - 1], front[k]);
            y0 + (y1 - y0) * (x - x0) / (x1 - x0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A curve rising 6 dB per doubling of bytes from 50 dB at 1000 B.
    fn curve(shift_db: f64) -> Vec<(usize, f64)> {
        (0..12)
            .map(|i| (1000 << i, 50.0 + 6.0 * i as f64 + shift_db))
            .collect()
    }

    #[test]
    fn mean_gain_of_a_shifted_curve_is_the_shift() {
        let g = mean_gain(&curve(0.0), &curve(2.5), (60.0, 78.0)).unwrap();
        assert!((g - 2.5).abs() < 1e-9, "{g}");
        let g = mean_gain(&curve(0.0), &curve(-1.0), (60.0, 78.0)).unwrap();
        assert!((g + 1.0).abs() < 1e-9, "{g}");
    }

    #[test]
    fn mean_gain_averages_over_log_bytes_between_the_ends() {
        // B is 3 dB above A up to A's 68 dB point and equal from its 74 dB
        // point on, a ramp between: less than 3 dB on average over A's
        // 60..78 dB stretch, more than the 1.5 of a step at its middle.
        let a = curve(0.0);
        let b: Vec<(usize, f64)> = a
            .iter()
            .map(|&(x, p)| (x, if p <= 69.0 { p + 3.0 } else { p }))
            .collect();
        // A reaches 60 and 78 dB 2/3 of a doubling past its 2000 and
        // 16000 B points: 4/3 doublings at +3, one ramping from 3 to 0 and
        // 2/3 at 0, over 3 doublings.
        let g = mean_gain(&a, &b, (60.0, 78.0)).unwrap();
        assert!((g - 11.0 / 6.0).abs() < 1e-6, "{g}");
        // A running best: a point below an earlier one counts as that one.
        let (mut dip, mut flat) = (b.clone(), b.clone());
        dip[4].1 = 0.0;
        flat[4].1 = b[3].1;
        assert_eq!(
            mean_gain(&a, &dip, (60.0, 78.0)),
            mean_gain(&a, &flat, (60.0, 78.0))
        );
        assert!(mean_gain(&a, &dip, (60.0, 78.0)).unwrap() < g);
    }

    #[test]
    fn mean_gain_needs_both_ends_on_a_and_b_from_the_start() {
        let short: Vec<(usize, f64)> = curve(0.0).into_iter().take(4).collect();
        assert_eq!(mean_gain(&short, &curve(0.0), (60.0, 78.0)), None);
        // B starts at 4000 B, after A's 60 dB (about 3175 B).
        let late: Vec<(usize, f64)> = curve(5.0).into_iter().skip(2).collect();
        assert_eq!(mean_gain(&curve(0.0), &late, (60.0, 78.0)), None);
        let in_time: Vec<(usize, f64)> = curve(5.0).into_iter().skip(1).collect();
        assert!(mean_gain(&curve(0.0), &in_time, (60.0, 78.0)).is_some());
    }
}
