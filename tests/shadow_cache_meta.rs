//! A shadow cache whose metadata was altered (in every grid, or in one of them) is
//! refused with one line, never rendered wrong: every grid must say what the others say,
//! and the charts must be those a bake of this density and light lays.

mod common;
use common::frames::*;
use common::tools;

use std::fs;
use std::path::Path;

fn cloud() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/cloud.vdb")
        .display()
        .to_string()
}

fn u32_at(b: &[u8], at: usize) -> usize {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap()) as usize
}

/// Rewrites the string metadata `key` in `src`'s grids (all of them, or only the
/// `nth` occurrence), keeping its length (padded with spaces, cut if longer), as an
/// editor of the bytes would; writes `dst`. Returns how many occurrences there are.
fn mutate(src: &Path, dst: &Path, key: &str, value: &str, nth: Option<usize>) -> usize {
    let mut b = fs::read(src).unwrap();
    let k = key.as_bytes();
    let mut found = Vec::new();
    for s in 4..b.len() - k.len() {
        if &b[s..s + k.len()] != k || u32_at(&b, s - 4) != k.len() {
            continue;
        }
        let p = s + k.len();
        let p = p + 4 + u32_at(&b, p);
        found.push((p + 4, u32_at(&b, p)));
    }
    for (i, &(at, len)) in found.iter().enumerate() {
        if nth.is_none_or(|n| n == i) {
            let mut v: Vec<u8> = value.bytes().take(len).collect();
            v.resize(len, b' ');
            b[at..at + len].copy_from_slice(&v);
        }
    }
    fs::write(dst, b).unwrap();
    found.len()
}

#[test]
fn altered_shadow_cache_metadata_is_refused() {
    let d = scratch("shadow-meta");
    ok(&d, &["bake-shadows", &cloud(), "-o", "sh.vdb", "--quiet"]);
    let sh = d.join("sh.vdb");
    let render = |cache: &str| {
        let c = cloud();
        let args = [
            "render",
            c.as_str(),
            "-o",
            "o.exr",
            "--res",
            "16x9",
            "--shadow-cache",
            cache,
        ];
        (
            args.iter().map(|s| s.to_string()).collect::<Vec<_>>(),
            murk(&d, &args),
        )
    };
    let (_, good) = render("sh.vdb");
    assert!(
        good.status.success(),
        "{}",
        String::from_utf8_lossy(&good.stderr)
    );
    let cases: [(&str, &str, Option<usize>, &str); 5] = [
        // Every grid says chart 1 of 1 (there is only chart 0).
        ("murk:chart", "1/1", None, "is not the chart its name says"),
        // One grid's lattice step (a bricks grid comes first).
        ("murk:lattice_step", "1e30", Some(0), "murk:lattice_step"),
        // The density hash of one grid of many.
        (
            "murk:density_hash",
            "0123456789abcdef",
            Some(3),
            "murk:density_hash",
        ),
        // Every grid agrees, but not with what a bake lays.
        ("murk:lattice_step", "1e30", None, "is not the chart a bake"),
        (
            "murk:chart_origin",
            "1,2,3",
            None,
            "is not the chart a bake",
        ),
    ];
    for (i, (key, value, nth, needle)) in cases.into_iter().enumerate() {
        let bad = format!("bad{i}.vdb");
        let n = mutate(&sh, &d.join(&bad), key, value, nth);
        assert!(n > 3, "{key}: {n} occurrences");
        let (args, _) = render(&bad);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        refused(&d, &args, needle);
    }
}

/// Names read from a cache are escaped and cut in errors: a light name of 650 bytes of
/// control characters, written by pyopenvdb, prints as 40 characters and its length.
#[test]
fn binary_names_in_a_cache_are_escaped_and_cut() {
    need!(tools::PYOPENVDB);
    let d = scratch("shadow-binary");
    let script = "import pyopenvdb as vdb, numpy as np, sys\n\
        g = vdb.FloatGrid()\n\
        g.name = 'dsm_x_c0_bricks'\n\
        g.copyFromArray(np.ones((2, 2, 2), dtype=np.float32))\n\
        g['murk:light'] = ''.join(chr(1 + i % 30) for i in range(650))\n\
        vdb.write(sys.argv[1], grids=[g])\n";
    let cache = d.join("odd.vdb");
    let o = tools::command(&tools::PYOPENVDB)
        .args(["-c", script, cache.to_str().unwrap()])
        .output()
        .expect("/usr/bin/python3 with pyopenvdb (Debian package python3-openvdb) is required");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let c = cloud();
    let args = [
        "render",
        c.as_str(),
        "-o",
        "o.exr",
        "--res",
        "8x6",
        "--shadow-cache",
        "odd.vdb",
    ];
    refused(&d, &args, "has no shadow map for light sun0");
    let err = String::from_utf8_lossy(&murk(&d, &args).stderr).into_owned();
    assert!(err.contains("bytes)"), "{err}");
    assert!(err.len() < 400, "{} bytes: {err}", err.len());
    assert!(!err.chars().any(|c| c.is_control() && c != '\n'), "{err:?}");
}
