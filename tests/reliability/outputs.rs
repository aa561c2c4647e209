//! What murk writes: never over an input or another output, never a non-finite value,
//! and nothing a kill leaves that the next run does not clean.

use super::*;

// ---------------------------------------------------------------------------------------
// 5. Outputs never replace an input, another output, or anything but a regular file.

#[test]
fn outputs_that_would_clobber_are_refused() {
    let dir = scratch("clobber");
    let input = dir.join("c.vdb");
    std::fs::copy(fixture("cloud.vdb"), &input).unwrap();
    let original = std::fs::read(&input).unwrap();
    let out = dir.join("out.exr");
    let i = s(&input);
    let o = s(&out);
    // --stats is the input, also spelled differently (-o must name an EXR).
    let other_spelling = format!("{}/./c.vdb", dir.display());
    for target in [i, other_spelling.as_str()] {
        refused(
            &murk(&["render", i, "-o", o, "--stats", target]),
            &["would overwrite the input"],
        );
    }
    // --stats or --preview equal to -o or to the input.
    let linked_png = dir.join("c.png");
    std::fs::hard_link(&input, &linked_png).unwrap();
    refused(
        &murk(&["render", i, "-o", o, "--stats", o]),
        &["the stats file would overwrite the output"],
    );
    refused(
        // A hard link of the input named as a preview: the same file.
        &murk(&["render", i, "-o", o, "--preview", s(&linked_png)]),
        &["the preview would overwrite the input"],
    );
    // A scene file as an output.
    let scene = dir.join("s.toml");
    std::fs::write(&scene, "input = \"c.vdb\"\noutput = \"s.exr\"\n").unwrap();
    refused(
        &murk(&["render", s(&scene), "--stats", s(&scene)]),
        &["would overwrite the scene file"],
    );
    // Not regular files: a FIFO, a symbolic link, a read-only file, a device node.
    let fifo = dir.join("fifo.exr");
    assert!(
        Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    refused(
        &murk(&["render", i, "-o", s(&fifo)]),
        &["not a regular file"],
    );
    let link = dir.join("link.exr");
    std::os::unix::fs::symlink(&out, &link).unwrap();
    refused(&murk(&["render", i, "-o", s(&link)]), &["symbolic link"]);
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    let ro = dir.join("ro.exr");
    std::fs::write(&ro, "keep").unwrap();
    let mut perm = std::fs::metadata(&ro).unwrap().permissions();
    perm.set_readonly(true);
    std::fs::set_permissions(&ro, perm).unwrap();
    refused(&murk(&["render", i, "-o", s(&ro)]), &["read-only"]);
    assert_eq!(std::fs::read(&ro).unwrap(), b"keep");
    // A character device (the null device's numbers) made here, where murk replacing it
    // would harm nothing; only where the test may make device nodes (root).
    let dev = dir.join("null.exr");
    if Command::new("mknod")
        .arg(&dev)
        .args(["c", "1", "3"])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
    {
        refused(
            &murk(&["render", i, "-o", s(&dev)]),
            &["not a regular file"],
        );
        assert!(
            std::fs::symlink_metadata(&dev)
                .unwrap()
                .file_type()
                .is_char_device()
        );
    } else {
        eprintln!("note: mknod not permitted here: the device case was not run");
    }
    assert_eq!(
        std::fs::read(&input).unwrap(),
        original,
        "the input changed"
    );
    use std::os::unix::fs::FileTypeExt;
    assert!(
        std::fs::symlink_metadata(&fifo)
            .unwrap()
            .file_type()
            .is_fifo()
    );
}

// ---------------------------------------------------------------------------------------
// 6. What a kill during a write leaves is cleaned by the next write of the same target.

#[test]
fn a_killed_write_s_temporary_is_removed_by_the_next_run() {
    let dir = scratch("stale-temp");
    let out = dir.join("o.exr");
    // What `kill -9` during the write of o.exr by process 4194305 (above Linux's largest
    // pid, so surely dead) leaves behind, and the same for the stats file.
    let stale = [".o.exr.tmp-4194305-0", ".o.json.tmp-4194305-2"];
    for f in stale {
        std::fs::write(dir.join(f), vec![0u8; 4096]).unwrap();
    }
    ok(&murk(&[
        "render",
        s(&fixture("sphere.vdb")),
        "-o",
        s(&out),
        "--stats",
        s(&dir.join("o.json")),
        "--res",
        "32x18",
        "--quiet",
    ]));
    let mut left: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(left, ["o.exr", "o.json"]);
}

// ---------------------------------------------------------------------------------------
// 4. No non-finite value in an EXR: layers beyond half float's range are written as float.

/// `oiiotool --stats` per channel: (name, min, max, NaN count, Inf count).
fn oiio_stats(path: &Path) -> Vec<(String, f64, f64, u64, u64)> {
    let text = common::tool(
        "oiiotool",
        &["--stats", path.to_str().unwrap()],
        "openimageio-tools",
    );
    let header = common::exrheader(path);
    let names: Vec<String> = common::exrheader_channels(&header)
        .into_iter()
        .map(|(n, _)| n)
        .collect();
    let row = |key: &str| -> Vec<f64> {
        let line = text
            .lines()
            .find(|l| l.trim_start().starts_with(key))
            .unwrap_or_else(|| panic!("no `{key}` in {text}"));
        line.split(':')
            .nth(1)
            .unwrap()
            .split_whitespace()
            .filter_map(|v| v.parse::<f64>().ok())
            .collect()
    };
    let (min, max, nan, inf) = (
        row("Stats Min:"),
        row("Stats Max:"),
        row("Stats NanCount:"),
        row("Stats InfCount:"),
    );
    assert_eq!(min.len(), names.len(), "{text}");
    (0..names.len())
        .map(|i| {
            (
                names[i].clone(),
                min[i],
                max[i],
                nan[i] as u64,
                inf[i] as u64,
            )
        })
        .collect()
}

#[test]
fn emission_beyond_half_range_is_written_as_float_and_said() {
    need!(tools::EXRHEADER, tools::OIIOTOOL);
    let dir = scratch("half-overflow");
    let out = dir.join("hot.exr");
    let stats = dir.join("hot.json");
    let o = murk(&[
        "render",
        s(&fixture("pyro.vdb")),
        "-o",
        s(&out),
        "--no-lights",
        "--emission-intensity",
        "1e6",
        "--res",
        "96x54",
        "--stats",
        s(&stats),
    ]);
    let err = ok(&o);
    assert!(err.contains("layer emission reaches"), "{err}");
    // Colour channels: finite everywhere, and beyond half's range (so stored as float).
    let mut peak: f64 = 0.0;
    for (name, _min, max, nan, inf) in oiio_stats(&out) {
        if name == "Z" {
            continue; // +inf there is the documented "no depth"
        }
        assert_eq!((nan, inf), (0, 0), "{name}: {nan} NaN, {inf} Inf");
        peak = peak.max(max);
    }
    assert!(peak > 65504.0, "the test should overflow half: peak {peak}");
    let channels = common::exrheader_channels(&common::exrheader(&out));
    for (name, ty) in &channels {
        if name.starts_with("emission.") || name == "R" {
            assert_eq!(ty, "32-bit floating-point", "{name}");
        }
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    let notes = json["notes"].to_string();
    assert!(
        notes.contains("emission") && notes.contains("32-bit float"),
        "{notes}"
    );
    // Without the overflow the colour stays half.
    let cool = dir.join("cool.exr");
    ok(&murk(&[
        "render",
        s(&fixture("pyro.vdb")),
        "-o",
        s(&cool),
        "--no-lights",
        "--res",
        "96x54",
        "--quiet",
    ]));
    let channels = common::exrheader_channels(&common::exrheader(&cool));
    assert!(
        channels
            .iter()
            .any(|(n, t)| n == "emission.R" && t == "16-bit floating-point")
    );
}
