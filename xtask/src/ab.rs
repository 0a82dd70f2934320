//! `ab`: two encoder (and remesher) settings on the same models, compared at
//! equal bytes.
//!
//! Each model is prepared (remeshed unless it has subdivision connectivity),
//! once if A and B remesh alike and once per side if not (`remesh=`), and
//! compressed losslessly with settings A and B; each stream is decoded at
//! the same log-spaced byte budgets (25, or `--cuts N`) and measured against
//! the input with the surface distance of `rd-curve`. The table gives, at the
//! sizes where A reaches 60, 65, 70 and 78 dB, the PSNR B reaches with the
//! same bytes (the gain) and the bytes B needs for the same PSNR (the ratio).

use std::fmt::Write as _;
use std::path::PathBuf;

use indicatif::{ProgressBar, ProgressStyle};
use qm::{
    BasePlacement, Contexts, DecodeOptions, EncodeOptions, Frames, RemeshOptions, UpdateRule,
    Weighting,
};

use crate::rd::{self, AtPsnr, bytes_at};

/// PSNR levels at which A and B are compared.
const TARGETS_DB: [f64; 4] = [60.0, 65.0, 70.0, 78.0];

/// Byte budgets per stream (log-spaced from the base mesh to the whole
/// file, as in `rd-curve`), unless `--cuts` says otherwise.
const BUDGETS: usize = 25;

/// The cuts `--cuts` takes (the interpolation needs a few; each costs a
/// decode and a surface distance).
const CUTS: std::ops::RangeInclusive<usize> = 5..=1000;

const USAGE: &str = "usage: cargo xtask ab [--models FILE|DIR ...] [--a SPEC] [--b SPEC] [--cuts N] [--out FILE]\n  \
    SPEC: comma-separated frames=auto|off|LEVEL, normal=BITS, weight=BITS, update=none|paper|mean,\n  \
    remesh=normal|plain (with or without the remesher's normal placement),\n  \
    level=L (remesh level), spv=N (remesh samples per input vertex), base=front|stream,\n  \
    holds=on|off, contexts=tree|neighbours\n  \
    (A defaults to frames=off,normal=0,contexts=tree, the version 1 coding; B to the defaults)";

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
            "base" => o.with_base(match value {
                "front" => BasePlacement::Front,
                "stream" => BasePlacement::Stream,
                _ => return Err(format!("{item}: front or stream")),
            }),
            "holds" => o.with_holds(match value {
                "on" => true,
                "off" => false,
                _ => return Err(format!("{item}: on or off")),
            }),
            "contexts" => o.with_contexts(match value {
                "tree" => Contexts::Tree,
                "neighbours" => Contexts::Neighbours,
                _ => return Err(format!("{item}: tree or neighbours")),
            }),
            _ => return Err(format!("{item}: unknown setting\n{USAGE}")),
        };
    }
    Ok((o, r))
}

pub fn run(args: &[String]) -> Result<(), String> {
    let mut models = Vec::new();
    let mut a = "frames=off,normal=0,contexts=tree".to_string();
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
        "| model | lossless A / B | remesh PSNR A / B | {} |\n|---|---|---|{}",
        head.join(" | "),
        "---|".repeat(TARGETS_DB.len())
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
            streams.push(
                qm::compress_against(&prepared.mesh, &input, o).map_err(|e| at(e.to_string()))?,
            );
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
        let first = |c: &qm::Compressed| c.header_bytes + c.base_bytes;
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
                let d = qm::decompress(
                    &c.bytes,
                    &DecodeOptions::default().with_max_bytes(Some(bytes)),
                )
                .map_err(|e| at(e.to_string()))?;
                let report = rd::measure(&input, &d.to_polymesh()).map_err(at)?;
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

/// PSNR of a curve (sorted by bytes) at `bytes`, interpolated in log-bytes
/// over its running best (a longer prefix is never worse than a shorter one
/// that was already decoded).
fn psnr_at(curve: &[(usize, f64)], bytes: f64) -> f64 {
    let mut best = f64::NEG_INFINITY;
    let front: Vec<(f64, f64)> = curve
        .iter()
        .map(|&(b, p)| {
            best = best.max(p);
            ((b as f64).ln(), best.min(200.0))
        })
        .collect();
    let x = bytes.ln();
    match front.iter().position(|&(b, _)| b >= x) {
        None => front.last().map_or(f64::NAN, |p| p.1),
        Some(0) => front[0].1,
        Some(k) => {
            let ((x0, y0), (x1, y1)) = (front[k - 1], front[k]);
            y0 + (y1 - y0) * (x - x0) / (x1 - x0)
        }
    }
}
