//! The pixels read back: windows, half values, an empty frame, NaNs.

use super::*;

#[test]
fn default_options_write_the_full_window_and_1e10_depth() {
    need!(tools::EXRHEADER, tools::OIIOTOOL);
    let dir = scratch("defaults");
    let path = dir.join("defaults.exr");
    let summary = write_exr(&path, &test_frame(), &ExrOptions::default()).unwrap();
    assert_eq!((summary.data_window.x, summary.data_window.y), (0, 0));
    let h = exrheader(&path);
    assert!(
        h.contains("dataWindow (type box2i): (0 0) - (63 47)\n"),
        "{h}"
    );
    let pixels = oiio_pixels(&path);
    // Z: 1e10 where the frame had +inf, its values elsewhere.
    assert_eq!(pixels["Z"][&(0, 0)], 1e10);
    assert!(pixels["Z"].values().all(|z| z.is_finite()));
}

#[test]
fn half_values_read_back_with_exr_crate_and_oiio() {
    need!(tools::OIIOTOOL);
    let dir = scratch("half-values");
    let path = dir.join("frame.exr");
    write_exr(&path, &test_frame(), &test_options()).unwrap();

    let image = read_all_flat_layers_from_file(&path).unwrap();
    assert_eq!(image.layer_data.len(), 1);
    let layer = &image.layer_data[0];
    assert_eq!(
        (
            layer.attributes.layer_position.0,
            layer.attributes.layer_position.1
        ),
        (10, 5)
    );
    assert_eq!((layer.size.0, layer.size.1), (20, 15));
    assert_eq!(layer.channel_data.list.len(), 17);
    for channel in &layer.channel_data.list {
        let name = channel.name.to_string();
        let (is_half, values): (bool, Vec<f32>) = match &channel.sample_data {
            FlatSamples::F16(v) => (true, v.iter().map(|h| h.to_f32()).collect()),
            FlatSamples::F32(v) => (false, v.clone()),
            FlatSamples::U32(_) => panic!("{name} is u32"),
        };
        assert_eq!(is_half, name != "Z", "{name} sample type");
        for (i, got) in values.into_iter().enumerate() {
            let (x, y) = (10 + i % 20, 5 + i / 20);
            let want = expected(&name, x, y);
            let ok = if is_half {
                close(got, want, 1e-3)
            } else {
                got == want
            };
            assert!(ok, "{name} at ({x},{y}): {got} != {want}");
        }
    }

    let pixels = oiio_pixels(&path);
    assert_eq!(pixels.len(), 17);
    for (name, values) in &pixels {
        assert_eq!(values.len(), 300, "{name}");
        for (&(x, y), &got) in values {
            let want = expected(name, x, y);
            let tol = if name == "Z" { 0.0 } else { 1e-3 };
            assert!(
                close(got, want, tol),
                "oiio {name} at ({x},{y}): {got} != {want}"
            );
        }
    }
}

#[test]
fn empty_frame_gets_a_one_pixel_window_at_top_left() {
    need!(tools::EXRHEADER);
    let dir = scratch("empty");
    let path = dir.join("empty.exr");
    let mut frame = Frame::new(W, H);
    frame.add_channel("R", vec![0.0; W * H]).unwrap();
    frame.add_channel("Z", vec![f32::INFINITY; W * H]).unwrap();
    write_exr(&path, &frame, &cropped()).unwrap();
    let h = exrheader(&path);
    assert!(
        h.contains("dataWindow (type box2i): (0 0) - (0 0)\n"),
        "{h}"
    );
    assert!(
        h.contains("displayWindow (type box2i): (0 0) - (63 47)\n"),
        "{h}"
    );
}

#[test]
fn nans_are_written_as_zero_and_counted() {
    need!(tools::EXRHEADER, tools::OIIOTOOL);
    let dir = scratch("nan");
    let path = dir.join("nan.exr");
    let mut frame = test_frame();
    frame.channel_mut("G").unwrap()[7 * W + 12] = f32::NAN;
    frame.channel_mut("emission.B").unwrap()[40 * W + 50] = f32::NAN; // outside: stays empty
    frame.channel_mut("Z").unwrap()[8 * W + 13] = f32::NAN;
    let summary = write_exr(&path, &frame, &cropped()).unwrap();
    assert_eq!(summary.nan_count, 3);
    let h = exrheader(&path);
    assert!(h.contains("murk/nanCount (type int): 3\n"), "{h}");
    assert!(
        h.contains("dataWindow (type box2i): (10 5) - (29 19)\n"),
        "{h}"
    );
    let stats = tool(
        "oiiotool",
        &["--stats", path.to_str().unwrap()],
        "openimageio-tools",
    );
    let nan_line = stats.lines().find(|l| l.contains("NanCount")).unwrap();
    assert!(
        nan_line.split_whitespace().skip(2).all(|n| n == "0"),
        "{nan_line}"
    );
    let pixels = oiio_pixels(&path);
    assert_eq!(pixels["G"][&(12, 7)], 0.0);
    assert_eq!(pixels["Z"][&(13, 8)], f32::INFINITY);
}
