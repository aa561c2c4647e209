//! Every command that writes a file passes it through one guard: no output replaces an
//! input (any frame of a pattern), another output, a device, a FIFO, a symbolic link, or
//! anything in a read-only folder. One test per command; each checks that what was
//! refused is left as it was. (A device node of the test's own making stands for
//! `/dev/null`, which must never be a test's target.)

mod common;
use common::frames::*;

use std::fs;
use std::os::unix::fs::{FileTypeExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::Command;

fn dir(name: &str) -> PathBuf {
    scratch(&format!("guard-{name}"))
}

fn fifo(path: &Path) {
    assert!(Command::new("mkfifo").arg(path).status().unwrap().success());
}

fn is_fifo(path: &Path) -> bool {
    fs::symlink_metadata(path).unwrap().file_type().is_fifo()
}

fn cloud() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/cloud.vdb")
        .display()
        .to_string()
}

/// A folder no one may write (mode 0555); murk refuses it by its mode even as root.
fn read_only_folder(d: &Path) -> PathBuf {
    let ro = d.join("ro");
    fs::create_dir(&ro).unwrap();
    fs::set_permissions(&ro, fs::Permissions::from_mode(0o555)).unwrap();
    ro
}

/// Copies frames 1 and 2 of the sequence fixture into `d`.
fn two_frames(d: &Path) -> Vec<u8> {
    for f in ["fluid_0001.vdb", "fluid_0002.vdb"] {
        fs::copy(seq(f), d.join(f)).unwrap();
    }
    fs::read(d.join("fluid_0001.vdb")).unwrap()
}

#[test]
fn farm_openjd_job_never_replaces_an_input_or_output_frame() {
    let d = dir("farm");
    let original = two_frames(&d);
    let job = |j: &str, tiles: &str| {
        vec![
            "farm",
            "openjd",
            "fluid_####.vdb",
            "--frames",
            "1-2",
            "--tiles",
            tiles,
            "-o",
            "o_####.exr",
            "--job",
            j,
        ]
        .into_iter()
        .map(String::from)
        .collect::<Vec<_>>()
    };
    let in_pieces = |j: &str, tiles: &str, needle: &str| {
        let args = job(j, tiles);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        refused(&d, &args, needle);
    };
    let run = |j: &str, needle: &str| in_pieces(j, "1", needle);
    run(
        "fluid_0001.vdb",
        "the job (--job) would overwrite frame 1's input",
    );
    run("./fluid_0002.vdb", "frame 2's input");
    run("o_0002.exr", "frame 2's output (-o)");
    in_pieces("o_0001.exr.piece2of2.exr", "2", "frame 1's piece 2");
    in_pieces("o_0002.exr.shadows.vdb", "2", "frame 2's shadow maps");
    fifo(&d.join("job.fifo"));
    run("job.fifo", "not a regular file");
    let ro = read_only_folder(&d);
    run(&format!("{}/job.yaml", ro.display()), "is read-only");
    assert_eq!(fs::read(d.join("fluid_0001.vdb")).unwrap(), original);
    assert!(is_fifo(&d.join("job.fifo")));
    let args = job("job.yaml", "1");
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    ok(&d, &args);
}

#[test]
fn stitch_output_is_guarded() {
    let d = dir("stitch");
    let mut pieces = Vec::new();
    for i in 1..=2 {
        let p = format!("p{i}.exr");
        let tile = format!("{i}/2");
        ok(
            &d,
            &[
                "render",
                &cloud(),
                "-o",
                &p,
                "--res",
                "16x8",
                "--tile",
                &tile,
                "--quiet",
            ],
        );
        pieces.push(p);
    }
    let piece_bytes = fs::read(d.join("p1.exr")).unwrap();
    let stitch = |out: &str, needle: &str| {
        refused(&d, &["stitch", "p1.exr", "p2.exr", "-o", out], needle);
    };
    stitch("p1.exr", "would overwrite a piece");
    // Stands for `-o /dev/null`: a FIFO and (as root) a character device made here.
    fifo(&d.join("null.exr"));
    stitch("null.exr", "not a regular file");
    assert!(is_fifo(&d.join("null.exr")));
    let dev = d.join("dev.exr");
    let made = Command::new("mknod")
        .arg(&dev)
        .args(["c", "1", "3"])
        .status()
        .is_ok_and(|s| s.success());
    if made {
        stitch("dev.exr", "not a regular file");
        assert!(
            fs::symlink_metadata(&dev)
                .unwrap()
                .file_type()
                .is_char_device()
        );
    } else {
        eprintln!("note: mknod not permitted here: the device case was not run");
    }
    std::os::unix::fs::symlink(d.join("elsewhere.exr"), d.join("link.exr")).unwrap();
    stitch("link.exr", "symbolic link");
    let ro = read_only_folder(&d);
    stitch(&format!("{}/whole.exr", ro.display()), "is read-only");
    assert_eq!(fs::read(d.join("p1.exr")).unwrap(), piece_bytes);
    ok(&d, &["stitch", "p1.exr", "p2.exr", "-o", "whole.exr"]);
}

#[test]
fn phase_tables_and_plots_are_guarded() {
    let d = dir("phase");
    fifo(&d.join("t.csv"));
    let phase = |extra: &[&str], needle: &str| {
        let mut args = vec!["phase", "water-drop", "--drop-radius", "10"];
        args.extend(extra);
        refused(&d, &args, needle);
    };
    phase(&["--csv", "t.csv"], "not a regular file");
    assert!(is_fifo(&d.join("t.csv")));
    std::os::unix::fs::symlink(d.join("x.png"), d.join("l.png")).unwrap();
    phase(&["--plot", "l.png"], "symbolic link");
    phase(
        &["--csv", "same", "--plot", "./same"],
        "the plot (--plot) would overwrite the table (--csv)",
    );
    assert!(!d.join("same").exists());
}

#[test]
fn a_sequence_output_never_replaces_another_frame_s_input() {
    let d = dir("sequence");
    fs::copy(seq("fluid_0001.vdb"), d.join("f_0001.vdb")).unwrap();
    fs::copy(seq("fluid_0002.vdb"), d.join("f_1001.vdb")).unwrap();
    let original = fs::read(d.join("f_1001.vdb")).unwrap();
    // Frame 1's stats would be f_1001.vdb: frame 1001's input.
    refused(
        &d,
        &[
            "render",
            "f_####.vdb",
            "--frames",
            "1,1001",
            "-o",
            "r_####.exr",
            "--stats",
            "f_1###.vdb",
            "--res",
            "8x6",
        ],
        "frame 1's stats file would overwrite frame 1001's input",
    );
    assert_eq!(fs::read(d.join("f_1001.vdb")).unwrap(), original);
    assert!(!d.join("r_0001.exr").exists(), "refused before any frame");
}

#[test]
fn render_and_bake_refuse_read_only_folders_and_fifos() {
    let d = dir("render");
    let ro = read_only_folder(&d);
    let into_ro = format!("{}/o.exr", ro.display());
    refused(
        &d,
        &["render", &cloud(), "-o", &into_ro, "--res", "8x6"],
        "is read-only",
    );
    fifo(&d.join("sh.vdb"));
    refused(
        &d,
        &["bake-shadows", &cloud(), "-o", "sh.vdb"],
        "not a regular file",
    );
    assert!(is_fifo(&d.join("sh.vdb")));
    let input = d.join("c.vdb");
    fs::copy(cloud(), &input).unwrap();
    refused(
        &d,
        &["bake-shadows", "c.vdb", "-o", "./c.vdb"],
        "would overwrite the input",
    );
}

#[test]
fn report_outputs_are_guarded_before_any_work() {
    let d = dir("reports");
    let out = d.join("out");
    fs::create_dir(&out).unwrap();
    fifo(&out.join("stability.json"));
    fifo(&out.join("converge.csv"));
    let o = out.display().to_string();
    refused(&d, &["check-stability", "--out", &o], "not a regular file");
    refused(
        &d,
        &["converge", &cloud(), "--out", &o, "--runs", "1"],
        "not a regular file",
    );
    assert!(is_fifo(&out.join("stability.json")));
    assert!(is_fifo(&out.join("converge.csv")));
}
