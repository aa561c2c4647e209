//! Frame sequences on the GPU: the scene's buffers kept there while a frame's bytes are
//! the frame before's (`gpu_upload_bytes` 0, counted in the summary), uploaded again
//! where they differ, and every frame the image it is when rendered alone — with the
//! next frame prepared on another thread while one renders.

use super::*;
use common::camera::samples;
use murk::render::sequence::{
    FrameOutcome, FramePaths, SequenceOptions, SequenceSummary, render_sequence,
};
use murk::render::stats::RenderStats;
use murk::render::{RenderError, Silent};
use std::path::Path;

/// `dir` holding `inputs` (fixtures) as the frames 1.. of `in_####.vdb`.
fn frames_of(dir: &Path, inputs: &[&str]) -> Vec<i64> {
    for (k, input) in inputs.iter().enumerate() {
        std::fs::copy(fixture(input), dir.join(format!("in_{:04}.vdb", k + 1))).unwrap();
    }
    (1..=inputs.len() as i64).collect()
}

/// The plan of the sequence in `dir` (`in_####.vdb` to `out_####.exr`, float EXRs).
fn sequence_plan(dir: &Path, o: &RenderOptions, device: Device) -> RenderPlan {
    let mut o = o.clone();
    o.device = Some(device);
    o.float = true;
    o.output = Some(dir.join("out_####.exr"));
    RenderPlan::new(&o, dir.join("in_####.vdb")).unwrap()
}

/// Renders the frames of `plan` as one sequence: every frame's stats, and the summary.
fn render_frames(plan: &RenderPlan, frames: &[i64]) -> (Vec<RenderStats>, SequenceSummary) {
    let mut stats = Vec::new();
    let summary = render_sequence::<RenderError>(
        plan,
        &FramePaths::of(plan),
        frames,
        SequenceOptions::default(),
        &Silent,
        &|_| Ok(()),
        &mut |f, _, outcome| match outcome {
            FrameOutcome::Written(st) => stats.push((**st).clone()),
            FrameOutcome::Failed(e) => panic!("frame {f}: {e}"),
            FrameOutcome::Skipped => panic!("frame {f} skipped"),
        },
    );
    assert_eq!(summary.written, frames.len());
    (stats, summary)
}

/// Every frame of the sequence `plan` wrote is, sample for sample, the frame rendered
/// alone on the GPU, and within the tolerance of the frame rendered on the CPU.
fn each_frame_is_its_own_render(dir: &Path, plan: &RenderPlan, frames: &[i64]) {
    let paths = FramePaths::of(plan);
    for &f in frames {
        let fp = paths.plan(plan, f);
        let mut alone = fp.clone();
        alone.outputs.path = dir.join(format!("alone_{f}.exr"));
        murk::render::run(&alone, &Silent).unwrap();
        let got = samples(&fp.outputs.path);
        assert_eq!(got, samples(&alone.outputs.path), "frame {f}");
        let mut cpu = fp.clone();
        cpu.sampling.device = Device::Cpu;
        let cpu = render_image(&cpu).unwrap();
        let (mut num, mut den) = (0.0, 0.0);
        for name in ["R", "G", "B"] {
            let bits = &got.iter().find(|(n, _)| n == name).unwrap().1;
            let want = plane(&cpu, name);
            for (g, c) in bits.iter().zip(want) {
                num += (f32::from_bits(*g) as f64 - *c as f64).powi(2);
                den += (*c as f64).powi(2);
            }
        }
        assert!(den > 0.0, "frame {f}: a black image proves nothing");
        let e = (num / den).sqrt();
        assert!(e <= RADIANCE_RMSE, "frame {f}: radiance rel. RMSE {e:e}");
    }
}

#[test]
fn an_unchanged_cache_is_uploaded_once_and_every_frame_is_its_own_render() {
    need_gpu!();
    let dir = scratch("gpu-sequence-unchanged");
    let frames = frames_of(&dir, &["cloud.vdb"; 3]);
    let plan = sequence_plan(&dir, &options("40x24"), Device::Gpu);
    let (stats, summary) = render_frames(&plan, &frames);
    let up: Vec<u64> = stats.iter().map(|s| s.scene.gpu_upload_bytes).collect();
    let held = stats[0].scene.gpu_memory_bytes as u64;
    // Frame 1 uploads every buffer (all but the parameters, set per batch); frames 2
    // and 3 none: the same grid, maps, lights and tables are still there.
    assert!(
        up[0] > 0 && up[0] <= held && up[0] + 4096 >= held,
        "{up:?} of {held}"
    );
    assert_eq!(&up[1..], &[0, 0], "bytes uploaded per frame");
    assert!(
        stats
            .iter()
            .all(|s| s.scene.gpu_memory_bytes as u64 == held)
    );
    assert_eq!(summary.gpu_scenes_kept, 2);
    assert_eq!(summary.shadow_maps_reused, 2);
    each_frame_is_its_own_render(&dir, &plan, &frames);
}

#[test]
fn frames_that_differ_are_uploaded_again_and_each_is_its_own_render() {
    need_gpu!();
    let dir = scratch("gpu-sequence-differ");
    // Three grids, then the first again (one frame's buffers are kept, not the first's).
    let inputs = [
        "seq/fluid_0002.vdb",
        "seq/fluid_0003.vdb",
        "seq/fluid_0004.vdb",
        "seq/fluid_0002.vdb",
    ];
    let frames = frames_of(&dir, &inputs);
    let mut o = options("40x24");
    // The camera placed by hand: each frame rendered alone frames what the sequence does.
    o.eye = Some("0,0.2,3".into());
    o.look_at = Some("0,0.2,0".into());
    o.light = vec!["sun:0.3,1,0.2:1,1,1:4".into()];
    let plan = sequence_plan(&dir, &o, Device::Gpu);
    let (stats, summary) = render_frames(&plan, &frames);
    for (k, s) in stats.iter().enumerate() {
        let (up, held) = (s.scene.gpu_upload_bytes, s.scene.gpu_memory_bytes as u64);
        assert!(up > 0 && up <= held, "frame {}: {up} of {held}", k + 1);
        if k > 0 {
            // The grid and its maps again, not the lights and the phase table.
            assert!(up + 200_000 < held, "frame {}: {up} of {held}", k + 1);
        }
    }
    assert_eq!(summary.gpu_scenes_kept, 0);
    each_frame_is_its_own_render(&dir, &plan, &frames);
}

#[test]
fn a_camera_moving_over_an_unchanged_cache_uploads_nothing_after_the_first_frame() {
    need_gpu!();
    let dir = scratch("gpu-sequence-camera");
    let frames = frames_of(&dir, &["cloud.vdb"; 3]);
    let chan = dir.join("shot.chan");
    std::fs::write(
        &chan,
        "1 0.2 0.3 6.5 -3 5 0 30\n2 0.5 0.4 6.2 -4 9 2 32\n3 0.8 0.5 5.9 -5 13 4 34\n",
    )
    .unwrap();
    let mut o = options("40x24");
    o.camera_file = Some(chan);
    let plan = sequence_plan(&dir, &o, Device::Gpu);
    let (stats, summary) = render_frames(&plan, &frames);
    let up: Vec<u64> = stats.iter().map(|s| s.scene.gpu_upload_bytes).collect();
    assert!(up[0] > 0 && up[1..] == [0, 0], "{up:?}");
    assert_eq!(summary.gpu_scenes_kept, 2);
    let paths = FramePaths::of(&plan);
    let out = |f| paths.plan(&plan, f).outputs.path;
    // The camera moved: the frames differ.
    assert_ne!(samples(&out(1)), samples(&out(2)));
    each_frame_is_its_own_render(&dir, &plan, &frames);
}

#[test]
fn on_the_cpu_a_sequence_uploads_nothing_and_counts_no_gpu_frames() {
    let dir = scratch("gpu-sequence-cpu");
    let frames = frames_of(&dir, &["seq/fluid_0001.vdb"; 2]);
    let plan = sequence_plan(&dir, &options("16x12"), Device::Cpu);
    let (stats, summary) = render_frames(&plan, &frames);
    assert!(stats.iter().all(|s| s.scene.gpu_upload_bytes == 0
        && s.scene.gpu_memory_bytes == 0
        && s.device == "cpu"));
    assert_eq!(summary.gpu_scenes_kept, 0);
}

#[test]
fn on_the_gpu_a_missing_frame_fails_alone_and_written_frames_are_skipped_in_order() {
    need_gpu!();
    let dir = scratch("gpu-sequence-missing");
    frames_of(&dir, &["seq/fluid_0001.vdb", "seq/fluid_0003.vdb"]);
    std::fs::rename(dir.join("in_0002.vdb"), dir.join("in_0004.vdb")).unwrap();
    let plan = sequence_plan(&dir, &options("16x12"), Device::Gpu);
    let paths = FramePaths::of(&plan);
    let run = |skip_existing| {
        let mut seen = Vec::new();
        let summary = render_sequence::<RenderError>(
            &plan,
            &paths,
            &[1, 2, 4],
            SequenceOptions {
                skip_existing,
                piece: None,
            },
            &Silent,
            &|_| Ok(()),
            &mut |f, _, outcome| {
                seen.push(match outcome {
                    FrameOutcome::Written(_) => (f, "written"),
                    FrameOutcome::Skipped => (f, "skipped"),
                    FrameOutcome::Failed(e) => {
                        assert!(e.to_string().contains("in_0002.vdb"), "{e}");
                        (f, "failed")
                    }
                })
            },
        );
        assert_eq!(summary.failed, [2]);
        seen
    };
    assert_eq!(run(false), [(1, "written"), (2, "failed"), (4, "written")]);
    let out = |f| paths.plan(&plan, f).outputs.path;
    assert!(out(1).is_file() && !out(2).exists() && out(4).is_file());
    let first = samples(&out(4));
    assert_eq!(run(true), [(1, "skipped"), (2, "failed"), (4, "skipped")]);
    assert_eq!(samples(&out(4)), first);
}
