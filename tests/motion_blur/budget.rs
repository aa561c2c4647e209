//! `--max-error` with the shutter open: the samples a pixel it chooses for the shutter's
//! noise meet the error against a many-sample reference; without motion nothing changes;
//! an explicit `--spp` wins.

use super::cli::write_caches;
use super::common::frames::{ok, scratch};
use super::common::motion::BOX_CAMERA;
use super::common::tools;
use super::common::volumes::channel;
use crate::need;
use std::path::Path;

/// The moving box of [`write_caches`] seen from the front ([`BOX_CAMERA`]), lit by the default sun and
/// scattering: its +x edge blurs into a ramp 0.5 wide at 24 units a second over a 180°
/// shutter at 24 fps.
const LIT_LOOK: [&str; 10] = [
    "--res",
    "32x4",
    "--sigma-a",
    "0.5,0.5,0.5",
    "--sigma-s",
    "1,1,1",
    "--float",
    "--fps",
    "24",
    "--quiet",
];

fn render(dir: &Path, input: &str, out: &str, extra: &[&str]) -> serde_json::Value {
    let stats = format!("{out}.json");
    let mut args = vec!["render", input, "-o", out, "--stats", &stats];
    args.extend(BOX_CAMERA);
    args.extend(LIT_LOOK);
    args.extend(extra);
    ok(dir, &args);
    serde_json::from_str(&std::fs::read_to_string(dir.join(&stats)).unwrap()).unwrap()
}

fn spp_of(stats: &serde_json::Value) -> u64 {
    stats["spp"].as_u64().unwrap()
}

/// ‖a − b‖ / ‖b‖ over the beauty's R, G and B.
fn relative_error(a: &Path, b: &Path) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for c in ["R", "G", "B"] {
        for (x, y) in channel(a, c).iter().zip(channel(b, c)) {
            num += (*x as f64 - y as f64).powi(2);
            den += (y as f64).powi(2);
        }
    }
    (num / den).sqrt()
}

/// The blurred box at `--max-error 0.03`: murk takes more than one sample a pixel for
/// the shutter's noise, predicts an error within 0.03, and the image meets it against
/// the same pixel centres converged (`--max-error 0.002`: many times, a fine step, a
/// tight map). Without the noise's term it keeps one sample a pixel and misses it
/// (0.065). At an explicit `--spp 2` (samples jittered over the pixel) the prediction
/// and the measurement against 512 samples a pixel at a fine step, no termination and a
/// tight map agree within 2×.
#[test]
fn max_error_chooses_the_samples_that_meet_it_with_the_shutter_open() {
    need!(tools::PYOPENVDB);
    let dir = scratch("motion-budget");
    write_caches(&dir, 24.0);
    let shutter = ["--shutter", "-0.25,0.25"];
    let reference = [
        &shutter[..],
        &[
            "--step",
            "0.5",
            "--termination",
            "0",
            "--dsm-tolerance",
            "1e-4",
            "--spp",
            "512",
        ],
    ]
    .concat();
    render(&dir, "moving.vdb", "reference.exr", &reference);
    let e = 0.03;
    let stats = render(
        &dir,
        "moving.vdb",
        "budget.exr",
        &[&shutter[..], &["--max-error", "0.03"]].concat(),
    );
    let budget = &stats["error_budget"];
    // Against the same pixels converged: their centres at a fine step, no termination
    // to speak of, a tight map and many times.
    let fine = render(
        &dir,
        "moving.vdb",
        "fine.exr",
        &[&shutter[..], &["--max-error", "0.002"]].concat(),
    );
    let fine_noise = &fine["error_budget"]["shutter_noise"];
    assert!(fine_noise["centred"] == true && fine["spp"].as_u64().unwrap() > 4 * spp_of(&stats));
    let measured = relative_error(&dir.join("budget.exr"), &dir.join("fine.exr"));
    assert!(
        measured <= e,
        "measured {measured} at {} samples a pixel: {budget}",
        stats["spp"]
    );
    let noise = &budget["shutter_noise"];
    let spp = noise["spp"].as_u64().unwrap();
    assert!(spp > 1 && stats["spp"] == noise["spp"], "{budget}");
    assert_eq!(noise["spp_given"], false);
    assert!(noise["error"].as_f64().unwrap() <= e / 2.0, "{budget}");
    assert!(budget["predicted_error"].as_f64().unwrap() <= e, "{budget}");
    // An explicit --spp wins: its noise is measured and predicted beyond the error.
    let stats = render(
        &dir,
        "moving.vdb",
        "given.exr",
        &[&shutter[..], &["--max-error", "0.03", "--spp", "2"]].concat(),
    );
    let budget = &stats["error_budget"];
    assert_eq!(stats["spp"], 2);
    assert_eq!(budget["shutter_noise"]["spp_given"], true);
    let predicted = budget["predicted_error"].as_f64().unwrap();
    let measured = relative_error(&dir.join("given.exr"), &dir.join("reference.exr"));
    assert!(
        predicted > e && measured > e && (0.5..2.0).contains(&(measured / predicted)),
        "predicted {predicted}, measured {measured}"
    );
}

/// Without motion (a cache without velocity) the shutter changes nothing under
/// `--max-error`: the same image, the same choices, no noise term.
#[test]
fn max_error_without_motion_ignores_the_shutter() {
    need!(tools::PYOPENVDB);
    let dir = scratch("motion-budget-still");
    write_caches(&dir, 24.0);
    let open = render(
        &dir,
        "still.vdb",
        "open.exr",
        &["--max-error", "0.03", "--shutter", "-0.25,0.25"],
    );
    let shut = render(&dir, "still.vdb", "shut.exr", &["--max-error", "0.03"]);
    for c in ["R", "G", "B", "A"] {
        let (a, b) = (dir.join("open.exr"), dir.join("shut.exr"));
        assert!(channel(&a, c) == channel(&b, c), "{c}");
    }
    let (a, b) = (&open["error_budget"], &shut["error_budget"]);
    assert!(a.get("shutter_noise").is_none(), "{a}");
    for k in [
        "step_voxels",
        "termination",
        "dsm_tolerance",
        "predicted_error",
    ] {
        assert_eq!(a[k], b[k], "{k}");
    }
    assert_eq!(open["spp"], 1);
}
