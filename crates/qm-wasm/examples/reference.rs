//! What the one-shot native decoder (`qm_codec::decompress`) makes of a file or
//! a prefix of it, for the browser test to compare the viewer against:
//!
//! ```sh
//! cargo run -p qm-wasm --example reference -- FILE.qm [BYTES [LEVEL]]
//! ```
//!
//! (LEVEL: a number, `auto`, the default, or `finest`) prints one JSON
//! line: bytes given and used, level, passes, vertices, triangles, the
//! estimated error and PSNR,
//! the [`qm_wasm::mesh_checksum`] of the mesh (the viewer's triangulation of
//! the quads, two triangles each), and for a file with colours the
//! [`qm_wasm::colour_checksum`] of its vertex colours (else `null`), and
//! for a file with colour finer than its geometry its texture's width,
//! height and [`qm_wasm::colour_checksum`] of the texels (else `null`).

use std::process::ExitCode;

use qm_codec::{DecodeOptions, LevelChoice, decompress};

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
    let level = match args.get(2).map(String::as_str) {
        None | Some("auto") => LevelChoice::Auto,
        Some("finest") => LevelChoice::Finest,
        Some(_) => match number(2) {
            Some(l) => LevelChoice::Fixed(l as u32),
            None => {
                eprintln!("usage: reference FILE.qm [BYTES [LEVEL|auto|finest]]");
                return ExitCode::from(2);
            }
        },
    };
    let options = DecodeOptions::default()
        .with_max_bytes(Some(n))
        .with_level(level);
    let d = match decompress(&bytes, &options) {
        Ok(d) => d,
        Err(e) => {
            eprintln!("error: {path}: {e}");
            return ExitCode::from(1);
        }
    };
    let (checksum, vertices, triangles) = qm_wasm::decompressed_checksum(&d);
    let used = d.header_bytes + d.base_bytes + d.decoded_stream_bytes;
    let error = d.estimate.error(d.level);
    let psnr = d.estimate.psnr_db(d.level);
    let colours = d.colours.as_deref().map_or("null".to_string(), |c| {
        format!("\"{:016x}\"", qm_wasm::colour_checksum(c))
    });
    let texture = d.texture.as_ref().map_or("null".to_string(), |a| {
        format!(
            "{{\"width\":{},\"height\":{},\"checksum\":\"{:016x}\"}}",
            a.width,
            a.height,
            qm_wasm::colour_checksum(&a.texels)
        )
    });
    println!(
        "{{\"bytes\":{n},\"bytesUsed\":{used},\"level\":{},\"passes\":{},\"vertices\":{},\"triangles\":{},\"error\":{},\"psnr\":{},\"checksum\":\"{checksum:016x}\",\"colours\":{colours},\"texture\":{texture}}}",
        d.level,
        d.passes,
        vertices,
        triangles,
        json_number(error),
        json_number(psnr)
    );
    ExitCode::SUCCESS
}

/// A JSON number, or `null` for what JSON cannot hold.
fn json_number(x: f64) -> String {
    if x.is_finite() {
        format!("{x:e}")
    } else {
        "null".to_string()
    }
}
