//! Single scattering: emission, absorption and light scattered once toward the camera,
//! by the ray march ([`march`]), with an optional ground plane behind the volume.

use super::deep::{DeepAov, DeepTrace};
use super::ground::{ALBEDO, Ground, GroundLight};
use super::integrator::{CameraSample, Integrator, SampleRng};
use super::march::{Illumination, MarchSettings, RayResult, Scratch, Volume, march};
use super::pass::PassLayout;
use super::scatter_passes::{ScatterPassSpec, ScatterPasses};
use glam::DVec3;

pub use super::scatter_passes::pass_names;

/// What single scattering integrates: the volume, the lights it scatters (if anything
/// scatters), and a ground plane lit through the volume.
pub struct SingleScattering<'a> {
    volume: &'a Volume<'a>,
    lights: Option<&'a dyn Illumination>,
    ground: Option<(Ground, &'a dyn Illumination)>,
    settings: MarchSettings,
    passes: ScatterPasses,
    /// Deep output: every camera ray keeps its record.
    deep: bool,
    /// Deep AOVs: the records keep the layers' values too.
    deep_aovs: bool,
}

impl<'a> SingleScattering<'a> {
    /// `emits`: the emission layer is written; `lights`: the lights that scatter, with
    /// their names (a layer each when there are several); `ground`: a plane and the lights
    /// that reach it.
    pub fn new(
        volume: &'a Volume<'a>,
        emits: bool,
        lights: Option<(&'a dyn Illumination, Vec<String>)>,
        ground: Option<(Ground, &'a dyn Illumination)>,
        settings: MarchSettings,
    ) -> Self {
        let passes = ScatterPasses::new(&ScatterPassSpec {
            emits,
            lights: lights.as_ref().map(|(_, n)| n.clone()).unwrap_or_default(),
            // Lights that carry multiple scattering (`integrate::fast`) fill `indirect`.
            indirect: lights.as_ref().is_some_and(|(l, _)| l.scatters_multiply()),
            shadow: ground.is_some(),
            ground_visible: ground.is_some_and(|(g, _)| g.visible),
            volumes: volume.mattes.map(|m| m.names.to_vec()).unwrap_or_default(),
        });
        SingleScattering {
            volume,
            lights: lights.map(|(l, _)| l),
            ground,
            settings,
            passes,
            deep: false,
            deep_aovs: false,
        }
    }

    /// With `on`, every camera ray keeps its deep record ([`Integrator::deep_trace`]).
    pub fn with_deep(mut self, on: bool) -> Self {
        self.deep = on;
        self
    }

    /// With `on` (and deep output), the records keep every layer's values for the deep
    /// AOVs ([`Integrator::deep_aovs`]).
    pub fn with_deep_aovs(mut self, on: bool) -> Self {
        self.deep_aovs = on;
        self
    }
}

impl Integrator for SingleScattering<'_> {
    type Scratch = Scratch;

    fn passes(&self) -> &PassLayout {
        self.passes.layout()
    }

    fn scratch(&self) -> Scratch {
        let mut s = Scratch::new(self.lights.map_or(0, |l| l.light_count()));
        if self.deep {
            s.deep = Some(DeepTrace {
                aov_width: if self.deep_aovs {
                    super::deep::aov_width(s.per_light.len())
                } else {
                    0
                },
                ..DeepTrace::default()
            });
        }
        s
    }

    fn deep_trace<'s>(&self, scratch: &'s Scratch) -> Option<&'s DeepTrace> {
        scratch.deep.as_ref()
    }

    fn deep_aovs(&self) -> Vec<DeepAov> {
        self.passes.deep_aovs()
    }

    /// A camera sample through the volume as it is at the sample's time.
    fn sample(
        &self,
        camera: &CameraSample,
        rng: &mut SampleRng,
        scratch: &mut Scratch,
        acc: &mut [f64],
    ) -> u64 {
        let Some(keyed) = self.volume.keyed else {
            return self.sample_in(self.volume, camera, rng, scratch, acc);
        };
        let mut samples = 0;
        keyed.at_time(self.volume, camera.ray.time, &mut |v| {
            samples = self.sample_in(v, camera, rng, scratch, acc);
        });
        samples
    }
}

impl SingleScattering<'_> {
    /// [`Integrator::sample`] through `volume` (this one's, or it as it is at the
    /// sample's time).
    fn sample_in(
        &self,
        volume: &Volume,
        camera: &CameraSample,
        rng: &mut SampleRng,
        scratch: &mut Scratch,
        acc: &mut [f64],
    ) -> u64 {
        let mut ray = camera.ray;
        let u = rng.uniform();
        let sigma_t = volume.medium.sigma_t();
        let hit = self.ground.and_then(|(g, lights)| {
            let (t, n) = g.hit(ray.origin, ray.dir)?;
            Some((
                g,
                t,
                g.light_at(ray.origin + ray.dir * t, n, lights, sigma_t),
            ))
        });
        // A ground behind the ray's end (a holdout) is not seen, and shadows nothing here.
        let hit = hit.filter(|(_, t, _)| *t <= ray.t_max);
        let visible = hit.filter(|(g, _, _)| g.visible);
        if let Some((_, t, _)) = visible {
            ray.t_max = t;
        }
        let r = march(volume, self.lights, &ray, &self.settings, u, scratch);
        if let Some(m) = volume.mattes.filter(|_| self.passes.has_mattes()) {
            let alphas = m.alphas(
                sigma_t,
                ray.origin,
                ray.dir,
                ray.t_min,
                ray.t_max,
                self.settings.termination,
                &mut scratch.mattes,
            );
            self.passes.add_mattes(acc, alphas, 1.0);
        }
        if let (Some((_, t, light)), Some(tr)) = (visible, scratch.deep.as_mut()) {
            // The opaque floor: a sample of no depth that ends the ray.
            let radiance = light.irradiance * (ALBEDO / std::f64::consts::PI);
            let (a0, c0) = tr.last();
            let added = tr.segment(t, t, a0, c0, 1.0, c0 + r.transmittance * radiance);
            // In the beauty, not in a layer.
            tr.hold_aovs(added);
        }
        self.record(
            &r,
            hit,
            &scratch.per_light,
            scratch.indirect,
            camera.depth_rate,
            acc,
        );
        r.samples
    }
}

impl SingleScattering<'_> {
    /// The density the march integrates.
    pub fn density(&self) -> &dyn crate::field::Field {
        self.volume.density
    }

    /// The ground plane lit through the volume, if any.
    pub fn ground(&self) -> Option<Ground> {
        self.ground.map(|(g, _)| g)
    }

    /// The march's step and termination.
    pub fn settings(&self) -> MarchSettings {
        self.settings
    }

    /// Adds one camera sample's march result `r` to `acc` (laid out by the passes): the
    /// ground `hit` (its ray parameter and the light there) if the ray met it, and each
    /// light's share of the scattered radiance. The GPU backend, which marches elsewhere,
    /// writes its results through this too.
    pub fn record(
        &self,
        r: &RayResult,
        hit: Option<(Ground, f64, GroundLight)>,
        per_light: &[DVec3],
        indirect: DVec3,
        depth_rate: f64,
        acc: &mut [f64],
    ) {
        let visible = hit.filter(|(g, _, _)| g.visible);
        let p = &self.passes;
        if p.has_shadow() {
            match hit {
                Some((_, _, light)) => p.add_shadow(acc, light.fraction),
                None => p.add_shadow(acc, DVec3::ONE),
            }
        }
        let mut half_t = r.half_opacity_t;
        if let Some((_, t, light)) = visible {
            // An opaque grey floor behind the volume.
            let radiance = light.irradiance * (ALBEDO / std::f64::consts::PI);
            p.add_ground(acc, r.transmittance * radiance);
            p.add_alpha(acc, 1.0);
            half_t = half_t.or(Some(t));
        } else {
            p.add_alpha(acc, r.alpha());
        }
        p.add_emission(acc, r.emission);
        p.add_scatter_total(acc, r.scatter);
        p.add_indirect_share(acc, indirect);
        if p.has_per_light() {
            for (l, v) in per_light.iter().enumerate() {
                p.add_light_share(acc, l, *v);
            }
        }
        if let Some(t) = half_t {
            p.add_depth(acc, t * depth_rate);
        }
    }
}
