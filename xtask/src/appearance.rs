//! `cargo xtask appearance [--samples N] [FILE ...]`: how well colour
//! travels with the geometry (issue 46's targets).
//!
//! For each asset (default: the coloured and textured files of
//! `assets/appearance/`), compresses it with its colours
//! ([`qm::encode_asset`]) and without ([`qm::encode`]), and measures, the
//! way `qm distance` does (symmetric, area-sampled, `--samples` points a
//! side): the geometric and colour PSNR of the whole file, of the
//! shortest prefix whose geometry reaches 65 dB, and of the shortest whose
//! colour reaches 25 dB (found by bisection over the prefix length,
//! decoded at the level the bytes support). One markdown row per asset.

use qm::param::distance::{DistanceOptions, distance};
use qm::{AssetOptions, DecodeOptions, Options};

/// The geometric PSNR whose prefix the colour is measured at.
const TARGET_DB: f64 = 65.0;

/// The colour PSNR whose prefix the geometry is measured at.
const COLOUR_TARGET_DB: f64 = 25.0;

pub fn run(args: &[String]) -> Result<(), String> {
    let mut samples = 200_000usize;
    let mut files = Vec::new();
    let mut it = args.iter();
    while let Some(arg) = it.next() {
        match arg.as_str() {
            "--samples" => {
                samples = (it.next().and_then(|v| v.parse().ok()))
                    .ok_or("--samples takes a whole number")?
            }
            _ => files.push(arg.clone()),
        }
    }
    if files.is_empty() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/appearance");
        let mut found: Vec<String> = std::fs::read_dir(dir)
            .map_err(|e| format!("{dir}: {e}"))?
            .filter_map(|e| e.ok().map(|e| e.path().display().to_string()))
            .filter(|p| p.ends_with(".glb") || p.ends_with(".ply") || p.ends_with(".obj"))
            .collect();
        found.sort();
        files = found;
    }
    let options = DistanceOptions::DEFAULT.with_samples(samples);
    println!(
        "| asset | vertices | samples | geometry only | with colour | lossless geometry | lossless colour | 65 dB prefix (geometry) | its colour | 25 dB colour prefix (its geometry) |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for file in &files {
        row(file, &options).map_err(|e| format!("{file}: {e}"))?;
    }
    Ok(())
}

fn row(file: &str, options: &DistanceOptions) -> Result<(), String> {
    let text = |e: qm::Error| e.to_string();
    let input = qm::read_asset(file, &AssetOptions::DEFAULT.with_images(true)).map_err(text)?;
    let plain = qm::encode(&input.mesh, &Options::default()).map_err(text)?;
    let coloured = qm::encode_asset(&input, &Options::default()).map_err(text)?;
    let bytes = &coloured.bytes;
    let measure = |n: usize| -> Result<(f64, f64), String> {
        let decoded = qm::decode(&bytes[..n], &DecodeOptions::default()).map_err(text)?;
        let geometry = distance(&input.mesh, &decoded.mesh, options).map_err(|e| e.to_string())?;
        // The decode's look: its texture, or its colours at the vertices.
        let colour = qm::param::colour_distance(&input, &decoded.to_asset(), options)
            .map_err(|e| e.to_string())?
            .map_or(f64::NAN, |r| r.psnr_db);
        Ok((geometry.psnr_db, colour))
    };
    let whole = measure(bytes.len())?;
    // The shortest prefixes at the targets, by bisection (the geometry's
    // error does not rise with the bytes, holds and all; the colour's
    // hardly).
    let start = coloured.header_bytes + coloured.base_bytes;
    let shortest = |reached: &dyn Fn((f64, f64)) -> bool| -> Result<usize, String> {
        let (mut lo, mut hi) = (start, bytes.len());
        if reached(measure(lo)?) {
            return Ok(lo);
        }
        while hi - lo > 1.max(bytes.len() / 1000) {
            let mid = (lo + hi) / 2;
            if reached(measure(mid)?) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        Ok(hi)
    };
    let geometry_at = shortest(&|(g, _)| g >= TARGET_DB)?;
    let at = measure(geometry_at)?;
    let colour_at = shortest(&|(_, c)| c >= COLOUR_TARGET_DB)?;
    let then = measure(colour_at)?;
    let name = std::path::Path::new(file)
        .file_name()
        .map_or(file.into(), |n| n.to_string_lossy());
    println!(
        "| {name} | {} | {} | {} | {} | {:.1} dB | {:.1} dB | {} B ({:.1} dB) | {:.1} dB | {} B ({:.1} dB) |",
        input.mesh.positions.len(),
        coloured.samples,
        plain.bytes.len(),
        bytes.len(),
        whole.0,
        whole.1,
        geometry_at,
        at.0,
        at.1,
        colour_at,
        then.0
    );
    Ok(())
}
