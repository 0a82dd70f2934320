//! Experiments behind the figures in the README and `docs/`: `cargo xtask <task>`.
//!
//! - `pass-table [MESH ...]`: for each mesh (default: the bundled quad
//!   meshes), compress it losslessly and decode 2, 4, ..., 12 passes and the
//!   whole stream; print a Markdown table of file sizes and PSNR. PSNR is
//!   `20 log10(bbox diagonal / RMS)` with RMS the vertex-to-vertex distance
//!   between corresponding samples and input vertices (exact correspondence
//!   exists for meshes taken as they are).
//! - `rd-curve [--models FILE|DIR ...] [--out DIR] [--draco PATH]
//!   [--base-domain auto|square|charts|input]`: qm's
//!   rate-distortion curve against Google Draco's command-line coder on each
//!   mesh (default: the bundled meshes in `assets/`), measured as surface
//!   distance to the input; writes `rd.csv`, `table1.md`, `summary.md`,
//!   `rd.svg` and `rd.png` (default into `target/rd/`). See [`rd`].
//! - `remesh-bench [--level L] [--normal-remesh on|off] [--runs N]
//!   [--against XTASK] [MESH ...]`: remesh time and peak memory per mesh,
//!   each in a process of its own (default: the bunny and a generated
//!   500k-vertex torus), medians of `N` runs, interleaved with another
//!   build's. See [`remesh_bench`].
//! - `ab [--models FILE|DIR ...] [--a SPEC] [--b SPEC] [--cuts N]
//!   [--out FILE]`: two encoder (and remesher) settings compared at equal
//!   bytes on the same models. See [`ab`].
//! - `details [FILE|DIR ...]`: remesh PSNR, lossless size and the tangential
//!   share of the codec's details, with and without the remesher's normal
//!   placement. See [`details`].
//! - `budget [--models FILE|DIR ...] [--db DB ...]`: bits by symbol class
//!   at the passes closest to each PSNR (default 65 and 78 dB). See
//!   [`budget`].
//! - `corpus`: writes the malformed `.qm` files of `tests/corrupt/` anew
//!   from one valid stream and prints their table rows. See [`corpus`].
//! - `stress DIR`: writes four generated meshes of hard topology into `DIR`
//!   (genus 12, 100 holes, 300 parts, a ragged open height field) and prints
//!   their topology. See [`stress`].
//! - `cad DIR`: renders ten of OpenSCAD's CC0 examples (needs Debian's
//!   `openscad`) into welded OBJ meshes: faceted CAD parts. See [`cad`].
//! - `valence [--max N]`: encode time against the valence of one vertex
//!   (fan-capped cylinders and n-gons of 100 to 10,000). See [`valence`].
//! - `decode-time FILE.qm [--runs N] [--bytes N ...]`: the median time of
//!   [`qm::decode`] on the file or its prefixes, for the Python binding's
//!   benchmark. See [`decode_time`].
//! - `memory [--max-level L] [MESH[:DOMAIN] ...]`: peak memory of compress
//!   against the memory model's estimate, on soups, fans, a plane at levels
//!   6 to `L` and the bunny. See [`memory`].
//! - `scale [--sizes 0.5M,2M,8M] [--mesh FILE] [--max-memory SIZE] [--no-draco] [--keep DIR]`: time,
//!   peak memory, estimate, lossless PSNR and bytes at 65 and 78 dB against
//!   Draco on dense scan-like meshes. See [`scale`].

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use qm::{DecodeOptions, EncodeOptions};

mod ab;
mod appearance;
mod budget;
mod cad;
mod corpus;
mod curves;
mod decode_time;
mod details;
mod memory;
mod pcd_mesh;
mod plot;
mod rd;
mod remesh_bench;
mod scale;
mod stress;
mod valence;

const PASSES: [u32; 6] = [2, 4, 6, 8, 10, 12];

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("pass-table") => pass_table(&args[1..]),
        Some("rd-curve") => rd::run(&args[1..]),
        Some("remesh-bench") => remesh_bench::run(&args[1..]),
        Some("ab") => ab::run(&args[1..]),
        Some("details") => details::run(&args[1..]),
        Some("budget") => budget::run(&args[1..]),
        Some("corpus") => corpus::run(&args[1..]),
        Some("stress") => stress::run(&args[1..]),
        Some("cad") => cad::run(&args[1..]),
        Some("valence") => valence::run(&args[1..]),
        Some("decode-time") => decode_time::run(&args[1..]),
        Some("memory") => memory::run(&args[1..]),
        Some("scale") => scale::run(&args[1..]),
        Some("appearance") => appearance::run(&args[1..]),
        Some("pcd-mesh") => pcd_mesh::run(&args[1..]),
        _ => Err("usage: cargo xtask pass-table [MESH ...]\n       \
                  cargo xtask rd-curve [--models FILE|DIR ...] [--out DIR] [--draco PATH] [--base-domain D]\n       \
                  cargo xtask remesh-bench [--level L] [--normal-remesh on|off] [--runs N] [--against XTASK] [MESH ...]\n       \
                  cargo xtask ab [--models FILE|DIR ...] [--a SPEC] [--b SPEC] [--cuts N] [--out FILE]\n       \
                  cargo xtask details [FILE|DIR ...]\n       \
                  cargo xtask budget [--models FILE|DIR ...] [--db DB ...]\n       \
                  cargo xtask corpus\n       \
                  cargo xtask stress DIR\n       \
                  cargo xtask cad DIR\n       \
                  cargo xtask valence [--max N]\n       \
                  cargo xtask decode-time FILE.qm [--runs N] [--bytes N ...]\n       \
                  cargo xtask memory [--max-level L] [MESH[:DOMAIN] ...]\n       \
                  cargo xtask scale [--sizes 0.5M,2M,8M] [--mesh FILE] [--max-memory SIZE] [--no-draco] [--keep DIR]\n       \
                  cargo xtask appearance [--samples N] [FILE ...]\n       \
                  cargo xtask pcd-mesh IN.pcd OUT.ply"
            .to_string()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn pass_table(args: &[String]) -> Result<(), String> {
    let files: Vec<PathBuf> = if args.is_empty() {
        [
            "cc_cube.obj",
            "cc_dodecahedron.obj",
            "torus_4x6_l4.obj",
            "holed_grid_l4.obj",
        ]
        .iter()
        .map(|n| workspace().join("assets/quad").join(n))
        .collect()
    } else {
        args.iter().map(PathBuf::from).collect()
    };
    let head: Vec<String> = PASSES.iter().map(|p| format!("{p} passes")).collect();
    println!(
        "| model | input | base | {} | all (lossless) |",
        head.join(" | ")
    );
    println!("|---|---|---|{}---|", "---|".repeat(PASSES.len()));
    for file in files {
        let name = file
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned());
        let input = qm::read_mesh(&file).map_err(|e| e.to_string())?;
        let prepared = qm::detect(&input).map_err(|e| format!("{}: {e}", file.display()))?;
        let original: Vec<_> = prepared
            .source
            .iter()
            .map(|&v| input.positions[v as usize])
            .collect();
        let (lo, hi) = qm::lift::bounding_box(&original);
        let diagonal = (hi - lo).length();
        let compressed = qm::codec::compress(&prepared.mesh, &EncodeOptions::DEFAULT)
            .map_err(|e| e.to_string())?;
        let input_bytes = std::fs::metadata(&file).map_err(|e| e.to_string())?.len();
        let psnr = |options: DecodeOptions| -> Result<f64, String> {
            let decoded =
                qm::codec::decompress(&compressed.bytes, &options).map_err(|e| e.to_string())?;
            let sum: f64 = original
                .iter()
                .enumerate()
                .map(|(s, p)| decoded.position(s).distance_squared(*p))
                .sum();
            Ok(20.0 * (diagonal / (sum / original.len() as f64).sqrt()).log10())
        };
        let mut cells = Vec::new();
        for p in PASSES {
            let bytes = compressed
                .pass_ends
                .get(p as usize - 1)
                .copied()
                .unwrap_or(compressed.bytes.len());
            let db = psnr(DecodeOptions::FINEST.with_passes(Some(p)))?;
            cells.push(format!("{} B, {db:.1} dB", bytes));
        }
        let db = psnr(DecodeOptions::FINEST)?;
        println!(
            "| {name} | {} KB, {} vertices | {} B ({} quads, level {}) | {} | {} B, {db:.1} dB |",
            input_bytes / 1024,
            original.len(),
            compressed.header_bytes + compressed.base_bytes,
            prepared.mesh.layout().face_count(),
            prepared.level,
            cells.join(" | "),
            compressed.bytes.len(),
        );
    }
    Ok(())
}
