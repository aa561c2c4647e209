//! Robustness against hostile scene files: scenes built from `fixtures/scene.toml` and
//! the fixtures, with keys deleted, duplicated, retyped or set to hostile values (huge,
//! negative, NaN, infinite, empty, control characters, absurd counts, paths that are the
//! input, the scene, a directory or a device), and with random byte edits, are rendered
//! by `murk render <scene>` in a child process under a time limit and an address-space
//! limit. Every run must end cleanly: exit 0 having written the EXR, or exit 2 with one
//! line `murk: error: ...` naming the scene or a file it names, and nothing written.
//!
//! `cargo test --release --test mutation_scenes -- --nocapture` runs the default set and
//! prints a summary; `-- --ignored` runs the long one (docs/testing.md).

use murk::field::random::SplitMix64;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

const DEFAULT_SCENES: usize = 400;
const LONG_SCENES: usize = 4000;
const TIMEOUT: Duration = Duration::from_secs(60);
const MEMORY_LIMIT_KIB: u64 = 2048 * 1024;
const WORKERS: usize = 3;

/// Keys and the values a hostile scene gives them (TOML text).
const HOSTILE: &[&str] = &[
    "-1e308",
    "1e308",
    "nan",
    "inf",
    "-inf",
    "0",
    "-1",
    "4294967296",
    "18446744073709551615",
    "1e-300",
    "\"\"",
    "\"\\u001b[31mred\\u001b[0m\"",
    "\"1e308,1e308,1e308\"",
    "\"nan,0,0\"",
    "\"0,0,0\"",
    "\"16384x16384\"",
    "\"0x0\"",
    "\"c.vdb\"",
    "\"s.toml\"",
    "\".\"",
    "\"/dev/zero\"",
    "\"out.exr\"",
    "true",
    "[1, 2]",
    "{ a = 1 }",
];

const KEYS: &[&str] = &[
    "input",
    "output",
    "preview",
    "stats",
    "res",
    "camera",
    "eye",
    "look_at",
    "up",
    "fov",
    "ortho_width",
    "density_grid",
    "emission_grid",
    "sigma_a",
    "sigma_s",
    "density_scale",
    "g",
    "emission_intensity",
    "step",
    "shadow_step",
    "shadows",
    "dsm_tolerance",
    "termination",
    "spp",
    "seed",
    "threads",
    "compression",
    "exposure",
    "background",
    "ground",
    "shadow_cache",
];

/// A sound scene over `c.vdb` in the same folder; small, so that renders are quick.
fn base_scene(lights: usize) -> String {
    let mut s = String::from(
        "input = \"c.vdb\"\noutput = \"out.exr\"\nres = \"48x27\"\nfov = 36\n\
         sigma_s = \"1.8,1.9,2.0\"\ng = 0.3\nshadows = \"dsm\"\n",
    );
    for k in 0..lights {
        s.push_str(&format!(
            "[[lights]]\nname = \"l{k}\"\nspec = \"sun:0.6,1,{k}:1,0.95,0.85:6\"\n"
        ));
    }
    s
}

fn mutate(rng: &mut SplitMix64, base: &str) -> (String, String) {
    let below = |rng: &mut SplitMix64, n: usize| (rng.next_u64() % n as u64) as usize;
    let kind = below(rng, 10);
    let lines: Vec<&str> = base.lines().collect();
    match kind {
        0..=3 => {
            // A key set to a hostile value (before the lights table, so it stays top-level).
            let key = KEYS[below(rng, KEYS.len())];
            let value = HOSTILE[below(rng, HOSTILE.len())];
            let body: Vec<&str> = lines
                .iter()
                .copied()
                .filter(|l| !l.starts_with(&format!("{key} =")))
                .collect();
            let cut = body
                .iter()
                .position(|l| l.starts_with("[[lights]]"))
                .unwrap_or(body.len());
            let mut out: Vec<String> = body[..cut].iter().map(|s| s.to_string()).collect();
            out.push(format!("{key} = {value}"));
            out.extend(body[cut..].iter().map(|s| s.to_string()));
            (format!("set-{key}-{value}"), out.join("\n") + "\n")
        }
        4 => {
            let at = below(rng, lines.len());
            let mut out: Vec<&str> = lines.clone();
            out.remove(at);
            (format!("delete-line-{at}"), out.join("\n") + "\n")
        }
        5 => {
            let at = below(rng, lines.len());
            let mut out: Vec<&str> = lines.clone();
            out.insert(at, lines[at]);
            (format!("duplicate-line-{at}"), out.join("\n") + "\n")
        }
        6 => {
            // A light's name or spec made hostile.
            let value = HOSTILE[below(rng, HOSTILE.len())];
            let field = if rng.next_u64().is_multiple_of(2) {
                "name"
            } else {
                "spec"
            };
            let text = base.replacen(&format!("{field} = "), &format!("{field} = {value}\n#"), 1);
            (format!("light-{field}-{value}"), text)
        }
        7 => {
            let mut b = base.as_bytes().to_vec();
            let at = below(rng, b.len());
            b[at] = rng.next_u64() as u8;
            (
                format!("byte-{at}"),
                String::from_utf8_lossy(&b).into_owned(),
            )
        }
        8 => {
            let at = below(rng, base.len());
            let cut = (0..=at)
                .rev()
                .find(|&i| base.is_char_boundary(i))
                .unwrap_or(0);
            (format!("truncate-{cut}"), base[..cut].to_string())
        }
        _ => {
            // Light specs with hostile parts.
            let spec = [
                "sun:0,0,0",
                "point:1e308,0,0:1,1,1:1e308",
                "sun:1,1,1:-1,0,0",
                "point:nan,0,0",
                "sun:1,1,1:1,1,1:inf",
                "laser:1,1,1",
                "sun",
                "sun:1,1,1:1,1,1:1:1",
            ][below(rng, 8)];
            (
                format!("spec-{spec}"),
                base.replacen(
                    "spec = \"sun:0.6,1,0:1,0.95,0.85:6\"",
                    &format!("spec = \"{spec}\""),
                    1,
                ),
            )
        }
    }
}

#[derive(Debug)]
enum Outcome {
    Ok,
    Err,
    Bad(String),
}

fn run_scene(dir: &Path, scene: &Path) -> Outcome {
    let out = dir.join("out.exr");
    let _ = std::fs::remove_file(&out);
    let err_path = scene.with_extension("err");
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v {MEMORY_LIMIT_KIB} || exit 99; exec \"$0\" \"$@\""
        ))
        .arg(env!("CARGO_BIN_EXE_murk"))
        .arg("render")
        .arg(scene)
        .args(["--quiet", "--threads", "2"])
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&err_path).unwrap())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            return Outcome::Bad(format!("hang (killed after {TIMEOUT:?})"));
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let err = std::fs::read_to_string(&err_path).unwrap_or_default();
    let first = err.lines().next().unwrap_or("").to_string();
    match status.code() {
        Some(0) if err.contains("panicked") => {
            Outcome::Bad(format!("exit 0 with a panic: {first}"))
        }
        Some(0) => Outcome::Ok,
        Some(2) => {
            let body = err.strip_suffix('\n').unwrap_or(&err);
            if body.contains('\n') || !body.starts_with("murk: error: ") {
                return Outcome::Bad(format!("exit 2 but not one `murk: error:` line: {err:?}"));
            }
            if body.contains('\u{1b}') {
                return Outcome::Bad(format!("raw escape in the message: {body:?}"));
            }
            // Names the scene, or a file the scene names (its input, an output).
            let scene_name = scene.file_name().unwrap().to_string_lossy().into_owned();
            if !(body.contains(&scene_name)
                || body.contains(".vdb")
                || body.contains(".exr")
                || body.contains(".png")
                || body.contains(".json")
                || body.contains("/dev/zero")
                || body.contains(": ") && body.contains(&dir.display().to_string()))
            {
                return Outcome::Bad(format!("exit 2 naming no file: {body:?}"));
            }
            Outcome::Err
        }
        Some(99) => panic!("`ulimit -v` is not available in sh"),
        Some(c) => Outcome::Bad(format!("exit {c}: {first}")),
        None => Outcome::Bad(format!("signal: {status:?}: {first}")),
    }
}

fn run(tag: &str, total: usize, seed: u64) {
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("mutation-scenes-{tag}"));
    let _ = std::fs::remove_dir_all(&root);
    let cloud =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/cloud.vdb")).unwrap();
    let mut rng = SplitMix64(seed);
    let scenes: Vec<(String, String)> = (0..total)
        .map(|i| {
            let base = base_scene(1 + i % 3);
            let (name, text) = mutate(&mut rng, &base);
            (format!("{i:05}-{name}"), text)
        })
        .collect();
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<(usize, Outcome)>> = Mutex::new(Vec::new());
    let started = Instant::now();
    std::thread::scope(|s| {
        for w in 0..WORKERS {
            let (root, cloud, scenes, next, results) = (&root, &cloud, &scenes, &next, &results);
            s.spawn(move || {
                // One folder per worker: the scene's relative paths point into it.
                let dir: PathBuf = root.join(format!("w{w}"));
                std::fs::create_dir_all(&dir).unwrap();
                std::fs::write(dir.join("c.vdb"), cloud).unwrap();
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some((_, text)) = scenes.get(i) else {
                        break;
                    };
                    let scene = dir.join("s.toml");
                    std::fs::write(&scene, text).unwrap();
                    let outcome = run_scene(&dir, &scene);
                    // The scene and the input are never overwritten.
                    let outcome = if std::fs::read(dir.join("c.vdb")).unwrap() != *cloud {
                        std::fs::write(dir.join("c.vdb"), cloud).unwrap();
                        Outcome::Bad("the input was overwritten".into())
                    } else if std::fs::read_to_string(&scene).unwrap() != *text {
                        Outcome::Bad("the scene was overwritten".into())
                    } else {
                        outcome
                    };
                    results.lock().unwrap().push((i, outcome));
                }
            });
        }
    });
    let results = results.into_inner().unwrap();
    let (mut ok, mut err) = (0, 0);
    let mut bad = Vec::new();
    for (i, o) in &results {
        match o {
            Outcome::Ok => ok += 1,
            Outcome::Err => err += 1,
            Outcome::Bad(why) => bad.push(format!("{}: {why}\n{}", scenes[*i].0, scenes[*i].1)),
        }
    }
    println!(
        "scene mutation ({tag}): {} scenes in {:.1} s: {ok} clean Ok, {err} clean Err, {} bad",
        results.len(),
        started.elapsed().as_secs_f64(),
        bad.len()
    );
    assert_eq!(results.len(), total);
    assert!(
        bad.is_empty(),
        "{} bad:\n{}",
        bad.len(),
        bad.iter().take(20).cloned().collect::<Vec<_>>().join("\n")
    );
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn mutated_scenes_end_cleanly() {
    run("default", DEFAULT_SCENES, 0x5ce7e);
}

#[test]
#[ignore = "long: thousands of scene renders; run with --ignored"]
fn mutated_scenes_end_cleanly_long() {
    run("long", LONG_SCENES, 0x1000_5ce7e);
}
