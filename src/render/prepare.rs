//! A frame prepared for its render: the piece's rows and the holdout checked, the input
//! read and the scene built (shadow maps baked or reused). A sequence on the GPU
//! prepares the next frame so while the GPU renders one.

use super::device::build_scene;
use super::{FrameJob, RenderError, Result, gpu};
use crate::scene::RenderPlan;
use crate::scene::Scene;
use crate::scene::progress::Progress;
use crate::scene::reuse::FrameReuse;
use std::time::Instant;

/// A frame read and its scene built (its shadow maps baked or reused), not yet rendered:
/// what a sequence prepares of the next frame while the GPU renders one.
pub(super) struct PreparedFrame {
    pub scene: Scene,
    pub columns: Option<std::sync::Arc<gpu::GpuColumns>>,
    pub holdout: Option<crate::scene::holdout::Holdout>,
    pub rows: std::ops::Range<usize>,
    /// Seconds the preparing took (counted in the frame's time).
    pub seconds: f64,
}

impl PreparedFrame {
    /// When the frame's time is counted from: now less the preparing's seconds, so a
    /// frame prepared ahead (during the frame before) counts its preparing, not its wait.
    pub fn started(&self) -> std::time::Instant {
        let now = std::time::Instant::now();
        now.checked_sub(std::time::Duration::from_secs_f64(self.seconds))
            .unwrap_or(now)
    }
}

/// Everything of a frame before its pixels that needs no GPU of its own: the piece's
/// rows and the holdout checked, the input read and the scene built.
pub(super) fn prepare_frame(
    plan: &RenderPlan,
    progress: &dyn Progress,
    reuse: &mut FrameReuse,
    job: FrameJob,
) -> Result<PreparedFrame> {
    let start = Instant::now();
    if plan.outputs.deep.is_some() && job.piece.is_some() {
        return Err(RenderError::Flag(
            "--deep is not rendered in pieces (a deep image is not stitched): render the whole frame".into(),
        ));
    }
    let rows = match job.piece {
        Some(p) => {
            p.check(plan.camera.height)?;
            p.rows(plan.camera.height)
        }
        None => 0..plan.camera.height,
    };
    // The holdout first: a wrong one is refused before anything is built.
    let holdout = match &plan.production.holdout {
        Some(spec) => Some(
            crate::scene::holdout::load(
                spec,
                plan.camera.width,
                plan.camera.height,
                plan.camera.overscan,
            )
            .map_err(|problem| RenderError::Input {
                path: spec.path.clone(),
                problem,
            })?,
        ),
        None => None,
    };
    let (scene, columns) = build_scene(plan, progress, reuse)?;
    Ok(PreparedFrame {
        scene,
        columns,
        holdout,
        rows,
        seconds: start.elapsed().as_secs_f64(),
    })
}
