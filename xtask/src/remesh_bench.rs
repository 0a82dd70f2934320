//! `cargo xtask remesh-bench [--level L] [--normal-remesh on|off] [--runs N]
//! [--against XTASK] [MESH ...]`: remesh time and peak memory.
//!
//! Each mesh is remeshed (with the defaults, or at level `L`, or without
//! the normal placement of the samples) in a child
//! process of its own, so that its peak resident memory (`VmHWM` of
//! `/proc/self/status`) is its own; the child reports read and remesh
//! times. A mesh is a file or `generated-torus-<N>k`, a bumpy torus of `N`
//! thousand vertices. Default meshes: the Stanford bunny from
//! `../shared/models` (when present) and `generated-torus-500k`. Prints a
//! Markdown table.
//!
//! With `--runs N` each mesh is remeshed `N` times and the table gives the
//! medians (and the range of the remesh times). With `--against XTASK`,
//! another build's xtask binary (a copy of `target/release/xtask` made
//! before a change) remeshes each mesh too, its runs interleaved with this
//! build's so that both meet the same machine, and a second table gives
//! the ratio of the median remesh times and peaks, this build over that.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use qm::PolyMesh;

/// Prefix of the names standing for a generated torus instead of a file.
const TORUS: &str = "generated-torus-";

pub fn run(args: &[String]) -> Result<(), String> {
    let mut args = args.to_vec();
    let level = take(&mut args, "--level", "a value")?
        .map(|value| {
            value
                .parse::<u32>()
                .map_err(|_| format!("--level {value}: not a level"))
        })
        .transpose()?;
    let normal = match take(&mut args, "--normal-remesh", "on or off")?.as_deref() {
        None => qm::RemeshOptions::DEFAULT.normal,
        Some("on") => true,
        Some("off") => false,
        Some(_) => return Err("--normal-remesh needs on or off".into()),
    };
    if let [flag, mesh] = &args[..]
        && flag == "--child"
    {
        return child(mesh, level, normal);
    }
    let runs = take(&mut args, "--runs", "a value")?
        .map(|value| {
            value
                .parse::<usize>()
                .ok()
                .filter(|&n| n >= 1)
                .ok_or_else(|| format!("--runs {value}: not a count of at least 1"))
        })
        .transpose()?
        .unwrap_or(1);
    // Absolute, so that a bare name means the file here, not one on the
    // PATH.
    let against = take(&mut args, "--against", "an xtask binary")?
        .map(|value| {
            std::fs::canonicalize(&value)
                .ok()
                .filter(|p| p.is_file())
                .ok_or_else(|| format!("--against {value}: no such file"))
        })
        .transpose()?;
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
    let builds: Vec<PathBuf> = std::iter::once(me).chain(against.clone()).collect();
    let mut table = String::from(
        "| mesh | input vertices | samples | read | remesh | peak memory |\n|---|---|---|---|---|---|\n",
    );
    let mut ratios =
        String::from("| mesh | remesh, this / against | peak, this / against |\n|---|---|---|\n");
    // Progress on a terminal only.
    let tty = std::io::IsTerminal::is_terminal(&std::io::stderr());
    for mesh in meshes {
        // Per build, its runs' rows; the builds take turns.
        let mut rows: Vec<Vec<Row>> = vec![Vec::new(); builds.len()];
        for round in 0..runs {
            // Each build goes first in every other round.
            let mut order: Vec<usize> = (0..builds.len()).collect();
            if round % 2 == 1 {
                order.reverse();
            }
            for build in order {
                if tty {
                    eprint!("\r{mesh}: run {} of {runs}\x1b[K", round + 1);
                }
                let row = run_child(&builds[build], &mesh, level, normal);
                if tty && row.is_err() {
                    eprintln!();
                }
                rows[build].push(row?);
            }
        }
        if tty {
            eprint!("\r\x1b[K");
        }
        let medians: Vec<Row> = rows.iter().map(|r| Row::median(r)).collect();
        for (build, (row, runs)) in medians.iter().zip(&rows).enumerate() {
            let label = if build == 0 { "" } else { " (against)" };
            let (lo, hi) = runs.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), r| {
                (lo.min(r.remesh_s), hi.max(r.remesh_s))
            });
            let spread = if runs.len() > 1 {
                format!(" ({lo:.2} to {hi:.2}, median of {})", runs.len())
            } else {
                String::new()
            };
            table.push_str(&format!(
                "| {}{label} | {} | {} | {:.2} s | {:.2} s{spread} | {} |\n",
                row.name,
                row.vertices,
                row.samples,
                row.read_s,
                row.remesh_s,
                row.peak_mb.map_or("?".into(), |mb| format!("{mb:.0} MB"))
            ));
        }
        if let [this, other] = &medians[..] {
            ratios.push_str(&format!(
                "| {} | {:.2} | {} |\n",
                this.name,
                this.remesh_s / other.remesh_s,
                this.peak_mb
                    .zip(other.peak_mb)
                    .map_or("?".into(), |(a, b)| format!("{:.2}", a / b))
            ));
        }
    }
    print!("{table}");
    if against.is_some() {
        print!("\n{ratios}");
    }
    Ok(())
}

/// Removes `flag` and the value after it from `args`, and returns that
/// value; an error saying the flag needs `what` if nothing follows it.
pub(crate) fn take(
    args: &mut Vec<String>,
    flag: &str,
    what: &str,
) -> Result<Option<String>, String> {
    let Some(at) = args.iter().position(|a| a == flag) else {
        return Ok(None);
    };
    if at + 1 >= args.len() {
        return Err(format!("{flag} needs {what}"));
    }
    Ok(args.drain(at..at + 2).nth(1))
}

/// One remesh as a child reports it (its table row, parsed).
#[derive(Clone, Debug, PartialEq)]
struct Row {
    name: String,
    vertices: String,
    samples: String,
    read_s: f64,
    remesh_s: f64,
    /// `None` where the child could not tell (`?`).
    peak_mb: Option<f64>,
}

impl Row {
    /// Parses `| name | vertices | samples | 0.02 s | 2.38 s | 334 MB |`
    /// (the peak may be `? MB`), as [`child`] prints it.
    fn parse(line: &str) -> Option<Row> {
        let cells: Vec<&str> = line
            .trim()
            .trim_matches('|')
            .split('|')
            .map(str::trim)
            .collect();
        let [name, vertices, samples, read, remesh, peak] = cells[..] else {
            return None;
        };
        let number = |cell: &str, unit: &str| cell.strip_suffix(unit)?.trim().parse::<f64>().ok();
        Some(Row {
            name: name.to_string(),
            vertices: vertices.to_string(),
            samples: samples.to_string(),
            read_s: number(read, "s")?,
            remesh_s: number(remesh, "s")?,
            peak_mb: match peak.strip_suffix("MB").map(str::trim) {
                Some("?") => None,
                _ => Some(number(peak, "MB")?),
            },
        })
    }

    /// The first row with each time and the peak replaced by its median
    /// over `rows` (the mean of the middle two for an even count).
    fn median(rows: &[Row]) -> Row {
        let median = |value: fn(&Row) -> Option<f64>| {
            let mut v: Vec<f64> = rows.iter().map(value).collect::<Option<_>>()?;
            v.sort_by(f64::total_cmp);
            let n = v.len();
            Some((v[(n - 1) / 2] + v[n / 2]) / 2.0)
        };
        Row {
            read_s: median(|r| Some(r.read_s)).expect("every row has it"),
            remesh_s: median(|r| Some(r.remesh_s)).expect("every row has it"),
            peak_mb: median(|r| r.peak_mb),
            ..rows[0].clone()
        }
    }
}

/// Remeshes `mesh` in a child process of the xtask binary `exe`.
fn run_child(exe: &Path, mesh: &str, level: Option<u32>, normal: bool) -> Result<Row, String> {
    let mut command = Command::new(exe);
    command.args(["remesh-bench", "--child", mesh]);
    if let Some(level) = level {
        command.args(["--level", &level.to_string()]);
    }
    command.args(["--normal-remesh", if normal { "on" } else { "off" }]);
    let exe_name = exe.display();
    let out = command
        .output()
        .map_err(|e| format!("{exe_name} on {mesh}: {e}"))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        // The child's own error names the mesh.
        return Err(format!(
            "{exe_name} remesh-bench --child ({}): {}",
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    stdout
        .lines()
        .find_map(Row::parse)
        .ok_or_else(|| format!("{exe_name} on {mesh} printed no table row: {stdout}"))
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
        "{}",
        child_row(
            &name,
            input.positions.len(),
            remeshed.mesh.layout().sample_count(),
            (read_s, remesh_s),
            peak_kb(),
        )
    );
    Ok(())
}

/// The child's table row, which [`Row::parse`] reads.
fn child_row(
    name: &str,
    vertices: usize,
    samples: usize,
    (read_s, remesh_s): (f64, f64),
    peak_kb: Option<u64>,
) -> String {
    format!(
        "| {name} | {vertices} | {samples} | {read_s:.3} s | {remesh_s:.3} s | {} MB |",
        peak_kb.map_or("?".into(), |kb| (kb / 1024).to_string()),
    )
}

fn read(path: &Path) -> Result<PolyMesh, String> {
    qm::read_mesh(path).map_err(|e| e.to_string())
}

/// Peak resident memory of this process in KiB (Linux).
pub(crate) fn peak_kb() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// A triangulated torus of `n x m` vertices with a fine relief.
fn bumpy_torus(n: u32, m: u32) -> PolyMesh {
    let minor = |u: f64, v: f64| 1.0 + 0.02 * (17.0 * u).sin() * (11.0 * v).cos();
    qm_shapes::poly(qm_shapes::torus(n, m, 3.0, minor))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(remesh_s: f64, peak_mb: f64) -> Row {
        Row {
            name: "m".into(),
            vertices: "3".into(),
            samples: "9".into(),
            read_s: 0.01,
            remesh_s,
            peak_mb: Some(peak_mb),
        }
    }

    #[test]
    fn a_child_row_parses() {
        let r = Row::parse("| stanford-bunny.obj | 35947 | 1049277 | 0.02 s | 2.38 s | 334 MB |");
        let expected = Row {
            name: "stanford-bunny.obj".into(),
            vertices: "35947".into(),
            samples: "1049277".into(),
            read_s: 0.02,
            remesh_s: 2.38,
            peak_mb: Some(334.0),
        };
        assert_eq!(r, Some(expected.clone()));
        let r = Row::parse("| stanford-bunny.obj | 35947 | 1049277 | 0.02 s | 2.38 s | ? MB |");
        let unknown = Row {
            peak_mb: None,
            ..expected
        };
        assert_eq!(r, Some(unknown));
        assert_eq!(
            Row::parse("| mesh | input vertices | samples | read | remesh | peak memory |"),
            None
        );
        assert_eq!(Row::parse("|---|---|---|---|---|---|"), None);
    }

    #[test]
    fn the_child_row_parses_back() {
        for peak_kb in [Some(342_016), None] {
            let line = child_row("spot.obj", 2930, 10804, (0.0125, 1.5), peak_kb);
            let r = Row::parse(&line).expect(&line);
            assert_eq!((r.name.as_str(), r.vertices.as_str()), ("spot.obj", "2930"));
            assert_eq!((r.read_s, r.remesh_s), (0.013, 1.5));
            assert_eq!(r.peak_mb, peak_kb.map(|_| 334.0));
        }
    }

    #[test]
    fn flags_take_their_values_out() {
        let mut args: Vec<String> = ["a.obj", "--runs", "3", "b.obj", "--level"]
            .map(String::from)
            .to_vec();
        assert_eq!(take(&mut args, "--against", "x"), Ok(None));
        assert_eq!(take(&mut args, "--runs", "a value"), Ok(Some("3".into())));
        assert_eq!(args, ["a.obj", "b.obj", "--level"]);
        assert_eq!(
            take(&mut args, "--level", "a value"),
            Err("--level needs a value".into())
        );
    }

    #[test]
    fn medians_of_odd_and_even_counts() {
        let rows = [row(3.0, 10.0), row(1.0, 30.0), row(2.0, 20.0)];
        let m = Row::median(&rows);
        assert_eq!((m.remesh_s, m.peak_mb), (2.0, Some(20.0)));
        let m = Row::median(&rows[..2]);
        assert_eq!((m.remesh_s, m.peak_mb), (2.0, Some(20.0)));
    }
}
