//! What murk promises whatever it is given (docs/guide.md, "What murk promises"): it ends, with exit 0
//! or 2 and one line; it never writes a non-finite value or over its own inputs; a kill
//! leaves nothing that the next run does not clean. Each test here reproduces one finding
//! of a fuzz campaign and fails on the code before its fix.

#[path = "../common/mod.rs"]
mod common;
use common::tools;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn fixture(name: &str) -> PathBuf {
    root().join("fixtures").join(name)
}

/// An empty scratch directory for one test.
fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("reliability-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs murk with `args`, killing it (and failing the test) after `limit`.
fn murk_within(limit: Duration, args: &[&str]) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_murk"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn murk");
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            return child.wait_with_output().unwrap();
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("`murk {}` still ran after {limit:?}", args.join(" "));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn murk(args: &[&str]) -> Output {
    murk_within(Duration::from_secs(120), args)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Exit 2 with exactly one line `murk: error: ...` containing every needle.
fn refused(o: &Output, needles: &[&str]) -> String {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "expected exit 2, stderr: {err}");
    assert_eq!(err.lines().count(), 1, "expected one line: {err:?}");
    assert!(err.starts_with("murk: error: "), "{err}");
    for n in needles {
        assert!(err.contains(n), "{err:?} does not contain {n:?}");
    }
    err
}

fn ok(o: &Output) -> String {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(0), "expected exit 0, stderr: {err}");
    err
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

mod inputs;
mod outputs;
