//! A ground plane `y = height` lit by the scene's lights through the volume ("volume
//! shadows on polygons"): for compositors, the fraction of light it receives (the
//! `shadow` layer, 1 where nothing shadows it); with `--ground-visible`, also a grey
//! Lambertian floor in the beauty pass behind the volume.

use crate::integrate::Illumination;
use glam::DVec3;

/// Reflectance of the visible floor (18 % grey).
pub const ALBEDO: f64 = 0.18;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ground {
    pub height: f64,
    pub visible: bool,
}

/// What reaches a point of the ground.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroundLight {
    /// Irradiance received through the volume over irradiance without it (RGB); 1 where
    /// no light reaches the side of the plane the camera sees.
    pub fraction: DVec3,
    /// Irradiance received through the volume (RGB).
    pub irradiance: DVec3,
}

impl Ground {
    /// Where the ray `o + t·d` meets the plane (t > 0), and the plane's normal on the
    /// camera's side.
    pub fn hit(&self, o: DVec3, d: DVec3) -> Option<(f64, DVec3)> {
        let t = (self.height - o.y) / d.y;
        (t > 0.0 && t.is_finite()).then_some({
            (
                t,
                if o.y >= self.height {
                    DVec3::Y
                } else {
                    DVec3::NEG_Y
                },
            )
        })
    }

    /// The light arriving at `x` (on the plane, normal `n`), each light attenuated by
    /// `e^{−σt·∫ρ ds}` toward it.
    pub fn light_at(
        &self,
        x: DVec3,
        n: DVec3,
        lights: &dyn Illumination,
        sigma_t: DVec3,
    ) -> GroundLight {
        let (mut open, mut through) = (DVec3::ZERO, DVec3::ZERO);
        for l in 0..lights.light_count() {
            let (irradiance, travel) = lights.incident(l, x);
            let cos = n.dot(-travel);
            if !(cos > 0.0) {
                continue;
            }
            let e = irradiance * cos;
            let tau = sigma_t * lights.density_to_light(l, x);
            open += e;
            through += e * DVec3::new((-tau.x).exp(), (-tau.y).exp(), (-tau.z).exp());
        }
        GroundLight::through(open, through)
    }
}

impl GroundLight {
    /// The light of irradiance `open` without the volume and `through` through it.
    pub fn through(open: DVec3, through: DVec3) -> GroundLight {
        let ratio = |a: f64, b: f64| {
            if b > 0.0 {
                (a / b).clamp(0.0, 1.0)
            } else {
                1.0
            }
        };
        GroundLight {
            fraction: DVec3::new(
                ratio(through.x, open.x),
                ratio(through.y, open.y),
                ratio(through.z, open.z),
            ),
            irradiance: through,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Sun(f64);
    impl Illumination for Sun {
        fn light_count(&self) -> usize {
            1
        }
        fn incident(&self, _: usize, _: DVec3) -> (DVec3, DVec3) {
            (DVec3::splat(2.0), DVec3::new(0.0, -1.0, 0.0))
        }
        fn density_to_light(&self, _: usize, x: DVec3) -> f64 {
            if x.x < 0.0 { self.0 } else { 0.0 }
        }
    }

    #[test]
    fn fraction_is_transmittance_of_the_light_and_one_in_the_open() {
        let g = Ground {
            height: -1.0,
            visible: false,
        };
        let (t, n) = g
            .hit(DVec3::new(0.0, 1.0, 0.0), DVec3::new(0.0, -1.0, 0.0))
            .unwrap();
        assert_eq!((t, n), (2.0, DVec3::Y));
        assert!(g.hit(DVec3::ZERO, DVec3::Y).is_none());
        let sun = Sun(0.5);
        let shade = g.light_at(
            DVec3::new(-1.0, -1.0, 0.0),
            n,
            &sun,
            DVec3::new(1.0, 2.0, 4.0),
        );
        let want = DVec3::new((-0.5f64).exp(), (-1.0f64).exp(), (-2.0f64).exp());
        assert!((shade.fraction - want).abs().max_element() < 1e-15);
        assert!((shade.irradiance - want * 2.0).abs().max_element() < 1e-15);
        let open = g.light_at(DVec3::new(1.0, -1.0, 0.0), n, &sun, DVec3::ONE);
        assert_eq!(open.fraction, DVec3::ONE);
        // Seen from below, the sun does not light this side: nothing to shadow.
        let below = g.light_at(DVec3::new(-1.0, -1.0, 0.0), DVec3::NEG_Y, &sun, DVec3::ONE);
        assert_eq!(below.fraction, DVec3::ONE);
    }
}
