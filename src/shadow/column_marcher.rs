//! Light columns marched outside the bake's own loop (on a GPU), through one seam: the
//! bake sets each column up in f64 — its ray from where its march starts, how its points
//! move across the light, its sample depths — and hands a level's batch to a
//! [`ColumnMarcher`]; the columns that one could not march, [`super::columns`] marches
//! itself. The marcher lives above this module (the render's GPU
//! backend) and is passed down to [`super::bake::bake_with`], so `shadow` imports none of it.

use crate::field::{Field, IndexRay, Sideways};

/// Samples the bake makes per batch (more only when one brick stack alone has more):
/// 10 MB in f32, a few thousand bricks at the levels most bricks stop at, so the columns
/// still spread over every thread. A [`ColumnMarcher`] may ask for larger batches.
pub const BAKE_BATCH_SAMPLES: usize = 1 << 19;

/// One light column to march.
#[derive(Clone, Copy, Debug)]
pub struct ColumnJob {
    /// The column in the density's local index space from where its march starts:
    /// `ray.at(0)` is the start, t in world units.
    pub ray: IndexRay,
    /// How its points move across the light ([`Sideways`]), t from the same start.
    pub side: Sideways,
    /// Its sample depths are `depths[first..first + count]` of the batch: ascending,
    /// measured from the start (some may be ≤ 0: those read 0).
    pub first: usize,
    pub count: usize,
}

/// A batch's samples: per job, its `count` samples `[∫ρ, ρ, ∂x∫ρ, ∂y∫ρ, ∂x∂y∫ρ]` — what
/// [`Field::slopes_along`] gives from the start to each depth, and the density at the
/// depth — the jobs one after another. `done[j]` is false where the marcher did not
/// march job j (its samples are then not read and the bake marches it).
pub struct MarchedColumns {
    pub samples: Vec<[f32; 5]>,
    pub done: Vec<bool>,
}

/// Marches light columns for the bake somewhere other than this module's loop.
pub trait ColumnMarcher: Send + Sync {
    /// Whether it marches columns through `density` (else the bake marches them all).
    fn takes(&self, density: &dyn Field) -> bool;

    /// About how many samples it marches best in one batch: the bake's own batch size
    /// unless it says otherwise.
    fn batch_samples(&self) -> usize {
        BAKE_BATCH_SAMPLES
    }

    /// Marches `jobs` through `density`; an error leaves the whole batch to the bake.
    fn march(
        &self,
        density: &dyn Field,
        jobs: &[ColumnJob],
        depths: &[f64],
    ) -> Result<MarchedColumns, String>;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::VoxelGrid;
    use crate::field::random::SplitMix64;
    use crate::shadow::{BakeSettings, LightGeometry, bake, bake_with};
    use glam::{DMat4, DVec3, IVec3};
    use std::sync::atomic::{AtomicU64, Ordering};

    /// The closed forms in f64, as the bake's own loop marches them, from the jobs the
    /// seam sets up; every third job refused (the bake marches those itself).
    struct Refusing {
        asked: AtomicU64,
        marched: AtomicU64,
        /// Its batches' samples.
        batch: usize,
        /// Batches it was handed, and the most samples in one.
        calls: AtomicU64,
        largest: AtomicU64,
    }

    impl ColumnMarcher for Refusing {
        fn takes(&self, density: &dyn Field) -> bool {
            density.as_voxel_grid().is_some()
        }

        fn batch_samples(&self) -> usize {
            self.batch
        }

        fn march(
            &self,
            density: &dyn Field,
            jobs: &[ColumnJob],
            depths: &[f64],
        ) -> Result<MarchedColumns, String> {
            let mut samples = Vec::new();
            let mut done = Vec::new();
            let mut sums = Vec::new();
            for (n, job) in jobs.iter().enumerate() {
                let ts = &depths[job.first..job.first + job.count];
                sums.clear();
                let ok =
                    n % 3 != 1 && density.slopes_along(&job.ray, 0.0, ts, &job.side, &mut sums);
                done.push(ok);
                for (k, &t) in ts.iter().enumerate() {
                    let [tau, tx, ty, txy] = if ok { sums[k] } else { [f64::NAN; 4] };
                    let rho = density.value_at_index(job.ray.at(t)) as f64;
                    samples.push([tau, rho, tx, ty, txy].map(|v| v as f32));
                }
            }
            self.asked.fetch_add(jobs.len() as u64, Ordering::Relaxed);
            self.calls.fetch_add(1, Ordering::Relaxed);
            self.largest
                .fetch_max(samples.len() as u64, Ordering::Relaxed);
            let marched = done.iter().filter(|&&d| d).count() as u64;
            self.marched.fetch_add(marched, Ordering::Relaxed);
            Ok(MarchedColumns { samples, done })
        }
    }

    /// A lumpy 24³ blob.
    fn blob() -> VoxelGrid {
        let mut rng = SplitMix64(12);
        let mut voxels = Vec::new();
        for z in 0..24 {
            for y in 0..24 {
                for x in 0..24 {
                    let r = (DVec3::new(x as f64, y as f64, z as f64) - 11.5).length() / 12.0;
                    let v = ((1.0 - r) * (0.6 + 0.8 * rng.next_f64())).max(0.0);
                    voxels.push((IVec3::new(x, y, z), v as f32));
                }
            }
        }
        VoxelGrid::from_voxels("density", voxels, DMat4::from_scale(DVec3::splat(0.05))).unwrap()
    }

    /// The map baked through the seam — the columns set up from where each march starts,
    /// most marched by the marcher, every third by the bake — is the map baked here: the
    /// same bricks, levels and forms, and ∫ρ ds equal to f32 rounding everywhere, for a
    /// sun (a parallel chart) and a point light (perspective charts, every sideways term);
    /// in batches of the bake's own size and in batches of a few bricks, which the map
    /// does not depend on.
    #[test]
    fn a_map_baked_through_the_seam_is_the_bakes_own() {
        let g = blob();
        let settings = BakeSettings::new(1e-3, DVec3::splat(6.0));
        for light in [
            LightGeometry::Sun {
                travel: -DVec3::new(0.6, 1.0, 0.5).normalize(),
            },
            LightGeometry::Point {
                position: DVec3::new(2.0, 1.5, -1.0),
            },
        ] {
            let (own, own_report) = bake(&g, light, &settings);
            let mut batches = Vec::new();
            for batch in [BAKE_BATCH_SAMPLES, 1000] {
                let marcher = Refusing {
                    asked: AtomicU64::new(0),
                    marched: AtomicU64::new(0),
                    batch,
                    calls: AtomicU64::new(0),
                    largest: AtomicU64::new(0),
                };
                let (seam, seam_report) = bake_with(&g, light, &settings, Some(&marcher));
                batches.push((
                    marcher.calls.load(Ordering::Relaxed),
                    marcher.largest.load(Ordering::Relaxed),
                ));
                let (asked, marched) = (
                    marcher.asked.load(Ordering::Relaxed),
                    marcher.marched.load(Ordering::Relaxed),
                );
                assert_eq!(asked, own_report.columns, "{light:?}");
                assert!(marched > 0 && marched < asked, "{marched} of {asked}");
                assert_eq!(seam_report.columns, own_report.columns);
                assert_eq!(seam_report.bricks, own_report.bricks);
                assert_eq!(seam_report.points_per_level, own_report.points_per_level);
                assert_eq!(seam_report.linear_bricks, own_report.linear_bricks);
                assert_eq!(seam_report.dark_bricks, own_report.dark_bricks);
                assert!(own_report.bricks > 8 && own_report.points_per_level[3] > 0);
                let mut rng = SplitMix64(5);
                let mut deepest = 0.0f64;
                for _ in 0..5000 {
                    let u = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64());
                    let p = (u * 1.3 - 0.15) * 24.0 * 0.05;
                    let (a, b) = (own.density_integral(p), seam.density_integral(p));
                    assert!(
                        (a - b).abs() <= 1e-6 * (1.0 + a),
                        "{light:?} at {p}: {a} vs {b}"
                    );
                    deepest = deepest.max(a);
                }
                assert!(deepest > 0.5, "{deepest}");
            }
            // The small batches were asked for and given: more of them, each smaller.
            let ((own_calls, own_largest), (calls, largest)) = (batches[0], batches[1]);
            assert!(
                calls > 2 * own_calls && largest < own_largest,
                "{batches:?}"
            );
        }
    }
}
