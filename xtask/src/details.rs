//! `details`: how normal the codec's details are, per remesh setting.
//!
//! Each model is remeshed without and with normal placement
//! ([`RemeshOptions::with_normal`]); for each remesh it reports the
//! remesh PSNR against the input (`qm distance`, 1M samples each way), the
//! remesh time, the lossless size with the default encoder, and per level
//! the tangential share of the detail energy in the codec's frames
//! (16 bits, the default update): `(t1^2 + t2^2) / |d|^2` summed over the
//! level's details.

use std::path::PathBuf;
use std::time::Instant;

use qm::lift::{Lifting, Quantizer};
use qm::param::distance::{DistanceOptions, distance};
use qm::{EncodeOptions, PolyMesh, RemeshOptions};

use crate::rd;

pub fn run(args: &[String]) -> Result<(), String> {
    let mut files = Vec::new();
    for a in args {
        let p = PathBuf::from(a);
        if p.is_dir() {
            files.extend(rd::mesh_files(&p)?);
        } else {
            files.push(p);
        }
    }
    if files.is_empty() {
        files.push(crate::workspace().join("assets/spot.obj"));
    }
    println!(
        "| model | remesh | PSNR | time | lossless | moved / kept | tangential share per level, 1..L |"
    );
    println!("|---|---|---|---|---|---|---|");
    for file in &files {
        let name = rd::file_name(file);
        let at = |e: String| format!("{}: {e}", file.display());
        let input = qm::read_mesh(file).map_err(|e| at(e.to_string()))?;
        for normal in [false, true] {
            let start = Instant::now();
            let r = qm::remesh(&input, &RemeshOptions::DEFAULT.with_normal(normal))
                .map_err(|e| at(e.to_string()))?;
            let seconds = start.elapsed().as_secs_f64();
            let layout = r.mesh.layout();
            let quads =
                PolyMesh::from_faces(r.mesh.positions().to_vec(), &layout.quads(layout.level()));
            let psnr = distance(&input, &quads, &DistanceOptions::DEFAULT)
                .map_err(|e| at(e.to_string()))?
                .psnr_db;
            let encoder = EncodeOptions::DEFAULT;
            let lossless = qm::codec::compress(&r.mesh, &encoder)
                .map_err(|e| at(e.to_string()))?
                .bytes
                .len();
            // The details as the encoder turns them.
            let quantizer =
                Quantizer::fit(r.mesh.positions(), encoder.bits).map_err(|e| at(e.to_string()))?;
            let mut data = quantizer.quantize_all(r.mesh.positions());
            // (frames from the default parent level, which the remesher's
            // placement follows, whatever source the encoder picks)
            Lifting::new(layout, encoder.update)
                .with_frames(true)
                .forward(&mut data);
            let mut shares = Vec::new();
            for level in 1..=layout.level() {
                let coarse: std::collections::HashSet<u32> =
                    layout.samples_at(level - 1).into_iter().collect();
                let (mut n, mut t) = (0f64, 0f64);
                for id in layout.samples_at(level) {
                    if coarse.contains(&id) {
                        continue;
                    }
                    let d = data[id as usize].map(f64::from);
                    n += d[0] * d[0];
                    t += d[1] * d[1] + d[2] * d[2];
                }
                shares.push(format!("{:.3}", t / (n + t).max(1.0)));
            }
            let placed = r
                .report
                .normal
                .map_or("-".to_string(), |p| format!("{} / {}", p.moved, p.kept));
            println!(
                "| {name} | {} | {psnr:.2} dB | {seconds:.2} s | {lossless} B | {placed} | {} |",
                if normal { "normal" } else { "plain" },
                shares.join(" ")
            );
        }
    }
    Ok(())
}
