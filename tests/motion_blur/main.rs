//! Motion blur from a velocity: a slab moving at constant velocity against the closed
//! form of its blurred edge, a still one bit for bit, and `murk render --shutter` end to
//! end on a cache with a velocity grid (`cli`), a moving camera (`camera`) and moving
//! `[[volume]]`s (`keyed`).

#[path = "../common/mod.rs"]
mod common;

mod budget;
mod camera;
mod cli;
mod keyed;

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
