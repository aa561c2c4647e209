//! `converge.png`: error against time on log–log axes, one line per sweep (plotters).
//!
//! Text needs a TrueType font; plotters is built without system font lookup (a fresh
//! machine may have no fontconfig), so the first of a few common font files found is
//! registered. With none, the plot is drawn without text and `converge.md` names the
//! colours.

use super::ReportError;
use super::converge::Measured;
use super::converge_table::SWEEPS;
use crate::files::write_atomically;
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

type Result<T> = std::result::Result<T, ReportError>;

/// Line colours, in [`SWEEPS`] order, then the `default` point.
pub const COLOURS: [(&str, RGBColor); 7] = [
    ("blue", RGBColor(31, 119, 180)),
    ("orange", RGBColor(255, 127, 14)),
    ("green", RGBColor(44, 160, 44)),
    ("purple", RGBColor(148, 103, 189)),
    ("brown", RGBColor(140, 86, 75)),
    ("red", RGBColor(214, 39, 40)),
    ("pink", RGBColor(227, 119, 194)),
];

const FONT_FILES: [&str; 4] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/Library/Fonts/Arial.ttf",
];

/// Registers a font once; whether one was found.
pub(crate) fn font() -> bool {
    static FOUND: OnceLock<bool> = OnceLock::new();
    *FOUND.get_or_init(|| {
        for path in FONT_FILES {
            if let Ok(bytes) = std::fs::read(path) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok() {
                    return true;
                }
            }
        }
        false
    })
}

const SIZE: (u32, u32) = (900, 600);

/// A tick label with at most three significant digits.
pub(crate) fn significant(v: f64) -> String {
    let digits = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Draws one measured line of a log–log chart with a dot at each point, and its legend
/// entry (`label`) when the plot has text.
pub(crate) fn draw_line<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<LogCoord<f64>, LogCoord<f64>>>,
    line: Vec<(f64, f64)>,
    colour: RGBColor,
    label: Option<String>,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let err = |e: &dyn std::fmt::Display| ReportError::draw("a plot", e);
    let drawn = chart
        .draw_series(LineSeries::new(line.clone(), colour.stroke_width(2)))
        .map_err(|e| err(&e))?;
    if let Some(label) = label {
        drawn.label(label).legend(move |(x, y)| {
            PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
        });
    }
    chart
        .draw_series(line.iter().map(|p| Circle::new(*p, 4, colour.filled())))
        .map_err(|e| err(&e))?;
    Ok(())
}

/// Draws the legend box of a chart's labelled lines.
pub(crate) fn draw_legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    font_size: u32,
    position: SeriesLabelPosition,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .label_font(("sans-serif", font_size))
        .position(position)
        .draw()
        .map_err(|e| ReportError::draw("a plot's legend", &e))
}

/// Draws the plot into an RGB buffer.
fn draw(rows: &[Measured], buffer: &mut [u8]) -> Result<bool> {
    let text = font();
    let points: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| (r.total_seconds, r.rel_rmse))
        .filter(|(t, e)| *t > 0.0 && *e > 0.0 && t.is_finite() && e.is_finite())
        .collect();
    let (mut t0, mut t1, mut e0, mut e1) = (f64::INFINITY, 0.0f64, f64::INFINITY, 0.0f64);
    for (t, e) in &points {
        (t0, t1, e0, e1) = (t0.min(*t), t1.max(*t), e0.min(*e), e1.max(*e));
    }
    if points.is_empty() {
        (t0, t1, e0, e1) = (1e-3, 1.0, 1e-6, 1.0);
    }
    let (t0, t1, e0, e1) = (t0 / 1.3, t1 * 1.3, e0 / 2.0, e1 * 2.0);
    let err = |e: &dyn std::fmt::Display| ReportError::draw("converge.png", e);
    let root = BitMapBackend::with_buffer(buffer, SIZE).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let mut builder = ChartBuilder::on(&root);
    builder.margin(20);
    if text {
        builder
            .caption("relative RMSE against time (log–log)", ("sans-serif", 22))
            .x_label_area_size(45)
            .y_label_area_size(70);
    }
    let mut chart = builder
        .build_cartesian_2d((t0..t1).log_scale(), (e0..e1).log_scale())
        .map_err(|e| err(&e))?;
    let mut mesh = chart.configure_mesh();
    if text {
        mesh.x_desc("time per frame (s): shadow bake + render")
            .y_desc("relative RMSE vs reference")
            .x_label_formatter(&|v| significant(*v))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .label_style(("sans-serif", 14));
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw().map_err(|e| err(&e))?;
    let series = SWEEPS
        .iter()
        .map(|s| s.to_string())
        .chain(["default".to_string()]);
    for (sweep, (_, colour)) in series.zip(COLOURS) {
        let mut line: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.sweep == sweep && r.total_seconds > 0.0 && r.rel_rmse > 0.0)
            .map(|r| (r.total_seconds, r.rel_rmse))
            .collect();
        line.sort_by(|a, b| a.0.total_cmp(&b.0));
        draw_line(&mut chart, line, colour, text.then(|| sweep.clone()))?;
    }
    if text {
        draw_legend(&mut chart, 14, SeriesLabelPosition::UpperRight)?;
    }
    root.present().map_err(|e| err(&e))?;
    Ok(text)
}

/// Writes the plot as a PNG (atomically); returns whether it has text.
pub fn write_plot(path: &Path, rows: &[Measured]) -> Result<bool> {
    let mut buffer = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
    let text = draw(rows, &mut buffer)?;
    write_png(path, SIZE, buffer)?;
    Ok(text)
}

/// Writes an RGB buffer of `size` as a PNG, atomically.
pub(crate) fn write_png(path: &Path, size: (u32, u32), buffer: Vec<u8>) -> Result<()> {
    let image = image::RgbImage::from_raw(size.0, size.1, buffer)
        .ok_or_else(|| ReportError::write(path, "plot buffer of the wrong size"))?;
    write_atomically(path, |tmp| {
        image
            .save_with_format(tmp, image::ImageFormat::Png)
            .map_err(|e| ReportError::write(path, e))
    })
}
