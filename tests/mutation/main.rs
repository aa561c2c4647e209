//! Robustness against malformed files: every fixture is mutated (truncations, bit flips,
//! byte overwrites and structural edits such as huge length fields, bad offsets, renamed
//! grid types, cyclic instances, nested frustum maps and corrupted Blosc frames) and
//! `murk info --stats --json` is run on each mutant in a child process, under a time
//! limit and an address-space limit; every 16th mutant (every 4th in the long run) is
//! also rendered (`murk render`, a small image, default flags) under its own limits. Every run must end cleanly: exit 0 with JSON on
//! stdout, or exit 2 with exactly one line `murk: error: <path>: ...` on stderr. A panic,
//! abort (stack overflow, failed allocation), signal or hang fails the test; the failing
//! mutants are kept in `target/tmp/mutation-failures-<run>/` and named in the message.
//!
//! `cargo test --test mutation -- --nocapture` runs the default set (a few thousand
//! mutants) and prints the summary; `-- --ignored` runs the long one. Set
//! `MUTATION_FILTER=<text>` to run only the mutants whose names contain `<text>` (names
//! are `<fixture>-<index>-<mutation>`, as in the failure list).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

mod layout;
mod mutants;
mod structural;

use mutants::{Fixture, Mutant, apply, fixtures, mutants};

/// Mutants in the default test (the requirement is at least 2,000).
const DEFAULT_MUTANTS: usize = 3000;
/// The default test runs every n-th structural mutant (the long test runs all of them).
const DEFAULT_STRUCTURAL_STEP: usize = 2;
/// Mutants in the ignored long test (the requirement is at least 20,000).
const LONG_MUTANTS: usize = 24000;
/// A child running longer than this is a hang.
const TIMEOUT: Duration = Duration::from_secs(10);
/// Address-space limit for each child, in KiB (`ulimit -v`). The fixtures are at most
/// half a megabyte and murk needs well under 64 MiB for any of them, so an allocation
/// that does not fit into 512 MiB is out of all proportion to the input.
const MEMORY_LIMIT_KIB: u64 = 512 * 1024;
/// Concurrent children (the machine has few cores; the children are short).
const WORKERS: usize = 3;
/// Every n-th mutant is also rendered (`murk render`, default flags but a small image:
/// the shadow bake, the march and the EXR writer see the mutant too); the long test
/// renders every `LONG_RENDER_STEP`-th.
const DEFAULT_RENDER_STEP: usize = 16;
const LONG_RENDER_STEP: usize = 4;
/// A render may take this long (a bake of a mutant is bounded by the bake's budgets,
/// which a loaded machine runs in well under a minute).
const RENDER_TIMEOUT: Duration = Duration::from_secs(60);
/// Address space for a render: its worker threads' stacks and the frame need more than
/// `info` does, but nothing near this for a half-megabyte fixture.
const RENDER_MEMORY_LIMIT_KIB: u64 = 2048 * 1024;

// ------------------------------------------------------------------------------------
// Running murk on a file.

#[derive(Debug)]
enum Outcome {
    Ok,
    /// The error message, without `murk: error: <path>: `.
    Err(String),
    Bad(String),
}

/// Runs `murk info --stats --json path` under the time and memory limits and judges it.
fn run_murk(path: &Path, scratch: &Path) -> Outcome {
    run_limited(path, scratch, None)
}

/// Runs `murk render path -o <scratch>.exr` (a small image, default flags otherwise)
/// under the render's limits and judges it: exit 0 must leave the EXR, exit 2 one line.
fn render_murk(path: &Path, scratch: &Path) -> Outcome {
    let exr = scratch.with_extension("exr");
    let outcome = run_limited(path, scratch, Some(&exr));
    let wrote = exr.exists();
    let _ = std::fs::remove_file(&exr);
    match outcome {
        Outcome::Ok if !wrote => Outcome::Bad("render: exit 0 but no EXR".to_string()),
        Outcome::Err(_) if wrote => Outcome::Bad("render: exit 2 but an EXR".to_string()),
        Outcome::Bad(why) => Outcome::Bad(format!("render: {why}")),
        other => other,
    }
}

/// Runs murk on `path`: `info --stats --json`, or with `render`, a render to that EXR.
fn run_limited(path: &Path, scratch: &Path, render: Option<&Path>) -> Outcome {
    let out_path = scratch.with_extension("out");
    let err_path = scratch.with_extension("err");
    let stdout = std::fs::File::create(&out_path).unwrap();
    let stderr = std::fs::File::create(&err_path).unwrap();
    let (memory, timeout) = match render {
        Some(_) => (RENDER_MEMORY_LIMIT_KIB, RENDER_TIMEOUT),
        None => (MEMORY_LIMIT_KIB, TIMEOUT),
    };
    let mut command = Command::new("sh");
    command
        .arg("-c")
        .arg(format!("ulimit -v {memory} || exit 99; exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_murk"));
    match render {
        Some(exr) => command.arg("render").arg(path).arg("-o").arg(exr).args([
            "--res",
            "48x27",
            "--quiet",
            "--threads",
            "2",
        ]),
        None => command.args(["info", "--stats", "--json"]).arg(path),
    };
    let mut child = command
        .stdin(Stdio::null())
        .stdout(stdout)
        .stderr(stderr)
        .spawn()
        .expect("spawn sh");
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > timeout {
            let _ = child.kill();
            let _ = child.wait();
            return Outcome::Bad(format!("hang (killed after {timeout:?})"));
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    let out = std::fs::read(&out_path).unwrap_or_default();
    let err = String::from_utf8_lossy(&std::fs::read(&err_path).unwrap_or_default()).into_owned();
    let _ = std::fs::remove_file(&out_path);
    let _ = std::fs::remove_file(&err_path);
    judge(status, &out, &err, path, render.is_some())
}

fn judge(
    status: std::process::ExitStatus,
    out: &[u8],
    err: &str,
    path: &Path,
    render: bool,
) -> Outcome {
    use std::os::unix::process::ExitStatusExt;
    let first = err
        .lines()
        .next()
        .unwrap_or("")
        .chars()
        .take(300)
        .collect::<String>();
    if let Some(sig) = status.signal() {
        let what = match sig {
            6 => "abort (SIGABRT: failed allocation, stack overflow or abort)",
            9 => "killed (SIGKILL)",
            11 => "segfault (SIGSEGV)",
            _ => "signal",
        };
        return Outcome::Bad(format!("{what} {sig}: {first}"));
    }
    match status.code() {
        Some(0) => {
            if err.contains("panicked") {
                return Outcome::Bad(format!("exit 0 but a panic was printed: {first}"));
            }
            if render {
                return Outcome::Ok;
            }
            match serde_json::from_slice::<serde_json::Value>(out) {
                Ok(_) => Outcome::Ok,
                Err(e) => Outcome::Bad(format!("exit 0 but stdout is not JSON: {e}")),
            }
        }
        Some(2) => {
            let p = path.display().to_string();
            let prefix = "murk: error: ";
            let body = err.strip_suffix('\n').unwrap_or(err);
            if body.contains('\n') {
                let n = body.lines().count();
                return Outcome::Bad(format!(
                    "exit 2 with {n} lines on stderr: {:?}",
                    err.chars().take(400).collect::<String>()
                ));
            }
            if !body.starts_with(prefix) || !body.contains(&p) {
                return Outcome::Bad(format!(
                    "exit 2 but stderr is not `murk: error: <path>: ...`: {body:?}"
                ));
            }
            let rest = body[prefix.len()..].replacen(&p, "<file>", 1);
            Outcome::Err(rest.strip_prefix("<file>: ").unwrap_or(&rest).to_string())
        }
        Some(101) => Outcome::Bad(format!("panic (exit 101): {first}")),
        Some(134) => Outcome::Bad(format!("abort (exit 134): {first}")),
        Some(99) => panic!("`ulimit -v` is not available in sh"),
        Some(c) => Outcome::Bad(format!("exit code {c}: {first}")),
        None => Outcome::Bad("no exit code".to_string()),
    }
}

fn work_dir(tag: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("mutation-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Where a run keeps its failing mutants (emptied when the run starts).
fn failure_dir(tag: &str) -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("mutation-failures-{tag}"))
}

/// An error message's first 60 characters, numbers replaced by `N` so that messages
/// differing only in sizes and offsets count together.
fn message_kind(msg: &str) -> String {
    let mut out = String::new();
    for c in msg.chars() {
        if c.is_ascii_digit() {
            if !out.ends_with('N') {
                out.push('N');
            }
        } else {
            out.push(c);
        }
    }
    out.chars().take(60).collect()
}

/// Runs every mutant (and renders every `render_step`-th, but not those of fixtures
/// whose own render takes tens of seconds), prints a summary and fails listing the bad
/// ones.
fn run_all(tag: &str, fixtures: &[Fixture], mutants: Vec<Mutant>, render_step: usize) {
    // MUTATION_FILTER=text runs only the mutants whose names contain `text`.
    let filter = std::env::var("MUTATION_FILTER").ok();
    let mutants: Vec<Mutant> = match &filter {
        Some(f) => mutants
            .into_iter()
            .filter(|m| m.name.contains(f.as_str()))
            .collect(),
        None => {
            assert!(mutants.len() >= 2000, "only {} mutants", mutants.len());
            mutants
        }
    };
    let started = Instant::now();
    let _ = std::fs::remove_dir_all(failure_dir(tag));
    let dir = work_dir(tag);
    let next = AtomicUsize::new(0);
    let renders = AtomicUsize::new(0);
    let results: Mutex<Vec<(usize, Outcome)>> = Mutex::new(Vec::with_capacity(mutants.len()));
    std::thread::scope(|s| {
        for _ in 0..WORKERS {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(m) = mutants.get(i) else { break };
                    let path = dir.join(format!("{}.vdb", m.name));
                    std::fs::write(&path, apply(&fixtures[m.fixture].bytes, &m.edit)).unwrap();
                    let scratch = dir.join(format!("run-{i}"));
                    let mut outcome = run_murk(&path, &scratch);
                    let slow = SLOW_TO_RENDER.contains(&fixtures[m.fixture].stem.as_str());
                    if i.is_multiple_of(render_step) && !slow && !matches!(outcome, Outcome::Bad(_))
                    {
                        let rendered = render_murk(&path, &scratch);
                        if let Outcome::Bad(_) = rendered {
                            outcome = rendered;
                        }
                        renders.fetch_add(1, Ordering::Relaxed);
                    }
                    if let Outcome::Bad(_) = outcome {
                        let keep = failure_dir(tag);
                        std::fs::create_dir_all(&keep).unwrap();
                        std::fs::copy(&path, keep.join(format!("{}.vdb", m.name))).unwrap();
                    }
                    let _ = std::fs::remove_file(&path);
                    results.lock().unwrap().push((i, outcome));
                }
            });
        }
    });
    let _ = std::fs::remove_dir_all(&dir);
    let mut results = results.into_inner().unwrap();
    results.sort_by_key(|(i, _)| *i);

    let (mut ok, mut err) = (0, 0);
    let mut messages: BTreeMap<String, usize> = BTreeMap::new();
    let mut bad = Vec::new();
    for (i, o) in &results {
        match o {
            Outcome::Ok => ok += 1,
            Outcome::Err(msg) => {
                err += 1;
                *messages.entry(message_kind(msg)).or_default() += 1;
            }
            Outcome::Bad(why) => bad.push(format!("{}.vdb: {why}", mutants[*i].name)),
        }
    }
    let mut by_count: Vec<_> = messages.into_iter().collect();
    by_count.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    println!(
        "mutation ({tag}): {} mutants ({} also rendered) in {:.1} s: {ok} clean Ok, {err} clean Err, {} bad",
        results.len(),
        renders.load(Ordering::Relaxed),
        started.elapsed().as_secs_f64(),
        bad.len()
    );
    println!("distinct error messages (first 60 chars, numbers as N), by count:");
    for (msg, n) in &by_count {
        println!("{n:>7}  {msg}");
    }
    assert_eq!(results.len(), mutants.len());
    assert!(
        bad.is_empty(),
        "{} of {} mutants did not end cleanly (copies in {}):\n{}",
        bad.len(),
        results.len(),
        failure_dir(tag).display(),
        bad.iter().take(60).cloned().collect::<Vec<_>>().join("\n")
    );
}

/// Fixtures whose sound render takes tens of seconds (tiles.vdb: 2^28 voxels of tiles):
/// their mutants are inspected, not rendered.
const SLOW_TO_RENDER: &[&str] = &["tiles"];

#[test]
fn mutated_fixtures_end_cleanly() {
    let f = fixtures();
    let m = mutants(&f, DEFAULT_MUTANTS, DEFAULT_STRUCTURAL_STEP, 0x6d75_726b);
    run_all("default", &f, m, DEFAULT_RENDER_STEP);
}

/// The long run (docs/testing.md says how long it takes).
#[test]
#[ignore = "long: tens of thousands of mutants; run with --ignored"]
fn mutated_fixtures_end_cleanly_long() {
    let f = fixtures();
    let m = mutants(&f, LONG_MUTANTS, 1, 0x1000_0000_6d75_726b);
    assert!(m.len() >= 20_000, "only {} mutants", m.len());
    run_all("long", &f, m, LONG_RENDER_STEP);
}

// ------------------------------------------------------------------------------------
// Plain bad inputs.

fn expect_clean_error(path: &Path, what: &str) {
    // One directory per case: the cases run in parallel and each removes its own.
    let dir = work_dir(&format!("plain-{}", what.replace(' ', "-")));
    let o = run_murk(path, &dir.join("run"));
    let _ = std::fs::remove_dir_all(&dir);
    match o {
        Outcome::Err(msg) => assert!(!msg.is_empty(), "{what}: empty message"),
        other => panic!(
            "{what}: expected exit 2 with one `murk: error: <path>: ...` line, got {other:?}"
        ),
    }
}

fn plain_file(name: &str, bytes: &[u8]) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("mutation-plain");
    std::fs::create_dir_all(&d).unwrap();
    let p = d.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn empty_file_is_a_clean_error() {
    expect_clean_error(&plain_file("empty.vdb", b""), "empty file");
}

#[test]
fn directory_is_a_clean_error() {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("mutation-plain")
        .join("a-directory.vdb");
    std::fs::create_dir_all(&d).unwrap();
    expect_clean_error(&d, "directory");
}

#[test]
fn missing_file_is_a_clean_error() {
    let p = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("mutation-plain")
        .join("does-not-exist.vdb");
    let _ = std::fs::remove_file(&p);
    expect_clean_error(&p, "missing file");
}

#[test]
fn non_vdb_files_are_clean_errors() {
    let png = [
        0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n', 0, 0, 0, 13, b'I', b'H', b'D', b'R', 0,
        0, 1, 0,
    ];
    expect_clean_error(&plain_file("image.png.vdb", &png), "PNG header");
    expect_clean_error(
        &plain_file("text.vdb", b"this is not a volume\nat all\n"),
        "text file",
    );
    expect_clean_error(&plain_file("one-byte.vdb", b"V"), "one byte");
}

#[test]
fn file_truncated_to_ten_bytes_is_a_clean_error() {
    let b =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/cloud.vdb")).unwrap();
    expect_clean_error(
        &plain_file("cloud-10-bytes.vdb", &b[..10]),
        "truncated to 10 bytes",
    );
}

#[test]
fn unsupported_grid_types_are_fine_for_info() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/bad_types.vdb");
    for args in [
        &["info"][..],
        &["info", "--json"],
        &["info", "--stats", "--json"],
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_murk"))
            .args(args)
            .arg(&p)
            .output()
            .unwrap();
        assert_eq!(
            out.status.code(),
            Some(0),
            "murk {args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            out.stderr.is_empty(),
            "murk {args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let dir = work_dir("bad-types");
    let o = run_murk(&p, &dir.join("bad-types"));
    let _ = std::fs::remove_dir_all(&dir);
    assert!(matches!(o, Outcome::Ok), "{o:?}");
}
