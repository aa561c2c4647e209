//! Command-line parsing and dispatch. Errors are printed as one line; exit code 2.

mod info;

use clap::{Parser, Subcommand};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(name = "murk", version, about = "Render OpenVDB volume caches to multi-layer OpenEXR images")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Describe a .vdb file: its metadata and every grid (no trees are decoded without --stats).
    #[command(after_help = "Examples:\n  murk info fixtures/cloud.vdb\n  murk info fixtures/pyro.vdb --stats --json")]
    Info {
        /// The .vdb file.
        file: PathBuf,
        /// Decode every float and vec3 grid and report value statistics and memory.
        #[arg(long)]
        stats: bool,
        /// Print JSON (stable keys, documented in README) instead of a table.
        #[arg(long)]
        json: bool,
    },
}

/// Runs the command line; returns the process exit code.
pub fn run() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return code;
        }
    };
    let result = match cli.command {
        Command::Info { file, stats, json } => info::run(&file, stats, json),
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("murk: error: {}", one_line(&format!("{e:#}")));
            2
        }
    }
}

fn one_line(s: &str) -> String {
    s.replace('\n', " ")
}
