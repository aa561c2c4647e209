//! The EXR header, per exrheader and oiiotool: channels, layers, compression, float.

use super::*;

#[test]
fn exr_header_per_exrheader() {
    need!(tools::EXRHEADER);
    let dir = scratch("exrheader");
    let input = fixture("cloud.vdb");
    let exr = render(
        &dir,
        "cloud.vdb",
        "x",
        &[
            "--preview",
            dir.join("x.png").to_str().unwrap(),
            "--stats",
            dir.join("x.json").to_str().unwrap(),
        ],
    );
    let h = exrheader(&exr);
    // single-part scanline: no multi-part (0x1000), tiled (0x200) or deep (0x800) flag
    assert!(h.contains("file format version: 2, flags 0x0\n"), "{h}");
    assert!(h.contains("type (type string): \"scanlineimage\""), "{h}");
    assert!(!h.contains("tiles (type tiledesc)"), "{h}");
    assert!(!h.contains(" part "), "{h}");

    let channels = exrheader_channels(&h);
    let names: BTreeSet<String> = channels.iter().map(|(n, _)| n.clone()).collect();
    let mut want = set(&["R", "G", "B", "A", "Z"]);
    want.extend(rgb("scatter"));
    want.extend(rgb("indirect")); // the default mode, fast
    assert_eq!(
        names, want,
        "no emission layer (no emission grid), no per-light layer (one light)"
    );
    assert_eq!(channels.len(), want.len());
    for (name, ty) in &channels {
        let want_ty = if name == "Z" {
            "32-bit floating-point"
        } else {
            "16-bit floating-point"
        };
        assert_eq!(ty, want_ty, "type of {name}");
    }

    let display = exrheader_box(&h, "displayWindow");
    assert_eq!(display, [0, 0, W as i64 - 1, H as i64 - 1]);
    let [x0, y0, x1, y1] = exrheader_box(&h, "dataWindow");
    assert!(
        0 <= x0 && x0 <= x1 && x1 < W as i64 && 0 <= y0 && y0 <= y1 && y1 < H as i64,
        "dataWindow ({x0} {y0}) - ({x1} {y1}) outside the display window"
    );
    for line in [
        "compression (type compression): zip, individual scanlines",
        "lineOrder (type lineOrder): increasing y",
        "chromaticities (type chromaticities):",
        "    red   (0.64 0.33)",
        "    green (0.3 0.6)",
        "    blue  (0.15 0.06)",
        "    white (0.3127 0.329)",
        "worldToCamera (type m44f):",
        "worldToNDC (type m44f):",
        &format!("inputFile (type string): \"{}\"", input.display()),
    ] {
        assert!(
            h.lines().any(|l| l == line),
            "exrheader lacks `{line}`:\n{h}"
        );
    }
    let software = h
        .lines()
        .find_map(|l| l.strip_prefix("software (type string): "))
        .unwrap_or_else(|| panic!("no software:\n{h}"));
    assert!(software.starts_with("\"murk "), "{software}");
    let render_time: f64 = h
        .lines()
        .find_map(|l| l.strip_prefix("renderTime (type float): "))
        .unwrap_or_else(|| panic!("no renderTime:\n{h}"))
        .parse()
        .unwrap();
    assert!(
        render_time > 0.0 && render_time < 600.0,
        "renderTime {render_time}"
    );
    let rule = h
        .lines()
        .find_map(|l| l.strip_prefix("murk/depthRule (type string): "))
        .unwrap_or_else(|| panic!("no murk/depthRule:\n{h}"));
    assert!(rule.contains("0.5") && rule.contains("1e10"), "{rule}");
    assert!(!h.contains("murk/nanCount"), "a render has no NaNs:\n{h}");
}

#[test]
fn exr_header_per_oiiotool() {
    need!(tools::OIIOTOOL);
    let dir = scratch("oiiotool");
    // OpenImageIO prints the full/display window only where it differs from the data
    // window: with the default (dataWindow = displayWindow) it does not.
    let full = oiio_info(&render(&dir, "cloud.vdb", "full", &[]));
    assert!(!full.contains("full/display size"), "{full}");
    assert!(full.contains(":   96 x   54, "), "{full}");
    let exr = render(&dir, "cloud.vdb", "x", &["--crop-data-window"]);
    let info = oiio_info(&exr);
    for line in [
        "full/display size: 96 x 54",
        "full/display origin: 0, 0",
        "compression: \"zips\"",
        "chromaticities: 0.64, 0.33, 0.3, 0.6, 0.15, 0.06, 0.3127, 0.329",
        "oiio:subimages: 1",
    ] {
        assert!(
            info.lines().any(|l| l.trim() == line),
            "oiiotool lacks `{line}`:\n{info}"
        );
    }
    for key in [
        "worldToCamera: ",
        "worldToNDC: ",
        "renderTime: ",
        "inputFile: ",
        "software: \"murk ",
        "murk/depthRule: ",
    ] {
        assert!(
            info.lines().any(|l| l.trim().starts_with(key)),
            "oiiotool lacks `{key}`:\n{info}"
        );
    }
    assert!(!info.contains("tile size"), "must be scanline:\n{info}");
    let channels = oiio_channels(&info);
    let mut want: BTreeMap<String, String> = ["R", "G", "B", "A"]
        .iter()
        .map(|c| (c.to_string(), "half".to_owned()))
        .collect();
    want.insert("Z".into(), "float".into());
    for c in rgb("scatter").into_iter().chain(rgb("indirect")) {
        want.insert(c, "half".into());
    }
    assert_eq!(channels, want, "{info}");
}

#[test]
fn float_flag_stores_colour_as_float() {
    need!(tools::EXRHEADER, tools::OIIOTOOL);
    let dir = scratch("float");
    let exr = render(&dir, "cloud.vdb", "x", &["--float"]);
    let channels = exrheader_channels(&exrheader(&exr));
    assert_eq!(channels.len(), 11); // R G B A Z, scatter and indirect (fast, the default)
    assert!(
        channels.iter().all(|(_, t)| t == "32-bit floating-point"),
        "{channels:?}"
    );
    let info = oiio_info(&exr);
    // OIIO names a channel's type only when the channels' types differ.
    assert!(
        info.contains("11 channel, float openexr") && !info.contains("(half)"),
        "{info}"
    );
    let e = Exr::read(&exr);
    assert!(e.channels.values().all(|(half, _)| !half));

    // Float data: the data window is the tight bounding box of the non-empty pixels.
    let (wx, wy, ww, wh) = e.window;
    let occupied = |x: usize, y: usize| {
        let i = (y - wy) * ww + (x - wx);
        e.channels.iter().any(|(n, (_, v))| {
            if n == "Z" {
                v[i].is_finite()
            } else {
                v[i] != 0.0
            }
        })
    };
    let edges = [
        ("left", (wy..wy + wh).any(|y| occupied(wx, y))),
        ("right", (wy..wy + wh).any(|y| occupied(wx + ww - 1, y))),
        ("top", (wx..wx + ww).any(|x| occupied(x, wy))),
        ("bottom", (wx..wx + ww).any(|x| occupied(x, wy + wh - 1))),
    ];
    for (edge, any) in edges {
        assert!(
            any,
            "the data window {:?} has an empty {edge} edge",
            e.window
        );
    }
    // In float, beauty = emission + scatter (the cloud has no emission) exactly as summed.
    for (c, sc) in ["R", "G", "B"].iter().zip(rgb("scatter")) {
        assert_eq!(e.get(c), e.get(&sc), "{c} = scatter.{c}");
    }
}

#[test]
fn every_compression_shows_up_in_the_header() {
    need!(tools::EXRHEADER, tools::OIIOTOOL);
    let dir = scratch("compression");
    for (name, _) in COMPRESSIONS {
        let exr = render(
            &dir,
            "cloud.vdb",
            name,
            &["--compression", name, "--step", "2"],
        );
        assert_compression_named(&exr, name);
        // readable by the exr crate too
        // R G B A Z, scatter and indirect (fast, the default).
        assert_eq!(Exr::read(&exr).channels.len(), 11, "--compression {name}");
    }
}

#[test]
fn two_lights_get_their_own_layers() {
    need!(tools::EXRHEADER);
    let dir = scratch("two-suns");
    let exr = render(
        &dir,
        "cloud.vdb",
        "suns",
        &[
            "--light",
            "sun:1,1,0:1,0.9,0.8:4",
            "--light",
            "sun:-1,0.2,0:0.3,0.4,1:2",
        ],
    );
    let h = exrheader(&exr);
    let names: BTreeSet<String> = exrheader_channels(&h).into_iter().map(|(n, _)| n).collect();
    let mut want = set(&["R", "G", "B", "A", "Z"]);
    for layer in ["scatter", "indirect", "scatter_sun0", "scatter_sun1"] {
        want.extend(rgb(layer));
    }
    assert_eq!(names, want);

    let exr = render(
        &dir,
        "cloud.vdb",
        "sun-point",
        &["--light", "sun:1,1,0", "--light", "point:0,3,3:1,1,1:40"],
    );
    let names: BTreeSet<String> = exrheader_channels(&exrheader(&exr))
        .into_iter()
        .map(|(n, _)| n)
        .collect();
    let mut want = set(&["R", "G", "B", "A", "Z"]);
    for layer in ["scatter", "indirect", "scatter_sun0", "scatter_point0"] {
        want.extend(rgb(layer));
    }
    assert_eq!(names, want);
}
