//! The count at the end of `cargo test`: how many tests were skipped for a tool nobody
//! here wrote that is missing on this machine (see `tests/common/tools.rs`), and which.
//!
//! Cargo runs the test binaries of a package in one fixed order: the library's unit
//! tests, the binary's, then `tests/*.rs` sorted by name (and doc tests last, which this
//! package turns off), so this binary, named to sort last, runs after every test that
//! can skip. It has no test harness: it only prints.

mod common;

use common::tools::{skip_dir, skip_file};
use std::fs;

fn main() {
    // `cargo test -- --list` asks every binary for its tests: this one has none.
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let file = skip_file();
    let text = fs::read_to_string(&file).unwrap_or_default();
    let _ = fs::remove_file(&file);
    forget_finished_runs();
    let skipped: Vec<&str> = text.lines().collect();
    if skipped.is_empty() {
        println!("\nNo test skipped for a missing tool.\n");
        return;
    }
    println!(
        "\n{} test{} SKIPPED for a missing tool (MURK_REQUIRE_TOOLS=1 makes that a failure; \
         tests/README.md lists the tools):",
        skipped.len(),
        if skipped.len() == 1 { "" } else { "s" }
    );
    for line in skipped {
        println!("  {line}");
    }
    println!();
}

/// Removes the skip files of runs that stopped before this binary (a failing test
/// stops `cargo test`; `--test NAME` runs one binary): those whose cargo has ended.
fn forget_finished_runs() {
    let Ok(entries) = fs::read_dir(skip_dir()) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let pid = name
            .to_str()
            .and_then(|n| n.split('-').next())
            .unwrap_or("");
        if !std::path::Path::new(&format!("/proc/{pid}")).exists() {
            let _ = fs::remove_file(entry.path());
        }
    }
}
