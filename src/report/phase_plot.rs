//! `murk phase water-drop`: a water-drop phase function as a CSV table and a PNG plot
//! (plotters), so a user can see the bows a render will get before rendering.

use super::ReportError;
use super::plot::font;
use crate::files::write_atomically;
use crate::integrate::phase::PhaseFunction;
use crate::integrate::phase::water_drop::{WAVELENGTHS_NM, WaterDrop};
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::Path;

type Result<T> = std::result::Result<T, ReportError>;

const SIZE: (u32, u32) = (1200, 500);

/// The CSV: one row per table node: the scattering angle and the angle from the
/// antisolar point (degrees), the phase function (per steradian) in R, G, B, and with
/// `spectral` one column per wavelength (`p_380nm`, …).
pub fn csv_text(drop: &WaterDrop, spectral: bool) -> String {
    let mut text = String::from("scattering_angle_deg,from_antisolar_deg,r,g,b");
    if spectral {
        for l in WAVELENGTHS_NM {
            let _ = write!(text, ",p_{l:.0}nm");
        }
    }
    text.push('\n');
    for (i, (theta, rgb)) in drop.angles().iter().zip(drop.rgb_table()).enumerate() {
        let deg = theta.to_degrees();
        let _ = write!(
            text,
            "{deg:.6},{:.6},{:.9e},{:.9e},{:.9e}",
            180.0 - deg,
            rgb.x,
            rgb.y,
            rgb.z
        );
        if spectral {
            for j in 0..WAVELENGTHS_NM.len() {
                let _ = write!(text, ",{:.9e}", drop.spectral_table(j)[i]);
            }
        }
        text.push('\n');
    }
    text
}

/// Writes [`csv_text`] to `path` (atomically).
pub fn write_csv(path: &Path, drop: &WaterDrop, spectral: bool) -> Result<()> {
    let text = csv_text(drop, spectral);
    write_atomically(path, |tmp| {
        std::fs::write(tmp, &text).map_err(|e| ReportError::write(path, e))
    })
}

/// The maxima of the three channels in the primary (30–46° from the antisolar point)
/// and secondary (47–60°) bows, in degrees from the antisolar point: `[R, G, B]`
/// for each.
pub fn bow_maxima(drop: &WaterDrop) -> ([f64; 3], [f64; 3]) {
    let argmax = |lo: f64, hi: f64, c: usize| {
        let n = ((hi - lo) / 0.01).round() as usize;
        (0..=n)
            .map(|i| lo + i as f64 * 0.01)
            .map(|a| (a, drop.eval((180.0 - a).to_radians().cos())[c]))
            .fold(
                (lo, f64::NEG_INFINITY),
                |b, x| if x.1 > b.1 { x } else { b },
            )
            .0
    };
    (
        [0, 1, 2].map(|c| argmax(30.0, 46.0, c)),
        [0, 1, 2].map(|c| argmax(47.0, 60.0, c)),
    )
}

const CHANNELS: [(&str, RGBColor); 3] = [
    ("R", RGBColor(214, 39, 40)),
    ("G", RGBColor(44, 160, 44)),
    ("B", RGBColor(31, 119, 180)),
];

fn draw(drop: &WaterDrop, buffer: &mut [u8]) -> Result<bool> {
    let text = font();
    let err = |e: &dyn std::fmt::Display| ReportError::draw("the phase plot", e);
    let root = BitMapBackend::with_buffer(buffer, SIZE).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let (left, right) = root.split_horizontally(SIZE.0 / 2);
    let nodes = drop.angles();
    let table = drop.rgb_table();
    // Left: every angle, log scale (the forward peak is 10⁶ times the bows).
    let (lo, hi) = table
        .iter()
        .flat_map(|v| v.to_array())
        .filter(|v| *v > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    let (lo, hi) = if lo < hi {
        (lo / 2.0, hi * 2.0)
    } else {
        (1e-4, 1e4)
    };
    let mut builder = ChartBuilder::on(&left);
    builder.margin(15);
    if text {
        builder
            .caption(
                format!("water drops {} µm: phase function", drop.radius_um()),
                ("sans-serif", 20),
            )
            .x_label_area_size(40)
            .y_label_area_size(60);
    }
    let mut chart = builder
        .build_cartesian_2d(0.0..180.0, (lo..hi).log_scale())
        .map_err(|e| err(&e))?;
    let mut mesh = chart.configure_mesh();
    if text {
        mesh.x_desc("scattering angle (°)")
            .y_desc("p per steradian")
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .label_style(("sans-serif", 14));
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw().map_err(|e| err(&e))?;
    for (c, (_, colour)) in CHANNELS.iter().enumerate() {
        let line = nodes
            .iter()
            .zip(table)
            .filter(|(_, v)| v[c] > 0.0)
            .map(|(t, v)| (t.to_degrees(), v[c]));
        chart
            .draw_series(LineSeries::new(line, colour.stroke_width(1)))
            .map_err(|e| err(&e))?;
    }
    // Right: the bows, linear, against the angle from the antisolar point.
    let (a0, a1) = (30.0, 60.0);
    let bows = nodes
        .iter()
        .zip(table)
        .map(|(t, v)| (180.0 - t.to_degrees(), v))
        .filter(|(a, _)| (a0..=a1).contains(a));
    let top = bows
        .clone()
        .map(|(_, v)| v.max_element())
        .fold(0.0, f64::max)
        * 1.05;
    let top = if top > 0.0 { top } else { 1.0 };
    let mut builder = ChartBuilder::on(&right);
    builder.margin(15);
    if text {
        builder
            .caption("the bows", ("sans-serif", 20))
            .x_label_area_size(40)
            .y_label_area_size(60);
    }
    let mut chart = builder
        .build_cartesian_2d(a0..a1, 0.0..top)
        .map_err(|e| err(&e))?;
    let mut mesh = chart.configure_mesh();
    if text {
        mesh.x_desc("angle from the antisolar point (°)")
            .y_desc("p per steradian")
            .label_style(("sans-serif", 14));
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw().map_err(|e| err(&e))?;
    for (c, (name, colour)) in CHANNELS.iter().enumerate() {
        let colour = *colour;
        let drawn = chart
            .draw_series(LineSeries::new(
                bows.clone().map(|(a, v)| (a, v[c])),
                colour.stroke_width(2),
            ))
            .map_err(|e| err(&e))?;
        if text {
            drawn.label(*name).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
        }
    }
    if text {
        super::plot::draw_legend(&mut chart, 14, SeriesLabelPosition::UpperRight)?;
    }
    root.present().map_err(|e| err(&e))?;
    Ok(text)
}

/// Writes the plot as a PNG (atomically); returns whether it has text (a font was
/// found).
pub fn write_plot(path: &Path, drop: &WaterDrop) -> Result<bool> {
    let mut buffer = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
    let text = draw(drop, &mut buffer)?;
    super::plot::write_png(path, SIZE, buffer)?;
    Ok(text)
}
