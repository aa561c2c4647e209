//! Each volume's alpha in a scene of several (the `volume_<name>.A` layers): the share of
//! the camera ray's opacity that volume `i` takes, under the occlusion of all of them,
//!
//! `Aᵢ = ⟨∫ T(t) σt,ᵢ(t) dt⟩`, `T(t) = e^{−∫₀ᵗ Σⱼ σt,ⱼ}`,
//!
//! (⟨·⟩ the mean over R, G, B, as the beauty's `A`): what a compositor's per-object
//! matte holds when every other object is a holdout. Since `Σᵢ σt,ᵢ T = −dT/dt`, the
//! volumes' alphas add up to the beauty's `A = ⟨1 − T⟩`; a volume seen through another
//! is dimmed by it, one in front of another is not.
//!
//! The ray is cut into pieces of at most a voxel of the summed density's lattice
//! (within its non-empty cells); over each piece every volume's exact density integral
//! `dᵢ` is taken, the piece's opacity `⟨T₀(1 − e^{−σt·Σdᵢ})⟩` is exact, and volume `i`
//! takes the fraction `dᵢ / Σdⱼ` of it (exact where the volumes' proportions hold over
//! the piece). The volumes share one extinction colour (`plan::volumes`), so that
//! fraction is the same in every channel. As the march does, the ray stops once every
//! channel's transmittance is below `termination`, the last piece then taking all that
//! is left, so the alphas add up to the march's `A` (1 there) too.

use crate::accel::{IndexRay, Spans};
use crate::field::sum::FieldSum;
use glam::DVec3;

/// The volumes of a scene of several: their summed density (member `i` is volume `i`)
/// and names.
#[derive(Clone, Copy)]
pub struct Mattes<'a> {
    pub sum: &'a FieldSum,
    pub names: &'a [String],
}

/// The pieces a span is cut into at most (a span longer than this many voxels has longer
/// pieces).
const MAX_PIECES: usize = 4096;

/// Per-thread buffers of [`Mattes::alphas`].
#[derive(Clone, Debug, Default)]
pub struct MatteScratch {
    ends: Vec<f64>,
    /// Volume `i`'s integral over piece `k` at `i·n + k`.
    each: Vec<f64>,
    alpha: Vec<f64>,
}

impl Mattes<'_> {
    /// Each volume's alpha along the world ray `origin + t·dir`, `t ∈ [t_min, t_max]`,
    /// in a medium of extinction `sigma_t` per unit of the summed density; see the
    /// module's documentation.
    #[allow(clippy::too_many_arguments)]
    pub fn alphas<'s>(
        &self,
        sigma_t: DVec3,
        origin: DVec3,
        dir: DVec3,
        t_min: f64,
        t_max: f64,
        termination: f64,
        scratch: &'s mut MatteScratch,
    ) -> &'s [f64] {
        let members = self.sum.members();
        let n_members = members.len();
        scratch.alpha.clear();
        scratch.alpha.resize(n_members, 0.0);
        let ray = IndexRay::new(self.sum, origin, dir);
        let speed = ray.index_speed();
        if !(speed > 0.0 && speed.is_finite()) {
            return &scratch.alpha;
        }
        let mut depth = 0.0f64;
        for span in Spans::new(self.sum, ray, t_min, t_max) {
            let (t0, t1) = (span.t0, span.t1);
            let n = (((t1 - t0) * speed).ceil().max(1.0) as usize).min(MAX_PIECES);
            let h = (t1 - t0) / n as f64;
            scratch.ends.clear();
            scratch
                .ends
                .extend((1..=n).map(|k| if k == n { t1 } else { t0 + h * k as f64 }));
            scratch.each.clear();
            scratch.each.resize(n_members * n, 0.0);
            for (i, m) in members.iter().enumerate() {
                m.piece_integrals(&ray, t0, &scratch.ends, &mut scratch.each[i * n..][..n]);
            }
            for k in 0..n {
                let d: f64 = (0..n_members).map(|i| scratch.each[i * n + k]).sum();
                if !(d > 0.0) {
                    continue;
                }
                let before = (-sigma_t * depth).exp();
                depth += d;
                let after = (-sigma_t * depth).exp();
                let stop = after.max_element() < termination;
                let taken = if stop {
                    before.element_sum() / 3.0
                } else {
                    let piece = (-sigma_t * d).to_array().map(|x| -x.exp_m1());
                    (before * DVec3::from_array(piece)).element_sum() / 3.0
                };
                for i in 0..n_members {
                    scratch.alpha[i] += taken * (scratch.each[i * n + k] / d);
                }
                if stop {
                    return &scratch.alpha;
                }
            }
        }
        &scratch.alpha
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::Field;
    use crate::field::shapes::ConstantBox;
    use glam::DMat4;
    use std::sync::Arc;

    /// Two slabs 1 thick along z, one behind the other with a gap, of densities 2 and 3 in
    /// a grey medium of σt 0.5: the front one's alpha is 1 − e^{−1}, the back one's
    /// e^{−1}(1 − e^{−1.5}); overlapping by half, their alphas add up to 1 − e^{−2.5}.
    #[test]
    fn slabs_give_the_closed_forms_and_add_up_to_the_alpha() {
        let slab = |rho: f32| -> Arc<dyn Field> {
            Arc::new(
                ConstantBox::new(
                    DVec3::new(-1.0, -1.0, 0.0),
                    DVec3::new(1.0, 1.0, 1.0),
                    rho,
                    0.05,
                )
                .unwrap(),
            )
        };
        let names = ["front".to_string(), "back".to_string()];
        let sigma = DVec3::splat(0.5);
        let mut scratch = MatteScratch::default();
        let o = DVec3::new(0.013, 0.021, 5.0);
        for (shift, want) in [
            (
                -1.5,
                [-(-1.0f64).exp_m1(), (-1.0f64).exp() * -(-1.5f64).exp_m1()],
            ),
            (-0.5, [f64::NAN, f64::NAN]),
        ] {
            let sum = FieldSum::new(vec![
                (slab(2.0), DMat4::IDENTITY, 1.0),
                (slab(3.0), DMat4::from_translation(DVec3::Z * shift), 1.0),
            ])
            .unwrap();
            let m = Mattes {
                sum: &sum,
                names: &names,
            };
            let a = m
                .alphas(sigma, o, DVec3::NEG_Z, 0.0, 20.0, 0.0, &mut scratch)
                .to_vec();
            let total = 1.0 - (-0.5f64 * (2.0 + 3.0)).exp();
            assert!((a[0] + a[1] - total).abs() < 1e-12, "{a:?} vs {total}");
            if !want[0].is_nan() {
                assert!((a[0] - want[0]).abs() < 1e-9, "{a:?} vs {want:?}");
                assert!((a[1] - want[1]).abs() < 1e-9, "{a:?} vs {want:?}");
            }
            // Stopped where the transmittance falls below 0.3: the alphas add up to 1.
            let stopped = m.alphas(sigma, o, DVec3::NEG_Z, 0.0, 20.0, 0.3, &mut scratch);
            assert!(
                (stopped.iter().sum::<f64>() - 1.0).abs() < 1e-12,
                "{stopped:?}"
            );
        }
    }
}
