//! Scenes of `[[volume]]`s that move within the shutter: by their keyed placements and
//! by their files' velocity grids, against the same closed form as the cache moved by its
//! velocity.

use super::cli::{alpha, assert_ramp, render, write_caches};
use super::common::frames::scratch;
use super::common::tools;
use crate::need;

/// A `[[volume]]` keyed to move along +x at 1 world unit a frame (as the `vel` grid
/// above moves the box: 24 units a second at 24 fps) blurs into the same closed-form
/// ramp, by single scattering and by the path tracer (under the majorants of the
/// density swept over the shutter); keys that do not move it render the sharp image
/// bit for bit; a `[[volume]]` of the cache with the `vel` grid blurs by it into the
/// same ramp.
#[test]
fn a_keyed_volume_blurs_as_the_closed_form_says() {
    need!(tools::PYOPENVDB);
    let dir = scratch("motion-keyed");
    write_caches(&dir, 24.0);
    let scene = |name: &str, keys: &str| {
        let text = format!("[[volume]]\nfile = \"still.vdb\"\n{keys}");
        std::fs::write(dir.join(name), text).unwrap();
    };
    scene(
        "keyed.toml",
        "[[volume.keys]]\nframe = 1\ntranslate = [-1, 0, 0]\n\
         [[volume.keys]]\nframe = 3\ntranslate = [1, 0, 0]\n",
    );
    let at2 = ["--frames", "2", "--shutter", "-0.25,0.25"];
    let err = render(&dir, "keyed.toml", "keyed.exr", &at2);
    assert!(err.contains("volumes that move while it is open"), "{err}");
    assert_ramp(&dir.join("keyed.exr"), 0.5);
    let path = [&at2[..], &["--scattering", "path"]].concat();
    render(&dir, "keyed.toml", "keyed-path.exr", &path);
    assert_ramp(&dir.join("keyed-path.exr"), 0.5);
    // Keys that hold the volume where it is: the sharp image, bit for bit.
    scene(
        "held.toml",
        "[[volume.keys]]\nframe = 1\n[[volume.keys]]\nframe = 3\n",
    );
    scene("plain.toml", "");
    render(&dir, "held.toml", "held.exr", &at2);
    render(&dir, "plain.toml", "plain.exr", &[]);
    let bits = |f: &str| {
        let (_, a) = alpha(&dir.join(f));
        a.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    };
    assert_eq!(bits("held.exr"), bits("plain.exr"));
    // And the keyed volume without a shutter: sharp, where frame 2 places it.
    render(&dir, "keyed.toml", "keyed-sharp.exr", &["--frames", "2"]);
    assert_eq!(bits("keyed-sharp.exr"), bits("plain.exr"));
    // A volume whose file has a `vel` grid blurs by it, as the same file given as
    // the input does; `--velocity-grid none` leaves it sharp.
    std::fs::write(dir.join("vel.toml"), "[[volume]]\nfile = \"moving.vdb\"\n").unwrap();
    let shutter = ["--shutter", "-0.25,0.25"];
    render(&dir, "vel.toml", "vel.exr", &shutter);
    assert_ramp(&dir.join("vel.exr"), 0.5);
    let none = [&shutter[..], &["--velocity-grid", "none"]].concat();
    let err = render(&dir, "vel.toml", "vel-none.exr", &none);
    assert!(err.contains("no volume moves"), "{err}");
    assert_eq!(bits("vel-none.exr"), bits("plain.exr"));
}

/// A `[[volume]]` placed by `matrix` and keyed by matrices (the same motion along +x,
/// as a pure translation each) blurs into the same closed-form ramp.
#[test]
fn a_volume_keyed_by_matrices_blurs_as_the_closed_form_says() {
    need!(tools::PYOPENVDB);
    let dir = scratch("motion-keyed-matrix");
    write_caches(&dir, 24.0);
    let at =
        |x: i32| format!("matrix = [[1, 0, 0, {x}], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]");
    let text = format!(
        "[[volume]]\nfile = \"still.vdb\"\n{}\n[[volume.keys]]\nframe = 1\n{}\n[[volume.keys]]\nframe = 3\n{}\n",
        at(0),
        at(-1),
        at(1)
    );
    std::fs::write(dir.join("matrix.toml"), text).unwrap();
    render(
        &dir,
        "matrix.toml",
        "matrix.exr",
        &["--frames", "2", "--shutter", "-0.25,0.25"],
    );
    assert_ramp(&dir.join("matrix.exr"), 0.5);
}
