//! The example scene file `fixtures/scene.toml`: it renders, flags override it, its
//! resolution, output paths and lights are used.

use super::*;

#[test]
fn scene_file_renders_and_flags_override_it() {
    need!(tools::EXRHEADER);
    let dir = scratch("scene");
    let cwd = scratch("scene-cwd");
    let exr = dir.join("x.exr");
    let json = dir.join("x.json");
    let png = dir.join("x.png");
    // Absolute scene path, run elsewhere: `input` must resolve next to the scene file.
    let scene = fixture("scene.toml");
    murk_ok_in(
        &cwd,
        &[
            "render".into(),
            s(&scene),
            "-o".into(),
            s(&exr),
            "--res".into(),
            "64x36".into(),
            "--stats".into(),
            s(&json),
            "--preview".into(),
            s(&png),
        ],
    );
    assert_eq!(
        fs::read_dir(&cwd).unwrap().count(),
        0,
        "nothing written in the cwd"
    );

    // The scene says 160x90: --res wins.
    let e = Exr::read(&exr);
    assert_eq!((e.width, e.height), (64, 36));
    let h = exrheader(&exr);
    assert_eq!(exrheader_box(&h, "displayWindow"), [0, 0, 63, 35]);
    let stats = read_json(&json);
    assert_eq!(
        (stats["width"].as_u64(), stats["height"].as_u64()),
        (Some(64), Some(36))
    );
    assert!(
        stats["input"]
            .as_str()
            .unwrap()
            .ends_with("fixtures/cloud.vdb"),
        "input is relative to the scene file: {}",
        stats["input"]
    );
    assert_eq!(stats["output"].as_str(), Some(s(&exr).as_str()), "-o wins");
    assert!(png.is_file(), "--preview wins over the scene's preview");
    assert_eq!(string_list(&stats["lights"]), ["key", "fill"]);

    // Named lights give named layers; the default mode (fast) adds `indirect`.
    let mut want = set(&["R", "G", "B", "A", "Z"]);
    for layer in ["scatter", "indirect", "scatter_key", "scatter_fill"] {
        want.extend(rgb(layer));
    }
    assert_eq!(e.names(), want);
    let listed: BTreeSet<String> = string_list(&stats["channels"]).into_iter().collect();
    assert_eq!(listed, want, "stats.channels lists the EXR's channels");
    for layer in ["scatter_key", "scatter_fill"] {
        let sum: f32 = rgb(layer).iter().flat_map(|c| e.get(c)).sum();
        assert!(sum > 0.0, "{layer} is black");
    }

    // The scene's camera is used: eye → origin, look_at on the −z axis.
    let scene: toml::Table = toml::from_str(&fs::read_to_string(&scene).unwrap()).unwrap();
    let vec3 = |key: &str| -> [f64; 3] {
        let v: Vec<f64> = scene[key]
            .as_str()
            .unwrap()
            .split(',')
            .map(|c| c.trim().parse().unwrap())
            .collect();
        [v[0], v[1], v[2]]
    };
    let (eye_w, look_w) = (vec3("eye"), vec3("look_at"));
    let m = e.world_to_camera.expect("worldToCamera");
    let eye = transform(&m, eye_w);
    assert!(
        eye.iter().all(|v| v.abs() < 1e-3),
        "eye in camera space: {eye:?}"
    );
    let look = transform(&m, look_w);
    let dist = (0..3)
        .map(|k| (look_w[k] - eye_w[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(
        look[0].abs() < 1e-3 && look[1].abs() < 1e-3 && (look[2] + dist).abs() < 1e-3,
        "look_at in camera space: {look:?}"
    );
}

#[test]
fn scene_resolution_and_output_paths_are_used_without_flags() {
    // A copy of the scene next to a copy of the cloud, rendered from another
    // directory with no output flags: every output lands next to the scene.
    let dir = scratch("scene-copy");
    let cwd = scratch("scene-copy-cwd");
    fs::copy(fixture("scene.toml"), dir.join("scene.toml")).unwrap();
    fs::copy(fixture("cloud.vdb"), dir.join("cloud.vdb")).unwrap();
    let text = fs::read_to_string(dir.join("scene.toml")).unwrap();
    let scene: toml::Table = toml::from_str(&text).unwrap();
    let res = scene["res"].as_str().unwrap();
    let (w, h) = res.split_once('x').unwrap();
    let (w, h): (usize, usize) = (w.parse().unwrap(), h.parse().unwrap());
    // A cheap render at the scene's resolution: coarse steps, no shadows.
    murk_ok_in(
        &cwd,
        &args(&[
            "render",
            dir.join("scene.toml").to_str().unwrap(),
            "--step",
            "4",
            "--shadows",
            "none",
        ]),
    );
    assert_eq!(
        fs::read_dir(&cwd).unwrap().count(),
        0,
        "nothing written in the cwd"
    );
    for key in ["output", "preview", "stats"] {
        let name = scene[key]
            .as_str()
            .unwrap_or_else(|| panic!("scene has no {key}"));
        assert!(
            dir.join(name).is_file(),
            "{key} {name} not written next to the scene"
        );
    }
    let e = Exr::read(&dir.join(scene["output"].as_str().unwrap()));
    assert_eq!((e.width, e.height), (w, h));
    let png = image::open(dir.join(scene["preview"].as_str().unwrap())).unwrap();
    assert_eq!((png.width() as usize, png.height() as usize), (w, h));
}

#[test]
fn light_flag_replaces_the_scenes_lights() {
    let dir = scratch("scene-light");
    let exr = dir.join("x.exr");
    let json = dir.join("x.json");
    murk_ok(&args(&[
        "render",
        "fixtures/scene.toml",
        "-o",
        exr.to_str().unwrap(),
        "--res",
        "48x27",
        "--stats",
        json.to_str().unwrap(),
        "--preview",
        dir.join("x.png").to_str().unwrap(),
        "--light",
        "sun:0,1,0",
    ]));
    let stats = read_json(&json);
    assert_eq!(string_list(&stats["lights"]), ["sun0"]);
    let mut want = set(&["R", "G", "B", "A", "Z"]);
    want.extend(rgb("scatter"));
    want.extend(rgb("indirect")); // the default mode, fast
    assert_eq!(Exr::read(&exr).names(), want);
}
