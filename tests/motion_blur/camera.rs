//! A camera moving over a still cache blurs it as the cache moving the other way does.

use super::cli::{alpha, write_caches};
use super::common::frames::{ok, scratch};
use super::common::motion::{ABSORBING, BOX_CAMERA, BOX_RES};
use super::common::tools;
use crate::need;

/// A camera keyed to move along −x at 1 world unit a frame, over a still box, blurs as
/// the box moving along +x at 1 unit a frame (its `vel` grid: 24 units a second at 24
/// fps) does under the same shutter: the same samples see the same points, so the
/// images agree to rounding — and that one matches the closed form of the ramp
/// (`a_velocity_grid_blurs_the_render_as_the_closed_form_says`).
#[test]
fn a_moving_camera_blurs_as_the_same_motion_of_the_volume() {
    need!(tools::PYOPENVDB);
    let dir = scratch("motion-camera");
    write_caches(&dir, 24.0);
    std::fs::write(
        dir.join("shot.toml"),
        "input = \"still.vdb\"\n\
         [camera]\n\
         projection = \"orthographic\"\n\
         horizontal_aperture = 32\n\
         vertical_aperture = 32\n\
         translate = [1.95, 1, 5]\n\
         [[camera.keys]]\n\
         frame = 1\n\
         translate = [2.95, 1, 5]\n\
         [[camera.keys]]\n\
         frame = 3\n\
         translate = [0.95, 1, 5]\n",
    )
    .unwrap();
    let look = [&BOX_RES[..], &ABSORBING[..], &["--shutter", "-0.25,0.25"]].concat();
    let mut args = vec!["render", "shot.toml", "-o", "cam.exr", "--frames", "2"];
    args.extend(&look);
    ok(&dir, &args);
    let mut args = vec!["render", "moving.vdb", "-o", "vel.exr"];
    args.extend(BOX_CAMERA);
    args.extend(&look);
    ok(&dir, &args);
    let (w, cam) = alpha(&dir.join("cam.exr"));
    let (_, vel) = alpha(&dir.join("vel.exr"));
    assert_eq!(cam.len(), vel.len());
    let worst = cam
        .iter()
        .zip(&vel)
        .map(|(a, b)| (a - b).abs())
        .fold(0f32, f32::max);
    assert!(
        worst < 1e-4,
        "largest |Δα| {worst}: {:?} {:?}",
        &cam[..w],
        &vel[..w]
    );
    // And it is blurred: a ramp, not an edge.
    let ramp = cam[..w].iter().filter(|a| **a > 0.01 && **a < 0.76).count();
    assert!(ramp >= 12, "{ramp} ramp pixels: {:?}", &cam[..w]);
}
