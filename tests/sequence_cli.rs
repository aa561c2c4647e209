//! Frame sequences and pieces, end to end through the `murk` binary, on the
//! four-frame cache `fixtures/seq/fluid_0001..0004.vdb` (scripts/make_fixtures.py: frames
//! 1 and 2 hold the same grid, then the blob rises and grows). Images are compared
//! exactly, by OpenImageIO's `idiff -fail 0` and sample by sample with the `exr` crate.
//! The farm's job template is tested in `tests/farm_openjd.rs`.

mod common;
use common::exrheader;
use common::frames::*;
use common::tools;

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

#[test]
fn every_pattern_style_renders_the_sequence_as_direct_renders() {
    need!(tools::EXRHEADER, tools::IDIFF);
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
    // Each frame's map's source, and whether it reports a bake's phases.
    let source = |f: u32| {
        let st: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(dir.join(format!("a_{f:04}.json"))).unwrap())
                .unwrap();
        let map = &st["shadow_maps"][0];
        (
            map["source"].as_str().unwrap().to_string(),
            map.get("phases").is_some(),
        )
    };
    assert_eq!(source(1), ("baked".into(), true));
    let (reused, phases) = source(2);
    assert!(reused.starts_with("reused") && !phases, "{reused}");
    assert_eq!(source(3), ("baked".into(), true));
}

#[test]
fn a_missing_or_unreadable_frame_is_one_line_and_the_others_are_written() {
    need!(tools::IDIFF);
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
    need!(tools::IDIFF);
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
    need!(tools::EXRHEADER, tools::IDIFF);
    let dir = scratch("stitch");
    let written_as = [
        "--colorspace",
        "acescg",
        "--z-empty",
        "inf",
        "--crop-data-window",
    ];
    for (pieces, extra) in [
        (1, &[][..]),
        (3, &[][..]),
        (5, &["--float"][..]),
        (2, &written_as[..]),
    ] {
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
        // The header says what the one-piece render's does: chromaticities (ACEScg's
        // with --colorspace acescg) and the data window (cropped with
        // --crop-data-window).
        let attribute = |header: &str, name: &str| -> String {
            let at = header
                .find(&format!("{name} (type"))
                .unwrap_or_else(|| panic!("no {name} in {header}"));
            header[at..].lines().take(3).collect::<Vec<_>>().join("\n")
        };
        let whole = exrheader(&one);
        for name in ["chromaticities", "dataWindow", "displayWindow"] {
            assert_eq!(attribute(&stitched, name), attribute(&whole, name));
        }
        if extra.contains(&"acescg") {
            assert!(
                attribute(&stitched, "chromaticities").contains("0.713"),
                "{stitched}"
            );
        }
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
    let one = one.to_str().unwrap();
    refused(
        &dir,
        &["converge", one, "--frames", "1-2"],
        "times one image",
    );
}

#[test]
fn a_scene_file_may_hold_the_frames() {
    need!(tools::IDIFF);
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

/// A sequence into folders that do not exist makes them; a place that cannot be written
/// is found before the first frame, in one line (it was found after every frame, a line
/// each).
#[test]
fn a_sequence_makes_its_folders_and_checks_them_first() {
    let dir = scratch("folders");
    let input = seq("fluid_####.vdb");
    let mut args = vec![
        "render",
        input.to_str().unwrap(),
        "-o",
        "seqA/fluid_####.exr",
        "--preview",
        "seqA/png/fluid_####.png",
        "--stats",
        "stats_####/s.json",
        "--quiet",
    ];
    args.extend(LOOK);
    ok(&dir, &args);
    for f in 1..=4 {
        for p in [
            format!("seqA/fluid_{f:04}.exr"),
            format!("seqA/png/fluid_{f:04}.png"),
            format!("stats_{f:04}/s.json"),
        ] {
            assert!(dir.join(&p).is_file(), "{p}");
        }
    }
    fs::write(dir.join("file"), b"x").unwrap();
    let mut args = vec![
        "render",
        input.to_str().unwrap(),
        "-o",
        "seqB/fluid_####.exr",
        "--preview",
        "file/fluid_####.png",
    ];
    args.extend(LOOK);
    refused(&dir, &args, "file/fluid_0001.png");
    assert!(!dir.join("seqB/fluid_0001.exr").exists());
}

/// `--skip-existing` leaves a frame only when all its outputs are there: a deleted
/// preview (or stats file) brings the frame back.
#[test]
fn skip_existing_brings_back_a_deleted_preview() {
    let dir = scratch("skip-preview");
    let input = seq("fluid_####.vdb");
    let mut args = vec![
        "render",
        input.to_str().unwrap(),
        "--frames",
        "1-2",
        "-o",
        "r_####.exr",
        "--preview",
        "r_####.png",
        "--stats",
        "r_####.json",
    ];
    args.extend(LOOK);
    ok(&dir, &args);
    fs::remove_file(dir.join("r_0002.png")).unwrap();
    args.push("--skip-existing");
    let err = ok(&dir, &args);
    assert!(dir.join("r_0002.png").is_file(), "{err}");
    assert!(err.contains("1 written, 1 skipped"), "{err}");
    fs::remove_file(dir.join("r_0001.json")).unwrap();
    let err = ok(&dir, &args);
    assert!(dir.join("r_0001.json").is_file(), "{err}");
    assert!(err.contains("1 written, 1 skipped"), "{err}");
}

/// `--frames` of which no input exists is refused before any render, saying which
/// frames the cache holds; another syntax gets the syntax.
#[test]
fn frames_that_do_not_exist_and_other_syntaxes_are_one_line() {
    let dir = scratch("frames-exist");
    let input = seq("fluid_####.vdb");
    let i = input.to_str().unwrap();
    refused(
        &dir,
        &["render", i, "--frames", "150-152", "-o", "o_####.exr"],
        "no file for --frames 150-152; the files found hold frames 1-4",
    );
    refused(
        &dir,
        &["render", i, "--frames", "1..3", "-o", "o_####.exr"],
        "write a range as A-B",
    );
    assert!(!dir.join("o_0001.exr").exists());
}

/// A stitch writes the whole frame's preview and removes the pieces when asked.
#[test]
fn stitch_writes_the_preview_and_removes_the_pieces() {
    let dir = scratch("stitch-preview");
    for (extra, name) in [(&[][..], "rec"), (&["--colorspace", "acescg"][..], "aces")] {
        let pieces = pieces_of_frame_3(&dir, 2, extra);
        let whole = dir.join(format!("{name}.exr"));
        let png = dir.join(format!("{name}.png"));
        let mut args = vec!["stitch"];
        args.extend(pieces.iter().map(|p| p.to_str().unwrap()));
        args.extend([
            "-o",
            whole.to_str().unwrap(),
            "--preview",
            png.to_str().unwrap(),
        ]);
        args.extend(["--exposure", "-1", "--remove-pieces"]);
        ok(&dir, &args);
        assert!(pieces.iter().all(|p| !p.exists()), "pieces left");
        let input = seq("fluid_0003.vdb");
        let direct_png = dir.join(format!("{name}-direct.png"));
        let mut args = vec![
            "render",
            input.to_str().unwrap(),
            "-o",
            "scratch.exr",
            "--preview",
            direct_png.to_str().unwrap(),
            "--exposure",
            "-1",
            "--quiet",
        ];
        args.extend(LOOK);
        args.extend(extra);
        ok(&dir, &args);
        let (a, b) = (
            image::open(&png).unwrap().to_rgba8(),
            image::open(&direct_png).unwrap().to_rgba8(),
        );
        let worst = a
            .as_raw()
            .iter()
            .zip(b.as_raw())
            .map(|(x, y)| x.abs_diff(*y))
            .max()
            .unwrap();
        // Up to the rounding of the pieces' half floats (and ACEScg's round trip).
        assert!(worst <= 1, "{name}: preview codes differ by {worst}");
    }
}
