//! `--scattering path` on the GPU: the same paths as the CPU's (the same random streams,
//! so far closer than the noise), a closed form, and the image the same however the
//! frame's rows are split.

use super::*;
use murk::render::piece::Piece;
use murk::render::{FrameJob, Silent, render_image_frame};
use murk::scene::reuse::FrameReuse;

pub(super) fn path(mut o: RenderOptions, spp: u32) -> RenderOptions {
    o.scattering = Some(ScatteringMode::Path);
    o.spp = Some(spp);
    o
}

fn mean(p: &[f32]) -> f64 {
    p.iter().map(|v| *v as f64).sum::<f64>() / p.len() as f64
}

/// The GPU's path-traced image of `input` against the CPU's at the same seed, and the
/// CPU's at another seed (the noise): the density samples taken within 5 %, alpha and Z
/// as exact as single scattering's; the
/// beauty's and every layer's mean within four standard errors of the CPU's (from the
/// two seeds' per-pixel differences); the beauty's per-pixel relative RMSE against the
/// CPU's under `same` (the streams are the CPU's: only paths where f32 and f64 decide
/// differently differ), and far under the noise's. Returns (GPU/CPU relative RMSE, CPU
/// seed-to-seed relative RMSE).
pub(super) fn gpu_traces_the_cpus_paths(
    input: &str,
    o: &RenderOptions,
    same: f64,
    pixel: f32,
) -> (f64, f64) {
    let cpu = render(input, o, Device::Cpu);
    let gpu = render(input, o, Device::Gpu);
    let mut other = o.clone();
    other.seed = Some(o.seed.unwrap_or(0) + 1);
    let cpu2 = render(input, &other, Device::Cpu);
    assert_eq!(gpu.stats.device, gpu_device());
    assert_eq!(cpu.frame.channel_names(), gpu.frame.channel_names());
    // The same paths take the same density samples, but where f32 decides otherwise
    // (and in spans too dense to track, whose root finding meets f32's precision a few
    // steps sooner: 2 % fewer on the slab).
    let (sg, sc) = (gpu.stats.samples as f64, cpu.stats.samples as f64);
    assert!(
        sc > 0.0 && (sg - sc).abs() <= 0.05 * sc,
        "{input}: {sg} density samples on the GPU, {sc} on the CPU"
    );
    let alpha = rmse(plane(&gpu, "A"), plane(&cpu, "A"));
    assert!(alpha <= ALPHA_RMSE, "{input}: alpha RMSE {alpha:e}");
    let (zg, zc) = (plane(&gpu, "Z"), plane(&cpu, "Z"));
    let differ = zg
        .iter()
        .zip(zc)
        .filter(|(g, c)| {
            g.is_finite() != c.is_finite() || (c.is_finite() && (*g - *c).abs() > 1e-3 * c.abs())
        })
        .count();
    assert!(
        differ * 100 <= zg.len(),
        "{input}: Z differs at {differ} pixels"
    );
    for name in cpu.frame.channel_names() {
        if name == "A" || name == "Z" {
            continue;
        }
        let (g, c, c2) = (plane(&gpu, name), plane(&cpu, name), plane(&cpu2, name));
        // The standard error of the image's mean, from the two seeds' difference.
        let n = c.len() as f64;
        let var: f64 = c
            .iter()
            .zip(c2)
            .map(|(a, b)| (*a as f64 - *b as f64).powi(2))
            .sum::<f64>()
            / 2.0;
        let se = var.sqrt() / n;
        let (mg, mc) = (mean(g), mean(c));
        assert!(
            (mg - mc).abs() <= 4.0 * se + 1e-6 * mc.abs(),
            "{input}: {name} mean {mg} on the GPU, {mc} on the CPU (standard error {se:e})"
        );
    }
    // The same paths: nearly every pixel's beauty is the CPU's within `pixel` (relative).
    let (rg, rc) = (plane(&gpu, "R"), plane(&cpu, "R"));
    let apart = rg
        .iter()
        .zip(rc)
        .filter(|(g, c)| (*g - *c).abs() > pixel * c.abs().max(1e-3))
        .count();
    assert!(
        apart * 20 <= rg.len(),
        "{input}: {apart} of {} pixels differ from the CPU's",
        rg.len()
    );
    let stage = |name: &str| gpu.stats.scene.stages.get(name).map(|s| s.seconds);
    // The shadow maps' light columns were marched on the GPU too (with maps to bake).
    let baked = o.shadows.as_deref() != Some("march");
    for name in [
        "gpu_bake",
        "gpu_upload",
        "gpu_rays",
        "gpu_march",
        "gpu_record",
    ] {
        if name == "gpu_bake" && !baked {
            assert!(stage(name).is_none(), "{name}: {:?}", stage(name));
            continue;
        }
        assert!(
            stage(name).is_some_and(|s| s > 0.0),
            "{name}: {:?}",
            stage(name)
        );
    }
    let e = rel_rmse(&gpu, &cpu, &["R", "G", "B"]);
    let noise = rel_rmse(&cpu2, &cpu, &["R", "G", "B"]);
    eprintln!("{input}, path: GPU against CPU rel. RMSE {e:e}, CPU seed to seed {noise:e}");
    assert!(
        mean(plane(&cpu, "R")) > 0.0,
        "{input}: a black image proves nothing"
    );
    assert!(e <= same, "{input}: rel. RMSE {e:e} against the CPU's");
    assert!(
        e <= 0.25 * noise,
        "{input}: rel. RMSE {e:e}, the noise's {noise:e}"
    );
    (e, noise)
}

#[test]
fn the_gpu_traces_the_cpus_paths_through_the_demo_cloud() {
    need_gpu!();
    let mut o = path(options("32x18"), 4);
    o.bounces = Some(8);
    gpu_traces_the_cpus_paths("cloud.vdb", &o, 1e-3, 1e-4);
}

#[test]
fn the_gpu_traces_paths_with_a_forward_peaked_phase_and_a_point_light() {
    need_gpu!();
    let mut o = path(forward_peaked_sphere(), 4);
    o.light.push("point:1.5,1.5,1.5:1,0.8,0.6:20".into());
    gpu_traces_the_cpus_paths("sphere.vdb", &o, 1e-3, 1e-4);
}

#[test]
fn the_gpu_traces_paths_through_a_coloured_medium_by_spectral_tracking() {
    need_gpu!();
    // One sample a pixel: the silhouette's pixels are traced again on the 4×4 grid.
    let o = path(two_lights_in_a_coloured_medium(), 1);
    gpu_traces_the_cpus_paths("cloud.vdb", &o, 1e-3, 1e-4);
}

#[test]
fn a_scattering_slab_seen_straight_through_has_the_closed_form_alpha_on_the_gpus_paths() {
    need_gpu!();
    // slab.vdb: ∫ρ dz = 1 world unit straight through, so alpha = 1 − e^{−σt} whatever
    // scatters; the scattered light is the CPU's.
    let mut o = path(options("8x8"), 4);
    o.camera = Some("ortho".into());
    o.eye = Some("0,0,5".into());
    o.look_at = Some("0,0,0".into());
    o.ortho_width = Some(0.5);
    o.sigma_a = Some("0.3,0.3,0.3".into());
    o.sigma_s = Some("0.9,0.9,0.9".into());
    let gpu = render("slab.vdb", &o, Device::Gpu);
    let want = 1.0 - (-1.2f64).exp();
    for a in plane(&gpu, "A") {
        assert!(
            (*a as f64 - want).abs() < 1e-5,
            "alpha {a}, closed form {want}"
        );
    }
    assert!(mean(plane(&gpu, "R")) > 0.0);
}

#[test]
fn the_gpu_tracks_shadow_rays_and_finds_the_environment_as_the_cpu_does() {
    need_gpu!();
    // --shadows march: every light's transmittance by ratio tracking on its own stream;
    // the dome: a path's escape after an event, and the last event's tracked ray.
    let mut o = path(options("32x18"), 2);
    o.light = vec![
        "sun:0.3,1,0.2:1,0.9,0.8:4".into(),
        "point:2,2,3:0.6,0.8,1:30".into(),
        "env:0.3,0.4,0.6".into(),
    ];
    o.shadows = Some("march".into());
    o.bounces = Some(4);
    gpu_traces_the_cpus_paths("cloud.vdb", &o, 1e-3, 1e-4);
}

#[test]
fn the_gpu_crosses_spans_too_dense_to_track_by_their_integral() {
    need_gpu!();
    // σt = 3000 in slab.vdb (voxels 0.05 wide): a majorant block's optical depth is
    // ~600, over the 256 above which a flight goes on by the density's integral.
    let mut o = path(options("8x8"), 4);
    o.camera = Some("ortho".into());
    o.eye = Some("0.3,0.4,5".into());
    o.look_at = Some("0,0,0".into());
    o.ortho_width = Some(0.5);
    o.sigma_a = Some("2000,2000,2000".into());
    o.sigma_s = Some("1000,1000,1000".into());
    o.bounces = Some(16);
    gpu_traces_the_cpus_paths("slab.vdb", &o, 1e-3, 1e-2);
}

#[test]
fn the_gpus_paths_are_the_same_however_the_rows_are_split() {
    need_gpu!();
    // Each piece is its own dispatch, with its samples at other places in it.
    let mut o = path(options("24x12"), 3);
    o.device = Some(Device::Gpu);
    let plan = RenderPlan::new(&o, fixture("cloud.vdb")).unwrap();
    let frame = |piece| {
        render_image_frame(
            &plan,
            &Silent,
            &mut FrameReuse::default(),
            FrameJob { frame: None, piece },
        )
        .unwrap()
    };
    let whole = frame(None);
    assert!(
        whole.stats.device.starts_with("gpu"),
        "{}",
        whole.stats.device
    );
    let w = 24;
    for count in [3] {
        for index in 1..=count {
            let p = Piece { index, count };
            let part = frame(Some(p));
            for name in ["R", "G", "B", "A"] {
                let (a, b) = (plane(&part, name), plane(&whole, name));
                for y in p.rows(12) {
                    for x in 0..w {
                        let at = if a.len() == b.len() {
                            y * w + x
                        } else {
                            (y - p.rows(12).start) * w + x
                        };
                        assert_eq!(
                            a[at].to_bits(),
                            b[y * w + x].to_bits(),
                            "{name} at {x},{y}, piece {p}"
                        );
                    }
                }
            }
        }
    }
    assert!(mean(plane(&whole, "R")) > 0.0);
}
