//! Single scattering: emission, absorption and light scattered once toward the camera,
//! by the ray march ([`march`]), with an optional ground plane behind the volume.

use super::ground::{ALBEDO, Ground};
use super::integrator::{CameraSample, Integrator, SampleRng};
use super::march::{Illumination, MarchSettings, Scratch, Volume, march};
use super::pass::{Pass, PassLayout};

/// Names of the passes single scattering writes (the EXR layers).
pub mod pass_names {
    pub const EMISSION: &str = "emission";
    pub const SCATTER: &str = "scatter";
    pub const SHADOW: &str = "shadow";
    /// A visible floor's radiance: summed into the beauty, not written as a layer.
    pub const GROUND: &str = "ground";
    /// The layer of one light's share of `scatter`.
    pub fn scatter_of(light: &str) -> String {
        format!("scatter_{light}")
    }
}

/// What single scattering integrates: the volume, the lights it scatters (if anything
/// scatters), and a ground plane lit through the volume.
pub struct SingleScattering<'a> {
    volume: &'a Volume<'a>,
    lights: Option<&'a dyn Illumination>,
    ground: Option<(Ground, &'a dyn Illumination)>,
    settings: MarchSettings,
    layout: PassLayout,
    /// Offsets of the passes in the pixel buffer.
    at: Offsets,
}

#[derive(Clone, Copy, Debug, Default)]
struct Offsets {
    alpha: usize,
    depth: usize,
    emission: Option<usize>,
    scatter: Option<usize>,
    /// First light's layer; the others follow, 3 slots each.
    per_light: Option<usize>,
    shadow: Option<usize>,
    ground: Option<usize>,
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
        let mut passes = vec![Pass::alpha(), Pass::depth()];
        if emits {
            passes.push(Pass::beauty(pass_names::EMISSION));
        }
        let mut names = Vec::new();
        if let Some((_, n)) = &lights {
            passes.push(Pass::beauty(pass_names::SCATTER));
            names.clone_from(n);
            if names.len() > 1 {
                for n in &names {
                    passes.push(Pass::layer(&pass_names::scatter_of(n)));
                }
            }
        }
        if ground.is_some() {
            passes.push(Pass::layer(pass_names::SHADOW));
        }
        if ground.is_some_and(|(g, _)| g.visible) {
            passes.push(Pass {
                layer: false,
                ..Pass::beauty(pass_names::GROUND)
            });
        }
        let layout = PassLayout::new(passes);
        let off = |name: &str| layout.find(name).map(|i| layout.offset(i));
        let at = Offsets {
            alpha: 0,
            depth: 1,
            emission: off(pass_names::EMISSION),
            scatter: off(pass_names::SCATTER),
            per_light: names
                .first()
                .filter(|_| names.len() > 1)
                .and_then(|n| off(&pass_names::scatter_of(n))),
            shadow: off(pass_names::SHADOW),
            ground: off(pass_names::GROUND),
        };
        SingleScattering {
            volume,
            lights: lights.map(|(l, _)| l),
            ground,
            settings,
            layout,
            at,
        }
    }
}

impl Integrator for SingleScattering<'_> {
    type Scratch = Scratch;

    fn passes(&self) -> &PassLayout {
        &self.layout
    }

    fn scratch(&self) -> Scratch {
        Scratch::new(self.lights.map_or(0, |l| l.light_count()))
    }

    fn sample(
        &self,
        camera: &CameraSample,
        rng: &mut SampleRng,
        scratch: &mut Scratch,
        acc: &mut [f64],
    ) -> u64 {
        let mut ray = camera.ray;
        let u = rng.uniform();
        let sigma_t = self.volume.medium.sigma_t();
        let hit = self.ground.and_then(|(g, lights)| {
            let (t, n) = g.hit(ray.origin, ray.dir)?;
            Some((
                g,
                t,
                g.light_at(ray.origin + ray.dir * t, n, lights, sigma_t),
            ))
        });
        let visible = hit.filter(|(g, _, _)| g.visible);
        if let Some((_, t, _)) = visible {
            ray.t_max = t;
        }
        let r = march(self.volume, self.lights, &ray, &self.settings, u, scratch);
        let at = &self.at;
        if let Some(s) = at.shadow {
            match hit {
                Some((_, _, light)) => (0..3).for_each(|c| acc[s + c] += light.fraction[c]),
                None => (0..3).for_each(|c| acc[s + c] += 1.0),
            }
        }
        let mut half_t = r.half_opacity_t;
        if let Some((_, t, light)) = visible {
            // An opaque grey floor behind the volume.
            let radiance = light.irradiance * (ALBEDO / std::f64::consts::PI);
            if let Some(gr) = at.ground {
                (0..3).for_each(|c| acc[gr + c] += r.transmittance[c] * radiance[c]);
            }
            acc[at.alpha] += 1.0;
            half_t = half_t.or(Some(t));
        } else {
            acc[at.alpha] += r.alpha();
        }
        if let Some(e) = at.emission {
            (0..3).for_each(|c| acc[e + c] += r.emission[c]);
        }
        if let Some(s) = at.scatter {
            (0..3).for_each(|c| acc[s + c] += r.scatter[c]);
        }
        if let Some(pl) = at.per_light {
            for (l, v) in scratch.per_light.iter().enumerate() {
                (0..3).for_each(|c| acc[pl + 3 * l + c] += v[c]);
            }
        }
        if let Some(t) = half_t {
            acc[at.depth] += t * camera.depth_rate;
            acc[at.depth + 1] += 1.0;
        }
        r.samples
    }
}
