//! The cost-growth benchmark's Rust side (`harness = false`; `scripts/bench_growth.sh`
//! makes the clouds, runs the renders and calls it).
//!
//! ```text
//! cargo bench --bench growth -- RESULTS.jsonl --out DIR
//! ```
//! RESULTS.jsonl holds one JSON object per render: `series` ("pixels" or "voxels"), `x`
//! (pixels, or active voxels), `label`, `cpu` and `wall` seconds and `rss_kb` of the
//! whole process (/usr/bin/time), `stages` (murk's stats: seconds per stage), and the
//! density's and the shadow maps' bytes. Repeated runs of one point are reduced to their
//! medians. The stages' wall seconds are scaled by the run's CPU / wall, so with one
//! thread they are CPU seconds even on a busy machine. Prints a markdown table per series with the share of each stage, the fitted
//! exponents (`murk::report::growth::fit_power_law`), and writes DIR/growth.png (one
//! log–log panel per series) and DIR/growth.md (the same text).
//!
//! With no arguments (plain `cargo bench`) it does nothing.

use murk::report::growth::{Panel, Series, fit_power_law, write_growth_plot};
use serde_json::Value;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::PathBuf;

/// The stages shown, as (label, stats stage names summed into it).
const STAGES: [(&str, &[&str]); 5] = [
    ("load + build", &["load", "build"]),
    ("shadow bake", &["shadows"]),
    ("multiple scattering", &["multiple_scattering"]),
    ("render", &["render", "emission", "scatter", "phase"]),
    ("write", &["write"]),
];

#[derive(Default, Clone)]
struct Point {
    label: String,
    cpu: Vec<f64>,
    wall: Vec<f64>,
    rss_kb: Vec<f64>,
    stages: Vec<[f64; STAGES.len()]>,
    density_bytes: f64,
    map_bytes: f64,
}

fn median(values: &[f64]) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

impl Point {
    fn stage(&self, i: usize) -> f64 {
        median(&self.stages.iter().map(|s| s[i]).collect::<Vec<_>>())
    }
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    if args.is_empty() {
        eprintln!("growth bench: nothing to do without arguments (run scripts/bench_growth.sh)");
        return;
    }
    if let Err(e) = run(&args) {
        eprintln!("growth bench: {e:#}");
        std::process::exit(2);
    }
}

fn run(args: &[String]) -> anyhow::Result<()> {
    let mut input = None;
    let mut out = PathBuf::from(".");
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--out" => {
                out = PathBuf::from(
                    it.next()
                        .ok_or_else(|| anyhow::anyhow!("--out needs a directory"))?,
                )
            }
            _ => input = Some(PathBuf::from(a)),
        }
    }
    let input = input.ok_or_else(|| anyhow::anyhow!("usage: growth RESULTS.jsonl --out DIR"))?;
    let text =
        std::fs::read_to_string(&input).map_err(|e| anyhow::anyhow!("{}: {e}", input.display()))?;

    // series -> x (as bits, for exact grouping) -> point
    let mut series: BTreeMap<String, BTreeMap<u64, (f64, Point)>> = BTreeMap::new();
    for (n, line) in text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
    {
        let v: Value = serde_json::from_str(line)
            .map_err(|e| anyhow::anyhow!("{} line {}: {e}", input.display(), n + 1))?;
        let name = v["series"].as_str().unwrap_or("?").to_string();
        let x = v["x"].as_f64().unwrap_or(f64::NAN);
        let entry = series
            .entry(name)
            .or_default()
            .entry(x.to_bits())
            .or_insert_with(|| (x, Point::default()));
        let p = &mut entry.1;
        p.label = v["label"].as_str().unwrap_or("").to_string();
        p.cpu.push(v["cpu"].as_f64().unwrap_or(f64::NAN));
        p.wall.push(v["wall"].as_f64().unwrap_or(f64::NAN));
        p.rss_kb.push(v["rss_kb"].as_f64().unwrap_or(f64::NAN));
        // The stages' seconds are wall-clock; on a shared machine a one-thread process
        // gets less than a core, so they are scaled by the whole run's CPU / wall (exact
        // for one thread under a steady load): the table's stage seconds are CPU seconds.
        let cpu_per_wall = match (v["cpu"].as_f64(), v["wall"].as_f64()) {
            (Some(c), Some(w)) if w > 0.0 && c > 0.0 => c / w,
            _ => 1.0,
        };
        let mut stages = [0.0; STAGES.len()];
        for (i, (_, names)) in STAGES.iter().enumerate() {
            stages[i] = cpu_per_wall
                * names
                    .iter()
                    .map(|s| v["stages"][s].as_f64().unwrap_or(0.0))
                    .sum::<f64>();
        }
        p.stages.push(stages);
        p.density_bytes = v["density_bytes"].as_f64().unwrap_or(f64::NAN);
        p.map_bytes = v["map_bytes"].as_f64().unwrap_or(f64::NAN);
    }

    let mut md = String::new();
    let mut panels = Vec::new();
    for (name, points) in &series {
        let points: Vec<&(f64, Point)> = points.values().collect();
        let unit = if name == "pixels" {
            "pixels"
        } else {
            "active voxels"
        };
        writeln!(md, "\n**Cost against {unit}**\n")?;
        let mut header = format!("| {unit} | case | CPU s | wall s |");
        for (label, _) in STAGES {
            write!(header, " {label}, CPU s (share) |")?;
        }
        header.push_str(" dominant | peak RSS MB | map / density MB |");
        writeln!(md, "{header}")?;
        writeln!(md, "|{}", "---|".repeat(7 + STAGES.len()))?;
        for (x, p) in &points {
            let stages: Vec<f64> = (0..STAGES.len()).map(|i| p.stage(i)).collect();
            let sum: f64 = stages.iter().sum();
            let mut row = format!(
                "| {:.3e} | {} | {:.2} | {:.2} |",
                x,
                p.label,
                median(&p.cpu),
                median(&p.wall)
            );
            for s in &stages {
                write!(row, " {s:.2} ({:.0} %) |", 100.0 * s / sum.max(1e-12))?;
            }
            let dominant = stages
                .iter()
                .enumerate()
                .max_by(|a, b| a.1.total_cmp(b.1))
                .map(|(i, _)| STAGES[i].0)
                .unwrap_or("?");
            write!(
                row,
                " {dominant} | {:.0} | {:.1} / {:.1} |",
                median(&p.rss_kb) / 1024.0,
                p.map_bytes / 1e6,
                p.density_bytes / 1e6
            )?;
            writeln!(md, "{row}")?;
        }
        // Exponents: whole-process CPU and wall, and each stage.
        let mut lines: Vec<Series> = vec![
            Series {
                label: "whole run, CPU".into(),
                points: points.iter().map(|(x, p)| (*x, median(&p.cpu))).collect(),
            },
            Series {
                label: "whole run, wall".into(),
                points: points.iter().map(|(x, p)| (*x, median(&p.wall))).collect(),
            },
        ];
        for (i, (label, _)) in STAGES.iter().enumerate() {
            lines.push(Series {
                label: label.to_string(),
                points: points.iter().map(|(x, p)| (*x, p.stage(i))).collect(),
            });
        }
        write!(md, "\nFitted exponents (seconds ∝ {unit}^k):")?;
        for s in &lines {
            match fit_power_law(&s.points) {
                Some(f) => write!(
                    md,
                    " {} k = {:.2} (R² {:.3});",
                    s.label, f.exponent, f.r_squared
                )?,
                None => write!(md, " {} —;", s.label)?,
            }
        }
        md.pop();
        md.push('\n');
        // The plot leaves out the wall line (the CPU one carries the trend) and stages
        // too small to place on a log axis.
        lines.retain(|s| s.label != "whole run, wall" && s.points.iter().any(|p| p.1 > 1e-3));
        panels.push(Panel {
            title: format!("cost against {unit} (log–log)"),
            x_desc: unit.to_string(),
            series: lines,
        });
    }
    std::fs::create_dir_all(&out).map_err(|e| anyhow::anyhow!("{}: {e}", out.display()))?;
    let png = out.join("growth.png");
    let text = write_growth_plot(&png, &panels)?;
    if !text {
        md.push_str("\n(growth.png has no text: no TrueType font was found. Colours in series order: blue, orange, green, purple, brown, red.)\n");
    }
    std::fs::write(out.join("growth.md"), &md)
        .map_err(|e| anyhow::anyhow!("{}: {e}", out.display()))?;
    print!("{md}");
    eprintln!("growth bench: wrote {} and growth.md", png.display());
    Ok(())
}
