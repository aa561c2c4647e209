//! The stats JSON: which stages ran and why.

use super::values::check_values;
use super::*;

#[test]
fn stats_of_an_emission_only_render() {
    let dir = scratch("stats-emission");
    let json = dir.join("x.json");
    let exr = render(
        &dir,
        "pyro.vdb",
        "x",
        &["--no-lights", "--stats", json.to_str().unwrap()],
    );
    let st = read_json(&json);
    for stage in ["scatter", "shadows"] {
        assert!(
            status(&st, stage).starts_with("skipped"),
            "{stage}: {}",
            status(&st, stage)
        );
    }
    assert_eq!(status(&st, "emission"), "ran");
    for stage in ["load", "build", "render", "write"] {
        assert_eq!(status(&st, stage), "ran", "{stage}");
    }
    let not_decoded = string_list(&st["grids_not_decoded"]);
    for g in ["vel", "Cd"] {
        assert!(
            not_decoded.contains(&g.to_string()),
            "{g} not in grids_not_decoded {not_decoded:?}"
        );
    }
    let roles = &st["grid_roles"];
    assert_eq!(roles["density"], "density");
    assert_eq!(roles["emission"], "flame");
    assert_eq!(roles["temperature"], "temperature");
    let decoded = string_list(&st["grids_decoded"]);
    assert!(
        !decoded.iter().any(|g| g == "vel" || g == "Cd"),
        "{decoded:?}"
    );
    assert_eq!(string_list(&st["lights"]), Vec::<String>::new());

    let e = Exr::read(&exr);
    let mut want = set(&["R", "G", "B", "A", "Z"]);
    want.extend(rgb("emission"));
    assert_eq!(e.names(), want, "emission layer, no scatter layer");
    let listed: BTreeSet<String> = string_list(&st["channels"]).into_iter().collect();
    assert_eq!(listed, want);
    check_values(&e, &[]);
}

#[test]
fn stats_of_a_scatter_only_render() {
    let dir = scratch("stats-scatter");
    let json = dir.join("x.json");
    let exr = render(&dir, "cloud.vdb", "x", &["--stats", json.to_str().unwrap()]);
    let st = read_json(&json);
    assert!(
        status(&st, "emission").starts_with("skipped"),
        "{}",
        status(&st, "emission")
    );
    assert!(
        status(&st, "scatter").starts_with("ran"),
        "{}",
        status(&st, "scatter")
    );
    assert!(
        status(&st, "shadows").starts_with("ran"),
        "{}",
        status(&st, "shadows")
    );
    assert_eq!(
        st["grid_roles"].as_object().unwrap().len(),
        1,
        "{}",
        st["grid_roles"]
    );
    assert_eq!(string_list(&st["lights"]), ["sun0"]);
    let names = Exr::read(&exr).names();
    assert!(
        !names.iter().any(|n| n.starts_with("emission")),
        "{names:?}"
    );
    assert!(names.contains("scatter.R"), "{names:?}");
}

#[test]
fn stats_with_sigma_s_zero_skip_scatter_and_shadows() {
    let dir = scratch("stats-no-scatter");
    let json = dir.join("x.json");
    let exr = render(
        &dir,
        "cloud.vdb",
        "x",
        &["--sigma-s", "0,0,0", "--stats", json.to_str().unwrap()],
    );
    let st = read_json(&json);
    for stage in ["scatter", "shadows", "emission"] {
        assert!(
            status(&st, stage).starts_with("skipped"),
            "{stage}: {}",
            status(&st, stage)
        );
    }
    let e = Exr::read(&exr);
    assert_eq!(e.names(), set(&["R", "G", "B", "A", "Z"]));
    assert!(
        e.get("A").iter().any(|a| *a > 0.05),
        "the cloud still absorbs"
    );
}

#[test]
fn stats_with_emission_and_temperature_turned_off() {
    let dir = scratch("stats-no-emission");
    let json = dir.join("x.json");
    let exr = render(
        &dir,
        "pyro.vdb",
        "x",
        &[
            "--emission-grid",
            "none",
            "--temperature-grid",
            "none",
            "--stats",
            json.to_str().unwrap(),
        ],
    );
    let st = read_json(&json);
    assert!(
        status(&st, "emission").starts_with("skipped"),
        "{}",
        status(&st, "emission")
    );
    assert_eq!(status(&st, "scatter"), "ran");
    let roles = st["grid_roles"].as_object().unwrap();
    assert_eq!(
        roles.get("density").and_then(|v| v.as_str()),
        Some("density")
    );
    for role in ["emission", "temperature"] {
        assert!(!roles.contains_key(role), "{role} role filled: {roles:?}");
    }
    let not_decoded = string_list(&st["grids_not_decoded"]);
    for g in ["temperature", "flame", "vel"] {
        assert!(
            not_decoded.contains(&g.to_string()),
            "{g} not in {not_decoded:?}"
        );
    }
    let names = Exr::read(&exr).names();
    assert!(
        !names.iter().any(|n| n.starts_with("emission")),
        "{names:?}"
    );
}
