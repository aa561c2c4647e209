//! How cost grows with the image and with the grid: power-law fits of measured times and
//! their log–log plot (the cost-growth benchmark, `scripts/bench_growth.sh`, measures;
//! this fits and draws).

use super::ReportError;
use super::fit_slope;
use super::plot::{COLOURS, draw_legend, draw_line, font, significant};
use plotters::prelude::*;
use std::path::Path;

type Result<T> = std::result::Result<T, ReportError>;

/// `y ≈ coefficient · x^exponent`, fitted by least squares on `ln y` against `ln x`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PowerLaw {
    pub exponent: f64,
    pub coefficient: f64,
    /// Fraction of the variance of `ln y` the line explains (1 for an exact power law).
    pub r_squared: f64,
}

/// Fits a power law to `(x, y)` points; `None` with fewer than two distinct positive `x`
/// (points with a non-positive or non-finite coordinate are left out: a stage that did
/// not run has no cost to fit).
pub fn fit_power_law(points: &[(f64, f64)]) -> Option<PowerLaw> {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0 && x.is_finite() && y.is_finite())
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    let exponent = fit_slope(&logs);
    if !exponent.is_finite() {
        return None;
    }
    let n = logs.len() as f64;
    let mx = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = logs.iter().map(|p| p.1).sum::<f64>() / n;
    let intercept = my - exponent * mx;
    let total: f64 = logs.iter().map(|p| (p.1 - my).powi(2)).sum();
    let residual: f64 = logs
        .iter()
        .map(|p| (p.1 - (intercept + exponent * p.0)).powi(2))
        .sum();
    let r_squared = if total > 0.0 {
        1.0 - residual / total
    } else {
        1.0
    };
    Some(PowerLaw {
        exponent,
        coefficient: intercept.exp(),
        r_squared,
    })
}

/// One measured line: a stage's (or the whole run's) seconds against the swept size.
#[derive(Debug, Clone)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
}

/// One log–log chart: a swept quantity (pixels, active voxels) and the lines measured
/// against it.
#[derive(Debug, Clone)]
pub struct Panel {
    pub title: String,
    pub x_desc: String,
    pub series: Vec<Series>,
}

const PANEL_SIZE: (u32, u32) = (700, 520);

fn bounds(points: impl Iterator<Item = (f64, f64)>) -> ((f64, f64), (f64, f64)) {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, 0.0f64, f64::INFINITY, 0.0f64);
    for (x, y) in points {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    if x0 > x1 || y0 > y1 {
        return ((1.0, 10.0), (0.1, 1.0));
    }
    // Room above the lines for the legend, which sits in the upper left.
    ((x0 / 1.4, x1 * 1.4), (y0 / 2.0, y1 * 12.0))
}

fn positive(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut kept: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0 && x.is_finite() && y.is_finite())
        .collect();
    kept.sort_by(|a, b| a.0.total_cmp(&b.0));
    kept
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    panel: &Panel,
    text: bool,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let err = |e: &dyn std::fmt::Display| ReportError::draw("the cost-growth plot", e);
    let ((x0, x1), (y0, y1)) = bounds(
        panel
            .series
            .iter()
            .flat_map(|s| positive(&s.points).into_iter()),
    );
    let mut builder = ChartBuilder::on(area);
    builder.margin(18);
    if text {
        builder
            .caption(&panel.title, ("sans-serif", 20))
            .x_label_area_size(45)
            .y_label_area_size(60);
    }
    let mut chart = builder
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(|e| err(&e))?;
    let mut mesh = chart.configure_mesh();
    if text {
        mesh.x_desc(panel.x_desc.as_str())
            .y_desc("seconds")
            .x_label_formatter(&|v| format!("{v:.0e}"))
            .y_label_formatter(&|v| significant(*v))
            .label_style(("sans-serif", 13));
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw().map_err(|e| err(&e))?;
    for (series, (_, colour)) in panel.series.iter().zip(COLOURS.iter().cycle()) {
        let line = positive(&series.points);
        let colour = *colour;
        let label = text.then(|| match fit_power_law(&line) {
            Some(fit) => format!("{} (x^{:.2})", series.label, fit.exponent),
            None => series.label.clone(),
        });
        draw_line(&mut chart, line, colour, label)?;
    }
    if text {
        draw_legend(&mut chart, 13, SeriesLabelPosition::UpperLeft)?;
    }
    Ok(())
}

/// Draws the panels side by side into a PNG (written atomically); returns whether it
/// has text (a TrueType font was found, see [`super::plot`]). Line colours follow
/// [`COLOURS`] in series order; each legend entry carries its fitted exponent.
pub fn write_growth_plot(path: &Path, panels: &[Panel]) -> Result<bool> {
    if panels.is_empty() {
        return Err(ReportError::write(path, "nothing to plot"));
    }
    let size = (PANEL_SIZE.0 * panels.len() as u32, PANEL_SIZE.1);
    let mut buffer = vec![0u8; (size.0 * size.1 * 3) as usize];
    let text = font();
    {
        let err = |e: &dyn std::fmt::Display| ReportError::draw(path.display().to_string(), e);
        let root = BitMapBackend::with_buffer(&mut buffer, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        for (area, panel) in root.split_evenly((1, panels.len())).iter().zip(panels) {
            draw_panel(area, panel, text)?;
        }
        root.present().map_err(|e| err(&e))?;
    }
    super::plot::write_png(path, size, buffer)?;
    Ok(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_exact_power_law_is_recovered() {
        let points: Vec<(f64, f64)> = [1e4, 3e4, 1e5, 1e6]
            .iter()
            .map(|&x: &f64| (x, 2.5e-6 * x.powf(1.37)))
            .collect();
        let fit = fit_power_law(&points).unwrap();
        assert!((fit.exponent - 1.37).abs() < 1e-12, "{fit:?}");
        assert!((fit.coefficient / 2.5e-6 - 1.0).abs() < 1e-9, "{fit:?}");
        assert!((fit.r_squared - 1.0).abs() < 1e-12, "{fit:?}");
    }

    #[test]
    fn a_fixed_cost_plus_linear_bends_below_one_and_r_squared_says_so() {
        // 2 s fixed + 1e-6 s per unit over two decades: the slope lies between 0 and 1,
        // and the fit is not exact.
        let points: Vec<(f64, f64)> = [1e4, 1e5, 1e6]
            .iter()
            .map(|&x: &f64| (x, 2.0 + 1e-6 * x))
            .collect();
        let fit = fit_power_law(&points).unwrap();
        assert!(fit.exponent > 0.05 && fit.exponent < 0.5, "{fit:?}");
        assert!(fit.r_squared < 0.999, "{fit:?}");
    }

    #[test]
    fn stages_that_did_not_run_are_left_out_and_one_point_fits_nothing() {
        assert_eq!(fit_power_law(&[(1e4, 0.0), (1e5, 0.0)]), None);
        assert_eq!(fit_power_law(&[(1e4, 1.0), (1e5, f64::NAN)]), None);
        assert_eq!(fit_power_law(&[(1e4, 1.0), (1e4, 2.0)]), None);
        let fit = fit_power_law(&[(1e4, 1.0), (1e5, 0.0), (1e6, 100.0)]).unwrap();
        assert!((fit.exponent - 1.0).abs() < 1e-12);
    }

    #[test]
    fn the_plot_is_a_png_of_the_panels_size() {
        let dir = std::env::temp_dir().join(format!("murk-growth-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("growth.png");
        let series = |label: &str, k: f64| Series {
            label: label.into(),
            points: vec![(1e4, k), (1e5, 8.0 * k), (1e6, 70.0 * k)],
        };
        let panels = [
            Panel {
                title: "pixels".into(),
                x_desc: "pixels".into(),
                series: vec![series("total", 1.0), series("render", 0.5)],
            },
            Panel {
                title: "voxels".into(),
                x_desc: "active voxels".into(),
                series: vec![series("total", 2.0)],
            },
        ];
        write_growth_plot(&path, &panels).unwrap();
        let image = image::open(&path).unwrap();
        assert_eq!(
            (image.width(), image.height()),
            (2 * PANEL_SIZE.0, PANEL_SIZE.1)
        );
        // Not a blank page: the lines and axes leave non-white pixels.
        let rgb = image.to_rgb8();
        let drawn = rgb.pixels().filter(|p| p.0 != [255, 255, 255]).count();
        assert!(drawn > 1000, "{drawn} non-white pixels");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
