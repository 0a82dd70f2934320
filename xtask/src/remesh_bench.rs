//! `cargo xtask remesh-bench [--level L] [--normal-remesh on|off] [MESH ...]`:
//! remesh time and peak memory.
//!
//! Each mesh is remeshed (with the defaults, or at level `L`, or without
//! the normal placement of the samples) in a child
//! process of its own, so that its peak resident memory (`VmHWM` of
//! `/proc/self/status`) is its own; the child reports read and remesh
//! times. A mesh is a file or `generated-torus-<N>k`, a bumpy torus of `N`
//! thousand vertices. Default meshes: the Stanford bunny from
//! `../shared/models` (when present) and `generated-torus-500k`. Prints a
//! Markdown table.

use std::f64::consts::TAU;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use qm::PolyMesh;
use qm::lift::glam::DVec3;

/// Prefix of the names standing for a generated torus instead of a file.
const TORUS: &str = "generated-torus-";

pub fn run(args: &[String]) -> Result<(), String> {
    let mut args = args.to_vec();
    let mut level = None;
    if let Some(at) = args.iter().position(|a| a == "--level") {
        let value = args.get(at + 1).ok_or("--level needs a value")?;
        level = Some(
            value
                .parse::<u32>()
                .map_err(|_| format!("--level {value}: not a level"))?,
        );
        args.drain(at..at + 2);
    }
    let mut normal = qm::RemeshOptions::DEFAULT.normal;
    if let Some(at) = args.iter().position(|a| a == "--normal-remesh") {
        normal = match args.get(at + 1).map(String::as_str) {
            Some("on") => true,
            Some("off") => false,
            _ => return Err("--normal-remesh needs on or off".into()),
        };
        args.drain(at..at + 2);
    }
    if let [flag, mesh] = &args[..]
        && flag == "--child"
    {
        return child(mesh, level, normal);
    }
    let meshes: Vec<String> = if args.is_empty() {
        let bunny = super::workspace().join("../shared/models/stanford-bunny.obj");
        let mut m = Vec::new();
        if bunny.exists() {
            m.push(bunny.display().to_string());
        }
        m.push(format!("{TORUS}500k"));
        m
    } else {
        args
    };
    let me = std::env::current_exe().map_err(|e| e.to_string())?;
    println!("| mesh | input vertices | samples | read | remesh | peak memory |");
    println!("|---|---|---|---|---|---|");
    for mesh in meshes {
        let mut command = Command::new(&me);
        command.args(["remesh-bench", "--child", &mesh]);
        if let Some(level) = level {
            command.args(["--level", &level.to_string()]);
        }
        command.args(["--normal-remesh", if normal { "on" } else { "off" }]);
        let out = command.output().map_err(|e| format!("{mesh}: {e}"))?;
        if !out.status.success() {
            return Err(format!(
                "{mesh}: {}",
                String::from_utf8_lossy(&out.stderr).trim()
            ));
        }
        print!("{}", String::from_utf8_lossy(&out.stdout));
    }
    Ok(())
}

/// Runs in the child: one mesh, one table row.
fn child(mesh: &str, level: Option<u32>, normal: bool) -> Result<(), String> {
    let start = Instant::now();
    let torus = mesh
        .strip_prefix(TORUS)
        .and_then(|n| n.strip_suffix('k'))
        .and_then(|n| n.parse::<f64>().ok());
    let input = match torus {
        // n x m vertices with n = 2m.
        Some(thousands) => {
            let m = (thousands * 500.0).sqrt().round().max(3.0) as u32;
            bumpy_torus(2 * m, m)
        }
        None => read(Path::new(mesh))?,
    };
    let read_s = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let options = qm::RemeshOptions::DEFAULT
        .with_level(level)
        .with_normal(normal);
    let remeshed = qm::remesh(&input, &options).map_err(|e| e.to_string())?;
    let remesh_s = start.elapsed().as_secs_f64();
    let name = PathBuf::from(mesh)
        .file_name()
        .map_or(mesh.to_string(), |n| n.to_string_lossy().into_owned());
    println!(
        "| {name} | {} | {} | {read_s:.2} s | {remesh_s:.2} s | {} MB |",
        input.positions.len(),
        remeshed.mesh.layout().sample_count(),
        peak_kb().map_or("?".into(), |kb| (kb / 1024).to_string()),
    );
    Ok(())
}

fn read(path: &Path) -> Result<PolyMesh, String> {
    qm::read_mesh(path).map_err(|e| e.to_string())
}

/// Peak resident memory of this process in KiB (Linux).
fn peak_kb() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// A triangulated torus of `n x m` vertices with a fine relief.
fn bumpy_torus(n: u32, m: u32) -> PolyMesh {
    let mut positions = Vec::with_capacity((n * m) as usize);
    for j in 0..m {
        for i in 0..n {
            let (u, v) = (i as f64 / n as f64 * TAU, j as f64 / m as f64 * TAU);
            let r = 1.0 + 0.02 * (17.0 * u).sin() * (11.0 * v).cos();
            positions.push(DVec3::new(
                (3.0 + r * v.cos()) * u.cos(),
                (3.0 + r * v.cos()) * u.sin(),
                r * v.sin(),
            ));
        }
    }
    let id = |i: u32, j: u32| (j % m) * n + (i % n);
    let mut faces = Vec::with_capacity(2 * (n * m) as usize);
    for j in 0..m {
        for i in 0..n {
            faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            faces.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    PolyMesh::from_faces(positions, &faces)
}
