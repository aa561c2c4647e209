//! Bad input ends in exit code 2 with one line `murk: error: ...` on stderr, no panic,
//! and nothing left in the output directory.

use super::*;

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
