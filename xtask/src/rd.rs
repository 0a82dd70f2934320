//! `rd-curve`: rate-distortion curves of qm against Google Draco.
//!
//! For each model qm remeshes and compresses once (lossless, 16 bits), then
//! decodes pass counts and log-spaced byte prefixes of that one stream; Draco
//! encodes the same surface at a range of quantization bits. Every
//! reconstruction is measured against the original input with Metro's
//! symmetric surface distance ([`qm::param::distance()`]), so both coders are
//! judged by the same yardstick, whatever their vertices.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use qm::param::distance::{DistanceOptions, DistanceReport, distance};
use qm::{DecodeOptions, EncodeOptions, PolyMesh, RemeshOptions};

pub use crate::curves::{AtPsnr, bytes_at};
use crate::curves::{ModelResult, Point, TARGETS_DB};
use crate::plot;

/// Pass counts decoded for the curve and Table 1 (the paper's columns).
const PASSES: [u32; 6] = [2, 4, 6, 8, 10, 12];

/// Byte budgets per model, log-spaced from the base mesh to the whole file.
const BUDGETS: usize = 16;

/// Draco quantization bits tried (`-qp`).
const DRACO_QP: std::ops::RangeInclusive<u32> = 6..=14;

/// Samples per direction of the distance: enough for a few hundredths of a
/// dB of sampling noise on the RMS, small enough that a run stays well under
/// the five minutes on two cores.
pub const SAMPLES: usize = 200_000;

/// Parsed `rd-curve` arguments.
struct Args {
    models: Vec<PathBuf>,
    out: PathBuf,
    draco: Option<PathBuf>,
    /// `--base-domain`: the remesher's choice of base domain for every model.
    domain: qm::param::BaseDomain,
}

fn parse_args(args: &[String]) -> Result<Args, String> {
    let usage = "usage: cargo xtask rd-curve [--models FILE|DIR ...] [--out DIR] [--draco PATH] \
                 [--base-domain auto|square|charts|input]";
    let mut models = Vec::new();
    let mut out = None;
    let mut draco = None;
    let mut domain = qm::param::BaseDomain::Auto;
    let mut i = 0;
    while i < args.len() {
        match args[i].as_str() {
            "--models" => {
                i += 1;
                while i < args.len() && !args[i].starts_with("--") {
                    models.extend(
                        args[i]
                            .split(',')
                            .filter(|s| !s.is_empty())
                            .map(PathBuf::from),
                    );
                    i += 1;
                }
                continue;
            }
            "--out" => out = Some(PathBuf::from(args.get(i + 1).ok_or(usage)?)),
            "--draco" => draco = Some(PathBuf::from(args.get(i + 1).ok_or(usage)?)),
            "--base-domain" => {
                domain = match args.get(i + 1).map(String::as_str) {
                    Some("auto") => qm::param::BaseDomain::Auto,
                    Some("square") => qm::param::BaseDomain::Square,
                    Some("charts") => qm::param::BaseDomain::Charts,
                    Some("input") => qm::param::BaseDomain::Input,
                    _ => return Err(usage.to_string()),
                }
            }
            "-h" | "--help" => return Err(usage.to_string()),
            other => return Err(format!("unknown argument {other}\n{usage}")),
        }
        i += 2;
    }
    let models = if models.is_empty() {
        let mut m = vec![crate::workspace().join("assets/spot.obj")];
        m.extend(mesh_files(&crate::workspace().join("assets/quad"))?);
        m
    } else {
        let mut m = Vec::new();
        for p in models {
            if p.is_dir() {
                m.extend(mesh_files(&p)?);
            } else {
                m.push(p);
            }
        }
        m
    };
    if models.is_empty() {
        return Err("no models".into());
    }
    Ok(Args {
        models,
        out: out.unwrap_or_else(|| crate::workspace().join("target/rd")),
        draco,
        domain,
    })
}

/// The mesh files directly inside `dir`, sorted.
pub fn mesh_files(dir: &Path) -> Result<Vec<PathBuf>, String> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| format!("{}: {e}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension().is_some_and(|x| {
                ["obj", "ply", "off", "stl"].contains(&x.to_string_lossy().to_lowercase().as_str())
            })
        })
        .collect();
    files.sort();
    Ok(files)
}

/// Draco's two command-line tools.
pub(crate) struct Draco {
    encoder: PathBuf,
    decoder: PathBuf,
}

/// Finds the Draco tools: `--draco` names their directory or the encoder
/// (the decoder beside it); without it they are looked up on `PATH`.
pub(crate) fn find_draco(path: Option<&Path>) -> Result<Draco, String> {
    let (encoder, decoder) = match path {
        Some(p) if p.is_dir() => (p.join("draco_encoder"), p.join("draco_decoder")),
        Some(p) => (p.to_path_buf(), p.with_file_name("draco_decoder")),
        None => (
            PathBuf::from("draco_encoder"),
            PathBuf::from("draco_decoder"),
        ),
    };
    for tool in [&encoder, &decoder] {
        // Both tools print usage and exit non-zero without arguments; only
        // failing to start at all means they are missing.
        Command::new(tool)
            .arg("--help")
            .output()
            .map_err(|e| format!("{}: {e}", tool.display()))?;
    }
    Ok(Draco { encoder, decoder })
}

pub fn run(args: &[String]) -> Result<(), String> {
    let args = parse_args(args)?;
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let draco = match find_draco(args.draco.as_deref()) {
        Ok(d) => Some(d),
        Err(e) => {
            eprintln!(
                "warning: Draco tools not found ({e}); qm only \
                 (install with `apt-get update && apt-get install -y draco`)"
            );
            None
        }
    };
    let draco_steps = if draco.is_some() { DRACO_QP.count() } else { 0 };
    // Per model: prepare+compress, the pass decodes, the budgets, the whole
    // stream, and Draco's settings.
    let per_model = 1 + PASSES.len() + BUDGETS + 1 + draco_steps;
    let bar = ProgressBar::new((per_model * args.models.len()) as u64);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} {msg}")
            .map_err(|e| e.to_string())?
            .progress_chars("=> "),
    );
    let started = Instant::now();
    let mut results = Vec::new();
    for file in &args.models {
        let r = model(file, draco.as_ref(), args.domain, &bar)?;
        results.push(r);
    }
    bar.finish_and_clear();
    let elapsed = started.elapsed().as_secs_f64();

    let csv = csv(&results);
    let table1 = table1(&results);
    let summary = summary(&results, draco.is_none(), elapsed);
    let write = |name: &str, text: &str| -> Result<(), String> {
        let path = args.out.join(name);
        std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))
    };
    write("rd.csv", &csv)?;
    write("table1.md", &table1)?;
    write("summary.md", &summary)?;
    plot::draw(&results, &args.out)?;
    println!("{summary}");
    let out = args.out.canonicalize().unwrap_or(args.out);
    println!(
        "wrote rd.csv, table1.md, summary.md, rd.svg and rd.png to {}",
        out.display()
    );
    Ok(())
}

pub fn file_name(file: &Path) -> String {
    file.file_name().map_or_else(
        || file.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

pub fn measure(input: &PolyMesh, recon: &PolyMesh) -> Result<DistanceReport, String> {
    distance(
        input,
        recon,
        &DistanceOptions::DEFAULT.with_samples(SAMPLES),
    )
    .map_err(|e| e.to_string())
}

fn model(
    file: &Path,
    draco: Option<&Draco>,
    domain: qm::param::BaseDomain,
    bar: &ProgressBar,
) -> Result<ModelResult, String> {
    let name = file_name(file);
    let at = |e: String| format!("{}: {e}", file.display());
    bar.set_message(format!("{name}: prepare + compress"));
    let input = qm::read_mesh(file).map_err(|e| at(e.to_string()))?;
    let input_bytes = std::fs::metadata(file)
        .map_err(|e| at(e.to_string()))?
        .len();
    let n = input.positions.len();
    let bpv = |bytes: usize| bytes as f64 * 8.0 / n as f64;

    let t = Instant::now();
    let options = RemeshOptions::DEFAULT.with_domain(domain);
    let prepared = qm::prepare(&input, &options).map_err(|e| at(e.to_string()))?;
    let prepare_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let compressed = qm::encode_prepared(&prepared, &input, &EncodeOptions::DEFAULT)
        .map_err(|e| at(e.to_string()))?;
    let encode_s = t.elapsed().as_secs_f64();
    bar.inc(1);
    let full = compressed.bytes.len();
    let first = compressed.header_bytes + compressed.base_bytes;

    let mut points = Vec::new();
    let mut decode = |setting: String, options: DecodeOptions, bytes: usize| {
        let t = Instant::now();
        let decoded = qm::decode(&compressed.bytes, &options).map_err(|e| at(e.to_string()))?;
        let decode_s = t.elapsed().as_secs_f64();
        let report = measure(&input, &decoded.mesh).map_err(at)?;
        points.push(Point {
            coder: "qm",
            setting,
            bytes,
            bpv: bpv(bytes),
            report,
            encode_s,
            decode_s,
        });
        bar.inc(1);
        Ok::<_, String>(report.psnr_db)
    };

    let mut passes = Vec::new();
    for p in PASSES {
        bar.set_message(format!("{name}: qm {p} passes"));
        let bytes = compressed
            .pass_ends
            .get(p as usize - 1)
            .copied()
            .unwrap_or(full);
        let db = decode(
            format!("passes={p}"),
            DecodeOptions::FINEST.with_passes(Some(p)),
            bytes,
        )?;
        passes.push((p, bytes - first, db));
    }
    for bytes in budgets(first, full, BUDGETS) {
        bar.set_message(format!("{name}: qm {bytes} B"));
        decode(
            format!("bytes={bytes}"),
            DecodeOptions::FINEST.with_max_bytes(Some(bytes)),
            bytes,
        )?;
    }
    bar.set_message(format!("{name}: qm lossless"));
    decode("lossless".into(), DecodeOptions::FINEST, full)?;

    let mut draco_missing = None;
    if let Some(draco) = draco {
        match run_draco(draco, &name, &input, bar, &mut points) {
            Ok(()) => {}
            Err(e) => {
                bar.println(format!("warning: {name}: Draco failed: {e}"));
                draco_missing = Some(e);
            }
        }
    } else {
        draco_missing = Some("Draco tools not found".into());
    }
    Ok(ModelResult {
        name,
        input_bytes,
        input_vertices: n,
        input_faces: input.face_count(),
        prepare_s,
        base_quads: prepared.mesh.layout().face_count(),
        level: prepared.mesh.layout().level(),
        header_base_bytes: first,
        full_bytes: full,
        passes,
        holds: qm::codec::container::read(&compressed.bytes, &qm::Limits::NONE)
            .map_err(|e| at(e.to_string()))?
            .header
            .holds,
        points,
        draco_missing,
    })
}

/// `count` sizes from `first` to `last`, log-spaced, without repeats.
pub fn budgets(first: usize, last: usize, count: usize) -> Vec<usize> {
    let (l0, l1) = ((first.max(1) as f64).ln(), (last.max(1) as f64).ln());
    let mut b: Vec<usize> = (0..count)
        .map(|i| {
            let t = i as f64 / (count - 1) as f64;
            ((l0 + t * (l1 - l0)).exp().round() as usize).clamp(first, last)
        })
        .collect();
    b.dedup();
    b
}

/// Encodes the input with Draco at every `-qp` and measures the decodes.
///
/// Draco is given the same surface qm sees: positions and faces only (no
/// texture coordinates or normals to pay for), polygons fanned into
/// triangles, since its mesh coder takes triangles.
pub(crate) fn run_draco(
    draco: &Draco,
    name: &str,
    input: &PolyMesh,
    bar: &ProgressBar,
    points: &mut Vec<Point>,
) -> Result<(), String> {
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let tri = dir.path().join("in.obj");
    std::fs::write(&tri, triangle_obj(input)).map_err(|e| e.to_string())?;
    let n = input.positions.len();
    for qp in DRACO_QP {
        bar.set_message(format!("{name}: Draco -qp {qp}"));
        let drc = dir.path().join(format!("q{qp}.drc"));
        let out = dir.path().join(format!("q{qp}.obj"));
        let t = Instant::now();
        tool(
            Command::new(&draco.encoder)
                .arg("-i")
                .arg(&tri)
                .arg("-o")
                .arg(&drc)
                .args(["-qp", &qp.to_string(), "-cl", "10"]),
        )?;
        let encode_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        tool(
            Command::new(&draco.decoder)
                .arg("-i")
                .arg(&drc)
                .arg("-o")
                .arg(&out),
        )?;
        let decode_s = t.elapsed().as_secs_f64();
        let bytes = std::fs::metadata(&drc).map_err(|e| e.to_string())?.len() as usize;
        let recon = qm::read_mesh(out).map_err(|e| e.to_string())?;
        let report = measure(input, &recon)?;
        points.push(Point {
            coder: "draco",
            setting: format!("qp={qp}"),
            bytes,
            bpv: bytes as f64 * 8.0 / n as f64,
            report,
            encode_s,
            decode_s,
        });
        bar.inc(1);
    }
    Ok(())
}

fn tool(cmd: &mut Command) -> Result<(), String> {
    let out = cmd.output().map_err(|e| e.to_string())?;
    if out.status.success() {
        Ok(())
    } else {
        Err(format!(
            "{:?} exited with {}: {}",
            cmd.get_program(),
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        ))
    }
}

/// Positions and fanned triangles as OBJ text, full `f64` precision.
fn triangle_obj(mesh: &PolyMesh) -> String {
    let mut s = String::new();
    for p in &mesh.positions {
        let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
    }
    for f in mesh.faces() {
        for k in 1..f.len().saturating_sub(1) {
            let _ = writeln!(s, "f {} {} {}", f[0] + 1, f[k] + 1, f[k + 1] + 1);
        }
    }
    s
}

fn csv(results: &[ModelResult]) -> String {
    let mut s = String::from(
        "model,coder,setting,bytes,bits_per_input_vertex,rms,hausdorff,psnr_db,encode_s,decode_s\n",
    );
    for r in results {
        for p in &r.points {
            let _ = writeln!(
                s,
                "{},{},{},{},{:.4},{:.6e},{:.6e},{:.3},{:.4},{:.4}",
                r.name,
                p.coder,
                p.setting,
                p.bytes,
                p.bpv,
                p.report.rms,
                p.report.hausdorff,
                p.report.psnr_db,
                p.encode_s,
                p.decode_s
            );
        }
    }
    s
}

fn table1(results: &[ModelResult]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Table 1: size of input, base mesh and coefficients per pass count\n\n\
         As the paper's Table 1: coefficient bytes are the stream after the \
         header and base mesh needed for that many passes (whole `.qm` file = \
         base + coefficients). PSNR is `20 log10(bbox diagonal / RMS)` with RMS \
         the symmetric Metro surface distance to the original input \
         ({SAMPLES} samples per direction). Written by `cargo xtask rd-curve`.\n"
    );
    let head: Vec<String> = PASSES.iter().map(|p| format!("{p} passes")).collect();
    let _ = writeln!(
        s,
        "| model | input | base mesh | {} | all (lossless) |",
        head.join(" | ")
    );
    let _ = writeln!(s, "|---|---|---|{}---|", "---|".repeat(PASSES.len()));
    for r in results {
        let cells: Vec<String> = r
            .passes
            .iter()
            .map(|&(_, b, db)| format!("{b} B, {db:.1} dB"))
            .collect();
        let lossless = r.lossless_psnr();
        let _ = writeln!(
            s,
            "| {} | {} B, {} vertices, {} faces | {} B ({} quads, level {}) | {} | {} B, {lossless:.1} dB |",
            r.name,
            r.input_bytes,
            r.input_vertices,
            r.input_faces,
            r.header_base_bytes,
            r.base_quads,
            r.level,
            cells.join(" | "),
            r.full_bytes - r.header_base_bytes,
        );
    }
    s
}

fn summary(results: &[ModelResult], no_draco: bool, elapsed: f64) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# qm vs Draco at equal PSNR\n\n\
         Bytes each coder needs to reach 65 dB and 78 dB (PSNR = 20 log10(bbox \
         diagonal / RMS), RMS the symmetric Metro surface distance to the \
         original input, {SAMPLES} samples per direction). Each curve is \
         reduced to its Pareto front (points beaten by a smaller one dropped) \
         and interpolated linearly in log-bytes between the two points around \
         the crossing; \"≤ B\" means the curve's smallest point already \
         reaches the target, \"n/a\" that the curve never does. qm: one \
         lossless stream (`RemeshOptions::DEFAULT`, `EncodeOptions::DEFAULT`), \
         decoded at pass counts and byte prefixes. Draco: `draco_encoder -qp Q \
         -cl 10`, Q = 6..14, on the positions and faces (triangulated) only. \
         Goal: qm ≤ 1/3 of Draco's bytes at 65 dB and ≤ 1/2 at 78 dB. \
         \"Fall\": the most qm's PSNR at a byte prefix lies below a shorter \
         prefix's (0 if it never falls).\n"
    );
    if no_draco {
        let _ = writeln!(s, "Draco's tools were not found: no Draco column.\n");
    }
    let _ = writeln!(
        s,
        "| model | vertices | qm @65 dB | Draco @65 dB | qm/Draco @65 | qm @78 dB | Draco @78 dB | qm/Draco @78 | qm lossless | fall | prepare |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|");
    for r in results {
        let (qm, dr) = (r.curve("qm"), r.curve("draco"));
        let mut cells = Vec::new();
        for t in TARGETS_DB {
            let (a, b) = (bytes_at(&qm, t), bytes_at(&dr, t));
            let ratio = match (a.value(), b.value()) {
                (Some(x), Some(y)) if r.draco_missing.is_none() => {
                    let approx = matches!(a, AtPsnr::AtMost(_)) || matches!(b, AtPsnr::AtMost(_));
                    format!("{}{:.2}", if approx { "~" } else { "" }, x / y)
                }
                _ => "n/a".into(),
            };
            cells.push(format!("{a} | {b} | {ratio}"));
        }
        let lossless_db = r.lossless_psnr();
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} B, {lossless_db:.1} dB | {:.2} dB | {:.1} s |",
            r.name,
            r.input_vertices,
            cells.join(" | "),
            r.full_bytes,
            r.largest_fall(),
            r.prepare_s,
        );
    }
    let _ = writeln!(s, "\nSizes in bytes. Whole run: {elapsed:.1} s.");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn budgets_are_log_spaced_and_bounded() {
        let b = budgets(300, 30_000, BUDGETS);
        assert_eq!(b.first(), Some(&300));
        assert_eq!(b.last(), Some(&30_000));
        assert!(b.len() >= 12 && b.windows(2).all(|w| w[0] < w[1]));
    }
}
