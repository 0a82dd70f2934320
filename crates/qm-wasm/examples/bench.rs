//! Native decode timings of a `.qm` file, to set against the browser's
//! (`web/test/measure.mjs` runs both):
//!
//! ```sh
//! cargo run --release -p qm-wasm --example bench -- FILE.qm [RUNS]
//! ```
//!
//! prints one JSON line with medians in ms: `fullMs`, the whole file through
//! the incremental decoder from scratch (header, base, layout, stream,
//! lifting, vertex buffers and normals: what the WebAssembly build does per
//! run of the page's benchmark); `baseMs`, the header and base section alone
//! (the first picture); `decompressMs`, `qm_codec::decompress` of the whole file.

use std::process::ExitCode;
use std::time::Instant;

use qm_codec::{DecodeOptions, Decoder, Limits, decompress};
use qm_wasm::Buffers;

fn median(mut xs: Vec<f64>) -> f64 {
    xs.sort_by(f64::total_cmp);
    xs[xs.len() / 2]
}

fn time(bytes: &[u8]) -> (f64, usize) {
    let t = Instant::now();
    let mut inc = Buffers::default();
    inc.decoder_mut().push(bytes).expect("a valid file");
    inc.refine().expect("a complete base mesh");
    (t.elapsed().as_secs_f64() * 1e3, inc.positions().len() / 3)
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: bench FILE.qm [RUNS]");
        return ExitCode::from(2);
    };
    let runs = args
        .get(1)
        .and_then(|r| r.parse().ok())
        .unwrap_or(9usize)
        .max(1);
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("error: {path}: {e}");
            return ExitCode::from(1);
        }
    };
    let start = match Decoder::new(&bytes, &Limits::DEFAULT) {
        Ok(d) => d.stream_start(),
        Err(e) => {
            eprintln!("error: {path}: {e}");
            return ExitCode::from(1);
        }
    };
    let (mut full, mut base, mut one_shot) = (Vec::new(), Vec::new(), Vec::new());
    let mut vertices = 0;
    for _ in 0..runs {
        let (ms, v) = time(&bytes);
        full.push(ms);
        vertices = v;
        base.push(time(&bytes[..start]).0);
        let t = Instant::now();
        let d = decompress(&bytes, &DecodeOptions::default()).expect("a valid file");
        std::hint::black_box(d.level_mesh());
        one_shot.push(t.elapsed().as_secs_f64() * 1e3);
    }
    let ms = median(full);
    println!(
        "{{\"bytes\":{},\"vertices\":{vertices},\"runs\":{runs},\"fullMs\":{ms:.3},\"baseMs\":{:.3},\"decompressMs\":{:.3},\"mbPerS\":{:.3},\"verticesPerS\":{:.0}}}",
        bytes.len(),
        median(base),
        median(one_shot),
        bytes.len() as f64 / 1e6 / (ms / 1e3),
        vertices as f64 / (ms / 1e3),
    );
    ExitCode::SUCCESS
}
