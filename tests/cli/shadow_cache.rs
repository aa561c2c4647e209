//! Shadow caches (`murk bake-shadows`) and the shadow map's budget, as the command line
//! meets them.

use super::*;

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
    // A map read from a cache has no bake's phases to report.
    assert!(doc["shadow_maps"][0].get("phases").is_none(), "{doc}");
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
    // A bake says where its time went.
    assert!(
        map["phases"]["columns_seconds"].as_f64().unwrap() > 0.0,
        "{map}"
    );
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
