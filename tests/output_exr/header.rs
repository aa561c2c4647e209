//! The header as exrheader and oiiotool read it: channels, half and float, every compression.

use super::*;

#[test]
fn half_exr_header_per_exrheader() {
    need!(tools::EXRHEADER);
    let dir = scratch("half-exrheader");
    let path = dir.join("frame.exr");
    let summary = write_exr(&path, &test_frame(), &test_options()).unwrap();
    assert_eq!((summary.data_window.x, summary.data_window.y), (10, 5));
    assert_eq!(summary.nan_count, 0);
    let h = exrheader(&path);

    // single-part scanline: no multi-part (0x1000), tiled (0x200) or deep (0x800) flag
    assert!(h.contains("file format version: 2, flags 0x0\n"), "{h}");
    assert!(
        !h.contains("tiles (type tiledesc)") && !h.contains("name (type string)"),
        "{h}"
    );
    assert!(!h.contains(" part "), "{h}");

    let channels = exrheader_channels(&h);
    let names: Vec<&str> = channels.iter().map(|(n, _)| n.as_str()).collect();
    let mut want: Vec<&str> = COLOUR.iter().copied().chain(["Z"]).collect();
    want.sort_unstable();
    assert_eq!(names, want, "channels must be all there, sorted");
    for (name, ty) in &channels {
        let want_ty = if name == "Z" {
            "32-bit floating-point"
        } else {
            "16-bit floating-point"
        };
        assert_eq!(ty, want_ty, "type of {name}");
    }
    for line in [
        "dataWindow (type box2i): (10 5) - (29 19)",
        "displayWindow (type box2i): (0 0) - (63 47)",
        "compression (type compression): zip, individual scanlines",
        "lineOrder (type lineOrder): increasing y",
        "chromaticities (type chromaticities):",
        "    red   (0.64 0.33)",
        "    green (0.3 0.6)",
        "    blue  (0.15 0.06)",
        "    white (0.3127 0.329)",
        "worldToCamera (type m44f):",
        "    0.5 -2 7 1)",
        "worldToNDC (type m44f):",
        "    0 0 -0.2 0)",
        "software (type string): \"murk test\"",
        "renderTime (type float): 12.5",
        "inputFile (type string): \"fixtures/smoke.vdb\"",
        &format!("murk/depthRule (type string): \"{DEPTH_RULE}\""),
    ] {
        assert!(
            h.lines().any(|l| l == line),
            "exrheader lacks `{line}`:\n{h}"
        );
    }
    assert!(!h.contains("murk/nanCount"), "{h}");
}

#[test]
fn half_exr_header_per_oiiotool() {
    need!(tools::OIIOTOOL);
    let dir = scratch("half-oiio");
    let path = dir.join("frame.exr");
    write_exr(&path, &test_frame(), &test_options()).unwrap();
    let info = oiio_info(&path);
    assert!(info.contains(":   20 x   15, 17 channel, "), "{info}");
    for line in [
        "pixel data origin: x=10, y=5",
        "full/display size: 64 x 48",
        "full/display origin: 0, 0",
        "compression: \"zips\"",
        "chromaticities: 0.64, 0.33, 0.3, 0.6, 0.15, 0.06, 0.3127, 0.329",
        "worldToCamera: 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0.5, -2, 7, 1",
        "worldToNDC: 2, 0, 0, 0, 0, 2.5, 0, 0, 0, 0, 1, 1, 0, 0, -0.2, 0",
        "renderTime: 12.5",
        "inputFile: \"fixtures/smoke.vdb\"",
        "software: \"murk test\"",
        "oiio:subimages: 1",
    ] {
        assert!(
            info.lines().any(|l| l.trim() == line),
            "oiiotool lacks `{line}`:\n{info}"
        );
    }
    assert!(!info.contains("tile size"), "must be scanline:\n{info}");
    let list = info
        .lines()
        .find_map(|l| l.trim().strip_prefix("channel list: "))
        .unwrap();
    for name in COLOUR {
        assert!(
            list.contains(&format!("{name} (half)")),
            "{name} not half: {list}"
        );
    }
    assert!(list.contains("Z (float)"), "Z not float: {list}");
}

#[test]
fn float_option_stores_colour_as_float() {
    need!(tools::EXRHEADER, tools::OIIOTOOL);
    let dir = scratch("float");
    let path = dir.join("frame.exr");
    let opts = ExrOptions {
        float: true,
        ..test_options()
    };
    write_exr(&path, &test_frame(), &opts).unwrap();
    let channels = exrheader_channels(&exrheader(&path));
    assert_eq!(channels.len(), 17);
    assert!(
        channels.iter().all(|(_, t)| t == "32-bit floating-point"),
        "{channels:?}"
    );
    let info = oiio_info(&path);
    assert!(
        !info.contains("(half)") && info.contains("17 channel, float openexr"),
        "{info}"
    );
    for (name, values) in oiio_pixels(&path) {
        for ((x, y), got) in values {
            assert_eq!(got, expected(&name, x, y), "{name} at ({x},{y})");
        }
    }
}

#[test]
fn every_compression_is_named_and_readable() {
    need!(tools::EXRHEADER, tools::OIIOTOOL);
    let dir = scratch("compression");
    let frame = test_frame();
    // the shared list names every compression the writer has
    assert_eq!(COMPRESSIONS.len(), ExrCompression::ALL.len());
    for (name, _) in COMPRESSIONS {
        let c: ExrCompression = name.parse().unwrap();
        let path = dir.join(format!("{c}.exr"));
        write_exr(
            &path,
            &frame,
            &ExrOptions {
                compression: c,
                ..test_options()
            },
        )
        .unwrap();
        assert_compression_named(&path, name);
        // lossless methods round-trip at half precision; DWAA is lossy on colour
        let tol = if c == ExrCompression::Dwaa {
            2e-2
        } else {
            1e-3
        };
        for (name, values) in oiio_pixels(&path) {
            for ((x, y), got) in values {
                let want = expected(&name, x, y);
                let ok = if name == "Z" {
                    got == want
                } else {
                    close(got, want, tol)
                };
                assert!(ok, "{c}: {name} at ({x},{y}): {got} != {want}");
            }
        }
    }
}
