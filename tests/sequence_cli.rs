//! Frame sequences, pieces and the farm, end to end through the `murk` binary, on the
//! four-frame cache `fixtures/seq/fluid_0001..0004.vdb` (scripts/make_fixtures.py: frames
//! 1 and 2 hold the same grid, then the blob rises and grows). Images are compared
//! exactly, by OpenImageIO's `idiff -fail 0` and sample by sample with the `exr` crate.
//! The farm test runs the generated job with `openjd` (openjd-cli, in /opt/murk-venv
//! from .ci/run, or MURK_OPENJD) and compares its frames with direct renders.

mod common;
use common::exrheader;

use exr::prelude::{FlatSamples, read_all_flat_layers_from_file};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const MURK: &str = env!("CARGO_BIN_EXE_murk");
/// Small and quick; jittered samples (spp 3) so the per-pixel random streams matter.
const LOOK: [&str; 8] = [
    "--res",
    "48x36",
    "--spp",
    "3",
    "--light",
    "point:0.3,1.5,0.5",
    "--ground",
    "-0.6",
];

fn seq(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/seq")
        .join(name)
}

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("sequence_cli-{name}"));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

fn murk(dir: &Path, args: &[&str]) -> Output {
    Command::new(MURK)
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

fn ok(dir: &Path, args: &[&str]) -> String {
    let out = murk(dir, args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "murk {}: {err}", args.join(" "));
    err
}

/// A bad-input case: exit code 2 and one line naming `needle`.
fn refused(dir: &Path, args: &[&str], needle: &str) {
    let out = murk(dir, args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "murk {}: {err}", args.join(" "));
    assert_eq!(
        err.lines().count(),
        1,
        "murk {}: not one line: {err}",
        args.join(" ")
    );
    assert!(
        err.contains(needle),
        "murk {}: {err} (wanted {needle})",
        args.join(" ")
    );
    assert!(!err.contains("panicked"), "{err}");
}

/// A direct, one-file render of frame `frame`.
fn direct(dir: &Path, frame: u32) -> PathBuf {
    let out = dir.join(format!("direct_{frame}.exr"));
    let input = seq(&format!("fluid_{frame:04}.vdb"));
    let mut args = vec![
        "render",
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--quiet",
    ];
    args.extend(LOOK);
    ok(dir, &args);
    out
}

/// The two images are the same: idiff with no tolerance, and every sample, channel,
/// storage type and window equal as read by the `exr` crate.
fn same_image(a: &Path, b: &Path) {
    let out = Command::new("idiff")
        .args(["-fail", "0", "-warn", "0"])
        .args([a, b])
        .output()
        .expect("idiff (Debian openimageio-tools) is required");
    assert!(
        out.status.success(),
        "idiff {} {}: {}",
        a.display(),
        b.display(),
        String::from_utf8_lossy(&out.stdout)
    );
    let (ia, ib) = (
        read_all_flat_layers_from_file(a).unwrap(),
        read_all_flat_layers_from_file(b).unwrap(),
    );
    assert_eq!(ia.attributes.display_window, ib.attributes.display_window);
    let (la, lb) = (&ia.layer_data[0], &ib.layer_data[0]);
    assert_eq!(la.size, lb.size, "{} {}", a.display(), b.display());
    assert_eq!(la.attributes.layer_position, lb.attributes.layer_position);
    assert_eq!(la.channel_data.list.len(), lb.channel_data.list.len());
    for (ca, cb) in la.channel_data.list.iter().zip(&lb.channel_data.list) {
        assert_eq!(ca.name, cb.name);
        let bits = |s: &FlatSamples| -> Vec<u32> {
            match s {
                FlatSamples::F16(v) => v.iter().map(|h| h.to_bits() as u32 | 1 << 31).collect(),
                FlatSamples::F32(v) => v.iter().map(|f| f.to_bits()).collect(),
                FlatSamples::U32(v) => v.clone(),
            }
        };
        assert!(
            bits(&ca.sample_data) == bits(&cb.sample_data),
            "channel {} differs: {} {}",
            ca.name,
            a.display(),
            b.display()
        );
    }
}

fn differs(a: &Path, b: &Path) -> bool {
    !Command::new("idiff")
        .args(["-fail", "0", "-warn", "0", "-q"])
        .args([a, b])
        .status()
        .unwrap()
        .success()
}

#[test]
fn every_pattern_style_renders_the_sequence_as_direct_renders() {
    let dir = scratch("styles");
    let styles = [
        ("fluid_####.vdb", "a_####.exr", "a_{:04}.exr"),
        ("fluid_%04d.vdb", "b_%04d.exr", "b_{:04}.exr"),
        ("fluid_$F4.vdb", "c_$F.exr", "c_{}.exr"),
    ];
    for (input, output, _) in styles {
        let input = seq(input);
        let mut args = vec![input.to_str().unwrap(), "-o", output, "--quiet"];
        args.extend(LOOK);
        if output.starts_with('a') {
            args.extend(["--stats", "a_####.json"]);
        }
        ok(
            &dir,
            &["render"].iter().chain(&args).copied().collect::<Vec<_>>(),
        );
    }
    let name = |pat: &str, f: u32| {
        if pat.contains("{:04}") {
            pat.replace("{:04}", &format!("{f:04}"))
        } else {
            pat.replace("{}", &f.to_string())
        }
    };
    for f in 1..=4u32 {
        let want = direct(&dir, f);
        for (_, _, got) in styles {
            same_image(&want, &dir.join(name(got, f)));
        }
        let header = exrheader(&dir.join(name("a_{:04}.exr", f)));
        assert!(
            header.contains(&format!("murk/frame (type string): \"{f}\"")),
            "{header}"
        );
    }
    // The frames are the frames: 1 and 2 hold the same grid, 3 does not.
    assert!(!differs(&dir.join("a_0001.exr"), &dir.join("a_0002.exr")));
    assert!(differs(&dir.join("a_0002.exr"), &dir.join("a_0003.exr")));
    // Frame 2's shadow map is frame 1's (same density hash); frame 3's is baked.
    let source = |f: u32| {
        let st: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(dir.join(format!("a_{f:04}.json"))).unwrap())
                .unwrap();
        st["shadow_maps"][0]["source"].as_str().unwrap().to_string()
    };
    assert_eq!(source(1), "baked");
    assert!(source(2).starts_with("reused"), "{}", source(2));
    assert_eq!(source(3), "baked");
}

#[test]
fn a_missing_or_unreadable_frame_is_one_line_and_the_others_are_written() {
    let dir = scratch("missing");
    let cache = dir.join("cache");
    fs::create_dir(&cache).unwrap();
    for f in [1, 2, 4] {
        fs::copy(
            seq(&format!("fluid_{f:04}.vdb")),
            cache.join(format!("fluid_{f:04}.vdb")),
        )
        .unwrap();
    }
    fs::write(cache.join("fluid_0003.vdb"), b"not a vdb at all").unwrap();
    let mut args = vec![
        "render",
        "cache/fluid_####.vdb",
        "--frames",
        "1-5",
        "-o",
        "out_####.exr",
        "--quiet",
    ];
    args.extend(LOOK);
    let out = murk(&dir, &args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    let lines: Vec<&str> = err.lines().collect();
    let frame_line = |f: u32| {
        lines
            .iter()
            .filter(|l| l.contains(&format!("frame {f}:")))
            .count()
    };
    assert_eq!(frame_line(3), 1, "{err}");
    assert_eq!(frame_line(5), 1, "{err}");
    assert!(
        err.contains("fluid_0005.vdb") && err.contains("fluid_0003.vdb"),
        "{err}"
    );
    assert!(
        lines
            .iter()
            .any(|l| l.contains("2 of 5 frames failed: 3,5")),
        "{err}"
    );
    for f in [1, 2, 4] {
        same_image(&direct(&dir, f), &dir.join(format!("out_{f:04}.exr")));
    }
    for f in [3, 5] {
        assert!(!dir.join(format!("out_{f:04}.exr")).exists());
    }
    let left: Vec<_> = fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().contains(".tmp-"))
        .collect();
    assert!(left.is_empty(), "temporaries left: {left:?}");
}

#[test]
fn skip_existing_resumes_a_killed_run() {
    let dir = scratch("resume");
    let input = seq("fluid_####.vdb");
    let mut args = vec![
        "render",
        input.to_str().unwrap(),
        "-o",
        "r_####.exr",
        "--quiet",
    ];
    // A real kill: a slower version of the same sequence, killed once frame 1 is out.
    let mut slow = args.clone();
    slow.extend(["--spp", "16", "--res", "128x96"]);
    args.extend(LOOK);
    let mut child = Command::new(MURK)
        .current_dir(&dir)
        .args(&slow)
        .spawn()
        .unwrap();
    let t = std::time::Instant::now();
    while !dir.join("r_0001.exr").exists() && t.elapsed().as_secs() < 120 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    // What a killed writer leaves: a temporary of frame 2 (murk's own naming, of a
    // process that no longer runs), and a frame 3 cut short (another tool's copy).
    fs::write(dir.join(".r_0002.exr.tmp-999999999-0"), b"half an EXR").unwrap();
    let whole = direct(&dir, 3);
    let bytes = fs::read(&whole).unwrap();
    fs::write(dir.join("r_0003.exr"), &bytes[..bytes.len() / 2]).unwrap();
    // Frame 4 is complete already (whatever its pixels): it must stay as it is.
    fs::copy(&whole, dir.join("r_0004.exr")).unwrap();
    let before = |f: u32| fs::read(dir.join(format!("r_{f:04}.exr"))).ok();
    let (one, four) = (before(1), before(4));
    let mut resume = args.clone();
    resume.retain(|a| *a != "--quiet");
    resume.push("--skip-existing");
    let err = ok(&dir, &resume);
    assert!(err.contains("frame 1:") && err.contains("skipped"), "{err}");
    assert!(err.contains("2 skipped"), "{err}");
    assert_eq!(before(1), one, "frame 1 was rewritten");
    assert_eq!(before(4), four, "frame 4 was rewritten");
    for f in [2, 3] {
        same_image(&direct(&dir, f), &dir.join(format!("r_{f:04}.exr")));
    }
    // Without --skip-existing everything is rendered again: frame 4 becomes frame 4.
    ok(&dir, &args);
    same_image(&direct(&dir, 4), &dir.join("r_0004.exr"));
}

/// Renders `pieces` pieces of frame 3 (each with one thread, in reverse order) and
/// stitches them in a shuffled order.
fn pieces_of_frame_3(dir: &Path, pieces: usize, extra: &[&str]) -> Vec<PathBuf> {
    let input = seq("fluid_0003.vdb");
    let mut paths = Vec::new();
    for i in (1..=pieces).rev() {
        let path = dir.join(format!("piece{i}of{pieces}.exr"));
        let tile = format!("{i}/{pieces}");
        let mut args = vec![
            "render",
            input.to_str().unwrap(),
            "-o",
            path.to_str().unwrap(),
            "--tile",
            &tile,
            "--threads",
            "1",
            "--quiet",
        ];
        args.extend(LOOK);
        args.extend(extra);
        ok(dir, &args);
        paths.push(path);
    }
    paths.rotate_left(pieces / 2);
    paths
}

#[test]
fn stitched_pieces_equal_the_one_piece_render() {
    let dir = scratch("stitch");
    for (pieces, extra) in [(1, &[][..]), (3, &[][..]), (5, &["--float"][..])] {
        let paths = pieces_of_frame_3(&dir, pieces, extra);
        let header = exrheader(&paths[0]);
        assert!(header.contains("murk/tile (type string)"), "{header}");
        assert!(header.contains("fluid_0003.vdb"), "{header}");
        let full = dir.join(format!("stitched{pieces}.exr"));
        let mut args = vec!["stitch"];
        args.extend(paths.iter().map(|p| p.to_str().unwrap()));
        args.extend(["-o", full.to_str().unwrap()]);
        ok(&dir, &args);
        let one = dir.join(format!("one{pieces}.exr"));
        let input = seq("fluid_0003.vdb");
        let mut args = vec![
            "render",
            input.to_str().unwrap(),
            "-o",
            one.to_str().unwrap(),
            "--threads",
            "2",
            "--quiet",
        ];
        args.extend(LOOK);
        args.extend(extra);
        ok(&dir, &args);
        same_image(&one, &full);
        if pieces > 1 {
            // A piece alone is not the frame: its other rows are empty.
            assert!(differs(&one, &paths[0]));
        }
        let stitched = exrheader(&full);
        assert!(!stitched.contains("murk/tile"), "{stitched}");
    }
    // Pieces of a frame of a sequence, found through --frame.
    let input = seq("fluid_####.vdb");
    for i in 1..=2 {
        let tile = format!("{i}/2");
        let out = format!("s_####.p{i}.exr");
        let mut args = vec![
            "render",
            input.to_str().unwrap(),
            "--frames",
            "3",
            "--tile",
            &tile,
        ];
        args.extend(["-o", &out, "--quiet"]);
        args.extend(LOOK);
        ok(&dir, &args);
    }
    ok(
        &dir,
        &[
            "stitch",
            "--frame",
            "3",
            "s_####.p2.exr",
            "s_####.p1.exr",
            "-o",
            "s_####.exr",
        ],
    );
    same_image(&direct(&dir, 3), &dir.join("s_0003.exr"));
}

#[test]
fn bad_pieces_and_sequences_are_one_line_and_exit_2() {
    let dir = scratch("bad");
    let three = pieces_of_frame_3(&dir, 3, &[]);
    let p = |i: usize| dir.join(format!("piece{i}of3.exr"));
    let s = |p: &PathBuf| p.to_str().unwrap().to_string();
    assert_eq!(three.len(), 3);
    let other = dir.join("other.exr");
    let input4 = seq("fluid_0004.vdb");
    let mut args = vec![
        "render",
        input4.to_str().unwrap(),
        "-o",
        "other.exr",
        "--tile",
        "3/3",
        "--quiet",
    ];
    args.extend(LOOK);
    ok(&dir, &args);
    let input3 = seq("fluid_0003.vdb");
    let mut args = vec![
        "render",
        input3.to_str().unwrap(),
        "-o",
        "small.exr",
        "--tile",
        "3/3",
        "--quiet",
    ];
    args.extend(["--res", "48x30"]);
    ok(&dir, &args);
    let stitch = |pieces: Vec<String>, needle: &str| {
        let mut args: Vec<String> = vec!["stitch".into()];
        args.extend(pieces);
        args.extend(["-o".into(), "x.exr".into()]);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        refused(&dir, &args, needle);
        assert!(!dir.join("x.exr").exists());
    };
    stitch(vec![s(&p(1)), s(&p(2))], "missing piece 3/3");
    stitch(
        vec![s(&p(1)), s(&p(2)), s(&p(2)), s(&p(3))],
        "both are piece 2/3",
    );
    stitch(vec![s(&p(1)), s(&p(2)), s(&other)], "another frame");
    stitch(
        vec![s(&p(1)), s(&p(2)), s(&dir.join("small.exr"))],
        "different sizes",
    );
    stitch(vec![s(&direct(&dir, 1))], "not a piece");
    stitch(vec![s(&dir.join("nothing.exr"))], "nothing.exr");
    let input = seq("fluid_####.vdb");
    let i = input.to_str().unwrap();
    let none = seq("none_####.vdb");
    let one = seq("fluid_0001.vdb");
    let cases: [(&[&str], &str); 10] = [
        (
            &["render", none.to_str().unwrap(), "-o", "o_####.exr"],
            "matches no file",
        ),
        (
            &["render", "cache/none_####.vdb", "-o", "o_####.exr"],
            "cannot list cache",
        ),
        (
            &["render", i, "--frames", "4-1", "-o", "o_####.exr"],
            "reversed",
        ),
        (
            &["render", i, "--frames", "1-3,2-4", "-o", "o_####.exr"],
            "named twice",
        ),
        (
            &["render", i, "--frames", "1-4x0", "-o", "o_####.exr"],
            "step is 0",
        ),
        (&["render", i, "-o", "o.exr"], "put a frame pattern"),
        (
            &["render", i, "-o", "o_####.exr", "--preview", "o.png"],
            "--preview o.png",
        ),
        (
            &["render", i, "--tile", "0/3", "-o", "o_####.exr"],
            "--tile 0/3",
        ),
        (
            &["render", i, "--tile", "4/3", "-o", "o_####.exr"],
            "--tile 4/3",
        ),
        (
            &[
                "render",
                one.to_str().unwrap(),
                "--tile",
                "40/40",
                "--res",
                "48x36",
                "-o",
                "o.exr",
            ],
            "more pieces than",
        ),
    ];
    for (args, needle) in cases {
        refused(&dir, args, needle);
    }
    assert!(!dir.join("o_0001.exr").exists());
}

#[test]
fn a_scene_file_may_hold_the_frames() {
    let dir = scratch("scene");
    let scene = dir.join("shot.toml");
    fs::write(
        &scene,
        format!(
            "input = \"{}\"\noutput = \"shot_####.exr\"\nframes = \"2-4x2\"\nres = \"48x36\"\nspp = 3\nlight = [\"point:0.3,1.5,0.5\"]\nground = -0.6\n",
            seq("fluid_####.vdb").display()
        ),
    )
    .unwrap();
    ok(&dir, &["render", "shot.toml", "--quiet"]);
    let written: Vec<bool> = (1..=4)
        .map(|f| dir.join(format!("shot_{f:04}.exr")).exists())
        .collect();
    assert_eq!(written, [false, true, false, true]);
    same_image(&direct(&dir, 4), &dir.join("shot_0004.exr"));
    // --frames overrides the scene's.
    ok(&dir, &["render", "shot.toml", "--frames", "1", "--quiet"]);
    assert!(dir.join("shot_0001.exr").exists());
}

fn openjd() -> Option<PathBuf> {
    let candidates = [
        std::env::var_os("MURK_OPENJD").map(PathBuf::from),
        Some(PathBuf::from("/opt/murk-venv/bin/openjd")),
    ];
    candidates
        .into_iter()
        .flatten()
        .find(|p| p.is_file())
        .or_else(|| {
            Command::new("openjd")
                .arg("--help")
                .output()
                .ok()
                .filter(|o| o.status.success())
                .map(|_| PathBuf::from("openjd"))
        })
}

#[test]
fn the_openjd_job_runs_and_its_frames_equal_direct_renders() {
    let Some(openjd) = openjd() else {
        eprintln!(
            "SKIPPED: openjd (openjd-cli from PyPI) not found in MURK_OPENJD, /opt/murk-venv/bin or PATH; .ci/run installs it"
        );
        return;
    };
    for tiles in ["1", "3"] {
        let dir = scratch(&format!("openjd-{tiles}"));
        // The job lives at the project's root, above the cache and the renders.
        std::os::unix::fs::symlink(seq(""), dir.join("cache")).unwrap();
        fs::create_dir(dir.join("render")).unwrap();
        let mut args = vec![
            "farm",
            "openjd",
            "cache/fluid_####.vdb",
            "--frames",
            "2-4",
            "--tiles",
            tiles,
            "-o",
            "render/fluid_####.exr",
            "--job",
            "job.yaml",
        ];
        args.extend(LOOK);
        ok(&dir, &args);
        let job: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(dir.join("job.yaml")).unwrap()).unwrap();
        assert_eq!(job["specificationVersion"], "jobtemplate-2023-09");
        let steps = job["steps"].as_array().unwrap();
        assert_eq!(steps[0]["name"], "Render");
        assert_eq!(steps[1]["name"], "Stitch");
        assert_eq!(steps[1]["dependencies"][0]["dependsOn"], "Render");
        let run = |args: &[&str]| {
            // From elsewhere: the defaults are relative to the template's folder.
            let out = Command::new(&openjd)
                .current_dir(std::env::temp_dir())
                .args(args)
                .output()
                .unwrap();
            assert!(
                out.status.success(),
                "openjd {}: {}{}",
                args.join(" "),
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
        };
        let job_path = dir.join("job.yaml");
        let j = job_path.to_str().unwrap();
        run(&["check", j]);
        run(&["run", j, "--step", "Stitch", "--run-dependencies"]);
        for f in 2..=4 {
            same_image(
                &direct(&dir, f),
                &dir.join(format!("render/fluid_{f:04}.exr")),
            );
        }
        assert!(!dir.join("render/fluid_0001.exr").exists());
    }
}

#[test]
fn farm_refuses_what_it_cannot_express() {
    let dir = scratch("farm-bad");
    let input = seq("fluid_####.vdb");
    let i = input.to_str().unwrap();
    refused(
        &dir,
        &[
            "farm",
            "openjd",
            i,
            "--frames",
            "1-2",
            "-o",
            "o_####.exr",
            "--job",
            "job.yaml",
        ],
        "outside",
    );
    std::os::unix::fs::symlink(seq(""), dir.join("cache")).unwrap();
    let base = [
        "farm",
        "openjd",
        "cache/fluid_####.vdb",
        "--job",
        "job.yaml",
    ];
    let cases: [(&[&str], &str); 4] = [
        (&["--frames", "1-2", "-o", "o.exr"], "put a frame pattern"),
        (&["--frames", "2-1", "-o", "o_####.exr"], "reversed"),
        (
            &["--frames", "1-2", "-o", "o_####.exr", "--tile", "1/2"],
            "--tiles",
        ),
        (
            &["--frames", "1-2", "-o", "o_####.exr", "--tiles", "0"],
            "--tiles 0",
        ),
    ];
    for (extra, needle) in cases {
        let args: Vec<&str> = base.iter().chain(extra).copied().collect();
        refused(&dir, &args, needle);
    }
    assert!(!dir.join("job.yaml").exists());
}
