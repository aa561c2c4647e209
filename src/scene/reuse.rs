//! What a sequence keeps from one frame to the next: the deep shadow maps, reused while
//! the density's content hash (and everything else a map depends on) is unchanged.

use crate::scene::RenderPlan;
use crate::shadow::{ColumnMarcher, ShadowMap, ShadowMapStats};
use glam::DVec3;

/// Carried across the frames of one `murk render` (a fresh one per frame is a plain render).
#[derive(Default)]
pub struct FrameReuse {
    /// Off (the default): nothing is kept, so a single render holds no second copy.
    keep: bool,
    shadows: Option<(String, Vec<ShadowMap>, Vec<ShadowMapStats>)>,
    /// Frames whose shadow maps were reused rather than baked.
    pub shadow_maps_reused: usize,
    /// The world box the default camera frames in every frame (the union of the
    /// frames' densities), so that it does not move; `None`: each frame's own.
    pub frame_box: Option<(DVec3, DVec3)>,
    /// Where the shadow bake's light columns are marched besides the CPU: the GPU's
    /// marcher, which the render sets under `--device gpu|auto`.
    pub columns: Option<std::sync::Arc<dyn ColumnMarcher>>,
}

/// Everything a set of shadow maps depends on, as one comparable string: the density's
/// content hash, the lights (kind, position or direction), σt, tolerance and verification.
fn key(plan: &RenderPlan, density_hash: u64, sigma_t: DVec3) -> String {
    let geometry: Vec<String> = plan
        .lights
        .iter()
        .map(|l| format!("{:?}", l.geometry()))
        .collect();
    format!(
        "{density_hash:016x} {geometry:?} {:?} {} {}",
        sigma_t.to_array().map(f64::to_bits),
        plan.shadows.dsm_tolerance.to_bits(),
        plan.shadows.dsm_verify
    )
}

impl FrameReuse {
    /// Keeps what the next frame may reuse.
    pub fn across_frames() -> FrameReuse {
        FrameReuse {
            keep: true,
            ..FrameReuse::default()
        }
    }

    /// The previous frame's maps when they were made for the same key.
    pub fn shadow_maps(
        &mut self,
        plan: &RenderPlan,
        density_hash: u64,
        sigma_t: DVec3,
    ) -> Option<(Vec<ShadowMap>, Vec<ShadowMapStats>)> {
        let k = key(plan, density_hash, sigma_t);
        let (kept, maps, stats) = self.shadows.as_ref()?;
        if *kept != k {
            return None;
        }
        self.shadow_maps_reused += 1;
        let stats = stats
            .iter()
            .map(|s| {
                let mut reused = ShadowMapStats {
                    source: "reused: the density is unchanged since the previous frame".into(),
                    bake_seconds: 0.0,
                    ..s.clone()
                };
                // No bake this frame: none of its time to report.
                reused.bake.phases = None;
                reused
            })
            .collect();
        Some((maps.clone(), stats))
    }

    /// Keeps this frame's maps for the next.
    pub fn keep_shadow_maps(
        &mut self,
        plan: &RenderPlan,
        density_hash: u64,
        sigma_t: DVec3,
        maps: &[ShadowMap],
        stats: &[ShadowMapStats],
    ) {
        if !self.keep {
            return;
        }
        self.shadows = Some((
            key(plan, density_hash, sigma_t),
            maps.to_vec(),
            stats.to_vec(),
        ));
    }
}
