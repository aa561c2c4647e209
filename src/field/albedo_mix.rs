//! The scattering tint of a [`FieldSum`] of media of different albedos.

use super::sum::FieldSum;
use super::{Field, IndexToWorld};
use glam::{DVec3, Vec3};

/// The scattering tint of a sum of media of one extinction colour: where member `i`
/// scatters the fraction `aᵢ` (per channel) of what it extinguishes, the tint at `x` is
/// `Σ wᵢρᵢaᵢ / Σ wᵢρᵢ`, so that `σs(x) = S·D(x)·tint(x) = Σ σs,ᵢ·ρᵢ(x)` for a medium of
/// scattering `S` (the common extinction) over the sum `D`.
#[derive(Clone)]
pub struct AlbedoMix {
    sum: FieldSum,
    albedo: Vec<DVec3>,
}

impl AlbedoMix {
    /// `albedo[i]`: member `i`'s σs/σt per channel (as many as members).
    pub fn new(sum: FieldSum, albedo: Vec<DVec3>) -> Option<Self> {
        (albedo.len() == sum.members().len()).then_some(AlbedoMix { sum, albedo })
    }
}

impl super::ColorField for AlbedoMix {
    fn transform(&self) -> &IndexToWorld {
        Field::transform(&self.sum)
    }

    fn color_at_index(&self, p: DVec3) -> Vec3 {
        let (mut num, mut den) = (DVec3::ZERO, 0.0f64);
        for (m, a) in self.sum.members().iter().zip(&self.albedo) {
            let v = m.weight() * m.value_at_sum_index(p).max(0.0) as f64;
            num += *a * v;
            den += v;
        }
        if den > 0.0 {
            (num / den).as_vec3()
        } else {
            Vec3::ZERO
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::shapes::ConstantBox;
    use glam::DMat4;
    use std::sync::Arc;

    fn unit_box(density: f32) -> Arc<dyn Field> {
        Arc::new(ConstantBox::new(DVec3::ZERO, DVec3::ONE, density, 0.05).unwrap())
    }

    #[test]
    fn the_albedo_mix_is_the_scattering_weighted_mean() {
        use crate::field::ColorField;
        let b = unit_box(1.0);
        let sum = FieldSum::new(vec![
            (b.clone(), DMat4::IDENTITY, 1.0),
            (b, DMat4::from_translation(DVec3::new(0.0, 0.0, 0.5)), 3.0),
        ])
        .unwrap();
        let mix = AlbedoMix::new(sum.clone(), vec![DVec3::splat(0.2), DVec3::splat(0.6)]).unwrap();
        let at = |z: f64| {
            let p = sum.transform().world_to_index(DVec3::new(0.5, 0.5, z));
            mix.color_at_index(p).x
        };
        assert!((at(0.25) - 0.2).abs() < 1e-6);
        assert!((at(0.75) - (0.2 + 3.0 * 0.6) / 4.0).abs() < 1e-6);
        assert!((at(1.25) - 0.6).abs() < 1e-6);
    }
}
