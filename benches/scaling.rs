//! The scaling benchmark's Rust side (`harness = false`; `scripts/bench_scaling.sh` runs
//! the renders and calls it).
//!
//! ```text
//! cargo bench --bench scaling -- OUT
//! ```
//! OUT/scaling.jsonl holds one JSON object per render: `kind` "threads" (with `case`,
//! `threads`) or "error" (with `renderer` "murk" and the `asked` error, or "vdb_render"
//! and its `step`, and the measured radiance `error`), the whole process's `time`
//! (`wall`, `cpu_user`, `cpu_sys` seconds) and murk's `stats` (its --stats JSON). Repeated runs are reduced to medians.
//! Prints the speed-up per stage against one thread, the error-vs-CPU table with the
//! CPU ratios against vdb_render at three errors, and draws OUT/scaling.png.
//!
//! With no arguments (plain `cargo bench`) it does nothing.

use murk::report::growth::{Panel, Series, write_growth_plot};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// The stages shown, as (label, stats stage names summed into it).
const STAGES: [(&str, &[&str]); 6] = [
    ("load + build", &["load", "build"]),
    ("shadow bake", &["shadows"]),
    ("multiple scattering", &["multiple_scattering"]),
    ("pilot", &["pilot"]),
    ("pixels", &["render", "emission", "scatter", "phase"]),
    ("write", &["write"]),
];

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

fn num(v: &Value, k: &str) -> f64 {
    v.get(k).and_then(Value::as_f64).unwrap_or(f64::NAN)
}

/// Whole-process wall and CPU (user + system) seconds of one run.
fn times(row: &Value) -> (f64, f64) {
    let t = &row["time"];
    (num(t, "wall"), num(t, "cpu_user") + num(t, "cpu_sys"))
}

/// Seconds of every shown stage in one run (the pilot from `error_budget`).
fn stages(row: &Value) -> [f64; STAGES.len()] {
    std::array::from_fn(|i| {
        STAGES[i]
            .1
            .iter()
            .map(|name| match *name {
                "pilot" => row["stats"]
                    .get("error_budget")
                    .map_or(0.0, |b| num(b, "pilot_seconds")),
                _ => row["stats"]["stages"]
                    .get(*name)
                    .map_or(0.0, |s| num(s, "seconds")),
            })
            .sum()
    })
}

/// `y` at `x` on the log–log polyline through `points` (sorted by x); `None` outside it.
fn interpolate(points: &[(f64, f64)], x: f64) -> Option<f64> {
    points.windows(2).find_map(|w| {
        let ((x0, y0), (x1, y1)) = (w[0], w[1]);
        if x0 <= x && x <= x1 && x1 > x0 {
            let t = (x.ln() - x0.ln()) / (x1.ln() - x0.ln());
            Some((y0.ln() + t * (y1.ln() - y0.ln())).exp())
        } else {
            None
        }
    })
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let Some(dir) = args.first().map(PathBuf::from) else {
        return;
    };
    let text = std::fs::read_to_string(dir.join("scaling.jsonl")).unwrap_or_default();
    let rows: Vec<Value> = text
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect();
    if let Ok(meta) = std::fs::read_to_string(dir.join("meta.json")) {
        println!(
            "_{}_\n",
            meta.split_whitespace().collect::<Vec<_>>().join(" ")
        );
    }
    let mut panels = Vec::new();

    // Threads: per case and thread count, the medians of the whole run and its stages.
    type Runs = (Vec<f64>, Vec<f64>, Vec<[f64; STAGES.len()]>);
    let mut by: BTreeMap<(String, u64), Runs> = BTreeMap::new();
    for r in rows.iter().filter(|r| r["kind"] == "threads") {
        let key = (
            r["case"].as_str().unwrap_or("?").to_owned(),
            r["threads"].as_u64().unwrap_or(0),
        );
        let e = by.entry(key).or_default();
        let (wall, cpu) = times(r);
        e.0.push(wall);
        e.1.push(cpu);
        e.2.push(stages(r));
    }
    let mut series = Vec::new();
    let cases: Vec<String> = by
        .keys()
        .map(|k| k.0.clone())
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    for case in cases {
        let mut table: Vec<(u64, f64, f64, [f64; STAGES.len()])> = by
            .iter_mut()
            .filter(|(k, _)| k.0 == case)
            .map(|((_, t), (wall, cpu, st))| {
                let s = std::array::from_fn(|i| {
                    median(&mut st.iter().map(|s| s[i]).collect::<Vec<_>>())
                });
                (*t, median(wall), median(cpu), s)
            })
            .collect();
        table.sort_by_key(|r| r.0);
        let Some(&(t1, wall1, _, st1)) = table.first() else {
            continue;
        };
        println!("**{case}**: wall seconds (speed-up against {t1} thread)\n");
        let shown: Vec<usize> = (0..STAGES.len()).filter(|&i| st1[i] > 0.0).collect();
        let mut head = "| threads | whole run | CPU s |".to_owned();
        for &i in &shown {
            head += &format!(" {} |", STAGES[i].0);
        }
        println!("{head}\n|{}", "---|".repeat(3 + shown.len()));
        for (t, wall, cpu, st) in &table {
            let mut line = format!("| {t} | {wall:.2} s ({:.2}×) | {cpu:.2} |", wall1 / wall);
            for &i in &shown {
                line += &format!(" {:.3} s ({:.2}×) |", st[i], st1[i] / st[i]);
            }
            println!("{line}");
        }
        // The targets: 2 threads within 0.53× of one for the run and each stage over
        // 0.1 s; 16 threads at 12× one for the whole run.
        if let Some((_, wall2, _, st2)) = table.iter().find(|r| r.0 == 2) {
            let mut worst = (wall2 / wall1, "whole run");
            for &i in &shown {
                if st1[i] > 0.1 && st2[i] / st1[i] > worst.0 {
                    worst = (st2[i] / st1[i], STAGES[i].0);
                }
            }
            println!(
                "\n2 threads ÷ 1: whole run {:.3}, worst stage over 0.1 s: {} {:.3} (target ≤ 0.53)",
                wall2 / wall1,
                worst.1,
                worst.0
            );
        }
        if let Some(&(tn, walln, ..)) = table.last().filter(|r| r.0 >= 16) {
            println!(
                "{tn} threads: {:.2}× one thread (target ≥ 12× at 16)",
                wall1 / walln
            );
        }
        println!();
        series.push(Series {
            label: format!("{case}, whole run"),
            points: table.iter().map(|r| (r.0 as f64, r.1)).collect(),
        });
        for &i in &shown {
            if st1[i] > 0.1 {
                series.push(Series {
                    label: format!("{case}, {}", STAGES[i].0),
                    points: table.iter().map(|r| (r.0 as f64, r.3[i])).collect(),
                });
            }
        }
    }
    if !series.is_empty() {
        panels.push(Panel {
            title: "wall seconds against threads".into(),
            x_desc: "threads".into(),
            series,
        });
    }

    // Error against CPU time.
    // Per renderer and setting: the runs' CPU seconds and errors.
    type Curve = BTreeMap<String, (Vec<f64>, Vec<f64>)>;
    let mut curves: BTreeMap<String, Curve> = BTreeMap::new();
    for r in rows.iter().filter(|r| r["kind"] == "error") {
        let renderer = r["renderer"].as_str().unwrap_or("?").to_owned();
        let setting = if renderer == "murk" {
            format!("--max-error {}", r["asked"])
        } else {
            format!("-step {}", r["step"])
        };
        let e = curves
            .entry(renderer)
            .or_default()
            .entry(setting)
            .or_default();
        e.0.push(times(r).1);
        e.1.push(num(r, "error"));
    }
    if !curves.is_empty() {
        println!("| renderer | setting | CPU s | radiance rel. RMSE |\n|---|---|---|---|");
        let mut lines: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
        let mut vdb_default = None;
        for (renderer, settings) in &mut curves {
            for (setting, (cpu, err)) in settings.iter_mut() {
                let (c, e) = (median(cpu), median(err));
                println!("| {renderer} | {setting} | {c:.2} | {e:.2e} |");
                lines.entry(renderer.clone()).or_default().push((e, c));
                if renderer == "vdb_render" && setting == "-step 1" {
                    vdb_default = Some((e, c));
                }
            }
        }
        for l in lines.values_mut() {
            l.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
        let murk = lines.get("murk").cloned().unwrap_or_default();
        let vdb = lines.get("vdb_render").cloned().unwrap_or_default();
        println!(
            "\nmurk's CPU ÷ vdb_render's at equal radiance error (log–log interpolation along each curve):\n"
        );
        println!(
            "| at error | murk CPU s | vdb_render CPU s | ratio | target |\n|---|---|---|---|---|"
        );
        let at = |label: String, e: f64, vdb_cpu: Option<f64>, target: &str| {
            // Past murk's loosest run, its cheapest run that is within `e` bounds its
            // cost there (murk's cost does not fall further with the error).
            let (m, bound) = match interpolate(&murk, e) {
                Some(m) => (Some(m), ""),
                None => (
                    murk.iter()
                        .filter(|p| p.0 <= e)
                        .map(|p| p.1)
                        .min_by(f64::total_cmp),
                    "≤ ",
                ),
            };
            let cell = |v: Option<f64>, b: &str| {
                v.map_or("outside its sweep".into(), |v| format!("{b}{v:.2}"))
            };
            let ratio_bound = if label.contains('≥') { "≤ " } else { bound };
            let ratio = match (m, vdb_cpu) {
                (Some(m), Some(v)) => format!("{ratio_bound}{:.2}×", m / v),
                _ => "–".into(),
            };
            println!(
                "| {label} | {} | {} | {ratio} | {target} |",
                cell(m, bound),
                cell(vdb_cpu, "")
            );
        };
        if let Some((e, c)) = vdb_default {
            at(
                format!("vdb_render's defaults' ({e:.2e})"),
                e,
                Some(c),
                "≤ 0.10×",
            );
        }
        // Below vdb_render's finest run it costs at least that run's CPU there: a
        // bound on the ratio, marked so.
        let vdb_at = |e: f64| match interpolate(&vdb, e) {
            Some(v) => (Some(v), false),
            None => (
                vdb.iter()
                    .filter(|p| p.0 >= e)
                    .map(|p| p.1)
                    .max_by(f64::total_cmp),
                true,
            ),
        };
        for (e, target) in [(1e-2, "≤ 0.25×"), (1e-3, "≤ 0.5×")] {
            let (v, beyond) = vdb_at(e);
            let label = if beyond {
                format!("{e:.0e} (vdb_render: ≥ its finest run's CPU)")
            } else {
                format!("{e:.0e}")
            };
            at(label, e, v, target);
        }
        panels.push(Panel {
            title: "CPU seconds against radiance error".into(),
            x_desc: "radiance relative RMSE".into(),
            series: lines
                .into_iter()
                .map(|(label, points)| Series { label, points })
                .collect(),
        });
    }
    if !panels.is_empty() {
        let png = dir.join("scaling.png");
        match write_growth_plot(&png, &panels) {
            Ok(_) => println!("\nplot: {}", png.display()),
            Err(e) => eprintln!("scaling: {e}"),
        }
    }
}
