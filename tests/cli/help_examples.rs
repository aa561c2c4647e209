//! Every example in `--help` runs, in order, and the help states every default.

use super::*;

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
