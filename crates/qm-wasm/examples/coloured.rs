//! Writes the coloured test file of the JavaScript and Python bindings'
//! tests (`js/test`, `crates/qm-python/tests`):
//!
//! ```sh
//! cargo run --release -p qm-wasm --example coloured -- OUT.qm [LEVEL]
//! ```
//!
//! `OUT.qm` is `qm_lift::synthetic::bumpy_sphere(LEVEL)` (default 4) with a
//! colour per sample, compressed with the default options by
//! `qm_codec::compress_coloured`; beside it, `OUT.rgb` holds those colours
//! as raw bytes, `r, g, b` per vertex of the finest level in the decoder's
//! vertex order: what decoding the whole file at the finest level must
//! give back exactly.

use std::path::Path;
use std::process::ExitCode;

use qm_codec::qm_lift::synthetic::bumpy_sphere;
use qm_codec::{Colours, EncodeOptions, compress_coloured};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let level = match args.get(1).map(|l| l.parse::<u32>()) {
        None => Ok(4),
        Some(Ok(l)) if l <= 7 => Ok(l),
        Some(_) => Err(()),
    };
    let (Some(out), Ok(level)) = (args.first(), level) else {
        eprintln!("usage: coloured OUT.qm [LEVEL 0..=7]");
        return ExitCode::from(2);
    };
    let mesh = bumpy_sphere(level);
    // Three waves over the sphere (bands of hue a viewer shows at once),
    // and a little per-sample noise that only the finest passes carry.
    let rgb: Vec<[u8; 3]> = (mesh.positions().iter().enumerate())
        .map(|(s, p)| {
            let noise = ((s as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 61) as f64;
            [(4.0, 0.0, 1.0), (0.0, -3.0, 2.0), (-2.0, 2.0, -3.0)].map(|(a, b, c)| {
                let wave = (a * p.x + b * p.y + c * p.z).sin();
                (127.5 + 110.0 * wave + noise - 4.0)
                    .round()
                    .clamp(0.0, 255.0) as u8
            })
        })
        .collect();
    let encoded = match compress_coloured(&mesh, Colours::new(&rgb), &EncodeOptions::DEFAULT, None)
    {
        Ok(e) => e,
        Err(e) => {
            eprintln!("error: {out}: {e}");
            return ExitCode::from(4);
        }
    };
    let rgb_path = Path::new(out).with_extension("rgb");
    for (path, bytes) in [
        (Path::new(out), &encoded.bytes[..]),
        (&rgb_path, rgb.as_flattened()),
    ] {
        if let Err(e) = std::fs::write(path, bytes) {
            eprintln!("error: {}: {e}", path.display());
            return ExitCode::from(1);
        }
    }
    ExitCode::SUCCESS
}
