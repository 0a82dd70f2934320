//! `budget`: where the bits of a stream go.
//!
//! Each model is prepared and compressed with the default settings; the
//! details are lifted again the way the encoder chose (its frame source) and
//! coded once more through a measuring coder that adds up `-log2 p` of every
//! symbol under the adaptive model at coding time. For the pass counts whose
//! cut comes closest to each target PSNR (surface distance, as in
//! `rd-curve`) it prints the bits by symbol class: significance by level
//! class and coordinate, signs by coordinate, zerotree bits by level class,
//! refinement by level class and coordinate. Level class 0 is the finest
//! level, 3 every level three or more above it; coordinate 0 is the normal
//! one with frames.

use std::fmt::Write as _;
use std::path::PathBuf;

use qm::ezw::{BitBudget, Cost, LEVEL_CLASSES, ZeroTree};
use qm::lift::Lifting;
use qm::{DecodeOptions, Decoder, EncodeOptions, Limits, RemeshOptions};

use crate::rd;

const USAGE: &str = "usage: cargo xtask budget [--models FILE|DIR ...] [--db DB ...]";

pub fn run(args: &[String]) -> Result<(), String> {
    let mut models = Vec::new();
    let mut targets = Vec::new();
    let mut i = 0;
    while i < args.len() {
        let list = match args[i].as_str() {
            "--models" => &mut models,
            "--db" => &mut targets,
            _ => return Err(USAGE.to_string()),
        };
        i += 1;
        while i < args.len() && !args[i].starts_with("--") {
            list.push(args[i].clone());
            i += 1;
        }
    }
    let targets: Vec<f64> = if targets.is_empty() {
        vec![65.0, 78.0]
    } else {
        targets
            .iter()
            .map(|t| t.parse().map_err(|_| format!("{t}: not a number")))
            .collect::<Result<_, _>>()?
    };
    let mut files = Vec::new();
    if models.is_empty() {
        files.push(crate::workspace().join("assets/spot.obj"));
    }
    for m in models.iter().map(PathBuf::from) {
        if m.is_dir() {
            files.extend(rd::mesh_files(&m)?);
        } else {
            files.push(m);
        }
    }
    for file in &files {
        let name = rd::file_name(file);
        let at = |e: String| format!("{}: {e}", file.display());
        let input = qm::read_mesh(file).map_err(|e| at(e.to_string()))?;
        let prepared =
            qm::prepare(&input, &RemeshOptions::DEFAULT).map_err(|e| at(e.to_string()))?;
        let options = EncodeOptions::DEFAULT;
        let c = qm::codec::compress(&prepared.mesh, &options).map_err(|e| at(e.to_string()))?;
        let decoder = Decoder::new(&c.bytes, &Limits::NONE).map_err(|e| at(e.to_string()))?;
        let header = decoder.header();
        let layout = prepared.mesh.layout();
        let mut data = c.quantized.clone();
        Lifting::new(layout, options.update)
            .with_parent_frames_from(header.parent_frames_from())
            .forward(&mut data);
        let tree = ZeroTree::new(layout);
        // The stream's own base bits, as the encoder chose them: with the
        // split implied, those of the corners alone (the first vertices).
        let coded = qm::codec::coded_base_values(layout.base(), header.implied());
        let base = qm::ezw::BaseBits {
            values: &data[..coded],
            most: header.stream_params().base_bits,
            whole: false,
            // This build's geometry rounds its base values.
            rounded: true,
        };
        let budgets = qm::ezw::bit_budget(
            &tree,
            &tree.gather(&data),
            Some(base),
            header.stream_params().weighting,
            header.stream_params().contexts,
            None,
        );
        let first = c.header_bytes + c.base_bytes;
        // PSNR after each pass until the last target is passed.
        let mut psnr = Vec::new();
        for p in 1..=budgets.len() as u32 {
            let d = qm::decode(&c.bytes, &DecodeOptions::FINEST.with_passes(Some(p)))
                .map_err(|e| at(e.to_string()))?;
            let db = rd::measure(&input, &d.mesh).map_err(at)?.psnr_db;
            psnr.push(db);
            if targets.iter().all(|&t| db > t + 3.0) {
                break;
            }
        }
        for &t in &targets {
            let Some(k) = (0..psnr.len())
                .min_by(|&a, &b| (psnr[a] - t).abs().total_cmp(&(psnr[b] - t).abs()))
            else {
                continue;
            };
            let bytes = c.pass_ends[k] - first;
            println!(
                "{}",
                table(&name, k as u32 + 1, psnr[k], bytes, &budgets[k])
            );
        }
    }
    Ok(())
}

fn table(name: &str, passes: u32, db: f64, bytes: usize, b: &BitBudget) -> String {
    let mut all = Cost::default();
    let mut add = |c: &Cost| {
        all.symbols += c.symbols;
        all.bits += c.bits;
    };
    b.significance.iter().flatten().for_each(&mut add);
    b.sign.iter().for_each(&mut add);
    b.zerotree.iter().for_each(&mut add);
    b.refinement.iter().flatten().for_each(&mut add);
    add(&b.base);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{name}, {passes} passes, {db:.1} dB, {bytes} B of stream ({:.0} B modelled)\n",
        all.bits / 8.0
    );
    let _ = writeln!(
        s,
        "| class | symbols | bits | bits/symbol | share |\n|---|---|---|---|---|"
    );
    let mut row = |label: String, c: &Cost| {
        if c.symbols > 0 {
            let _ = writeln!(
                s,
                "| {label} | {} | {:.0} | {:.3} | {:.1}% |",
                c.symbols,
                c.bits,
                c.bits / c.symbols as f64,
                100.0 * c.bits / all.bits
            );
        }
    };
    for class in (0..LEVEL_CLASSES).rev() {
        for coord in 0..3 {
            row(
                format!("significance L{class} c{coord}"),
                &b.significance[class][coord],
            );
        }
    }
    for coord in 0..3 {
        row(format!("sign c{coord}"), &b.sign[coord]);
    }
    for class in (0..LEVEL_CLASSES).rev() {
        row(format!("zerotree L{class}"), &b.zerotree[class]);
    }
    for class in (0..LEVEL_CLASSES).rev() {
        for coord in 0..3 {
            row(
                format!("refinement L{class} c{coord}"),
                &b.refinement[class][coord],
            );
        }
    }
    row("base values' low bits".into(), &b.base);
    s
}
