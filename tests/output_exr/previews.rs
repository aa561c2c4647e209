//! The PNG preview: composited, exposed and sRGB-encoded.

use super::*;

#[test]
fn previews_composite_expose_and_encode_srgb() {
    need!(tools::OIIOTOOL);
    let dir = scratch("preview");
    let frame = test_frame();
    let srgb = |l: f32| {
        let l = l.clamp(0.0, 1.0);
        if l <= 0.0031308 {
            l * 12.92
        } else {
            1.055 * l.powf(1.0 / 2.4) - 0.055
        }
    };
    let q = |v: f32| (v * 255.0).round() / 255.0;
    let (px, py) = (15, 9);
    let (r, a) = (expected("R", px, py), expected("A", px, py));

    let cases: [(&str, Background, f32, usize); 4] = [
        ("transparent", Background::Transparent, 0.0, 4),
        ("black", Background::Black, 1.0, 3),
        ("checker", Background::Checker, 0.0, 3),
        ("colour", Background::Color([0.2, 0.1, 0.05]), -1.0, 3),
    ];
    for (tag, background, exposure, nchannels) in cases {
        let path = dir.join(format!("{tag}.png"));
        write_preview(
            &path,
            &frame,
            &PreviewOptions {
                exposure,
                background,
            },
        )
        .unwrap();
        let info = oiio_info(&path);
        assert!(
            info.contains(&format!("64 x   48, {nchannels} channel, uint8 png")),
            "{info}"
        );
        let p = oiio_pixels(&path);
        let gain = exposure.exp2();
        let (want_in, want_out, want_alpha) = match background {
            Background::Transparent => (srgb(r / a), 0.0, Some((q(a), 0.0))),
            Background::Black => (srgb(r * gain), 0.0, None),
            Background::Checker => (srgb(r + (1.0 - a) * 0.132_868), 0.4, None),
            Background::Color(c) => (srgb((r + (1.0 - a) * c[0]) * gain), srgb(c[0] * gain), None),
        };
        assert!(
            (p["R"][&(px, py)] - q(want_in)).abs() < 1.5 / 255.0,
            "{tag} inside"
        );
        assert!(
            (p["R"][&(0, 0)] - q(want_out)).abs() < 1.5 / 255.0,
            "{tag} outside"
        );
        if let Some((inside, outside)) = want_alpha {
            assert_eq!(
                (p["A"][&(px, py)], p["A"][&(0, 0)]),
                (inside, outside),
                "{tag} alpha"
            );
        }
        if background == Background::Checker {
            assert!(
                (p["R"][&(16, 0)] - 0.6).abs() < 1.5 / 255.0,
                "second checker grey"
            );
        }
    }

    let mut no_alpha = Frame::new(4, 4);
    for c in ["R", "G", "B"] {
        no_alpha.add_channel(c, vec![0.5; 16]).unwrap();
    }
    let path = dir.join("no-alpha.png");
    let msg = write_preview(&path, &no_alpha, &PreviewOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains(&path.display().to_string()) && msg.contains('A'),
        "{msg}"
    );
    assert!(!path.exists());
    no_temp_files(&dir);
}
