//! The PNG preview.

use super::*;

#[test]
fn preview_has_the_frame_size_and_shows_something() {
    let dir = scratch("preview");
    let png = dir.join("x.png");
    render(
        &dir,
        "cloud.vdb",
        "x",
        &["--preview", png.to_str().unwrap()],
    );
    let img = image::open(&png).unwrap_or_else(|e| panic!("{}: {e}", png.display()));
    assert_eq!((img.width() as usize, img.height() as usize), (W, H));
    let rgb = img.to_rgb8();
    let first = rgb.get_pixel(0, 0);
    assert!(
        rgb.pixels().any(|p| p != first),
        "the preview is all one colour"
    );
    // The cloud is lit: some pixel is brighter than either checker grey (0.6 ⇒ 153).
    assert!(
        rgb.pixels().any(|p| p.0.iter().any(|c| *c > 160)),
        "no bright pixel in the preview"
    );

    let png = dir.join("t.png");
    render(
        &dir,
        "cloud.vdb",
        "t",
        &[
            "--preview",
            png.to_str().unwrap(),
            "--background",
            "transparent",
        ],
    );
    let img = image::open(&png).unwrap().to_rgba8();
    assert_eq!((img.width() as usize, img.height() as usize), (W, H));
    assert!(
        img.pixels().any(|p| p.0[3] == 0),
        "transparent background: corners are clear"
    );
    assert!(
        img.pixels().any(|p| p.0[3] > 128),
        "the cloud is opaque somewhere"
    );
}
