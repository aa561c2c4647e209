//! The command line as a user meets it: every example in `--help` runs, and bad
//! input ends in exit code 2 with one line `murk: error: ...` on stderr, no
//! panic, and nothing left in the output directory.

use std::collections::BTreeSet;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use exr::prelude::read_all_flat_layers_from_file;
use serde_json::Value;

#[path = "../common/mod.rs"]
mod common;

use common::examples;

const MURK: &str = env!("CARGO_BIN_EXE_murk");

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn fixture(name: &str) -> String {
    root()
        .join("fixtures")
        .join(name)
        .to_str()
        .unwrap()
        .to_owned()
}

/// A fresh, empty directory for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("cli-{name}"));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

fn murk(cwd: &Path, args: &[String]) -> Output {
    Command::new(MURK)
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {MURK}: {e}"))
}

fn listing(dir: &Path) -> BTreeSet<String> {
    match fs::read_dir(dir) {
        Ok(entries) => entries
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect(),
        Err(_) => BTreeSet::new(),
    }
}

mod bad_input;
mod help_examples;
mod shadow_cache;
