//! `murk check-stability` and `murk converge`.

use super::print_stdout;
use anyhow::{Result, anyhow};
use murk::output::write_atomically;
use murk::report::stability::{run_battery, table};
use std::path::Path;

pub const STABILITY_EXAMPLES: &str = "Examples:
  murk check-stability
  murk check-stability --out docs/accuracy --json

Exit status 0 when every case passes, 1 when one fails, 2 on an error.";

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
