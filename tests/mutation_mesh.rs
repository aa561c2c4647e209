//! Robustness of the mesh readers against malformed files: every mesh fixture (.vtu in
//! each encoding, .vtk ASCII and binary) is mutated — truncations, byte flips and
//! overwrites, numbers in the text replaced by huge, negative and non-numeric ones,
//! XML attributes (byte order, header type, compressor, format, offsets) changed — and
//! `murk info --json` runs on each mutant in a child process under a time limit and
//! an address-space limit. Every run must end cleanly: exit 0 with JSON on stdout, or
//! exit 2 with exactly one line `murk: error: <path>: ...`. A panic, abort, signal or
//! hang fails the test and names the mutant (kept in `target/tmp/mutation-mesh-failures/`).
//!
//! `cargo test --release --test mutation_mesh -- --nocapture` prints the summary;
//! `-- --ignored` runs the long one (ten times as many random mutants).

use murk::field::random::SplitMix64;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

const TIMEOUT: Duration = Duration::from_secs(10);
/// The fixtures are under 50 kB; 512 MiB is out of all proportion to any of them.
const MEMORY_LIMIT_KIB: u64 = 512 * 1024;
const WORKERS: usize = 3;

struct Rng(SplitMix64);
impl Rng {
    fn below(&mut self, n: usize) -> usize {
        (self.0.next_u64() % n.max(1) as u64) as usize
    }
}

/// Positions and texts of the numbers in the file's text parts (its first 4 kB and,
/// for ASCII files, everywhere).
fn numbers(b: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_digit() && (i == 0 || !b[i - 1].is_ascii_alphanumeric()) {
            let s = i;
            while i < b.len()
                && (b[i].is_ascii_digit() || b[i] == b'.' || b[i] == b'e' || b[i] == b'-')
            {
                i += 1;
            }
            out.push((s, i));
        } else {
            i += 1;
        }
    }
    out
}

const ATTRIBUTE_EDITS: &[(&str, &str)] = &[
    ("LittleEndian", "BigEndian"),
    ("header_type=\"UInt64\"", "header_type=\"UInt32\""),
    (
        "byte_order=\"LittleEndian\"",
        "byte_order=\"LittleEndian\" header_type=\"UInt64\"",
    ),
    ("compressor=\"vtkZLibDataCompressor\"", ""),
    ("format=\"binary\"", "format=\"ascii\""),
    ("format=\"ascii\"", "format=\"binary\""),
    ("format=\"appended\"", "format=\"binary\""),
    ("encoding=\"raw\"", "encoding=\"base64\""),
    ("type=\"Int64\"", "type=\"Float32\""),
    ("type=\"Float64\"", "type=\"UInt8\""),
    ("NumberOfComponents=\"3\"", "NumberOfComponents=\"2\""),
    ("UnstructuredGrid", "PolyData"),
    ("BINARY", "ASCII"),
    ("ASCII", "BINARY"),
    ("double", "float"),
    ("vtktypeint64", "int"),
    ("OFFSETS", "CONNECTIVITY"),
    ("</VTKFile>", ""),
    ("_", "?"),
];

fn mutants(name: &str, b: &[u8], random: usize, seed: u64) -> Vec<(String, Vec<u8>)> {
    let mut rng = Rng(SplitMix64(seed ^ (name.len() as u64 * 0x9E37_79B9)));
    let mut out = Vec::new();
    // Truncations: 40 spread over the file, and inside the first kilobyte.
    for k in 0..40 {
        let at = b.len() * k / 40;
        out.push((format!("trunc-{at}"), b[..at].to_vec()));
    }
    for (from, to) in ATTRIBUTE_EDITS {
        let pos = b.windows(from.len()).position(|w| w == from.as_bytes());
        if let Some(at) = pos {
            let mut m = b[..at].to_vec();
            m.extend_from_slice(to.as_bytes());
            m.extend_from_slice(&b[at + from.len()..]);
            out.push((
                format!("attr-{}", from.replace(['"', '=', '<', '/', '>'], "")),
                m,
            ));
        }
    }
    let nums = numbers(b);
    const REPLACEMENTS: &[&str] = &[
        "0",
        "-1",
        "4294967295",
        "18446744073709551615",
        "9999999999999",
        "nan",
        "1e308",
        "-7",
        "x",
        "",
    ];
    for _ in 0..random {
        let kind = rng.below(4);
        let mut m = b.to_vec();
        let label = match kind {
            0 if !nums.is_empty() => {
                let (s, e) = nums[rng.below(nums.len())];
                let r = REPLACEMENTS[rng.below(REPLACEMENTS.len())];
                m.splice(s..e, r.bytes());
                format!("num-{s}-{r}")
            }
            1 => {
                let at = rng.below(m.len());
                m[at] ^= 1 << rng.below(8);
                format!("flip-{at}")
            }
            2 => {
                let at = rng.below(m.len());
                let n = 1 + rng.below(8);
                for k in at..(at + n).min(m.len()) {
                    m[k] = rng.below(256) as u8;
                }
                format!("over-{at}")
            }
            _ => {
                let at = rng.below(m.len());
                let n = rng.below(64).min(m.len() - at);
                m.drain(at..at + n);
                format!("cut-{at}-{n}")
            }
        };
        out.push((label, m));
    }
    out
}

enum Outcome {
    Ok,
    Err(String),
    Bad(String),
}

fn run_murk(path: &Path) -> Outcome {
    use std::os::unix::process::ExitStatusExt;
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v {MEMORY_LIMIT_KIB} || exit 99; exec \"$0\" \"$@\""
        ))
        .arg(env!("CARGO_BIN_EXE_murk"))
        .args(["info", "--json"])
        .arg(path)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn sh");
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            return Outcome::Bad("hang".into());
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    if let Some(sig) = out.status.signal() {
        return Outcome::Bad(format!("signal {sig}: {err}"));
    }
    match out.status.code() {
        Some(0) => match serde_json::from_slice::<serde_json::Value>(&out.stdout) {
            Ok(_) if !err.contains("panicked") => Outcome::Ok,
            _ => Outcome::Bad(format!("exit 0 without JSON or with a panic: {err}")),
        },
        Some(2) => {
            let body = err.strip_suffix('\n').unwrap_or(&err);
            let p = path.display().to_string();
            let prefix = format!("murk: error: {p}: ");
            if body.contains('\n') || !body.starts_with(&prefix) {
                return Outcome::Bad(format!(
                    "exit 2 but stderr is not one line `murk: error: <path>: ...`: {body:?}"
                ));
            }
            Outcome::Err(body[prefix.len()..].to_string())
        }
        Some(99) => panic!("`ulimit -v` is not available in sh"),
        c => Outcome::Bad(format!("exit {c:?}: {}", err.lines().next().unwrap_or(""))),
    }
}

fn run_all(random_per_file: usize, seed: u64) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| murk::vtk::is_mesh_path(p))
        .collect();
    files.sort();
    assert!(files.len() >= 11, "mesh fixtures: {files:?}");
    let mut all: Vec<(String, Vec<u8>)> = Vec::new();
    for f in &files {
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        let b = std::fs::read(f).unwrap();
        for (label, m) in mutants(&name, &b, random_per_file, seed) {
            let ext = f.extension().unwrap().to_string_lossy();
            all.push((
                format!("{}-{label}.{ext}", f.file_stem().unwrap().to_string_lossy()),
                m,
            ));
        }
    }
    let work = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("mutation-mesh-{}", std::process::id()));
    let keep = Path::new(env!("CARGO_TARGET_TMPDIR")).join("mutation-mesh-failures");
    let _ = std::fs::remove_dir_all(&keep);
    std::fs::create_dir_all(&work).unwrap();
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<(usize, Outcome)>> = Mutex::new(Vec::new());
    let started = Instant::now();
    std::thread::scope(|s| {
        for _ in 0..WORKERS {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some((name, bytes)) = all.get(i) else {
                        break;
                    };
                    let path = work.join(format!("{i}-{name}"));
                    std::fs::write(&path, bytes).unwrap();
                    let o = run_murk(&path);
                    if let Outcome::Bad(_) = o {
                        std::fs::create_dir_all(&keep).unwrap();
                        std::fs::copy(&path, keep.join(name)).unwrap();
                    }
                    let _ = std::fs::remove_file(&path);
                    results.lock().unwrap().push((i, o));
                }
            });
        }
    });
    let _ = std::fs::remove_dir_all(&work);
    let results = results.into_inner().unwrap();
    let (mut ok, mut err) = (0, 0);
    let mut kinds: BTreeMap<String, usize> = BTreeMap::new();
    let mut bad = Vec::new();
    for (i, o) in &results {
        match o {
            Outcome::Ok => ok += 1,
            Outcome::Err(m) => {
                err += 1;
                let k: String = m
                    .chars()
                    .map(|c| if c.is_ascii_digit() { 'N' } else { c })
                    .take(60)
                    .collect();
                *kinds.entry(k).or_default() += 1;
            }
            Outcome::Bad(why) => bad.push(format!("{}: {why}", all[*i].0)),
        }
    }
    println!(
        "mesh mutation: {} mutants of {} files in {:.1} s: {ok} clean Ok, {err} clean Err, {} bad",
        results.len(),
        files.len(),
        started.elapsed().as_secs_f64(),
        bad.len()
    );
    let mut by: Vec<_> = kinds.into_iter().collect();
    by.sort_by_key(|k| std::cmp::Reverse(k.1));
    for (m, n) in by.iter().take(40) {
        println!("{n:>6}  {m}");
    }
    assert!(
        err > results.len() / 3,
        "most mutants should be refused: {err} of {}",
        results.len()
    );
    assert!(
        bad.is_empty(),
        "{} bad runs:\n{}",
        bad.len(),
        bad.join("\n")
    );
}

#[test]
fn mesh_mutants_end_cleanly() {
    run_all(150, 1);
}

/// Ten times as many random mutants (a few minutes): `cargo test --release --test
/// mutation_mesh -- --ignored`.
#[test]
#[ignore]
fn mesh_mutants_end_cleanly_long() {
    run_all(1500, 2);
}
