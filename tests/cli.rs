//! The command line as a user meets it: every example in `--help` runs, and bad
//! input ends in exit code 2 with one line `murk: error: ...` on stderr, no
//! panic, and nothing left in the output directory.

use std::collections::BTreeSet;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use exr::prelude::read_all_flat_layers_from_file;
use serde_json::Value;

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

// ------------------------------------------------------------------------------------
// 5. The examples in --help.

fn help(sub: &str) -> String {
    let out = murk(root(), &[sub.to_owned(), "--help".to_owned()]);
    assert!(
        out.status.success(),
        "murk {sub} --help failed: {}",
        out.status
    );
    String::from_utf8(out.stdout).unwrap()
}

const OUTPUT_FLAGS: [&str; 4] = ["-o", "--output", "--preview", "--stats"];

/// Checks a file an example wrote.
fn check_output(path: &Path, example: &str) {
    let len = fs::metadata(path)
        .unwrap_or_else(|e| panic!("`{example}` did not write {}: {e}", path.display()))
        .len();
    assert!(len > 0, "`{example}` wrote an empty {}", path.display());
    match path.extension().and_then(|e| e.to_str()) {
        Some("exr") => {
            let image = read_all_flat_layers_from_file(path)
                .unwrap_or_else(|e| panic!("`{example}`: {} unreadable: {e}", path.display()));
            let names: BTreeSet<String> = image.layer_data[0]
                .channel_data
                .list
                .iter()
                .map(|c| c.name.to_string())
                .collect();
            for c in ["R", "G", "B", "A", "Z"] {
                assert!(names.contains(c), "`{example}`: no {c} in {names:?}");
            }
        }
        Some("png") => {
            image::open(path)
                .unwrap_or_else(|e| panic!("`{example}`: {} unreadable: {e}", path.display()));
        }
        Some("json") => {
            let text = fs::read_to_string(path).unwrap();
            serde_json::from_str::<Value>(&text)
                .unwrap_or_else(|e| panic!("`{example}`: {} is not JSON: {e}", path.display()));
        }
        _ => {}
    }
}

#[test]
fn render_help_examples_run() {
    let text = help("render");
    let out_dir = scratch("examples-render");
    // Where the outputs would have gone unredirected: they must not appear there.
    let mut elsewhere = Vec::new();
    for (n, example) in examples(&text).into_iter().enumerate() {
        let shown = format!("murk {}", example.join(" "));
        assert_eq!(example[0], "render", "`{shown}` under `murk render --help`");
        // Output paths go to the scratch directory.
        let mut args = example.clone();
        let mut outputs = Vec::new();
        let mut given = BTreeSet::new();
        for i in 1..args.len() {
            if OUTPUT_FLAGS.contains(&args[i - 1].as_str()) {
                elsewhere.push(root().join(&args[i]));
                let name = Path::new(&args[i])
                    .file_name()
                    .unwrap()
                    .to_string_lossy()
                    .into_owned();
                let path = out_dir.join(format!("{n}-{name}"));
                args[i] = path.to_str().unwrap().to_owned();
                outputs.push(path);
                given.insert(if args[i - 1] == "--output" {
                    "-o".to_owned()
                } else {
                    args[i - 1].clone()
                });
            }
        }
        // A scene file may name outputs of its own (next to it, in fixtures/): send them
        // to the scratch directory too.
        let input = &example[1];
        if input.ends_with(".toml") {
            let scene: toml::Table =
                toml::from_str(&fs::read_to_string(root().join(input)).unwrap())
                    .unwrap_or_else(|e| panic!("`{shown}`: {input} is not TOML: {e}"));
            for (key, flag) in [
                ("output", "-o"),
                ("preview", "--preview"),
                ("stats", "--stats"),
            ] {
                let Some(name) = scene.get(key).and_then(|v| v.as_str()) else {
                    continue;
                };
                if given.contains(flag) {
                    continue;
                }
                elsewhere.push(root().join(input).with_file_name(name));
                let name = Path::new(name)
                    .file_name()
                    .unwrap()
                    .to_string_lossy()
                    .into_owned();
                let path = out_dir.join(format!("{n}-scene-{name}"));
                args.push(flag.to_owned());
                args.push(path.to_str().unwrap().to_owned());
                outputs.push(path);
            }
        }
        assert!(!outputs.is_empty(), "`{shown}` writes nothing");
        let existed: Vec<bool> = elsewhere.iter().map(|p| p.exists()).collect();
        let out = murk(root(), &args);
        assert!(
            out.status.success(),
            "`{shown}` (run as murk {}) failed ({}):\n{}",
            args.join(" "),
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
        for path in &outputs {
            check_output(path, &shown);
        }
        for (path, existed) in elsewhere.drain(..).zip(existed) {
            assert!(
                existed || !path.exists(),
                "`{shown}` wrote {} despite the redirection",
                path.display()
            );
        }
    }
}

#[test]
fn info_help_examples_run() {
    let text = help("info");
    for example in examples(&text) {
        let shown = format!("murk {}", example.join(" "));
        assert_eq!(example[0], "info", "`{shown}` under `murk info --help`");
        let out = murk(root(), &example);
        assert!(
            out.status.success(),
            "`{shown}` failed ({}):\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
        let stdout = String::from_utf8(out.stdout).unwrap();
        let file = Path::new(&example[1])
            .file_name()
            .unwrap()
            .to_str()
            .unwrap();
        assert!(
            stdout.contains(file),
            "`{shown}` does not name {file}:\n{stdout}"
        );
        if example.iter().any(|a| a == "--json") {
            let doc: Value = serde_json::from_str(&stdout)
                .unwrap_or_else(|e| panic!("`{shown}`: not JSON: {e}"));
            assert!(
                !doc["grids"].as_array().unwrap().is_empty(),
                "`{shown}`: no grids"
            );
        }
    }
}

// ------------------------------------------------------------------------------------
// 6. Bad input.

/// Runs `murk render <input> <flags> -o OUT/x.exr --preview OUT/x.png --stats OUT/x.json`
/// (outputs may be replaced in `flags`) and checks it fails cleanly: exit code 2, one
/// stderr line starting `murk: error:` that contains every `needle` (case-insensitive),
/// no panic, and OUT still empty. Returns the message.
fn fails(name: &str, input: &str, flags: &[&str], needles: &[&str]) -> String {
    let dir = scratch(name);
    let out_dir = dir.join("out");
    fs::create_dir(&out_dir).unwrap();
    let o = |f: &str| out_dir.join(f).to_str().unwrap().to_owned();
    let mut args = vec!["render".to_owned(), input.to_owned()];
    let flags: Vec<String> = flags
        .iter()
        .map(|f| f.replace("OUT", out_dir.to_str().unwrap()))
        .collect();
    for (flag, file) in [
        ("-o", "x.exr"),
        ("--preview", "x.png"),
        ("--stats", "x.json"),
    ] {
        if !flags.iter().any(|f| f == flag) {
            args.push(flag.to_owned());
            args.push(o(file));
        }
    }
    if !flags.iter().any(|f| f == "--res") {
        args.extend(["--res".to_owned(), "32x18".to_owned()]);
    }
    args.extend(flags);
    let out = murk(&dir, &args);
    let shown = format!("murk {}", args.join(" "));
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(
        !stderr.contains("panicked"),
        "`{shown}` panicked:\n{stderr}"
    );
    assert_eq!(
        out.status.code(),
        Some(2),
        "`{shown}`: exit status {}; stderr:\n{stderr}",
        out.status
    );
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(
        lines.len(),
        1,
        "`{shown}`: stderr is not one line:\n{stderr}"
    );
    let msg = lines[0];
    assert!(msg.starts_with("murk: error: "), "`{shown}`: {msg}");
    for needle in needles {
        assert!(
            msg.to_lowercase().contains(&needle.to_lowercase()),
            "`{shown}`: the message does not mention `{needle}`: {msg}"
        );
    }
    let left = listing(&out_dir);
    assert!(
        left.is_empty(),
        "`{shown}` failed but left {left:?} in the output directory ({msg})"
    );
    msg.to_owned()
}

#[test]
fn missing_input_file() {
    fails(
        "missing",
        "/nonexistent-murk-input/none.vdb",
        &[],
        &["none.vdb", "no such file"],
    );
}

#[test]
fn input_is_a_directory() {
    let dir = scratch("input-dir-src");
    fails(
        "input-dir",
        dir.to_str().unwrap(),
        &[],
        &[dir.to_str().unwrap(), "directory"],
    );
}

#[test]
fn input_is_not_a_vdb_file() {
    let dir = scratch("not-vdb-src");
    let file = dir.join("notes.vdb");
    fs::write(&file, "these are not voxels\n").unwrap();
    fails(
        "not-vdb",
        file.to_str().unwrap(),
        &[],
        &["notes.vdb", "not a VDB"],
    );
    let file = dir.join("tiny.vdb");
    fs::write(&file, [0x20, 0x42]).unwrap();
    fails("not-vdb-tiny", file.to_str().unwrap(), &[], &["tiny.vdb"]);
}

#[test]
fn unknown_density_grid_lists_the_grids() {
    fails(
        "density-grid",
        &fixture("pyro.vdb"),
        &["--density-grid", "nope"],
        &["nope", "density", "temperature", "flame", "vel", "Cd"],
    );
}

#[test]
fn zero_resolution() {
    fails(
        "res",
        &fixture("cloud.vdb"),
        &["--res", "0x10"],
        &["--res", "0x10"],
    );
}

/// A step so short the frame would never finish is refused, not left to run.
#[test]
fn march_steps_below_the_shortest_are_refused() {
    for flag in ["--step", "--shadow-step"] {
        fails(
            "tiny-step",
            &fixture("cloud.vdb"),
            &[flag, "1e-9", "--shadows", "march"],
            &[flag, "1e-9", "1/1024"],
        );
    }
}

#[test]
fn field_of_view_out_of_range() {
    fails(
        "fov",
        &fixture("cloud.vdb"),
        &["--fov", "200"],
        &["--fov", "200"],
    );
}

#[test]
fn unknown_light_type() {
    fails(
        "light",
        &fixture("cloud.vdb"),
        &["--light", "spot:1,2,3"],
        &["spot"],
    );
}

#[test]
fn unknown_shadow_mode() {
    fails(
        "shadows",
        &fixture("cloud.vdb"),
        &["--shadows", "foo"],
        &["--shadows", "foo"],
    );
}

#[test]
fn unknown_compression() {
    fails(
        "compression",
        &fixture("cloud.vdb"),
        &["--compression", "foo"],
        &["compression", "foo"],
    );
}

/// An output under a regular file (no folder can be made there, even as root).
fn under_a_file(output: &str) -> String {
    format!("{}/missing/{output}", fixture("cloud.vdb"))
}

/// A place that cannot be written is found before the render (the output folder stays
/// empty, the message is one line), whichever output it is.
#[test]
fn outputs_where_no_folder_can_be_made_fail_before_the_render() {
    for (flag, file) in [
        ("-o", "x.exr"),
        ("--preview", "x.png"),
        ("--stats", "x.json"),
    ] {
        let place = under_a_file(file);
        fails(
            &format!("place{flag}"),
            &fixture("cloud.vdb"),
            &[flag, &place],
            &[&format!("missing/{file}"), "cannot create the folder"],
        );
    }
}

/// Missing output folders are made, for every output.
#[test]
fn outputs_into_missing_folders_are_made() {
    let dir = scratch("new-folders");
    let args: Vec<String> = [
        "render",
        &fixture("cloud.vdb"),
        "-o",
        "seqA/x.exr",
        "--preview",
        "png/a/x.png",
        "--stats",
        "json/b/c/x.json",
        "--res",
        "32x18",
        "--quiet",
    ]
    .map(String::from)
    .to_vec();
    let out = murk(&dir, &args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for f in ["seqA/x.exr", "png/a/x.png", "json/b/c/x.json"] {
        assert!(dir.join(f).is_file(), "{f}");
    }
}

/// `-o` names an OpenEXR and `--preview` a PNG: another extension is refused with the
/// name that works (an EXR was silently written as out.png).
#[test]
fn outputs_named_for_another_format_are_refused() {
    fails(
        "o-png",
        &fixture("cloud.vdb"),
        &["-o", "OUT/out.png"],
        &["-o", "out.png", "OpenEXR", "out.exr", "--preview"],
    );
    fails(
        "preview-exr",
        &fixture("cloud.vdb"),
        &["--preview", "OUT/p.exr"],
        &["--preview", "p.exr", "PNG", "p.png"],
    );
}

/// A negative value for a triple is the value's error, not "unexpected argument '-1'";
/// a misspelt flag gets clap's suggestion.
#[test]
fn flag_values_and_names_get_what_to_write() {
    let msg = fails(
        "sigma-negative",
        &fixture("cloud.vdb"),
        &["--sigma-s", "-1,2,2"],
        &["--sigma-s", "negative"],
    );
    assert!(!msg.contains("unexpected argument"), "{msg}");
    fails(
        "preveiw",
        &fixture("cloud.vdb"),
        &["--preveiw", "OUT/y.png"],
        &["--preveiw", "did you mean '--preview'?"],
    );
}

#[test]
fn scene_file_with_an_unknown_key() {
    let dir = scratch("bad-scene-src");
    let scene = dir.join("scene.toml");
    fs::write(
        &scene,
        format!("input = \"{}\"\ncolour = \"red\"\n", fixture("cloud.vdb")),
    )
    .unwrap();
    fails(
        "bad-scene",
        scene.to_str().unwrap(),
        &[],
        &[
            "scene.toml: line 2, `colour = \"red\"`",
            "did you mean `color_grid`?",
        ],
    );
    // `[[light]]` (the key is a list of strings) gets the syntax, not serde's words.
    fs::write(
        &scene,
        format!(
            "input = \"{}\"\n[[light]]\nspec = \"sun:1,1,1\"\n",
            fixture("cloud.vdb")
        ),
    )
    .unwrap();
    fails(
        "bad-scene-light",
        scene.to_str().unwrap(),
        &[],
        &["line 2, `[[light]]`", "light = [\"sun:", "[[lights]]"],
    );
}

/// A scene's relative shadow cache is read from the scene's folder, like its input,
/// and named so in errors.
#[test]
fn a_scene_s_relative_shadow_cache_is_the_scene_folder_s() {
    let dir = scratch("scene-cache");
    fs::create_dir(dir.join("shot")).unwrap();
    fs::copy(fixture("cloud.vdb"), dir.join("shot/cloud.vdb")).unwrap();
    fs::write(
        dir.join("shot/scene.toml"),
        "input = \"cloud.vdb\"\nshadow_cache = \"shadows.vdb\"\nres = \"32x18\"\n",
    )
    .unwrap();
    let run = |args: &[&str]| {
        murk(
            &dir,
            &args.iter().map(|a| a.to_string()).collect::<Vec<_>>(),
        )
    };
    let out = run(&["render", "shot/scene.toml", "-o", "x.exr", "--quiet"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("shot/shadows.vdb"), "{err}");
    let bake = run(&[
        "bake-shadows",
        "shot/cloud.vdb",
        "-o",
        "shot/shadows.vdb",
        "--quiet",
    ]);
    assert!(
        bake.status.success(),
        "{}",
        String::from_utf8_lossy(&bake.stderr)
    );
    let out = run(&["render", "shot/scene.toml", "-o", "x.exr", "--quiet"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn unparseable_flag_value() {
    // clap rejects it before murk's own checks: the same one-line rule applies.
    fails(
        "fov-word",
        &fixture("cloud.vdb"),
        &["--fov", "wide"],
        &["--fov", "wide"],
    );
}

#[test]
fn error_messages_do_not_repeat_their_cause() {
    let place = under_a_file("x.exr");
    let msg = fails("repeat", &fixture("cloud.vdb"), &["-o", &place], &[]);
    let parts: Vec<&str> = msg.split(": ").collect();
    for pair in parts.windows(2) {
        assert_ne!(
            pair[0], pair[1],
            "the message says `{}` twice: {msg}",
            pair[0]
        );
    }
}

#[test]
fn bake_shadows_help_examples_run_in_order() {
    let text = help("bake-shadows");
    let dir = scratch("examples-bake");
    let all = examples(&text);
    assert!(all.len() >= 2, "{text}");
    for example in all {
        let shown = format!("murk {}", example.join(" "));
        let args: Vec<String> = example
            .iter()
            .map(|a| {
                if a.starts_with("fixtures/") {
                    root().join(a).to_str().unwrap().to_owned()
                } else {
                    a.clone()
                }
            })
            .collect();
        let out = murk(&dir, &args);
        assert!(
            out.status.success(),
            "`{shown}` failed ({}):\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
    }
    assert!(dir.join("shadows.vdb").is_file() && dir.join("frame1.exr").is_file());
}

#[test]
fn a_shadow_cache_for_other_lights_is_refused() {
    let dir = scratch("cache-refused");
    let cache = dir.join("shadows.vdb").to_str().unwrap().to_owned();
    let bake = murk(
        &dir,
        &[
            "bake-shadows".into(),
            fixture("cloud.vdb"),
            "-o".into(),
            cache.clone(),
            "--quiet".into(),
        ],
    );
    assert!(
        bake.status.success(),
        "{}",
        String::from_utf8_lossy(&bake.stderr)
    );
    let out = murk(
        &dir,
        &[
            "render".into(),
            fixture("cloud.vdb"),
            "-o".into(),
            "x.exr".into(),
            "--light".into(),
            "sun:1,0,0".into(),
            "--shadow-cache".into(),
            cache.clone(),
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("shadows.vdb") && err.contains("bake again"),
        "{err}"
    );
    assert!(!dir.join("x.exr").exists());
    // A render with the same light reuses it.
    let stats = dir.join("s.json");
    let out = murk(
        &dir,
        &[
            "render".into(),
            fixture("cloud.vdb"),
            "-o".into(),
            "y.exr".into(),
            "--res".into(),
            "32x18".into(),
            "--shadow-cache".into(),
            cache,
            "--stats".into(),
            stats.to_str().unwrap().into(),
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: Value = serde_json::from_str(&fs::read_to_string(&stats).unwrap()).unwrap();
    assert!(
        doc["shadow_maps"][0]["source"]
            .as_str()
            .unwrap()
            .starts_with("cache: "),
        "{doc}"
    );
}

/// `bake-shadows` takes the flags that decide a map and refuses camera and image flags
/// (they would change nothing); from a scene file it bakes the scene's named lights and
/// ignores its camera.
#[test]
fn bake_shadows_refuses_camera_flags_and_bakes_a_scene_s_lights() {
    let dir = scratch("bake-flags");
    let out = murk(
        &dir,
        &[
            "bake-shadows".into(),
            fixture("cloud.vdb"),
            "-o".into(),
            "x.vdb".into(),
            "--res".into(),
            "64x64".into(),
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--res"), "{err}");
    assert!(!dir.join("x.vdb").exists());

    let out = murk(
        &dir,
        &[
            "bake-shadows".into(),
            fixture("scene.toml"),
            "-o".into(),
            "scene.vdb".into(),
            "--stats".into(),
            "bake.json".into(),
            "--dsm-tolerance".into(),
            "5e-3".into(),
            "--quiet".into(),
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stats: Value =
        serde_json::from_str(&fs::read_to_string(dir.join("bake.json")).unwrap()).unwrap();
    let lights: Vec<&str> = stats["shadow_maps"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["light"].as_str().unwrap())
        .collect();
    assert_eq!(lights, ["key", "fill"]);
    assert!(dir.join("scene.vdb").is_file());
}

/// Every default lives in `murk::scene::plan::defaults`; the flags' help states each one,
/// so the two cannot drift apart (a changed default without its help fails here). The
/// library's own test holds every stated value to the plan; this one reads `--help` as a
/// user does, and covers the defaults that depend on other flags.
#[test]
fn help_states_every_default() {
    use murk::scene::plan::defaults as d;
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_murk"))
        .args(["render", "--help"])
        .output()
        .unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    let line = |flag: &str| {
        help.lines()
            .find(|l| l.trim_start().starts_with(&format!("{flag} ")))
            .unwrap_or_else(|| panic!("no {flag} in the help:\n{help}"))
            .to_string()
    };
    let rgb = |v: [f64; 3]| format!("{},{},{}", v[0], v[1], v[2]);
    let cases = [
        ("--res", format!("[default: {}x{}", d::RES.0, d::RES.1)),
        ("--fov", format!("[default: {}", d::FOV_DEG)),
        ("--sigma-a", format!("[default: {}", rgb([d::SIGMA_A; 3]))),
        ("--sigma-s", format!("[default: {}", rgb([d::SIGMA_S; 3]))),
        ("--density-scale", format!("[default: {}", d::DENSITY_SCALE)),
        ("--g", format!("[default: {}", d::G)),
        (
            "--emission-color",
            format!("[default: {}", rgb(d::EMISSION_COLOR)),
        ),
        (
            "--emission-intensity",
            format!("[default: {}", d::EMISSION_INTENSITY),
        ),
        ("--temperature-scale", "[default: detected".to_string()),
        (
            "--temperature-offset",
            format!("[default: {}, detected", d::TEMPERATURE_OFFSET),
        ),
        (
            "--blackbody-intensity",
            format!("[default: {}", d::BLACKBODY_INTENSITY),
        ),
        ("--light", format!("[default: {}", d::LIGHT)),
        (
            "--dsm-tolerance",
            format!("[default: {:e}", d::DSM_TOLERANCE),
        ),
        ("--step", format!("[default: {}", d::STEP)),
        ("--shadow-step", format!("[default: {}", d::SHADOW_STEP)),
        ("--termination", format!("[default: {:e}", d::TERMINATION)),
        ("--spp", format!("[default: {}", d::SPP)),
        ("--seed", format!("[default: {}", d::SEED)),
        ("--exposure", format!("[default: {}", d::EXPOSURE)),
        ("--drop-radius", format!("[default: {}", d::DROP_RADIUS_UM)),
        ("--z-empty", format!("[default: {:e}", d::Z_EMPTY)),
        ("--up-axis", "[default: auto]".to_string()),
        ("--colorspace", "[default: lin_rec709]".to_string()),
        ("--scattering", format!("[default: {}]", d::SCATTERING)),
        ("--bounces", format!("{} with path", d::PATH_BOUNCES)),
        (
            "--bounces",
            format!("[default: {} with fast", d::FAST_BOUNCES),
        ),
    ];
    for (flag, want) in cases {
        let l = line(flag);
        assert!(l.contains(&want), "{flag}: expected \"{want}\" in: {l}");
    }
}

/// A shadow map the sample budget stopped short of its tolerance is never silent: one
/// warning line on stderr, even with `--quiet`, and the same text in the stats. At the
/// default tolerance the demo cloud's map meets it and nothing is said.
#[test]
fn shadow_budget_shortfall_is_a_warning_even_when_quiet() {
    let dir = scratch("budget-warning");
    let run = |tol: &str| {
        let out = murk(
            &dir,
            &[
                "render",
                &fixture("cloud.vdb"),
                "--dsm-tolerance",
                tol,
                "-o",
                "out.exr",
                "--stats",
                "stats.json",
                "--quiet",
            ]
            .map(str::to_owned),
        );
        assert!(out.status.success(), "{out:?}");
        let stats: Value =
            serde_json::from_str(&fs::read_to_string(dir.join("stats.json")).unwrap()).unwrap();
        (String::from_utf8_lossy(&out.stderr).into_owned(), stats)
    };
    let (stderr, stats) = run("1e-4");
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 1, "{stderr}");
    let map = &stats["shadow_maps"][0];
    let stopped = map["bricks_stopped_by_budget"].as_u64().unwrap();
    assert!(stopped > 0, "{map}");
    assert!(
        lines[0].starts_with("murk: warning: shadow map of light sun0: ")
            && lines[0].contains(&format!("({stopped} stopped by the sample or work budget)")),
        "{stderr}"
    );
    assert_eq!(
        stats["warnings"][0].as_str().unwrap(),
        lines[0].trim_start_matches("murk: warning: ")
    );
    let (stderr, stats) = run("1e-3");
    assert_eq!(stderr, "");
    assert_eq!(stats["warnings"].as_array().unwrap().len(), 0);
}
