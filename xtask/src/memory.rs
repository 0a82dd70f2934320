//! `cargo xtask memory [--max-level L] [MESH[:DOMAIN] ...]`: the peak
//! memory of `qm`'s compress (remesh and encode) against the memory model
//! that limits it (`qm::param::remesh::encode_memory`, reported as
//! `RemeshReport::memory`).
//!
//! Each case runs in a child process of its own, so that its peak resident
//! memory (`VmHWM`) is its own. The cases: separate tiny triangles (a
//! soup), fan-capped cylinders and an n-gon (one vertex of high valence),
//! a 722-triangle plane at levels 6 to `L` (default 10: about 4 GB), the
//! bundled spot, the Stanford bunny through each base domain (when
//! `../shared/models` holds it), and any `MESH` given (a file, with
//! `:square`, `:charts` or `:input` for that base domain). Prints a
//! Markdown table with the estimate over the peak: the model holds where
//! that is at least 1.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use qm::PolyMesh;
use qm::lift::glam::DVec3;
use qm::param::BaseDomain;

use crate::remesh_bench::{peak_kb, take};
use crate::stress::{cylinder, unit};

pub fn run(args: &[String]) -> Result<(), String> {
    let mut args = args.to_vec();
    if let [flag, case] = &args[..]
        && flag == "--child"
    {
        return child(case);
    }
    let max_level = take(&mut args, "--max-level", "a level")?
        .map(|v| {
            v.parse::<u32>()
                .map_err(|_| format!("--max-level {v}: not a level"))
        })
        .transpose()?
        .unwrap_or(10);
    let mut cases: Vec<String> = ["soup-1000", "soup-10000", "fan-100", "fan-1000", "fan-3000"]
        .into_iter()
        .map(String::from)
        .collect();
    cases.push("ngon-1000".into());
    for level in 6..=max_level {
        cases.push(format!("plane-{level}:square"));
        cases.push(format!("plane-{level}"));
    }
    let workspace = super::workspace();
    cases.push(workspace.join("assets/spot.obj").display().to_string());
    let bunny = workspace.join("../shared/models/stanford-bunny.obj");
    if bunny.exists() {
        for domain in ["", ":square", ":charts"] {
            cases.push(format!("{}{domain}", bunny.display()));
        }
    }
    cases.extend(args);
    let me = std::env::current_exe().map_err(|e| e.to_string())?;
    println!(
        "| case | input triangles | parts | samples | compress | peak | estimate | estimate / peak |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for case in cases {
        let out = Command::new(&me)
            .args(["memory", "--child", &case])
            .output()
            .map_err(|e| format!("{case}: {e}"))?;
        let stdout = String::from_utf8_lossy(&out.stdout);
        if !out.status.success() {
            println!(
                "| {} | failed: {} | | | | | | |",
                short(&case),
                String::from_utf8_lossy(&out.stderr).trim()
            );
            continue;
        }
        print!("{stdout}");
    }
    Ok(())
}

/// A case's name without the folders of its file.
fn short(case: &str) -> String {
    Path::new(case)
        .file_name()
        .map_or(case.to_string(), |n| n.to_string_lossy().into_owned())
}

/// Runs in the child: one case, one table row.
fn child(case: &str) -> Result<(), String> {
    let (name, domain) = match case.rsplit_once(':') {
        Some((name, "square")) => (name, BaseDomain::Square),
        Some((name, "charts")) => (name, BaseDomain::Charts),
        Some((name, "input")) => (name, BaseDomain::Input),
        _ => (case, BaseDomain::Auto),
    };
    let mut options = qm::RemeshOptions::DEFAULT.with_domain(domain);
    let count = |prefix: &str| {
        name.strip_prefix(prefix)
            .and_then(|n| n.parse::<u32>().ok())
    };
    let input = if let Some(n) = count("soup-") {
        soup(n)
    } else if let Some(n) = count("fan-") {
        let fan = cylinder(n);
        PolyMesh::from_faces(fan.positions, &fan.faces)
    } else if let Some(n) = count("ngon-") {
        qm_shapes::ngon(n)
    } else if let Some(level) = count("plane-") {
        options = options.with_level(Some(level));
        qm_shapes::poly(qm_shapes::plane(19))
    } else {
        qm::read_mesh(name).map_err(|e| e.to_string())?
    };
    let start = Instant::now();
    let encoded = qm::encode(&input, &qm::Options::default().with_remesh(options))
        .map_err(|e| format!("{case}: {e}"))?;
    let seconds = start.elapsed().as_secs_f64();
    let report = encoded
        .remeshed
        .as_ref()
        .ok_or_else(|| format!("{case}: not remeshed"))?;
    let triangles: usize = input.faces().map(|f| f.len() - 2).sum();
    let peak = peak_kb().ok_or("no VmHWM in /proc/self/status")? as f64 * 1024.0;
    let estimate = report.memory as f64;
    println!(
        "| {} ({}) | {triangles} | {} | {} | {seconds:.1} s | {:.0} MB | {:.0} MB | {:.2} |",
        short(case),
        report.domain,
        report.components.len(),
        encoded.samples,
        peak / 1e6,
        estimate / 1e6,
        estimate / peak
    );
    Ok(())
}

/// `n` separate small triangles scattered through a unit cube.
fn soup(n: u32) -> PolyMesh {
    let mut positions = Vec::with_capacity(3 * n as usize);
    let mut faces = Vec::with_capacity(n as usize);
    for i in 0..u64::from(n) {
        let at = DVec3::new(unit(1, 4 * i), unit(2, 4 * i), unit(3, 4 * i));
        let size = 0.002;
        for (c, d) in [DVec3::X, DVec3::Y, DVec3::Z].into_iter().enumerate() {
            let jitter = 0.5 + unit(4 + c as u64, i);
            positions.push(at + size * jitter * d);
        }
        let v = 3 * i as u32;
        faces.push([v, v + 1, v + 2]);
    }
    PolyMesh::from_faces(positions, &faces)
}
