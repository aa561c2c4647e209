//! Rendering a frame sequence: the frame patterns of every per-frame path (input, `-o`,
//! `--preview`, `--stats`, `--shadow-cache`), which frames, and the frames rendered in
//! order — each with the whole thread pool, what does not change carried from one to
//! the next ([`FrameReuse`]; on the GPU its buffers, [`gpu::KeptBuffers`]), a failing
//! frame reported and the others still written, frames already written left alone with
//! `--skip-existing`; on the GPU the next frame prepared while one renders.

use super::RenderError;
use super::gpu;
use super::piece::Piece;
use super::prepare::{PreparedFrame, prepare_frame};
use super::stats::RenderStats;
use super::{FrameJob, render_prepared};
use crate::scene::RenderPlan;
use crate::scene::frames::{FramePattern, FramesError, frame_ranges, parse_frames};
use crate::scene::plan::Device;
use crate::scene::progress::{Progress, Silent};
use crate::scene::reuse::FrameReuse;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The per-frame paths of a plan, as patterns.
#[derive(Clone, Debug)]
pub struct FramePaths {
    pub input: FramePattern,
    pub output: FramePattern,
    preview: Option<FramePattern>,
    stats: Option<FramePattern>,
    shadow_cache: Option<FramePattern>,
    deep: Option<FramePattern>,
}

impl FramePaths {
    pub fn of(plan: &RenderPlan) -> FramePaths {
        FramePaths {
            input: FramePattern::new(&plan.input),
            output: FramePattern::new(&plan.outputs.path),
            preview: plan
                .outputs
                .preview
                .as_ref()
                .map(|p| FramePattern::new(&p.0)),
            stats: plan.outputs.stats.as_deref().map(FramePattern::new),
            shadow_cache: plan.shadows.cache.as_deref().map(FramePattern::new),
            deep: plan
                .outputs
                .deep
                .as_ref()
                .map(|d| FramePattern::new(&d.path)),
        }
    }

    /// Whether any path holds a frame pattern.
    pub fn any_pattern(&self) -> bool {
        self.input.is_pattern() || self.outputs().iter().any(|(p, _)| p.is_pattern())
    }

    /// The output paths with the flag that names them.
    fn outputs(&self) -> Vec<(&FramePattern, &'static str)> {
        let mut v = vec![(&self.output, "-o")];
        v.extend(self.preview.iter().map(|p| (p, "--preview")));
        v.extend(self.stats.iter().map(|p| (p, "--stats")));
        v.extend(self.deep.iter().map(|p| (p, "--deep")));
        v
    }

    /// The plan of frame `frame`: every pattern replaced by it.
    pub fn plan(&self, plan: &RenderPlan, frame: i64) -> RenderPlan {
        let mut p = plan.clone();
        p.input = self.input.path(frame);
        if let Some(v) = &mut p.volumes {
            for v in &mut v.list {
                v.file = FramePattern::new(&v.file).path(frame);
            }
            if v.frame.is_some() {
                v.at_frame(frame as f64);
            }
        }
        p.outputs.path = self.output.path(frame);
        p.outputs.exr.input_file = Some(p.input.display().to_string());
        if let Some(shot) = &mut p.camera.request.shot {
            shot.time = Some(frame as f64);
        }
        if let (Some((path, _)), Some(pat)) = (&mut p.outputs.preview, &self.preview) {
            *path = pat.path(frame);
        }
        if let Some(pat) = &self.stats {
            p.outputs.stats = Some(pat.path(frame));
        }
        if let Some(pat) = &self.shadow_cache {
            p.shadows.cache = Some(pat.path(frame));
        }
        if let (Some(d), Some(pat)) = (&mut p.outputs.deep, &self.deep) {
            d.path = pat.path(frame);
        }
        p
    }
}

/// Before any frame is rendered, when `--frames` picks the frames of an input pattern:
/// refuses a list of which no input exists, in one line that says which frames do
/// (`--frames 1-3` on a cache of frames 150 to 250). Some frames missing is not refused:
/// each is reported and the others are written. A folder that cannot be listed (or a
/// pattern in a folder name) is left to the frames to report.
pub fn check_inputs_exist(
    paths: &FramePaths,
    plan: &RenderPlan,
    frames: &[i64],
) -> Result<(), RenderError> {
    if !paths.input.is_pattern() || frames.iter().any(|&f| paths.input.path(f).exists()) {
        return Ok(());
    }
    let found = match paths.input.existing_frames(&plan.input) {
        Ok(found) => found,
        Err(e @ FramesError::NoMatch { .. }) => return Err(e.into()),
        Err(_) => return Ok(()),
    };
    Err(RenderError::Input {
        path: plan.input.clone(),
        problem: format!(
            "no file for --frames {}; the files found hold frames {}",
            clip(&frame_ranges(frames, "x")),
            clip(&frame_ranges(&found, "x"))
        ),
    })
}

/// A frame list as printed in a one-line error: at most 200 characters.
fn clip(s: &str) -> String {
    match s.char_indices().nth(200) {
        Some((at, _)) => format!("{}...", &s[..at]),
        None => s.to_string(),
    }
}

/// Whether frame `plan` needs no render with `--skip-existing`: its EXR is complete
/// and its preview and stats files exist (one deleted brings the frame back).
pub fn frame_is_done(plan: &RenderPlan) -> bool {
    is_complete_exr(&plan.outputs.path) && super::output_paths(plan).skip(1).all(|p| p.is_file())
}

/// Before any frame is rendered: the folder of every frame's every output made if
/// missing and checked writable (each folder once), so that a sequence that cannot be
/// written fails at once with one line, not once per frame after each render.
pub fn prepare_places(paths: &FramePaths, frames: &[i64]) -> Result<(), RenderError> {
    let mut seen = std::collections::HashSet::new();
    for &frame in frames {
        for (pattern, _) in paths.outputs() {
            let path = pattern.path(frame);
            if path.as_os_str() == "-" {
                continue;
            }
            let folder = path.parent().map(Path::to_path_buf).unwrap_or_default();
            if seen.insert(folder) {
                crate::files::place::prepare(&path)?;
            }
        }
    }
    Ok(())
}

/// The frames to render: `spec` (`--frames` or the scene's `frames`), else the frames
/// whose input files exist when the input is a pattern. Several frames need a frame
/// pattern in every output path (else they would overwrite one another).
pub fn choose_frames(
    paths: &FramePaths,
    plan: &RenderPlan,
    spec: Option<&str>,
) -> Result<Vec<i64>, RenderError> {
    // Every per-frame path, as given, with the flag that names it.
    let given = [
        (Some(&paths.input), "", Some(plan.input.as_path())),
        (
            Some(&paths.output),
            "-o ",
            Some(plan.outputs.path.as_path()),
        ),
        (
            paths.preview.as_ref(),
            "--preview ",
            plan.outputs.preview.as_ref().map(|p| p.0.as_path()),
        ),
        (
            paths.stats.as_ref(),
            "--stats ",
            plan.outputs.stats.as_deref(),
        ),
        (
            paths.shadow_cache.as_ref(),
            "--shadow-cache ",
            plan.shadows.cache.as_deref(),
        ),
        (
            paths.deep.as_ref(),
            "--deep ",
            plan.outputs.deep.as_ref().map(|d| d.path.as_path()),
        ),
    ];
    for (pattern, flag, path) in given {
        if let (Some(pattern), Some(path)) = (pattern, path) {
            pattern
                .check(&format!("{flag}{}", path.display()))
                .map_err(RenderError::Flag)?;
        }
    }
    let frames = match spec {
        Some(s) => parse_frames(s)?,
        None if paths.input.is_pattern() => paths.input.existing_frames(&plan.input)?,
        None => {
            return Err(RenderError::output_path(
                &plan.outputs.path,
                "a frame pattern in the outputs needs --frames (or a pattern in the input)",
            ));
        }
    };
    if frames.len() > 1 {
        for (p, flag) in paths.outputs() {
            if !p.is_pattern() {
                return Err(RenderError::Flag(format!(
                    "{flag} {}: {} frames would all be written to this one file; put a frame pattern (####) in it",
                    p.path(0).display(),
                    frames.len()
                )));
            }
        }
    }
    Ok(frames)
}

/// How a sequence is rendered.
#[derive(Clone, Copy, Debug, Default)]
pub struct SequenceOptions {
    /// Leave frames whose output is already a complete EXR (and whose preview and stats
    /// files exist).
    pub skip_existing: bool,
    /// Render only this piece of every frame.
    pub piece: Option<Piece>,
}

/// What became of one frame; `E` is the error of the caller's check (and the render's).
pub enum FrameOutcome<E> {
    Written(Box<RenderStats>),
    /// Its output already existed, complete.
    Skipped,
    Failed(E),
}

/// The whole sequence.
#[derive(Debug, Default)]
pub struct SequenceSummary {
    pub written: usize,
    pub skipped: usize,
    pub failed: Vec<i64>,
    /// Frames whose shadow maps were reused from the frame before.
    pub shadow_maps_reused: usize,
    /// Frames that uploaded none of the scene's buffers to the GPU: the frame before's
    /// (the grids, the maps, the lights and tables) were all kept there.
    pub gpu_scenes_kept: usize,
    pub seconds: f64,
}

/// Whether `path` is a complete EXR: it exists and every pixel of it decodes (a file cut
/// short by a killed writer does not). murk itself never leaves a partial file at the
/// final path (outputs are renamed into place), but another tool might.
pub fn is_complete_exr(path: &Path) -> bool {
    path.is_file() && exr::prelude::read_all_flat_layers_from_file(path).is_ok()
}

/// Renders `frames` of `plan` in order, one progress bar over all of them (`progress`);
/// `check` vets each frame's plan (outputs that would clobber an input); `on_frame`
/// hears what became of each frame as it ends. Under `--device gpu|auto` the scene's
/// buffers stay on the GPU while unchanged ([`gpu::KeptBuffers`]), and the next frame is
/// read and its scene built on another thread while the GPU renders one.
pub fn render_sequence<E: From<RenderError>>(
    plan: &RenderPlan,
    paths: &FramePaths,
    frames: &[i64],
    options: SequenceOptions,
    progress: &dyn Progress,
    check: &dyn Fn(&RenderPlan) -> Result<(), E>,
    on_frame: &mut dyn FnMut(i64, &RenderPlan, &FrameOutcome<E>),
) -> SequenceSummary {
    let start = Instant::now();
    let mut reuse = FrameReuse::across_frames();
    reuse.frame_box = sequence_box(plan, paths, frames);
    let mut summary = SequenceSummary::default();
    let mut kept = gpu::KeptBuffers::default();
    let mut record = |frame: i64, fp: &RenderPlan, outcome: FrameOutcome<E>| {
        match &outcome {
            FrameOutcome::Written(_) => summary.written += 1,
            FrameOutcome::Skipped => summary.skipped += 1,
            FrameOutcome::Failed(_) => summary.failed.push(frame),
        }
        on_frame(frame, fp, &outcome);
        progress.advance(1);
    };
    progress.start("frames", frames.len() as u64, "frames");
    // With --threads, one pool that both threads of an overlapped sequence run on.
    let pool = plan
        .sampling
        .threads
        .and_then(|n| rayon::ThreadPoolBuilder::new().num_threads(n).build().ok());
    let overlap = plan.sampling.device != Device::Cpu
        && frames.len() > 1
        && (pool.is_some() || plan.sampling.threads.is_none());
    let job = |frame| FrameJob {
        frame: Some(frame),
        piece: options.piece,
    };
    let reused = if overlap {
        let ahead = Ahead {
            plan,
            paths,
            frames,
            options,
            pool: pool.as_ref(),
        };
        ahead.run(reuse, |frame, fp, prepared| {
            progress.note(&format!("frame {frame}"));
            let outcome = match prepared {
                None => FrameOutcome::Skipped,
                Some(prepared) => {
                    let kept = Some(&mut kept);
                    let render = |p| render_prepared(fp, p, &Silent, kept, job(frame));
                    match check(fp).and_then(|_| Ok(on_pool(pool.as_ref(), || render(prepared?))?))
                    {
                        Ok(st) => FrameOutcome::Written(Box::new(st)),
                        Err(e) => FrameOutcome::Failed(e),
                    }
                }
            };
            record(frame, fp, outcome);
        })
    } else {
        for &frame in frames {
            let fp = paths.plan(plan, frame);
            progress.note(&format!("frame {frame}"));
            let outcome = if options.skip_existing && frame_is_done(&fp) {
                FrameOutcome::Skipped
            } else {
                let mut render = || {
                    super::on_plan_threads(&fp, || {
                        super::check_output_dirs(&fp)?;
                        let prepared = prepare_frame(&fp, &Silent, &mut reuse, job(frame))?;
                        render_prepared(&fp, prepared, &Silent, Some(&mut kept), job(frame))
                    })
                };
                match check(&fp).and_then(|_| Ok(render()?)) {
                    Ok(st) => FrameOutcome::Written(Box::new(st)),
                    Err(e) => FrameOutcome::Failed(e),
                }
            };
            record(frame, &fp, outcome);
        }
        reuse.shadow_maps_reused
    };
    progress.finish();
    summary.shadow_maps_reused = reused;
    summary.gpu_scenes_kept = kept.frames_kept;
    summary.seconds = start.elapsed().as_secs_f64();
    summary
}

/// Runs `work` on `pool` where there is one, else here (on rayon's global pool).
fn on_pool<T: Send>(pool: Option<&rayon::ThreadPool>, work: impl FnOnce() -> T + Send) -> T {
    match pool {
        Some(p) => p.install(work),
        None => work(),
    }
}

/// A frame as the preparing thread hands it over: its number, its plan, and its scene
/// built (none: its outputs exist and `--skip-existing` leaves it).
type Ready = (i64, RenderPlan, Option<Result<PreparedFrame, RenderError>>);

/// The frames of a sequence rendered on the GPU, each next one prepared ahead.
struct Ahead<'a> {
    plan: &'a RenderPlan,
    paths: &'a FramePaths,
    frames: &'a [i64],
    options: SequenceOptions,
    /// The plan's threads (`--threads`); none: rayon's global pool.
    pool: Option<&'a rayon::ThreadPool>,
}

impl Ahead<'_> {
    /// A second thread reads each frame and builds its scene (on the plan's threads),
    /// in order, while this one hands the frame before to `render` (which renders and
    /// writes it). A prepared frame waits until the one before is written: one frame
    /// ahead at most. Returns the frames whose shadow maps were reused.
    fn run(
        &self,
        mut reuse: FrameReuse,
        mut render: impl FnMut(i64, &RenderPlan, Option<Result<PreparedFrame, RenderError>>),
    ) -> usize {
        std::thread::scope(|s| {
            let (tx, rx) = std::sync::mpsc::sync_channel::<Ready>(0);
            let preparer = s.spawn(move || {
                for &frame in self.frames {
                    let fp = self.paths.plan(self.plan, frame);
                    let prepared =
                        (!(self.options.skip_existing && frame_is_done(&fp))).then(|| {
                            let job = FrameJob {
                                frame: Some(frame),
                                piece: self.options.piece,
                            };
                            on_pool(self.pool, || prepare_frame(&fp, &Silent, &mut reuse, job))
                        });
                    if tx.send((frame, fp, prepared)).is_err() {
                        break;
                    }
                }
                reuse.shadow_maps_reused
            });
            for (frame, fp, prepared) in rx {
                render(frame, &fp, prepared);
            }
            preparer
                .join()
                .unwrap_or_else(|e| std::panic::resume_unwind(e))
        })
    }
}

/// The box the default camera frames in every frame of a sequence rendered in one run:
/// the union of the frames' densities (each decoded once more for it), so that the
/// camera stays put and the last frame's plume is framed as tightly as the first's.
/// `None` for one frame, with the camera placed by hand, or with no frame to read.
fn sequence_box(
    plan: &RenderPlan,
    paths: &FramePaths,
    frames: &[i64],
) -> Option<(glam::DVec3, glam::DVec3)> {
    let req = &plan.camera.request;
    if frames.len() < 2
        || !paths.input.is_pattern()
        || req.eye.is_some()
        || req.look_at.is_some()
        || req.shot.is_some()
    {
        return None;
    }
    frames
        .iter()
        .filter_map(|&f| crate::scene::roles::density_box_of(&paths.plan(plan, f)))
        .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))
}

/// The path of frame `frame` of `pattern` (for tools that build command lines); a
/// pattern wider than murk pads is refused.
pub fn frame_path(pattern: &Path, frame: i64) -> Result<PathBuf, RenderError> {
    let p = FramePattern::new(pattern);
    p.check(&pattern.display().to_string())
        .map_err(RenderError::Flag)?;
    Ok(p.path(frame))
}
