//! `murk check-stability` and `murk converge`.

use super::print_stdout;
use anyhow::{Result, anyhow};
use murk::output::guard::Role;
use murk::output::write_atomically;
use murk::render::Progress;
use murk::render::RenderOptions;
use murk::report::converge::{self, ConvergeSettings};
use murk::report::converge_table::{csv, markdown, summarise, summary_table};
use murk::report::plot::{COLOURS, write_plot};
use murk::report::stability::{run_battery, table};
use std::path::Path;

pub const STABILITY_EXAMPLES: &str = "Examples:
  murk check-stability
  murk check-stability --out docs/accuracy --json

Exit status 0 when every case passes, 1 when one fails, 2 on an error.";

pub const CONVERGE_EXAMPLES: &str = "Examples:
  murk converge fixtures/cloud.vdb --res 64x36 --runs 1 --out converge
  murk converge fixtures/scene.toml --res 48x27 --runs 1 --light sun:1,1,0:1,1,1:4 --out converge-side

With no --res and --runs: 160x90 and the median of 3 runs (about a minute on the demo cloud).
Render flags set the scene (lights, sigma, camera); --step, --dsm-tolerance, --termination and
--shadows are what the sweeps vary, so they are overridden.";

/// Writes `text` to `dir/name` atomically, creating `dir` if needed.
pub fn write_text(dir: &Path, name: &str, text: &str) -> Result<()> {
    std::fs::create_dir_all(dir)
        .map_err(|e| anyhow!("{}: cannot create the directory: {e}", dir.display()))?;
    let path = dir.join(name);
    write_atomically(&path, |tmp| {
        std::fs::write(tmp, text.as_bytes()).map_err(|e| anyhow!("{}: {e}", path.display()))
    })
}

/// Runs the battery; prints the table (or JSON) and writes `stability.json` in `out`.
/// Returns whether every case passed.
pub fn check_stability(out: &Path, json: bool) -> Result<bool> {
    super::guard::check_outputs(&[], &[Role::new(out.join("stability.json"), "the report")])?;
    let results = run_battery()?;
    let pass = results.iter().all(|r| r.pass);
    let text = serde_json::to_string_pretty(&serde_json::json!({
        "pass": pass,
        "cases": results,
    }))?;
    write_text(out, "stability.json", &(text.clone() + "\n"))?;
    if json {
        print_stdout(&(text + "\n"))?;
    } else {
        let passed = results.iter().filter(|r| r.pass).count();
        print_stdout(&format!(
            "{}\n{passed}/{} cases pass; written {}\n",
            table(&results),
            results.len(),
            out.join("stability.json").display()
        ))?;
    }
    Ok(pass)
}

/// `murk converge`: sweeps, times and compares; writes converge.csv, converge.md and
/// converge.png in `out` and prints the summary.
pub fn converge(input: &Path, options: RenderOptions, out: &Path, runs: usize) -> Result<()> {
    if runs == 0 {
        return Err(anyhow!("--runs must be at least 1"));
    }
    let (mut options, vdb) = super::render::options_for(input, options)?;
    if options.res.is_none() {
        options.res = Some("160x90".into());
    }
    let mut inputs = vec![Role::new(&vdb, "the input")];
    if vdb != input {
        inputs.push(Role::new(input, "the scene file"));
    }
    let outputs: Vec<Role> = ["converge.csv", "converge.md", "converge.png"]
        .into_iter()
        .map(|n| Role::new(out.join(n), format!("the report's {n}")))
        .collect();
    super::guard::check_outputs(&inputs, &outputs)?;
    std::fs::create_dir_all(out)
        .map_err(|e| anyhow!("{}: cannot create the directory: {e}", out.display()))?;
    let progress = super::progress::Bars::new(options.quiet);
    let (reference, rows) = converge::run(&options, &vdb, &ConvergeSettings { runs }, &progress)?;
    progress.finish();
    let summary = summarise(&rows);
    let plan = murk::render::RenderPlan::new(
        &RenderOptions {
            output: Some("x.exr".into()),
            ..options.clone()
        },
        vdb.clone(),
    )?;
    write_text(out, "converge.csv", &csv(&reference, &rows))?;
    let text = write_plot(&out.join("converge.png"), &rows)?;
    let mut md = markdown(
        &vdb.display().to_string(),
        (plan.camera.width, plan.camera.height),
        &reference,
        &rows,
        &summary,
    );
    if !text {
        md += &format!(
            "\nNo font was found, so the plot has no text: lines are {}.\n",
            COLOURS
                .iter()
                .zip([
                    "step",
                    "dsm_tolerance",
                    "termination",
                    "path_spp",
                    "default",
                ])
                .map(|((c, _), s)| format!("{s} {c}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    write_text(out, "converge.md", &md)?;
    print_stdout(&format!(
        "{}\nwritten {}, converge.md, converge.png\n",
        summary_table(&summary),
        out.join("converge.csv").display()
    ))?;
    Ok(())
}
