//! The rate-distortion figure: one panel per model, PSNR against bits per
//! input vertex (log scale), qm's curve against Draco's, with the 65 and
//! 78 dB targets drawn across.
//!
//! Text needs a TrueType font (plotters' `ab_glyph` backend draws glyphs
//! itself instead of asking fontconfig): `QM_RD_FONT` names one, otherwise
//! DejaVu Sans from Debian's `fonts-dejavu-core` or Liberation Sans.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::curves::{ModelResult, TARGETS_DB};

const FONT_CANDIDATES: [&str; 3] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
];

const QM_COLOR: RGBColor = RGBColor(0x1f, 0x77, 0xb4);
const DRACO_COLOR: RGBColor = RGBColor(0xd6, 0x27, 0x28);

/// Registers a font as plotters' `sans-serif`, once.
fn register_font() -> Result<(), String> {
    static DONE: std::sync::OnceLock<Result<(), String>> = std::sync::OnceLock::new();
    DONE.get_or_init(|| {
        let path = std::env::var("QM_RD_FONT").ok().or_else(|| {
            FONT_CANDIDATES
                .iter()
                .find(|p| Path::new(p).exists())
                .map(|p| p.to_string())
        });
        let path = path
            .ok_or("no TrueType font for the plots: install fonts-dejavu-core or set QM_RD_FONT")?;
        let bytes = std::fs::read(&path).map_err(|e| format!("{path}: {e}"))?;
        // plotters keeps fonts for the life of the program.
        let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
        plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
            .map_err(|_| format!("{path}: not a usable font"))
    })
    .clone()
}

/// Writes `rd.svg` and `rd.png` into `out`.
pub fn draw(results: &[ModelResult], out: &Path) -> Result<(), String> {
    register_font()?;
    let cols = if results.len() > 1 { 2 } else { 1 };
    let rows = results.len().div_ceil(cols) as u32;
    let size = (560 * cols as u32, 400 * rows);
    let svg = out.join("rd.svg");
    {
        let root = SVGBackend::new(&svg, size).into_drawing_area();
        panels(&root, results, cols).map_err(|e| format!("{}: {e}", svg.display()))?;
    }
    let png = out.join("rd.png");
    {
        let root = BitMapBackend::new(&png, size).into_drawing_area();
        panels(&root, results, cols).map_err(|e| format!("{}: {e}", png.display()))?;
    }
    Ok(())
}

/// Labels 1, 2 and 5 times a power of ten; the other grid lines stay bare.
fn log_label(x: &f64) -> String {
    let decade = 10f64.powf(x.log10().floor());
    let mantissa = x / decade;
    if [1.0, 2.0, 5.0].iter().any(|m| (mantissa - m).abs() < 1e-6) {
        format!("{}", (mantissa.round() * decade * 1e6).round() / 1e6)
    } else {
        String::new()
    }
}

type DrawResult<T> = Result<T, Box<dyn std::error::Error>>;

fn panels<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    results: &[ModelResult],
    cols: usize,
) -> DrawResult<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let rows = results.len().div_ceil(cols);
    let areas = root.split_evenly((rows, cols));
    for (r, area) in results.iter().zip(areas.iter()) {
        panel(area, r)?;
    }
    root.present()?;
    Ok(())
}

fn panel<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, r: &ModelResult) -> DrawResult<()>
where
    DB::ErrorType: 'static,
{
    let series = |coder: &str| -> Vec<(f64, f64)> {
        let mut v: Vec<(f64, f64)> = r
            .points
            .iter()
            .filter(|p| p.coder == coder && p.report.psnr_db.is_finite() && p.bpv > 0.0)
            .map(|p| (p.bpv, p.report.psnr_db))
            .collect();
        // qm's points are prefixes of one stream: draw them in stream
        // order. Draco's are separate files: draw them in `-qp` order, as
        // measured, since a higher `-qp` can give a smaller file.
        if coder == "qm" {
            v.sort_by(|a, b| a.0.total_cmp(&b.0));
            v.dedup_by(|a, b| a.0 == b.0 && a.1 == b.1);
        }
        v
    };
    let (qm, draco) = (series("qm"), series("draco"));
    let all = qm.iter().chain(&draco);
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in all {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if x0 > x1 {
        (x0, x1, y0, y1) = (0.01, 100.0, 0.0, 100.0);
    }
    // Ten dB of room below the lowest point keeps the legend off the data.
    let y0 = (y0.min(TARGETS_DB[0]) / 10.0).floor() * 10.0 - 10.0;
    let y1 = (y1.max(TARGETS_DB[1]) / 10.0).ceil() * 10.0;
    let (x0, x1) = (x0 / 1.3, x1 * 1.3);

    let mut chart = ChartBuilder::on(area)
        .caption(
            format!("{} ({} vertices)", r.name, r.input_vertices),
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d((x0..x1).log_scale(), y0..y1)?;
    chart
        .configure_mesh()
        .x_desc("bits per input vertex")
        .y_desc("PSNR (dB)")
        .x_labels(20)
        .light_line_style(RGBColor(0xee, 0xee, 0xee))
        .x_label_formatter(&log_label)
        .y_label_formatter(&|y| format!("{y:.0}"))
        .label_style(("sans-serif", 12))
        .axis_desc_style(("sans-serif", 14))
        .draw()?;
    for t in TARGETS_DB {
        chart.draw_series(LineSeries::new(
            [(x0, t), (x1, t)],
            BLACK.mix(0.25).stroke_width(1),
        ))?;
    }
    chart
        .draw_series(LineSeries::new(
            qm.iter().copied(),
            QM_COLOR.stroke_width(2),
        ))?
        .label("qm (prefixes of one stream)")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], QM_COLOR.stroke_width(2)));
    chart.draw_series(qm.iter().map(|&p| Circle::new(p, 2, QM_COLOR.filled())))?;
    if !draco.is_empty() {
        chart
            .draw_series(LineSeries::new(
                draco.iter().copied(),
                DRACO_COLOR.stroke_width(1),
            ))?
            .label("Draco -qp 6..14 -cl 10")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], DRACO_COLOR.stroke_width(1)));
        chart.draw_series(
            draco
                .iter()
                .map(|&p| TriangleMarker::new(p, 4, DRACO_COLOR.filled())),
        )?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK.mix(0.3))
        .label_font(("sans-serif", 12))
        .draw()?;
    Ok(())
}
