//! `cargo xtask valence [--max N]`: `qm` encode time (remesh and coding, in
//! this process) against the valence of one vertex, on the shapes of CAD
//! and capped holes: a closed cylinder whose caps are fans of `n`
//! triangles around a hub, and one flat `n`-gon (the clean-up triangulates
//! it). Prints a Markdown table with the time per input vertex, so that
//! near-linear growth reads as a flat column.

use std::time::Instant;

use qm::PolyMesh;

use crate::stress::cylinder;

const SIZES: [u32; 5] = [100, 300, 1_000, 3_000, 10_000];

pub fn run(args: &[String]) -> Result<(), String> {
    let max = match args {
        [] => u32::MAX,
        [flag, n] if flag == "--max" => n.parse().map_err(|_| format!("--max {n}: not a count"))?,
        _ => return Err("usage: cargo xtask valence [--max N]".into()),
    };
    println!("| shape | n | input vertices | encode | per input vertex | samples | bytes |");
    println!("|---|---:|---:|---:|---:|---:|---:|");
    for &n in SIZES.iter().filter(|&&n| n <= max) {
        let fan = cylinder(n);
        let fan = PolyMesh::from_faces(fan.positions, &fan.faces);
        for (shape, mesh) in [("fan-capped cylinder", fan), ("n-gon", qm_shapes::ngon(n))] {
            let start = Instant::now();
            let encoded = qm::encode(&mesh, &qm::Options::default())
                .map_err(|e| format!("{shape} of {n}: {e}"))?;
            let seconds = start.elapsed().as_secs_f64();
            let vertices = mesh.positions.len();
            println!(
                "| {shape} | {n} | {vertices} | {seconds:.2} s | {:.0} µs | {} | {} |",
                1e6 * seconds / vertices as f64,
                encoded.samples,
                encoded.bytes.len()
            );
        }
    }
    Ok(())
}
