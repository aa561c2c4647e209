//! `murk render --shutter` end to end on a cache with a `vel` grid: the closed form of
//! its blurred edge, the path tracer's blur against single scattering's, what renders
//! sharp and what is refused.

use super::common::frames::{murk, ok, refused, same_image, scratch};
use super::common::motion::{ABSORBING, BOX_CAMERA, BOX_RES};
use super::common::tools;
use super::common::volumes::channel_with_width;
use crate::need;
use std::path::Path;

/// Writes `moving.vdb` into `dir`: a box of density 1 (voxels 0..=39, 0..=39, 0..=19 at
/// 0.05: x from 0 to 1.95) and a vec3 grid `vel` of (vx, 0, 0) over a larger box, as a
/// simulation writes velocity beyond the smoke; `still.vdb` without `vel`.
pub fn write_caches(dir: &Path, vx: f64) {
    let script = "import pyopenvdb as vdb, numpy as np, sys\n\
        d = vdb.FloatGrid()\n\
        d.name = 'density'\n\
        d.copyFromArray(np.ones((40, 40, 20), dtype=np.float32), ijk=(0, 0, 0))\n\
        d.transform = vdb.createLinearTransform(0.05)\n\
        d.gridClass = vdb.GridClass.FOG_VOLUME\n\
        v = vdb.Vec3SGrid()\n\
        v.name = 'vel'\n\
        a = np.zeros((80, 50, 30, 3), dtype=np.float32)\n\
        a[..., 0] = float(sys.argv[2])\n\
        v.copyFromArray(a, ijk=(-20, -5, -5))\n\
        v.transform = vdb.createLinearTransform(0.05)\n\
        vdb.write(sys.argv[1] + '/moving.vdb', grids=[d, v])\n\
        vdb.write(sys.argv[1] + '/still.vdb', grids=[d])\n";
    let o = tools::command(&tools::PYOPENVDB)
        .args(["-c", script, dir.to_str().unwrap(), &vx.to_string()])
        .output()
        .expect("/usr/bin/python3 with pyopenvdb");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// The alpha plane of an EXR, row-major, and its width.
pub fn alpha(path: &Path) -> (usize, Vec<f32>) {
    channel_with_width(path, "A")
}

/// The red plane of an EXR's beauty, row-major, and its width.
pub fn red(path: &Path) -> (usize, Vec<f32>) {
    channel_with_width(path, "R")
}

/// The box's front view ([`BOX_CAMERA`]), absorbing only ([`ABSORBING`]), [`BOX_RES`], at 24 fps.
fn view() -> Vec<&'static str> {
    [
        &BOX_CAMERA[..],
        &BOX_RES[..],
        &ABSORBING[..],
        &["--fps", "24"],
    ]
    .concat()
}

pub fn render(dir: &Path, input: &str, out: &str, extra: &[&str]) -> String {
    let mut args = vec!["render", input, "-o", out];
    args.extend(view());
    args.extend(extra);
    ok(dir, &args)
}

/// `murk render --shutter` on a cache whose `vel` grid moves a box at 24 world units a
/// second: with a 180° shutter at 24 fps (1/48 s) its +x edge becomes a ramp 0.5 wide,
/// as the closed form says (each row's mean, 8 rows of 64 jittered samples a pixel,
/// within 3e-3).
#[test]
fn a_velocity_grid_blurs_the_render_as_the_closed_form_says() {
    need!(tools::PYOPENVDB);
    let dir = scratch("motion-ramp");
    let vx = 24.0;
    write_caches(&dir, vx);
    render(&dir, "moving.vdb", "blur.exr", &["--shutter", "-0.25,0.25"]);
    assert_ramp(&dir.join("blur.exr"), vx * 0.5 / 24.0);
}

/// The closed form of the box's +x edge moved `width` world units across the shutter,
/// seen through [`view`]: the still edge (density 1 to x = 1.95, falling linearly to
/// 0 at 2.0) averaged over the shutter's displacements and the pixel, against each
/// column's mean (8 rows of 64 jittered samples a pixel) within 3e-3.
pub fn assert_ramp(path: &Path, width: f64) {
    let (w, a) = alpha(path);
    let h = a.len() / w;
    let sigma_t = 1.5;
    let (px, x0) = (3.2 / w as f64, 1.95 - 1.6);
    // The closed form of the pixel: the still edge (density 1 to x = 1.95, falling
    // linearly to 0 at 2.0) averaged over the shutter's displacements and the pixel.
    let sharp = |x: f64| {
        let r = ((2.0 - x) / 0.05).clamp(0.0, 1.0);
        -(-sigma_t * r).exp_m1()
    };
    let m = 400;
    for i in 0..w {
        let mut want = 0.0;
        for u in 0..m {
            let x = x0 + (i as f64 + (u as f64 + 0.5) / m as f64) * px;
            for k in 0..m {
                want += sharp(x - width * ((k as f64 + 0.5) / m as f64 - 0.5));
            }
        }
        want /= (m * m) as f64;
        let got = (0..h).map(|y| a[y * w + i] as f64).sum::<f64>() / h as f64;
        assert!(
            (got - want).abs() < 3e-3,
            "column {i}: alpha {got}, closed form {want}"
        );
    }
    // The ramp is there: half alpha near the edge, none past x = 2.25.
    let col = |x: f64| ((x - x0) / px) as usize;
    assert!(a[col(2.3)] == 0.0 && a[col(1.6)] > 0.77, "{:?}", &a[..w]);
}

/// The path tracer blurs as the march does: the same cache through `--scattering
/// path` gives the closed form's ramp in alpha (each path at its camera sample's
/// time, its camera ray's exact opacity through the moved density: as single's to
/// 5e-3), and with a sun and
/// one bounce (single scattering, by delta tracking under the padded majorants) its
/// radiance stands to single scattering's as it does without the blur: over the
/// ramp within 5 %, and column by column (each within 10 %) where the blur changed
/// single scattering's image by more than 20 %.
#[test]
fn the_path_tracer_blurs_as_single_scattering() {
    need!(tools::PYOPENVDB);
    let dir = scratch("motion-path");
    write_caches(&dir, 24.0);
    let blur = ["--shutter", "-0.25,0.25"];
    let path = ["--scattering", "path"];
    render(&dir, "moving.vdb", "single.exr", &blur);
    render(
        &dir,
        "moving.vdb",
        "path.exr",
        &[&blur[..], &path[..]].concat(),
    );
    let (w, single) = alpha(&dir.join("single.exr"));
    let (_, path_a) = alpha(&dir.join("path.exr"));
    let h = single.len() / w;
    let col = |a: &[f32], i: usize| (0..h).map(|y| a[y * w + i] as f64).sum::<f64>() / h as f64;
    for i in 0..w {
        let (s, p) = (col(&single, i), col(&path_a, i));
        // The path tracer takes alpha from a pixel's first samples only (their
        // times cover the shutter more coarsely): 5e-3, against a ramp 0.78 deep.
        assert!(
            (s - p).abs() < 5e-3,
            "column {i}: path alpha {p}, single {s}"
        );
    }
    // Radiance of a lit, thin medium (albedo 0.25) at one bounce.
    let lit = [
        "--sigma-a",
        "0.3,0.3,0.3",
        "--sigma-s",
        "0.1,0.1,0.1",
        "--spp",
        "256",
    ];
    let lit_args = |extra: &[&str]| {
        let mut v: Vec<&str> = view().into_iter().filter(|a| *a != "--no-lights").collect();
        // The view's own medium and samples are replaced by the lit ones.
        for key in ["--sigma-a", "--sigma-s", "--spp"] {
            if let Some(i) = v.iter().position(|a| *a == key) {
                v.drain(i..i + 2);
            }
        }
        v.extend(lit);
        v.extend(extra);
        v.into_iter().map(String::from).collect()
    };
    let run = |out: &str, extra: &[&str]| {
        let rest: Vec<String> = lit_args(extra);
        let mut args = vec!["render", "moving.vdb", "-o", out];
        args.extend(rest.iter().map(String::as_str));
        ok(&dir, &args);
        red(&dir.join(out))
    };
    let (_, s) = run(
        "lit_single.exr",
        &[&blur[..], &["--shadows", "march"]].concat(),
    );
    let (_, p) = run(
        "lit_path.exr",
        &[
            &blur[..],
            &path[..],
            &["--bounces", "1", "--shadows", "march"],
        ]
        .concat(),
    );
    let (_, s0) = run("lit_sharp.exr", &["--shadows", "march"]);
    let (_, p0) = run(
        "lit_path_sharp.exr",
        &[&path[..], &["--bounces", "1", "--shadows", "march"]].concat(),
    );
    // The ramp's columns: x from 1.7 to 2.2.
    let (px, x0) = (3.2 / w as f64, 1.95 - 1.6);
    let cols = ((1.7 - x0) / px) as usize..((2.2 - x0) / px) as usize;
    let per_col = |r: &[f32]| -> Vec<f64> { cols.clone().map(|i| col(r, i)).collect() };
    let (s, p, s0, p0) = (per_col(&s), per_col(&p), per_col(&s0), per_col(&p0));
    // The path tracer against single scattering is the same with the blur as without
    // (their ratio over the ramp), column by column where the blur changed the image.
    let total = |v: &[f64]| v.iter().sum::<f64>();
    let (blurred, sharp) = (total(&p) / total(&s), total(&p0) / total(&s0));
    eprintln!("path/single over the ramp: blurred {blurred}, sharp {sharp}");
    // Measured 0.930 blurred against 0.957 sharp at 256 samples: within 5 %.
    assert!(
        (blurred - sharp).abs() < 0.05,
        "path/single: blurred {blurred}, sharp {sharp}"
    );
    let moved: Vec<usize> = (0..s.len())
        .filter(|&i| (s[i] - s0[i]).abs() > 0.2 * s0[i].max(1e-3))
        .collect();
    assert!(moved.len() >= 5, "the blur moved nothing: {s:?} vs {s0:?}");
    for &i in &moved {
        let want = s[i] * sharp;
        assert!(
            (p[i] - want).abs() < 0.1 * want + 1e-3,
            "column {i}: path {}, single × {sharp} = {want}",
            p[i]
        );
    }
}

/// Without a shutter, with `--velocity-grid none`, or on a cache without velocity (which
/// says so), the render is the sharp one bit for bit; a shutter that opens after it
/// closes is refused in one line.
#[test]
fn no_shutter_no_velocity_and_bad_shutters() {
    need!(tools::PYOPENVDB, tools::IDIFF);
    let dir = scratch("motion-sharp");
    write_caches(&dir, 24.0);
    render(&dir, "moving.vdb", "sharp.exr", &[]);
    render(&dir, "still.vdb", "still.exr", &[]);
    same_image(&dir.join("sharp.exr"), &dir.join("still.exr"));
    let shutter = ["--shutter", "-0.25,0.25"];
    render(
        &dir,
        "moving.vdb",
        "none.exr",
        &[&shutter[..], &["--velocity-grid", "none"]].concat(),
    );
    same_image(&dir.join("sharp.exr"), &dir.join("none.exr"));
    let err = render(&dir, "still.vdb", "nothing.exr", &shutter);
    assert!(err.contains("no velocity grid found"), "{err}");
    same_image(&dir.join("sharp.exr"), &dir.join("nothing.exr"));
    let base = ["render", "moving.vdb", "-o", "x.exr", "--res", "8x8"];
    refused(
        &dir,
        &[&base[..], &["--shutter", "0.5,-0.5"]].concat(),
        "--shutter",
    );
    refused(
        &dir,
        &[&base[..], &["--shutter", "0.5"]].concat(),
        "OPEN,CLOSE",
    );
    refused(
        &dir,
        &[&base[..], &["--velocity-unit", "hour"]].concat(),
        "--velocity-unit",
    );
    refused(
        &dir,
        &[&base[..], &shutter, &["--velocity-grid", "density"]].concat(),
        "--velocity-grid",
    );
    // A velocity that would carry the box past its own size is clamped, with a note.
    let fast = [&shutter[..], &["--velocity-scale", "1000"]].concat();
    let err = render(&dir, "moving.vdb", "fast.exr", &fast);
    assert!(err.contains("speeds clamped"), "{err}");
    let _ = murk;
}
