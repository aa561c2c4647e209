//! Motion blur from a velocity: a slab moving at constant velocity against the closed
//! form of its blurred edge, a still one bit for bit, and `murk render --shutter` end to
//! end on a cache with a velocity grid.

mod common;

use common::march::{fixture, medium};
use common::tools;
use glam::DVec3;
use murk::field::advect::ConstantVelocity;
use murk::integrate::integrator::shutter_time;
use murk::integrate::motion::Motion;
use murk::integrate::{MarchSettings, Scratch, Volume, WorldRay, march};

/// The slab fixture's density is 1 for x up to 1.95 and falls linearly to 0 at 2.0 (its
/// last voxel's trilinear reach), over 20 voxels (1 world unit) along z.
const EDGE_IN: f64 = 1.95;
const EDGE_OUT: f64 = 2.0;

/// Alpha of the still slab along −z at x near its +x edge, σt per world unit.
fn sharp_alpha(x: f64, sigma_t: f64) -> f64 {
    let r = ((EDGE_OUT - x) / (EDGE_OUT - EDGE_IN)).clamp(0.0, 1.0);
    -(-sigma_t * r).exp_m1()
}

/// The mean over 64 shutter times of the march's alpha along −z at `x` (the pixel loop's
/// times for pixel (`px`, 0)).
fn blurred_alpha(vol: &Volume, x: f64, px: usize, shutter: (f64, f64)) -> f64 {
    let n = 64;
    let settings = MarchSettings {
        step_voxels: 0.5,
        termination: 0.0,
    };
    let mut scratch = Scratch::new(0);
    let mut sum = 0.0;
    for s in 0..n {
        let mut ray = WorldRay::new(DVec3::new(x, 0.013, 3.0), DVec3::NEG_Z);
        ray.time = shutter_time(7, px, 0, s, n, shutter);
        sum += march(vol, None, &ray, &settings, 0.37, &mut scratch).alpha();
    }
    sum / n as f64
}

/// A slab moving along +x at `v` world units a second, seen along −z through a shutter of
/// Δt: every point of its edge sweeps v·Δt, so alpha is the still edge's averaged over a
/// window of that width — the linear ramp from A = 1 − e^{−σt·D} inside to 0 outside,
/// over v·Δt (softened by the edge's own one-voxel ramp at its ends). Within 1e-3 at 64
/// samples a point (the shutter's times, one in each 64th of the shutter).
#[test]
fn a_moving_slab_blurs_its_edge_into_the_linear_ramp_of_its_displacement() {
    let slab = fixture("slab.vdb");
    let sigma_t = 1.5;
    let fps = 24.0;
    let shutter = (-0.25, 0.25);
    for speed in [12.0, -9.0, 4.8] {
        // Displacement over the shutter: v·Δt, Δt = 0.5 frame = 1/48 s.
        let width = speed * (shutter.1 - shutter.0) / fps;
        let velocity = ConstantVelocity(DVec3::new(speed, 0.0, 0.0));
        let vol = Volume {
            motion: Some(Motion {
                velocity: &velocity,
                per_frame: 1.0 / fps,
                frames: 0.25,
                cells: None,
            }),
            ..Volume::of(&slab, medium(sigma_t, 0.0, 0.0))
        };
        let a_inside = -(-sigma_t).exp_m1();
        // The closed form: the still alpha averaged over the displacements in the
        // shutter (a fine midpoint sum of a piecewise-smooth integrand).
        let want = |x: f64| {
            let m = 20_000;
            (0..m)
                .map(|i| {
                    let d = width * ((i as f64 + 0.5) / m as f64 - 0.5);
                    sharp_alpha(x - d, sigma_t)
                })
                .sum::<f64>()
                / m as f64
        };
        let half = width.abs() / 2.0;
        let (lo, hi) = (EDGE_IN - half - 0.1, EDGE_OUT + half + 0.1);
        let mut worst: f64 = 0.0;
        for (px, i) in (0..=80).enumerate() {
            let x = lo + (hi - lo) * i as f64 / 80.0 + 1e-4;
            let got = blurred_alpha(&vol, x, px, shutter);
            let w = want(x);
            worst = worst.max((got - w).abs());
            assert!(
                (got - w).abs() <= 1e-3,
                "v {speed}: alpha {got} at x {x}, closed form {w}"
            );
            // Where the window holds the edge's whole one-voxel ramp, alpha is linear in
            // x with slope A/(v·Δt): A·(the fraction of the window inside the slab), the
            // slab's edge taken where a sharp edge would give the same ∫α dx.
            let ramp = EDGE_OUT - EDGE_IN;
            let edge = EDGE_IN + ramp * (1.0 - a_inside / sigma_t) / a_inside;
            if (x - 0.5 * (EDGE_IN + EDGE_OUT)).abs() < half - ramp {
                let linear = a_inside * (0.5 - (x - edge) / (2.0 * half));
                assert!(
                    (got - linear).abs() <= 1e-3,
                    "v {speed}: alpha {got} at x {x}, linear ramp {linear}"
                );
            }
        }
        eprintln!("v {speed}: width {width}, largest |Δα| {worst:.2e}");
        // The ramp spans v·Δt: nothing beyond it, full alpha before it.
        let outside = blurred_alpha(&vol, EDGE_OUT + half + 0.01, 0, shutter);
        let inside = blurred_alpha(&vol, EDGE_IN - half - 0.01, 0, shutter);
        assert!(outside == 0.0, "v {speed}: alpha {outside} past the ramp");
        assert!(
            (inside - a_inside).abs() < 1e-9,
            "v {speed}: {inside} inside"
        );
    }
}

/// A velocity of zero, or no shutter, renders the still slab bit for bit.
#[test]
fn a_still_velocity_renders_the_sharp_image_bit_for_bit() {
    let slab = fixture("slab.vdb");
    let still = ConstantVelocity(DVec3::ZERO);
    let sharp = Volume::of(&slab, medium(1.5, 0.0, 0.0));
    let zero = Volume {
        motion: Some(Motion {
            velocity: &still,
            per_frame: 1.0 / 24.0,
            frames: 0.5,
            cells: None,
        }),
        ..Volume::of(&slab, medium(1.5, 0.0, 0.0))
    };
    let settings = MarchSettings::default();
    let mut scratch = Scratch::new(0);
    for (i, x) in [-2.2, -2.02, -1.0, 0.3, 1.97, 1.999]
        .into_iter()
        .enumerate()
    {
        let mut ray = WorldRay::new(DVec3::new(x, 0.4, 3.0), DVec3::new(0.1, 0.05, -1.0));
        let a = march(&sharp, None, &ray, &settings, 0.5, &mut scratch);
        ray.time = shutter_time(1, i, 0, 3, 16, (-0.5, 0.5));
        let b = march(&zero, None, &ray, &settings, 0.5, &mut scratch);
        assert_eq!(a, b, "x {x}");
    }
}

mod cli {
    use super::common::frames::{murk, ok, refused, same_image, scratch};
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

    const VIEW: [&str; 20] = [
        "--camera",
        "ortho",
        "--eye",
        "1.95,1,5",
        "--look-at",
        "1.95,1,0",
        "--ortho-width",
        "3.2",
        "--res",
        "96x8",
        "--no-lights",
        "--sigma-a",
        "1.5,1.5,1.5",
        "--sigma-s",
        "0,0,0",
        "--float",
        "--spp",
        "64",
        "--fps",
        "24",
    ];

    fn render(dir: &Path, input: &str, out: &str, extra: &[&str]) -> String {
        let mut args = vec!["render", input, "-o", out];
        args.extend(VIEW);
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
    /// seen through [`VIEW`]: the still edge (density 1 to x = 1.95, falling linearly to
    /// 0 at 2.0) averaged over the shutter's displacements and the pixel, against each
    /// column's mean (8 rows of 64 jittered samples a pixel) within 3e-3.
    fn assert_ramp(path: &Path, width: f64) {
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
            let mut v: Vec<&str> = VIEW
                .iter()
                .copied()
                .filter(|a| *a != "--no-lights")
                .collect();
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
}

/// The bias of shadows taken at the frame's time (one map at a centred shutter's centre)
/// against shadows of the volume as it is at each sample's time, on the Houdini pyro
/// fixture moved by its own `vel` grid, its motion scaled up to a blur of several voxels:
/// what docs/how-it-works.md states.
#[test]
fn shadows_at_the_shutters_centre_are_near_those_per_time() {
    use common::march::Sun;
    use murk::field::Field;
    use murk::field::VoxelGrid;
    use murk::field::advect::{Advected, GridVelocity, VelocityField};
    use murk::vdb::VdbFile;
    let path = format!("{}/fixtures/pyro.vdb", env!("CARGO_MANIFEST_DIR"));
    let file = VdbFile::open(path).unwrap();
    let pyro = VoxelGrid::load(&file, "density").unwrap();
    let vel = GridVelocity::vector(VoxelGrid::load(&file, "vel").unwrap(), false).unwrap();
    let (lo, hi) = pyro.world_bounds();
    let voxel = (hi - lo).x / pyro.active_bounds().extent().x as f64;
    // Scaled so the fastest voxel moves 4 voxels over the shutter.
    let shutter = (-0.25, 0.25);
    let per_frame = 4.0 * voxel / (vel.max_speed() * (shutter.1 - shutter.0));
    let motion = Motion {
        velocity: &vel,
        per_frame,
        frames: 0.25,
        cells: None,
    };
    let vol = Volume {
        motion: Some(motion),
        ..Volume::of(&pyro, medium(0.5, 4.0, 0.0))
    };
    let toward = DVec3::new(0.6, 1.0, 0.5).normalize();
    let settings = MarchSettings {
        step_voxels: 0.5,
        termination: 0.0,
    };
    let mut scratch = Scratch::new(1);
    let n = 24;
    let times = 16;
    let (mut still_sum, mut timed_sum, mut sq) = (0.0, 0.0, 0.0);
    for j in 0..n {
        for i in 0..n {
            let x = lo.x + (hi.x - lo.x) * (i as f64 + 0.5) / n as f64;
            let y = lo.y + (hi.y - lo.y) * (j as f64 + 0.5) / n as f64;
            let (mut still, mut timed) = (0.0, 0.0);
            for s in 0..times {
                let mut ray = WorldRay::new(DVec3::new(x, y, hi.z + 1.0), DVec3::NEG_Z);
                ray.time = shutter_time(3, i, j, s, times, shutter);
                let frame_sun = Sun {
                    field: &pyro,
                    toward,
                    irradiance: 1.0,
                };
                let moved = Advected::new(&pyro, &vel, motion.shift(ray.time));
                let time_sun = Sun {
                    field: &moved,
                    toward,
                    irradiance: 1.0,
                };
                let run = |sun: &Sun, scratch: &mut Scratch| {
                    march(&vol, Some(sun), &ray, &settings, 0.5, scratch)
                        .scatter
                        .x
                };
                still += run(&frame_sun, &mut scratch);
                timed += run(&time_sun, &mut scratch);
            }
            still_sum += still / times as f64;
            timed_sum += timed / times as f64;
            sq += ((still - timed) / times as f64).powi(2);
        }
    }
    let mean = timed_sum / (n * n) as f64;
    let rmse = (sq / (n * n) as f64).sqrt() / mean;
    let energy = (still_sum - timed_sum) / timed_sum;
    eprintln!("shadows at the frame's time: relative RMSE {rmse:.2e}, energy {energy:+.2e}");
    assert!(mean > 0.0);
    assert!(
        rmse < 0.02 && energy.abs() < 0.01,
        "rmse {rmse}, energy {energy}"
    );
}

mod camera {
    use super::cli::{alpha, write_caches};
    use super::common::frames::{ok, scratch};
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
        let look = [
            "--res",
            "96x8",
            "--no-lights",
            "--sigma-a",
            "1.5,1.5,1.5",
            "--sigma-s",
            "0,0,0",
            "--float",
            "--spp",
            "64",
            "--shutter",
            "-0.25,0.25",
        ];
        let mut args = vec!["render", "shot.toml", "-o", "cam.exr", "--frames", "2"];
        args.extend(look);
        ok(&dir, &args);
        let mut args = vec![
            "render",
            "moving.vdb",
            "-o",
            "vel.exr",
            "--camera",
            "ortho",
            "--eye",
            "1.95,1,5",
            "--look-at",
            "1.95,1,0",
            "--ortho-width",
            "3.2",
        ];
        args.extend(look);
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
}

/// Velocity grids as files hold them: NaN and Inf made 0 and counted, a staggered grid
/// read on its faces, three float grids with their negative values kept.
#[test]
fn velocity_grids_are_sanitised_staggered_and_signed() {
    use murk::field::advect::VelocityField;
    use murk::scene::source::{FieldSource, VdbSource, VelocityNames};
    need!(tools::PYOPENVDB);
    let dir = common::frames::scratch("motion-grids");
    let script = "import pyopenvdb as vdb, numpy as np, sys\n\
        t = vdb.createLinearTransform(0.5)\n\
        a = np.zeros((8, 8, 8, 3), dtype=np.float32)\n\
        a[..., 0] = 1.0\n\
        a[2, 2, 2, 1] = float('nan')\n\
        a[3, 3, 3, 2] = float('inf')\n\
        v = vdb.Vec3SGrid(); v.name = 'vel'; v.copyFromArray(a); v.transform = t\n\
        i = np.arange(8, dtype=np.float32)\n\
        s = np.zeros((8, 8, 8, 3), dtype=np.float32)\n\
        s[..., 0] = i[:, None, None]\n\
        s[..., 1] = 2 * i[None, :, None]\n\
        s[..., 2] = 3 * i[None, None, :]\n\
        g = vdb.Vec3SGrid(); g.name = 'stag'; g.copyFromArray(s); g.transform = t\n\
        g.gridClass = vdb.GridClass.STAGGERED\n\
        c = vdb.Vec3SGrid(); c.name = 'cent'; c.copyFromArray(s); c.transform = t\n\
        grids = [v, g, c]\n\
        for n, val in (('x', -2.0), ('y', 0.5), ('z', 1.0)):\n\
        \x20   f = vdb.FloatGrid(); f.name = 'vel.' + n\n\
        \x20   f.copyFromArray(np.full((8, 8, 8), val, dtype=np.float32)); f.transform = t\n\
        \x20   grids.append(f)\n\
        vdb.write(sys.argv[1], grids=grids)\n";
    let path = dir.join("grids.vdb");
    let o = tools::command(&tools::PYOPENVDB)
        .args(["-c", script, path.to_str().unwrap()])
        .output()
        .expect("/usr/bin/python3 with pyopenvdb");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let src = VdbSource::open(&path).unwrap();
    let load = |n: VelocityNames| src.load_velocity(&n).unwrap().unwrap();
    let vel = load(VelocityNames::Vector("vel".into()));
    assert_eq!((vel.sanitised.nan, vel.sanitised.inf), (1, 1));
    let p = DVec3::new(1.25, 1.5, 1.75); // index (2.5, 3, 3.5)
    assert_eq!(
        vel.field.velocity_at_world(DVec3::splat(1.0)),
        DVec3::X * 1.0
    );
    // Staggered: component c at index p lies half a voxel below p along c, so a value
    // linear in the index reads 0.5 (times its slope) more than on the centres.
    let stag = load(VelocityNames::Vector("stag".into())).field;
    let cent = load(VelocityNames::Vector("cent".into())).field;
    let (vs, vc) = (stag.velocity_at_world(p), cent.velocity_at_world(p));
    assert!(
        (vc - DVec3::new(2.5, 6.0, 10.5)).abs().max_element() < 1e-5,
        "{vc}"
    );
    assert!(
        (vs - vc - DVec3::new(0.5, 1.0, 1.5)).abs().max_element() < 1e-5,
        "{vs}"
    );
    let xyz = load(VelocityNames::Channels(
        ["vel.x", "vel.y", "vel.z"].map(String::from),
    ));
    assert_eq!(xyz.field.velocity_at_world(p), DVec3::new(-2.0, 0.5, 1.0));
    assert!((xyz.field.max_speed() - (4.0f64 + 0.25 + 1.0).sqrt()).abs() < 1e-9);
}
