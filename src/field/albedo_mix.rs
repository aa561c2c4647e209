//! The scattering tint of a [`FieldSum`] of media of different albedos or with colour
//! grids, and a colour field placed in the world.

use super::sum::FieldSum;
use super::{ColorField, Field, IndexToWorld};
use glam::{DMat4, DVec3, Vec3};
use std::sync::Arc;

/// The scattering tint of a sum of media of one extinction colour: where member `i`
/// scatters the fraction `aᵢ` (per channel) of the medium's scattering and its colour
/// grid `Cdᵢ` (1 without one, each channel clamped to [0, 1]) tints that, the tint at `x`
/// is `Σ wᵢρᵢaᵢCdᵢ / Σ wᵢρᵢ`, so that `σs(x) = S·D(x)·tint(x) = Σ σs,ᵢ·ρᵢ(x)·Cdᵢ(x)` for
/// a medium of scattering `S` over the sum `D`.
#[derive(Clone)]
pub struct AlbedoMix {
    sum: FieldSum,
    albedo: Vec<DVec3>,
    /// Member `i`'s colour grid, placed as the member is (`None`: untinted).
    colors: Vec<Option<Arc<dyn ColorField>>>,
}

impl AlbedoMix {
    /// `albedo[i]`: member `i`'s σs/σt per channel (as many as members).
    pub fn new(sum: FieldSum, albedo: Vec<DVec3>) -> Option<Self> {
        let colors = vec![None; albedo.len()];
        Self::with_colors(sum, albedo, colors)
    }

    /// As [`AlbedoMix::new`], each member's scattering tinted by its colour grid too
    /// (`colors[i]` placed in the world as member `i` is: [`PlacedColor`]).
    pub fn with_colors(
        sum: FieldSum,
        albedo: Vec<DVec3>,
        colors: Vec<Option<Arc<dyn ColorField>>>,
    ) -> Option<Self> {
        (albedo.len() == sum.members().len() && colors.len() == albedo.len()).then_some(AlbedoMix {
            sum,
            albedo,
            colors,
        })
    }
}

impl ColorField for AlbedoMix {
    fn transform(&self) -> &IndexToWorld {
        Field::transform(&self.sum)
    }

    fn color_at_index(&self, p: DVec3) -> Vec3 {
        let (mut num, mut den) = (DVec3::ZERO, 0.0f64);
        let mut world = None;
        for ((m, a), c) in self
            .sum
            .members()
            .iter()
            .zip(&self.albedo)
            .zip(&self.colors)
        {
            let v = m.weight() * m.value_at_sum_index(p).max(0.0) as f64;
            if v == 0.0 {
                continue;
            }
            let tint = match c {
                None => DVec3::ONE,
                Some(c) => {
                    let w =
                        *world.get_or_insert_with(|| Field::transform(&self.sum).index_to_world(p));
                    c.color_at_index(c.transform().world_to_index(w))
                        .as_dvec3()
                        .clamp(DVec3::ZERO, DVec3::ONE)
                }
            };
            num += *a * tint * v;
            den += v;
        }
        if den > 0.0 {
            (num / den).as_vec3()
        } else {
            Vec3::ZERO
        }
    }
}

/// A colour field placed in the world: its index→world map followed by `placement`.
pub struct PlacedColor {
    field: Arc<dyn ColorField>,
    transform: IndexToWorld,
}

impl PlacedColor {
    /// `None` when the placement is singular or not finite.
    pub fn new(field: Arc<dyn ColorField>, placement: DMat4) -> Option<Self> {
        let own = field.transform();
        let transform = IndexToWorld::new(placement * own.matrix(), own.origin)?;
        Some(PlacedColor { field, transform })
    }
}

impl ColorField for PlacedColor {
    fn transform(&self) -> &IndexToWorld {
        &self.transform
    }

    fn color_at_index(&self, p: DVec3) -> Vec3 {
        self.field.color_at_index(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::shapes::ConstantBox;

    fn unit_box(density: f32) -> Arc<dyn Field> {
        Arc::new(ConstantBox::new(DVec3::ZERO, DVec3::ONE, density, 0.05).unwrap())
    }

    /// A colour constant over all space, on a lattice of voxel size 0.05.
    struct Flat(Vec3, IndexToWorld);

    impl ColorField for Flat {
        fn transform(&self) -> &IndexToWorld {
            &self.1
        }
        fn color_at_index(&self, _: DVec3) -> Vec3 {
            self.0
        }
    }

    #[test]
    fn the_albedo_mix_is_the_scattering_weighted_mean() {
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

    /// A member's colour grid tints its own share only, clamped to [0, 1]: a magenta
    /// member (Cd 1, 0, 2: blue clamped to 1) alone is its albedo times its colour; where
    /// it overlaps an untinted one of three times the weight, green is the untinted share.
    #[test]
    fn colour_grids_tint_their_own_members() {
        let b = unit_box(1.0);
        let sum = FieldSum::new(vec![
            (b.clone(), DMat4::IDENTITY, 1.0),
            (b, DMat4::from_translation(DVec3::new(0.0, 0.0, 0.5)), 3.0),
        ])
        .unwrap();
        let lattice =
            IndexToWorld::new(DMat4::from_scale(DVec3::splat(0.05)), glam::IVec3::ZERO).unwrap();
        let red: Arc<dyn ColorField> = Arc::new(
            PlacedColor::new(
                Arc::new(Flat(Vec3::new(1.0, 0.0, 2.0), lattice)),
                DMat4::IDENTITY,
            )
            .unwrap(),
        );
        let mix = AlbedoMix::with_colors(
            sum.clone(),
            vec![DVec3::splat(0.5), DVec3::splat(0.5)],
            vec![Some(red), None],
        )
        .unwrap();
        let at = |z: f64| {
            let p = sum.transform().world_to_index(DVec3::new(0.5, 0.5, z));
            mix.color_at_index(p)
        };
        let (alone, both) = (at(0.25), at(0.75));
        assert!(
            (alone - Vec3::new(0.5, 0.0, 0.5)).abs().max_element() < 1e-6,
            "{alone}"
        );
        let want = Vec3::new(0.5, 0.5 * 3.0 / 4.0, 0.5);
        assert!((both - want).abs().max_element() < 1e-6, "{both}");
    }
}
