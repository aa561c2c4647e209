//! Memory: a scene whose grid exceeds the GPU's largest buffer (made so by lowering the
//! limit murk sees, MURK_GPU_MAX_BINDING) has its node tables and values cut into up to
//! four buffers each and renders as it does whole; one that four parts cannot hold is
//! never rendered wrong or refused silently: under `--device auto` the CPU renders it
//! with a note saying why, under `gpu` one line refuses it.

use super::*;
use common::volumes::{channel, channel_names};
use murk::render::gpu::MAX_BINDING_VAR;

/// murk's stderr, exit code and stats (null where none were written) for a render of
/// `input` with `args` (single scattering unless they say) and `env` set, into `out` (an EXR in a scratch folder).
fn render_with(
    input: &str,
    out: &str,
    args: &[&str],
    env: &[(&str, &str)],
) -> (String, Option<i32>, serde_json::Value, PathBuf) {
    let dir = scratch(&format!("gpu-memory-{out}"));
    let exr = dir.join(format!("{out}.exr"));
    let stats = dir.join(format!("{out}.json"));
    let _ = std::fs::remove_file(&stats);
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_murk"))
        .current_dir(&dir)
        .arg("render")
        .arg(fixture(input))
        .arg("-o")
        .arg(&exr)
        .arg("--stats")
        .arg(&stats)
        .args(args)
        .args(if args.contains(&"--scattering") {
            &[][..]
        } else {
            &["--scattering", "single"][..]
        })
        .envs(env.iter().copied())
        .output()
        .unwrap();
    let stats = std::fs::read_to_string(&stats)
        .ok()
        .and_then(|s| serde_json::from_str(&s).ok())
        .unwrap_or_default();
    let err = String::from_utf8_lossy(&run.stderr).into_owned();
    (err, run.status.code(), stats, exr)
}

#[test]
fn a_grid_cut_into_parts_renders_bit_for_bit_as_it_does_whole() {
    need_gpu!();
    // houdini_pyro.vdb: density, temperature and a colour grid Cd, lit through the
    // shadow map. Its node tables are 2.25 MiB, its values 3.75 MiB (every grid's), the
    // map's three buffers 1.4 MiB each: a 1.5 MiB binding cuts the grid into parts of
    // 1 MiB, the tables into 3, the values into 4 (a boundary inside the temperature's
    // and the colour's leaves, whose values do not start on a part).
    let gpu = ["--device", "gpu", "--res", "32x18"];
    let limit = [(MAX_BINDING_VAR, "1572864")];
    let (err, code, cut, cut_exr) = render_with("houdini_pyro.vdb", "cut", &gpu, &limit);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(cut["gpu_grid_parts"], serde_json::json!([3, 4]), "{err}");
    assert_eq!(cut["device"], gpu_device().as_str());
    let (err, code, whole, whole_exr) = render_with("houdini_pyro.vdb", "whole", &gpu, &[]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(whole["gpu_grid_parts"], serde_json::json!([1, 1]));
    // Every channel the same to the bit: a part chosen off by one reads another value.
    let names = channel_names(&whole_exr);
    assert_eq!(names, channel_names(&cut_exr));
    for name in &names {
        let (a, b) = (channel(&cut_exr, name), channel(&whole_exr, name));
        let same = a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(same && a.len() == b.len(), "{name} differs");
    }
    // And whole, the GPU's image is the CPU's (within the suite's tolerances).
    gpu_matches_cpu("houdini_pyro.vdb", &options("32x18"));
}

/// A grid cut into parts renders with marched shadow rays and under the path tracer
/// bit for bit as it does whole, on an adapter that does not run on the CPU (an NVIDIA
/// H200 does). On one that does (lavapipe compiles the march wrongly, ending some rays
/// early, and did not finish the path tracer) both are refused in one line, unless
/// MURK_GPU_CUT_ANYWAY asks for them: then they must render as whole, which is how a
/// newer driver is checked (`MURK_GPU_CUT_ANYWAY=1 cargo test --release --test gpu --
/// cut_grid`).
#[test]
fn a_cut_grid_under_shadow_rays_and_paths_renders_as_whole_or_is_refused_on_the_cpu() {
    need_gpu!();
    use murk::render::gpu::CUT_ANYWAY_VAR;
    // The fixture, its flags, the binding that cuts it, into how many parts, and the
    // refusal on an adapter that runs on the CPU.
    type Case<'a> = (&'a str, &'a [&'a str], &'a str, [u64; 2], &'a str);
    let cases: [Case; 2] = [
        (
            "cloud.vdb",
            &["--res", "32x18", "--antialias", "1", "--shadows", "march"],
            "1048576",
            [2, 4],
            "is not marched with shadow rays (--shadows march) on an adapter that runs on the CPU",
        ),
        (
            "houdini_pyro.vdb",
            &["--res", "16x9", "--scattering", "path"],
            "1572864",
            [3, 4],
            "is not path traced on an adapter that runs on the CPU",
        ),
    ];
    let anyway = std::env::var(CUT_ANYWAY_VAR).is_ok_and(|v| v.trim() == "1");
    let refused = test_gpu().on_cpu && !anyway;
    for (input, args, limit, parts, refusal) in cases {
        let mut gpu = vec!["--device", "gpu"];
        gpu.extend(args);
        let (err, code, cut, cut_exr) =
            render_with(input, "cut-or-refused", &gpu, &[(MAX_BINDING_VAR, limit)]);
        if refused {
            assert_eq!(code, Some(2), "{input}: {err}");
            assert_eq!(err.lines().count(), 1, "{err}");
            assert!(err.contains(refusal), "{err}");
            continue;
        }
        assert_eq!(code, Some(0), "{input}: {err}");
        assert_eq!(cut["gpu_grid_parts"], serde_json::json!(parts), "{input}");
        let (err, code, _, whole_exr) = render_with(input, "whole-not-refused", &gpu, &[]);
        assert_eq!(code, Some(0), "{input}: {err}");
        for name in channel_names(&whole_exr) {
            let (a, b) = (channel(&cut_exr, &name), channel(&whole_exr, &name));
            let differ = a
                .iter()
                .zip(&b)
                .filter(|(x, y)| x.to_bits() != y.to_bits())
                .count();
            assert_eq!(
                differ, 0,
                "{input} {args:?}: {name} differs in {differ} pixels"
            );
        }
    }
}

/// The shadow bake's light columns marched over a grid cut into parts bake the map they
/// bake over it whole, to the bit: the same bricks, and ∫ρ ds the same float everywhere
/// (a part chosen off by one reads another voxel's value). A sun and a point light over
/// cloud.vdb, whose node tables (1.1 MiB) and values (a little over 3 MiB) a 1 MiB
/// binding cuts into 2 and 4 parts.
#[test]
fn the_bakes_columns_over_a_cut_grid_bake_the_map_they_bake_whole() {
    use glam::DVec3;
    use murk::field::{Field, VoxelGrid};
    use murk::render::gpu::{Gpu, GpuColumns};
    use murk::shadow::{BakeSettings, LightGeometry, bake_with};
    need_gpu!();
    let gpu = Gpu::shared().unwrap();
    let path = fixture("cloud.vdb");
    let g = VoxelGrid::load(&murk::vdb::VdbFile::open(&path).unwrap(), "density").unwrap();
    let settings = BakeSettings::new(1e-3, DVec3::splat(3.0));
    let lights = [
        LightGeometry::Sun {
            travel: -DVec3::new(0.6, 1.0, 0.5).normalize(),
        },
        LightGeometry::Point {
            position: g.transform().index_to_world(DVec3::new(60.0, 90.0, 40.0)),
        },
    ];
    for light in lights {
        let whole = GpuColumns::new(gpu);
        let (whole_map, whole_report) = bake_with(&g, light, &settings, Some(&whole));
        let cut = GpuColumns::binding_at_most(gpu, 1 << 20);
        let (cut_map, cut_report) = bake_with(&g, light, &settings, Some(&cut));
        assert_eq!((whole.failure(), cut.failure()), (None, None), "{light:?}");
        assert_eq!(whole.grid_parts(), [1, 1]);
        assert_eq!(cut.grid_parts(), [2, 4], "{light:?}");
        assert!(cut_report.columns > 0 && cut.times().marched == cut_report.columns);
        assert_eq!(
            (
                whole_report.bricks,
                whole_report.columns,
                whole_report.memory_bytes
            ),
            (
                cut_report.bricks,
                cut_report.columns,
                cut_report.memory_bytes
            ),
            "{light:?}"
        );
        let (lo, hi) = (
            g.active_bounds().min.as_dvec3(),
            g.active_bounds().max.as_dvec3(),
        );
        let mut rng = murk::field::random::SplitMix64(11);
        let mut deepest = 0.0f64;
        for _ in 0..20_000 {
            let u = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64());
            let p = g.transform().index_to_world(lo + (hi - lo) * u);
            let (a, b) = (whole_map.density_integral(p), cut_map.density_integral(p));
            assert_eq!(
                a.to_bits(),
                b.to_bits(),
                "{light:?} at {p}: {a} whole, {b} cut"
            );
            deepest = deepest.max(a);
        }
        assert!(
            deepest > 0.1,
            "{light:?}: a map without shadow proves nothing"
        );
    }
}

#[test]
fn every_word_read_through_the_cut_arrays_is_the_word_at_that_index() {
    need_gpu!();
    use murk::render::gpu::{GridBinding, read_back};
    let gpu = test_gpu();
    // Parts of 8, 256 and 512 words (a part's boundary inside a leaf's 512 values, at
    // one, and a multiple of them), the last part short or full, 1 to 4 parts.
    for shift in [3u32, 8, 9] {
        let part = 1usize << shift;
        for words in [part - 1, part + 1, 3 * part - 5, 4 * part] {
            let tree: Vec<u32> = (0..words as u32)
                .map(|w| w.wrapping_mul(2654435761))
                .collect();
            let vals: Vec<f32> = (0..words + 3).map(|w| w as f32 * 0.5 + 1.0).collect();
            let vals = &vals[..vals.len().min(4 * part)];
            for binding in [GridBinding::Whole, GridBinding::Cut { shift }] {
                let (t, v) = read_back(gpu, binding, &tree, vals).unwrap();
                assert!(t == tree, "{binding:?}, {words} words: node tables");
                assert!(v == vals, "{binding:?}, {} words: values", vals.len());
            }
        }
    }
}

#[test]
fn a_grid_four_parts_cannot_hold_falls_back_under_auto_and_is_refused_under_gpu() {
    need_gpu!();
    // cloud.vdb's values are 3.0 MiB: four parts of 512 KiB do not hold them.
    let small = [(MAX_BINDING_VAR, "524288")];
    let gpu = ["--device", "gpu", "--res", "16x9"];
    let (err, code, _, _) = render_with("cloud.vdb", "refused", &gpu, &small);
    assert_eq!(code, Some(2), "{err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert!(
        lines[0].contains("--device gpu: the grids' values (3.0 MiB)")
            && lines[0].contains(&format!("exceed the largest buffer {}", test_gpu().name))
            && lines[0].contains("(512.0 KiB) in 4 parts of 512.0 KiB"),
        "{err}"
    );
    // Under auto, with the adapter named (else auto does not take lavapipe, which runs
    // on the CPU): the CPU renders it, and one note says why.
    let name = test_gpu().name.split(" (").next().unwrap_or_default();
    let named = ("WGPU_ADAPTER_NAME", name);
    let auto = ["--device", "auto", "--res", "16x9"];
    let (err, code, stats, _) = render_with("cloud.vdb", "auto", &auto, &[small[0], named]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(stats["device"], "cpu", "{err}");
    assert_eq!(stats["gpu_grid_parts"], serde_json::json!([0, 0]));
    let notes: Vec<&str> = err
        .lines()
        .filter(|l| l.contains("--device auto"))
        .collect();
    assert_eq!(notes.len(), 1, "{err}");
    assert!(
        notes[0].contains("rendered on the CPU: the grids' values")
            && notes[0].contains("(512.0 KiB)"),
        "{err}"
    );
    // With the adapter's own limits the same scene renders on it under auto.
    let (err, code, stats, _) = render_with("cloud.vdb", "auto-fits", &auto, &[named]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(stats["device"], gpu_device().as_str(), "{err}");
    assert!(!err.contains("--device auto"), "{err}");
}
