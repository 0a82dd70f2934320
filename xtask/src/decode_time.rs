//! `cargo xtask decode-time FILE.qm [--runs N] [--bytes N ...]`: the native
//! decoder's time, for the Python binding's benchmark
//! (`crates/qm-python/bench/bench.py`) to set its own against.
//!
//! Times [`qm::decode`] with default options (the level the bytes support)
//! on the file in memory, or on its first `N` bytes for each `--bytes`: the
//! median of `N` runs (default 21) after one warm-up, in milliseconds, one
//! JSON object per line (`bytes`, `ms`, `runs`, `vertices`, `level`).

use std::time::Instant;

pub fn run(args: &[String]) -> Result<(), String> {
    let mut file = None;
    let mut runs = 21usize;
    let mut cuts = Vec::new();
    let mut it = args.iter();
    while let Some(arg) = it.next() {
        let mut value = |name: &str| -> Result<usize, String> {
            it.next()
                .and_then(|v| v.parse().ok())
                .ok_or_else(|| format!("{name} takes a whole number"))
        };
        match arg.as_str() {
            "--runs" => runs = value("--runs")?.max(1),
            "--bytes" => cuts.push(value("--bytes")?),
            _ if file.is_none() => file = Some(arg.clone()),
            _ => return Err(format!("unexpected argument {arg:?}")),
        }
    }
    let file = file.ok_or("usage: cargo xtask decode-time FILE.qm [--runs N] [--bytes N ...]")?;
    let data = std::fs::read(&file).map_err(|e| format!("{file}: {e}"))?;
    if cuts.is_empty() {
        cuts.push(data.len());
    }
    for cut in cuts {
        let bytes = &data[..cut.min(data.len())];
        let decode = || qm::decode(bytes, &qm::DecodeOptions::default());
        let first = decode().map_err(|e| format!("{file}: {e}"))?;
        let mut times: Vec<f64> = (0..runs)
            .map(|_| {
                let t = Instant::now();
                let decoded = decode();
                let ms = t.elapsed().as_secs_f64() * 1e3;
                drop(decoded);
                ms
            })
            .collect();
        times.sort_by(f64::total_cmp);
        println!(
            "{{\"bytes\": {}, \"ms\": {:.3}, \"runs\": {runs}, \"vertices\": {}, \"level\": {}}}",
            bytes.len(),
            times[runs / 2],
            first.mesh.positions.len(),
            first.level()
        );
    }
    Ok(())
}
