//! `qm info` and `qm distance`: what a `.qm` file holds, and how far two
//! meshes are apart.

use std::path::Path;

use qm::codec::container;

use crate::output::Failure;

/// What `qm info` reports.
#[derive(serde::Serialize)]
struct Info {
    file: String,
    total_bytes: usize,
    header_bytes: usize,
    base_bytes: usize,
    stream_bytes: usize,
    version: u8,
    bits: u8,
    level: u8,
    passes: u8,
    planes: u8,
    update: String,
    weight_bits: u8,
    normal_bits: u8,
    frames: bool,
    parent_frames_from: Option<u32>,
    base_vertices: u32,
    base_faces: u32,
    base_low_bits_in_stream: u32,

    holds: Vec<[u32; 2]>,
    vertices: u64,
    faces: u64,
    bbox_min: [f64; 3],
    step: f64,
    /// For a file with colours: its colour stream.
    #[serde(skip_serializing_if = "Option::is_none")]
    colour: Option<ColourInfo>,
    #[serde(skip_serializing_if = "Option::is_none")]
    levels: Option<Vec<PrefixRow>>,
}

/// A file's colour stream, as `qm info` shows it.
#[derive(serde::Serialize)]
struct ColourInfo {
    /// Bytes of the whole colour stream, and of the geometry's beside it.
    stream_bytes: u64,
    geometry_stream_bytes: u64,
    /// Runs the two streams are interleaved in.
    runs: usize,
    /// Bit planes of the colour, and those its stream codes (fewer where
    /// it ends at what the samples miss of the input's colour).
    planes: u8,
    passes: u8,
    /// The colour's subdivision level: the geometry's, or finer (a texture).
    level: u32,
}

/// One row of `qm info --levels`: what the prefix ending at a pass decodes to.
#[derive(serde::Serialize)]
struct PrefixRow {
    bytes: usize,
    passes: u32,
    level: u32,
    vertices: usize,
    triangles: u64,
    error: f64,
    psnr: f64,
}

impl From<qm::PrefixRow> for PrefixRow {
    fn from(r: qm::PrefixRow) -> Self {
        PrefixRow {
            bytes: r.bytes,
            passes: r.passes,
            level: r.level,
            vertices: r.vertices,
            triangles: r.triangles,
            error: r.error,
            psnr: r.psnr_db,
        }
    }
}

pub fn info(input: &Path, levels: bool, json: bool) -> Result<(), Failure> {
    let data = std::fs::read(input).map_err(|e| Failure::about(input, e))?;
    // Describing a file allocates only its base mesh.
    let limits = qm::Limits::DEFAULT.with_max_memory(u64::MAX);
    let c = container::read(&data, &limits).map_err(|e| Failure::about(input, e))?;
    let h = &c.header;
    let base = qm::lift::BaseMesh::new(h.base_vertices, c.base.faces.clone())
        .map_err(|e| Failure::about(input, qm::codec::Error::from(e)))?;
    let n = 1u64 << h.level;
    let faces = h.base_faces as u64;
    let update = qm::UpdateRule::from_code(h.update).map_or("unknown".into(), |u| format!("{u:?}"));
    let levels = if levels {
        let rows = qm::prefix_table(&data, &qm::DecodeOptions::DEFAULT)
            .map_err(|e| Failure::about(input, e))?;
        Some(rows.into_iter().map(PrefixRow::from).collect())
    } else {
        None
    };
    let info = Info {
        file: input.display().to_string(),
        total_bytes: data.len(),
        header_bytes: c.header_bytes,
        base_bytes: c.base_bytes,
        stream_bytes: c.stream.len(),
        version: data[4],
        bits: h.bits,
        level: h.level,
        passes: h.passes,
        planes: h.planes,
        update,
        weight_bits: h.weight_bits,
        normal_bits: h.normal_bits,
        frames: h.frames > 0,
        parent_frames_from: h.parent_frames_from(),
        base_vertices: h.base_vertices,
        base_faces: h.base_faces,
        base_low_bits_in_stream: c.base.low_bits,
        holds: h.holds.clone(),
        vertices: base.sample_count(h.level as u32),
        faces: faces * n * n,
        bbox_min: h.origin,
        step: h.step,
        colour: h.colour.as_ref().map(|colour| ColourInfo {
            stream_bytes: colour.runs.iter().map(|r| r[1] as u64).sum(),
            geometry_stream_bytes: colour.runs.iter().map(|r| r[0] as u64).sum(),
            runs: colour.runs.len(),
            planes: colour.planes,
            passes: colour.passes,
            level: container::colour_level(h),
        }),
        levels,
    };
    if json {
        out!(
            "{}",
            serde_json::to_string_pretty(&info).expect("plain data serializes")
        );
    } else {
        let value = serde_json::to_value(&info).expect("plain data serializes");
        for (key, v) in value.as_object().expect("a struct is an object") {
            if key != "levels" && key != "colour" {
                out!(
                    "{key:>18}: {}",
                    v.as_str().map_or(v.to_string(), str::to_string)
                );
            }
        }
        if let Some(c) = &info.colour {
            out!(
                "{:>18}: {} bytes beside {} of geometry, in {} runs, {} of {} planes, level {}{}",
                "colour",
                c.stream_bytes,
                c.geometry_stream_bytes,
                c.runs,
                c.passes,
                c.planes,
                c.level,
                if c.level > u32::from(info.level) {
                    " (finer than the geometry: decoded as a texture)"
                } else {
                    ""
                }
            );
        }
        if let Some(rows) = &info.levels {
            out!("\nwhat each prefix decodes to (level auto, estimated error):");
            out!(
                "{:>10} {:>6} {:>5} {:>10} {:>11} {:>11} {:>8}",
                "bytes",
                "passes",
                "level",
                "vertices",
                "triangles",
                "rms",
                "psnr dB"
            );
            for r in rows {
                out!(
                    "{:>10} {:>6} {:>5} {:>10} {:>11} {:>11.3e} {:>8.2}",
                    r.bytes,
                    r.passes,
                    r.level,
                    r.vertices,
                    r.triangles,
                    r.error,
                    r.psnr
                );
            }
        }
    }
    Ok(())
}

pub fn distance(a: &Path, b: &Path, json: bool, samples: usize, seed: u64) -> Result<(), Failure> {
    use qm::param::distance::DistanceOptions;

    // Images decoded: a textured mesh's colours come from its texture.
    let read = |path: &Path| {
        qm::read_asset(path, &qm::AssetOptions::DEFAULT.with_images(true))
            .map_err(|e| Failure::about(path, e))
    };
    let (asset_a, asset_b) = (read(a)?, read(b)?);
    let options = DistanceOptions::DEFAULT
        .with_samples(samples)
        .with_seed(seed);
    let blame = |e| blame(e, a, b);
    let report = qm::param::distance(&asset_a.mesh, &asset_b.mesh, &options).map_err(blame)?;
    // Only when both carry appearance; otherwise the output is geometry's
    // alone, as it always was.
    let colour = qm::param::colour_distance(&asset_a, &asset_b, &options).map_err(blame)?;
    if json {
        let text = match &colour {
            Some(colour) => serde_json::to_string_pretty(&WithColour {
                geometry: &report,
                colour,
            }),
            None => serde_json::to_string_pretty(&report),
        };
        out!("{}", text.expect("plain data serializes"));
    } else {
        let side = |name: &str, s: &qm::param::OneSided| {
            out!(
                "{name:>10}: rms {:.6e}, mean {:.6e}, max {:.6e} ({} samples)",
                s.rms,
                s.mean,
                s.max,
                s.samples
            );
        };
        out!("{:>10}: {:.6e}", "rms", report.rms);
        out!("{:>10}: {:.6e}", "mean", report.mean);
        out!("{:>10}: {:.6e}", "hausdorff", report.hausdorff);
        out!("{:>10}: {:.3} dB", "psnr", report.psnr_db);
        if let Some(c) = &colour {
            out!(
                "{:>10}: psnr {:.3} dB, rms {:.4} (8-bit RGB; A -> B {:.3} dB, B -> A {:.3} dB)",
                "colour",
                c.psnr_db,
                c.rms,
                c.a_to_b.psnr_db,
                c.b_to_a.psnr_db
            );
        }
        out!("{:>10}: {:.6e}", "diag", report.diag);
        side("A -> B", &report.a_to_b);
        side("B -> A", &report.b_to_a);
    }
    Ok(())
}

/// `qm distance --json` when both meshes carry colour: the geometric report's
/// fields, then `colour`.
#[derive(serde::Serialize)]
struct WithColour<'a> {
    #[serde(flatten)]
    geometry: &'a qm::param::DistanceReport,
    colour: &'a qm::param::ColourReport,
}

/// A distance error, named after the mesh it is about.
fn blame(e: qm::param::Error, a: &Path, b: &Path) -> Failure {
    use qm::param::distance::Side;
    let path = match e {
        qm::param::Error::NoFaces {
            mesh: Some(Side::B),
        }
        | qm::param::Error::ZeroArea { mesh: Side::B }
        | qm::param::Error::MissingVertex {
            mesh: Some(Side::B),
            ..
        }
        | qm::param::Error::NonFinite {
            mesh: Some(Side::B),
            ..
        }
        | qm::param::Error::Appearance {
            mesh: Some(Side::B),
            ..
        } => b,
        _ => a,
    };
    Failure::about(path, qm::Error::from(e))
}
