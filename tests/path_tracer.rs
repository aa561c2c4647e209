//! The path tracer (`--scattering path`) against what must hold exactly, within its
//! own noise (every comparison is "within 5 standard errors", the standard error
//! measured from the samples themselves):
//!
//! - **white furnace**: a non-absorbing medium under a uniform dome of radiance 1
//!   scatters toward the camera exactly the light it takes out of the view ray:
//!   `scatter_c = 1 − T_c` per channel, for any density — grey and chromatic σ;
//! - **energy**: a non-absorbing slab under a sun reflects and transmits (diffuse plus
//!   unscattered) all the flux it receives, `F_r + F_t + E·μ0·e^{−τ/μ0} = E·μ0`, by
//!   Monte Carlo over cosine-weighted directions at the slab's centre;
//! - **one bounce is single scattering**: `--bounces 1` on the closed forms of
//!   `tests/accuracy.rs` (S2: homogeneous sphere, three cases; S3: stratified slab
//!   under a grazing sun), with the shadow lookup and with ratio tracking;
//! - the camera ray's opacity is exact (1e-9), not sampled;
//! - next-event estimation through the deep shadow map is biased by no more than the
//!   map's tolerance allows against unbiased ratio tracking, on the demo cloud.

mod common;

use common::march::{Sun, grey, medium, rel};
use glam::{DMat4, DVec3, IVec3};
use murk::field::VoxelGrid;
use murk::field::shapes::{ConstantBox, ConstantSphere};
use murk::integrate::integrator::{CameraSample, Integrator, SampleRng};
use murk::integrate::path::{LightTransmittance, PathSettings, PathTracer};
use murk::integrate::phase::hg;
use murk::integrate::{
    Illumination, MarchSettings, Medium, ScatteringMode, Scratch, Volume, WorldRay, march,
};
use murk::render::{RenderOptions, RenderPlan, render_image};

/// Per-sample values of pass `name` (RGB) and of alpha, for one camera ray per sample
/// from `ray_of(s)`.
fn run(
    pt: &PathTracer,
    name: &str,
    n: u32,
    ray_of: impl Fn(u32) -> (DVec3, DVec3),
) -> (Vec<DVec3>, Vec<f64>) {
    let layout = pt.passes().clone();
    let off = layout.offset(layout.find(name).expect("pass"));
    let alpha_at = layout.offset(layout.find("A").expect("alpha"));
    let mut acc = vec![0.0; layout.slots()];
    let (mut vals, mut alphas) = (Vec::new(), Vec::new());
    for s in 0..n {
        let (o, d) = ray_of(s);
        acc.fill(0.0);
        let cam = CameraSample {
            ray: WorldRay::new(o, d),
            depth_rate: 1.0,
        };
        let mut rng = SampleRng::new(0x5eed, 3, 4, s);
        pt.sample(&cam, &mut rng, &mut pt.scratch(), &mut acc);
        vals.push(DVec3::new(acc[off], acc[off + 1], acc[off + 2]));
        alphas.push(acc[alpha_at]);
    }
    (vals, alphas)
}

/// Mean and standard error of the mean, per channel.
fn mean_se(v: &[DVec3]) -> (DVec3, DVec3) {
    let n = v.len() as f64;
    let mean = v.iter().copied().sum::<DVec3>() / n;
    let var = v.iter().map(|x| (*x - mean) * (*x - mean)).sum::<DVec3>() / (n - 1.0);
    (mean, (var / n).powf(0.5))
}

fn assert_within(what: &str, got: (DVec3, DVec3), want: DVec3, floor: f64) {
    let (mean, se) = got;
    for c in 0..3 {
        let tol = 5.0 * se[c] + floor;
        assert!(tol.is_finite(), "{what}: not finite");
        assert!(
            (mean[c] - want[c]).abs() <= tol,
            "{what}: channel {c}: {} vs {} (5 SE = {})",
            mean[c],
            want[c],
            5.0 * se[c]
        );
    }
}

fn settings(bounces: u32, transmittance: LightTransmittance) -> PathSettings {
    PathSettings {
        bounces,
        transmittance,
    }
}

/// Transmittance per channel along a ray, exactly (the reference march).
fn transmittance(vol: &Volume, o: DVec3, d: DVec3) -> DVec3 {
    march(
        vol,
        None,
        &WorldRay::new(o, d),
        &MarchSettings::reference(),
        0.5,
        &mut Scratch::new(0),
    )
    .transmittance
}

/// A smooth heterogeneous blob (every cell has its own majorant, none is constant).
fn blob() -> VoxelGrid {
    let voxels = (-20..=20).flat_map(|i| {
        (-20..=20).flat_map(move |j| {
            (-20..=20).map(move |k| {
                let r2 = (i * i + j * j + k * k) as f64 / 100.0;
                (IVec3::new(i, j, k), (1.5 * (-r2).exp()) as f32)
            })
        })
    });
    VoxelGrid::from_voxels("density", voxels, DMat4::from_scale(grey(0.05))).unwrap()
}

/// White furnace: no absorption, a dome of radiance 1: every path that scatters escapes
/// with its full weight, so `scatter = 1 − T` per channel, at densities from thin to
/// thick, grey and chromatic (spectral tracking must stay unbiased per channel), with
/// an anisotropic phase function.
#[test]
fn white_furnace_scatter_equals_one_minus_transmittance() {
    let grid = blob();
    let rays = [
        (DVec3::new(0.0, 0.0, 3.0), DVec3::NEG_Z),
        (DVec3::new(0.3, -0.2, 3.0), DVec3::new(-0.05, 0.02, -1.0)),
        (DVec3::new(-3.0, 0.6, 0.1), DVec3::X),
    ];
    for sigma_s in [grey(2.0), DVec3::new(0.5, 1.5, 3.0)] {
        for scale in [0.25, 2.0, 6.0] {
            let m = Medium {
                sigma_a: DVec3::ZERO,
                sigma_s,
                density_scale: scale,
                g: 0.6,
            };
            let vol = Volume::of(&grid, m);
            let pt = PathTracer::new(
                &vol,
                false,
                None,
                Some((DVec3::ONE, "env0".into())),
                settings(1_000_000, LightTransmittance::Lookup),
            );
            for (o, d) in rays {
                let d = d.normalize();
                let (vals, alphas) = run(&pt, "scatter", 3000, |_| (o, d));
                let want = DVec3::ONE - transmittance(&vol, o, d);
                // Where nearly every path scatters, the samples' own spread can be 0:
                // the floor is a Bernoulli draw's standard error at `want`.
                let bernoulli = (want * (DVec3::ONE - want)).max_element() / vals.len() as f64;
                assert_within(
                    &format!("σs {sigma_s} × {scale}, ray {o}"),
                    mean_se(&vals),
                    want,
                    5.0 * bernoulli.sqrt() + 1e-9,
                );
                // The camera ray's opacity is exact.
                let a = alphas[0];
                assert!(rel(a, want.element_sum() / 3.0) < 1e-9, "α {a} vs {want}");
            }
        }
    }
}

/// Energy: a non-absorbing slab (τ = 1 vertically, 60 thicknesses wide) under a sun at
/// μ0 = 0.8: flux up out of the top plus flux down out of the bottom, diffuse, plus the
/// unscattered beam, is the flux in. Radiance leaving the centre of each face is
/// sampled over cosine-weighted directions (F = π·E[L]).
#[test]
fn energy_a_non_absorbing_slab_returns_all_the_light() {
    let (w, h) = (30.0, 1.0);
    let slab = ConstantBox::new(DVec3::new(-w, -w, 0.0), DVec3::new(w, w, h), 1.0, 0.05).unwrap();
    let mu0: f64 = 0.8;
    let toward = DVec3::new((1.0 - mu0 * mu0).sqrt(), 0.0, mu0);
    let e = 2.0;
    let sun = Sun {
        field: &slab,
        toward,
        irradiance: e,
    };
    for (sigma_s, g) in [(grey(1.0), 0.0), (DVec3::new(0.3, 1.0, 2.5), 0.7)] {
        let vol = Volume::of(
            &slab,
            Medium {
                sigma_a: DVec3::ZERO,
                sigma_s,
                density_scale: 1.0,
                g,
            },
        );
        for transmittance in [
            LightTransmittance::Lookup,
            LightTransmittance::RatioTracking,
        ] {
            let pt = PathTracer::new(
                &vol,
                false,
                Some((&sun as &dyn Illumination, vec!["sun0".into()])),
                None,
                settings(1_000_000, transmittance),
            );
            // A cosine-weighted direction out of a face (up for the top, down for the
            // bottom), from two uniform numbers of sample s.
            let dir = |s: u32, up: bool| {
                let mut r = murk::field::random::SplitMix64(0xface ^ (s as u64) << 1 | up as u64);
                let (u1, u2) = (r.next_f64(), r.next_f64());
                let (rad, phi) = (u1.sqrt(), 2.0 * std::f64::consts::PI * u2);
                let z = (1.0 - u1).max(0.0).sqrt();
                DVec3::new(rad * phi.cos(), rad * phi.sin(), if up { z } else { -z })
            };
            let n = 4000;
            let top = DVec3::new(0.0, 0.0, h);
            let (up, _) = run(&pt, "scatter", n, |s| {
                let w = dir(s, true);
                (top + w * 1e-3, -w)
            });
            let (down, _) = run(&pt, "scatter", n, |s| {
                let w = dir(s, false);
                (w * 1e-3, -w)
            });
            let pi = std::f64::consts::PI;
            let flux: Vec<DVec3> = up.iter().zip(&down).map(|(a, b)| (*a + *b) * pi).collect();
            let tau = sigma_s * h;
            let unscattered = (-tau / mu0).exp() * e * mu0;
            let (mean, se) = mean_se(&flux);
            assert_within(
                &format!("σs {sigma_s}, g {g}, {transmittance:?}"),
                (mean + unscattered, se),
                grey(e * mu0),
                1e-3 * e,
            );
        }
    }
}

/// S2 with one bounce: the homogeneous sphere (R = 1, σa 0.4, σs 1.1, g 0.3, E = 3),
/// sun behind the camera, behind the sphere, and the camera at the centre.
#[test]
fn one_bounce_is_single_scattering_on_the_sphere() {
    let r = 1.0;
    let sphere = ConstantSphere::new(DVec3::ZERO, r, 1.0, 0.05).unwrap();
    let (sigma_a, sigma_s, e, g) = (0.4, 1.1, 3.0, 0.3);
    let sigma_t = sigma_a + sigma_s;
    let vol = Volume::of(&sphere, medium(sigma_a, sigma_s, g));
    let sun = |toward| Sun {
        field: &sphere,
        toward,
        irradiance: e,
    };
    let (behind_camera, behind_sphere) = (sun(DVec3::Z), sun(DVec3::NEG_Z));
    for transmittance in [
        LightTransmittance::Lookup,
        LightTransmittance::RatioTracking,
    ] {
        for b in [0.0, 0.5, 0.9] {
            let ell = 2.0 * (r * r - b * b).sqrt();
            let h = ell / 2.0;
            let o = DVec3::new(b, 0.0, 4.0);
            let back =
                sigma_s * hg(-1.0, g) * e * -(-2.0 * sigma_t * ell).exp_m1() / (2.0 * sigma_t);
            let front = sigma_s * hg(1.0, g) * e * ell * (-sigma_t * ell).exp();
            let inside =
                sigma_s * hg(-1.0, g) * e * (-sigma_t * h).exp() * -(-2.0 * sigma_t * h).exp_m1()
                    / (2.0 * sigma_t);
            let centre = DVec3::new(b, 0.0, 0.0);
            for (name, light, origin, want, alpha) in [
                (
                    "sun behind camera",
                    &behind_camera,
                    o,
                    back,
                    -(-sigma_t * ell).exp_m1(),
                ),
                (
                    "sun behind sphere",
                    &behind_sphere,
                    o,
                    front,
                    -(-sigma_t * ell).exp_m1(),
                ),
                (
                    "camera inside",
                    &behind_camera,
                    centre,
                    inside,
                    -(-sigma_t * h).exp_m1(),
                ),
            ] {
                let pt = PathTracer::new(
                    &vol,
                    false,
                    Some((light as &dyn Illumination, vec!["sun0".into()])),
                    None,
                    settings(1, transmittance),
                );
                let (vals, alphas) = run(&pt, "scatter", 4000, |_| (origin, DVec3::NEG_Z));
                assert_within(
                    &format!("{name}, b {b}, {transmittance:?}"),
                    mean_se(&vals),
                    grey(want),
                    1e-12,
                );
                assert!(
                    rel(alphas[0], alpha) < 1e-9,
                    "{name}: α {} vs {alpha}",
                    alphas[0]
                );
                // Nothing scattered twice with one bounce.
                let (ind, _) = run(&pt, "indirect", 8, |_| (origin, DVec3::NEG_Z));
                assert!(ind.iter().all(|v| *v == DVec3::ZERO));
            }
        }
    }
}

/// S3 with one bounce: a slab whose σt ramps linearly with depth, under a sun grazing at
/// μl = 0.05: `L = a·p·E(1 − e^{−Kτ_D})/(μv·K)`, `K = 1/μv + 1/μl`.
#[test]
fn one_bounce_is_single_scattering_on_the_stratified_slab() {
    const NZ: i32 = 16;
    let (rho0, rho1) = (0.02f32, 0.12f32);
    let layer = |k: i32| rho0 + (rho1 - rho0) * k as f32 / (NZ - 1) as f32;
    let mut voxels = Vec::new();
    for i in -48..=400 {
        for j in -3..=3 {
            for k in 0..NZ {
                voxels.push((IVec3::new(i, j, k), layer(k)));
            }
        }
    }
    let grid = VoxelGrid::from_voxels("density", voxels, DMat4::IDENTITY).unwrap();
    let column: f64 = (0..NZ).map(|k| layer(k) as f64).sum();
    let (sigma_a, sigma_s, g) = (0.3, 1.2, 0.4);
    let sigma_t = sigma_a + sigma_s;
    let vol = Volume::of(&grid, medium(sigma_a, sigma_s, g));
    let (mu_l, e): (f64, f64) = (0.05, 2.0);
    let toward = DVec3::new((1.0 - mu_l * mu_l).sqrt(), 0.0, mu_l);
    let sun = Sun {
        field: &grid,
        toward,
        irradiance: e,
    };
    for transmittance in [
        LightTransmittance::Lookup,
        LightTransmittance::RatioTracking,
    ] {
        let pt = PathTracer::new(
            &vol,
            false,
            Some((&sun as &dyn Illumination, vec!["sun0".into()])),
            None,
            settings(1, transmittance),
        );
        for mu_v in [1.0f64, 0.5] {
            let d = DVec3::new(-(1.0 - mu_v * mu_v).sqrt(), 0.0, -mu_v);
            let o = DVec3::new(0.37, 0.3, NZ as f64 + 2.0) - d * 2.0;
            let tau_d = sigma_t * column;
            let k = 1.0 / mu_v + 1.0 / mu_l;
            let want =
                sigma_s / sigma_t * hg(toward.dot(d), g) * e * -(-k * tau_d).exp_m1() / (mu_v * k);
            let (vals, alphas) = run(&pt, "scatter", 4000, |_| (o, d));
            assert_within(
                &format!("μv {mu_v}, {transmittance:?}"),
                mean_se(&vals),
                grey(want),
                1e-12,
            );
            let alpha = -(-tau_d / mu_v).exp_m1();
            assert!(rel(alphas[0], alpha) < 1e-9, "α {} vs {alpha}", alphas[0]);
        }
    }
}

fn plan(flags: &[(&str, &str)]) -> RenderPlan {
    let mut o = RenderOptions {
        output: Some("x.exr".into()),
        res: Some("40x24".into()),
        scattering: Some(ScatteringMode::Path),
        float: true,
        quiet: true,
        ..Default::default()
    };
    for (k, v) in flags {
        match *k {
            "light" => o.light.push(v.to_string()),
            "sigma_a" => o.sigma_a = Some(v.to_string()),
            "sigma_s" => o.sigma_s = Some(v.to_string()),
            "density_scale" => o.density_scale = Some(v.parse().unwrap()),
            "spp" => o.spp = Some(v.parse().unwrap()),
            "threads" => o.threads = Some(v.parse().unwrap()),
            "seed" => o.seed = Some(v.parse().unwrap()),
            "shadows" => o.shadows = Some(v.to_string()),
            "dsm_tolerance" => o.dsm_tolerance = Some(v.parse().unwrap()),
            "g" => o.g = Some(v.parse().unwrap()),
            other => panic!("{other}"),
        }
    }
    let cloud = format!("{}/fixtures/cloud.vdb", env!("CARGO_MANIFEST_DIR"));
    RenderPlan::new(&o, cloud.into()).unwrap()
}

fn channel<'a>(f: &'a murk::output::Frame, name: &str) -> &'a [f32] {
    f.channel(name)
        .unwrap_or_else(|| panic!("no {name} in {:?}", f.channel_names()))
}

/// The white furnace on the demo cloud, through the whole render: beauty = alpha in
/// every pixel within a Bernoulli draw's noise (each path either scatters and escapes
/// with weight 1 or never scatters), at densities ×0.25, ×1 and ×4, and the mean over
/// the image within its own standard error.
#[test]
fn white_furnace_on_the_demo_cloud_beauty_equals_alpha() {
    let spp = 64.0;
    for scale in ["0.25", "1", "4"] {
        let p = plan(&[
            ("light", "env:1,1,1:1"),
            ("sigma_a", "0,0,0"),
            ("density_scale", scale),
            ("spp", "64"),
            ("g", "0.5"),
        ]);
        let f = render_image(&p).unwrap().frame;
        let (r, a) = (channel(&f, "R"), channel(&f, "A"));
        let (mut sum_d, mut sum_var, mut lit) = (0.0, 0.0, 0);
        for (i, (&r, &a)) in r.iter().zip(a).enumerate() {
            let (r, a) = (r as f64, a as f64);
            let var = a * (1.0 - a) / spp;
            assert!(
                (r - a).abs() <= 6.0 * var.sqrt() + 1e-6,
                "×{scale}, pixel {i}: beauty {r} vs alpha {a}"
            );
            sum_d += r - a;
            sum_var += var;
            lit += (a > 0.0) as usize;
        }
        assert!(lit > 100, "×{scale}: only {lit} pixels see the cloud");
        assert!(
            sum_d.abs() <= 5.0 * sum_var.sqrt() + 1e-4,
            "×{scale}: Σ(beauty − alpha) {sum_d}, 5 SE {}",
            5.0 * sum_var.sqrt()
        );
    }
}

/// The same seed gives the same image on 1 and 3 threads (each path draws from streams
/// of its own pixel sample), and another seed another image; scatter is the sum of the
/// per-light layers, indirect is part of it, and the direct part (scatter − indirect)
/// is single scattering's within the noise.
#[test]
fn deterministic_layers_add_up_and_the_direct_part_is_single_scattering() {
    let flags = [
        ("light", "sun:0.6,1,0.5:1,1,1:6"),
        ("light", "env:0.2,0.3,0.5:1"),
        ("spp", "16"),
    ];
    let render = |extra: (&str, &str)| {
        let mut f = flags.to_vec();
        f.push(extra);
        render_image(&plan(&f)).unwrap().frame
    };
    let one = render(("threads", "1"));
    let three = render(("threads", "3"));
    for name in one.channel_names() {
        assert_eq!(channel(&one, name), channel(&three, name), "{name}");
    }
    let other = render(("seed", "9"));
    assert_ne!(channel(&one, "scatter.R"), channel(&other, "scatter.R"));
    for c in ["R", "G", "B"] {
        let all = channel(&one, &format!("scatter.{c}"));
        let ind = channel(&one, &format!("indirect.{c}"));
        let sun = channel(&one, &format!("scatter_sun0.{c}"));
        let env = channel(&one, &format!("scatter_env0.{c}"));
        for i in 0..all.len() {
            assert!(
                (all[i] - sun[i] - env[i]).abs() <= 1e-5 * all[i].abs().max(1e-3),
                "{c} {i}"
            );
            assert!(
                ind[i] >= 0.0 && ind[i] <= all[i] * (1.0 + 1e-5) + 1e-7,
                "{c} {i}"
            );
        }
    }
    // The sun's direct light against single scattering (the march): mean over the image.
    let mut single = plan(&[("light", "sun:0.6,1,0.5:1,1,1:6"), ("spp", "16")]);
    // Single scattering explicitly (the default mode is fast).
    single.transport = Default::default();
    single.transport.mode = murk::integrate::ScatteringMode::Single;
    let s = render_image(&single).unwrap().frame;
    let p = render_image(&plan(&[("light", "sun:0.6,1,0.5:1,1,1:6"), ("spp", "64")]))
        .unwrap()
        .frame;
    let mean = |f: &murk::output::Frame, n: &str| {
        channel(f, n).iter().map(|&v| v as f64).sum::<f64>() / channel(f, n).len() as f64
    };
    let direct = mean(&p, "scatter.R") - mean(&p, "indirect.R");
    let want = mean(&s, "scatter.R");
    assert!(
        rel(direct, want) < 0.02,
        "direct {direct} vs single scattering {want}"
    );
    assert!(
        s.channel("indirect.R").is_none(),
        "single writes no indirect"
    );
}

/// Next-event estimation through the deep shadow map against ratio tracking on the demo
/// cloud, at ×1 and ×4 and two tolerances. A path's flights and events draw from streams
/// of their own, so the three renders below follow the same paths and differ only in
/// the transmittance each event's sun sample is multiplied by: through the map `T_m`,
/// by ratio tracking an unbiased estimate of the true `T`, with `--shadows none` 1. The
/// map's error is at most its tolerance, `|T_m − T| ≤ tol`, so per pixel the expected
/// difference `map − ratio` is at most `tol × none` (the same paths' sun samples with
/// T = 1). Checked on the image's sum, within 5 standard errors of the ratio-tracking
/// noise (the difference's spread over the pixels), and the measured bias printed.
#[test]
fn shadow_map_bias_of_next_event_estimation_is_within_its_tolerance() {
    for (scale, tol) in [("1", "1e-3"), ("1", "1e-2"), ("4", "1e-2")] {
        let render = |shadows: &str| {
            let f = render_image(&plan(&[
                ("light", "sun:0.6,1,0.5:1,1,1:6"),
                ("density_scale", scale),
                ("spp", "128"),
                ("shadows", shadows),
                ("dsm_tolerance", tol),
            ]))
            .unwrap()
            .frame;
            channel(&f, "scatter.R")
                .iter()
                .map(|&v| v as f64)
                .collect::<Vec<_>>()
        };
        let (map, ratio, none) = (render("dsm"), render("march"), render("none"));
        let n = map.len() as f64;
        let d: Vec<f64> = map.iter().zip(&ratio).map(|(m, r)| m - r).collect();
        let mean_d = d.iter().sum::<f64>() / n;
        let var = d.iter().map(|x| (x - mean_d).powi(2)).sum::<f64>() / (n - 1.0);
        let se = (var / n).sqrt();
        let bound = tol.parse::<f64>().unwrap() * none.iter().sum::<f64>() / n;
        let mean_r = ratio.iter().sum::<f64>() / n;
        println!(
            "×{scale} tol {tol}: map − ratio {mean_d:.3e} (SE {se:.1e}), tol × none {bound:.3e}, \
             relative to the image {:.2e}",
            mean_d / mean_r
        );
        assert!(
            mean_d.abs() <= bound + 5.0 * se,
            "×{scale} tol {tol}: map − ratio {mean_d} beyond tol × none {bound} + 5 SE {se}"
        );
        assert!(bound > 0.0 && mean_r > 0.0);
    }
}
