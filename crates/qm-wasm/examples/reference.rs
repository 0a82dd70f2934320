//! What the one-shot native decoder (`qm_codec::decompress`) makes of a file or
//! a prefix of it, for the browser test to compare the viewer against:
//!
//! ```sh
//! cargo run -p qm-wasm --example reference -- FILE.qm [BYTES [LEVEL]]
//! ```
//!
//! prints one JSON line: bytes used, level, passes, vertices, triangles and
//! the [`qm_wasm::mesh_checksum`] of the mesh (the viewer's triangulation of
//! the quads, two triangles each).

use std::process::ExitCode;

use qm_codec::{DecodeOptions, decompress};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: reference FILE.qm [BYTES [LEVEL]]");
        return ExitCode::from(2);
    };
    let number = |i: usize| args.get(i).and_then(|a| a.parse::<usize>().ok());
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("error: {path}: {e}");
            return ExitCode::from(1);
        }
    };
    let n = number(1).unwrap_or(bytes.len()).min(bytes.len());
    let options = DecodeOptions::default()
        .with_max_bytes(Some(n))
        .with_level(number(2).map(|l| l as u32));
    let d = match decompress(&bytes, &options) {
        Ok(d) => d,
        Err(e) => {
            eprintln!("error: {path}: {e}");
            return ExitCode::from(1);
        }
    };
    let (checksum, vertices, triangles) = qm_wasm::decompressed_checksum(&d);
    println!(
        "{{\"bytes\":{n},\"level\":{},\"passes\":{},\"vertices\":{},\"triangles\":{},\"checksum\":\"{checksum:016x}\"}}",
        d.level, d.passes, vertices, triangles
    );
    ExitCode::SUCCESS
}
