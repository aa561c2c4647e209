//! The passes every scattering integrator writes (`single`, `fast`, `path`), declared in
//! one place so their EXRs have the same layers in the same order: `A`, `Z`, `emission`,
//! `scatter` (all scattered light), `indirect` (the part scattered two or more times; not
//! for single scattering), one `scatter_<light>` per light when there are several (each
//! holding that light's direct and indirect light), `shadow`, a visible `ground`, and in a
//! scene of several volumes one alpha layer `volume_<name>` per volume
//! ([`super::mattes`]).

use super::pass::{Pass, PassLayout};
use glam::DVec3;

/// Names of the passes (the EXR layers).
pub mod pass_names {
    pub const EMISSION: &str = "emission";
    /// All scattered light, every order.
    pub const SCATTER: &str = "scatter";
    /// Light scattered two or more times: `scatter − indirect` is the direct part.
    pub const INDIRECT: &str = "indirect";
    pub const SHADOW: &str = "shadow";
    /// A visible floor's radiance: summed into the beauty, not written as a layer.
    pub const GROUND: &str = "ground";
    /// The layer of one light's share of `scatter`.
    pub fn scatter_of(light: &str) -> String {
        format!("scatter_{light}")
    }
    /// The alpha layer of one volume of several.
    pub fn volume_of(volume: &str) -> String {
        format!("volume_{volume}")
    }
}

/// Which of the passes an integrator writes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ScatterPassSpec {
    /// The emission layer is written.
    pub emits: bool,
    /// The names of the lights that scatter (empty: nothing scatters, no scatter layer);
    /// a layer each when there are several.
    pub lights: Vec<String>,
    /// The `indirect` layer is written (multiple scattering).
    pub indirect: bool,
    /// A ground plane's `shadow` layer is written.
    pub shadow: bool,
    /// A visible ground plane is summed into the beauty.
    pub ground_visible: bool,
    /// The names of the volumes of a scene of several (empty for one): an alpha layer
    /// each.
    pub volumes: Vec<String>,
}

/// The pass layout of a scattering integrator and where each pass sits in a pixel's
/// buffer, with the writes into it.
#[derive(Clone, Debug)]
pub struct ScatterPasses {
    layout: PassLayout,
    at: Offsets,
    /// The lights that scatter, in their layers' order.
    lights: Vec<String>,
}

#[derive(Clone, Copy, Debug, Default)]
struct Offsets {
    alpha: usize,
    depth: usize,
    emission: Option<usize>,
    scatter: Option<usize>,
    indirect: Option<usize>,
    /// First light's layer; the others follow, 3 slots each.
    per_light: Option<usize>,
    shadow: Option<usize>,
    ground: Option<usize>,
    /// First volume's alpha; the others follow, 1 slot each.
    mattes: Option<usize>,
}

#[inline]
fn add(acc: &mut [f64], at: Option<usize>, v: DVec3) {
    if let Some(s) = at {
        (0..3).for_each(|c| acc[s + c] += v[c]);
    }
}

impl ScatterPasses {
    pub fn new(spec: &ScatterPassSpec) -> Self {
        let mut passes = vec![Pass::alpha(), Pass::depth()];
        if spec.emits {
            passes.push(Pass::beauty(pass_names::EMISSION));
        }
        let names = &spec.lights;
        if !names.is_empty() {
            passes.push(Pass::beauty(pass_names::SCATTER));
            if spec.indirect {
                passes.push(Pass::layer(pass_names::INDIRECT));
            }
            if names.len() > 1 {
                for n in names {
                    passes.push(Pass::layer(&pass_names::scatter_of(n)));
                }
            }
        }
        if spec.shadow {
            passes.push(Pass::layer(pass_names::SHADOW));
        }
        if spec.ground_visible {
            passes.push(Pass {
                layer: false,
                ..Pass::beauty(pass_names::GROUND)
            });
        }
        for v in &spec.volumes {
            passes.push(Pass::matte(&pass_names::volume_of(v)));
        }
        let layout = PassLayout::new(passes);
        let off = |name: &str| layout.find(name).map(|i| layout.offset(i));
        let at = Offsets {
            alpha: 0,
            depth: 1,
            emission: off(pass_names::EMISSION),
            scatter: off(pass_names::SCATTER),
            indirect: off(pass_names::INDIRECT),
            per_light: names
                .first()
                .filter(|_| names.len() > 1)
                .and_then(|n| off(&pass_names::scatter_of(n))),
            shadow: off(pass_names::SHADOW),
            ground: off(pass_names::GROUND),
            mattes: spec
                .volumes
                .first()
                .and_then(|v| off(&pass_names::volume_of(v))),
        };
        ScatterPasses {
            layout,
            at,
            lights: names.clone(),
        }
    }

    /// The layers a deep file may carry as AOVs ([`super::deep`]'s record of a march:
    /// emission, scattered light per light and its indirect part): those of these passes.
    pub fn deep_aovs(&self) -> Vec<super::deep::DeepAov> {
        use super::deep::{AOV_EMISSION, AOV_INDIRECT, AOV_LIGHTS, DeepAov};
        let aov = |layer: &str, rows: Vec<usize>| DeepAov {
            layer: layer.to_string(),
            rows,
        };
        let lights: Vec<usize> = (0..self.lights.len()).map(|l| AOV_LIGHTS + 3 * l).collect();
        let mut out = Vec::new();
        if self.at.emission.is_some() {
            out.push(aov(pass_names::EMISSION, vec![AOV_EMISSION]));
        }
        if self.at.scatter.is_some() {
            out.push(aov(pass_names::SCATTER, lights.clone()));
        }
        if self.at.indirect.is_some() {
            out.push(aov(pass_names::INDIRECT, vec![AOV_INDIRECT]));
        }
        if self.at.per_light.is_some() {
            for (name, row) in self.lights.iter().zip(lights) {
                out.push(aov(&pass_names::scatter_of(name), vec![row]));
            }
        }
        out
    }

    pub fn layout(&self) -> &PassLayout {
        &self.layout
    }

    /// True when light `l`'s share is written as its own layer (several lights).
    pub fn has_per_light(&self) -> bool {
        self.at.per_light.is_some()
    }

    pub fn add_alpha(&self, acc: &mut [f64], alpha: f64) {
        acc[self.at.alpha] += alpha;
    }

    /// One sample's camera-space depth where its opacity crosses 0.5.
    pub fn add_depth(&self, acc: &mut [f64], depth: f64) {
        self.add_depths(acc, depth, 1.0);
    }

    /// The sum of `count` samples' depths (as [`add_depth`](Self::add_depth) adds each).
    pub fn add_depths(&self, acc: &mut [f64], sum: f64, count: f64) {
        acc[self.at.depth] += sum;
        acc[self.at.depth + 1] += count;
    }

    pub fn add_emission(&self, acc: &mut [f64], v: DVec3) {
        add(acc, self.at.emission, v);
    }

    /// Light `light` scattered toward the camera after `events` scattering events (1:
    /// direct): into `scatter`, the light's own layer and, from two events on, `indirect`.
    #[inline]
    pub fn add_scattered(&self, acc: &mut [f64], light: usize, events: u32, v: DVec3) {
        add(acc, self.at.scatter, v);
        if events >= 2 {
            add(acc, self.at.indirect, v);
        }
        self.add_light_share(acc, light, v);
    }

    /// The volume's own emission reaching the camera after `events` ≥ 1 scattering
    /// events: scattered light that no light's layer holds.
    pub fn add_scattered_emission(&self, acc: &mut [f64], events: u32, v: DVec3) {
        add(acc, self.at.scatter, v);
        if events >= 2 {
            add(acc, self.at.indirect, v);
        }
    }

    /// Scattered light summed over the lights, into `scatter` only (with
    /// [`ScatterPasses::add_light_share`] for the per-light layers).
    pub fn add_scatter_total(&self, acc: &mut [f64], v: DVec3) {
        add(acc, self.at.scatter, v);
    }

    /// The part of what [`ScatterPasses::add_scatter_total`] added that scattered two or
    /// more times, into `indirect` only.
    pub fn add_indirect_share(&self, acc: &mut [f64], v: DVec3) {
        add(acc, self.at.indirect, v);
    }

    /// Light `light`'s share of `scatter`, into its own layer (when there are several).
    #[inline]
    pub fn add_light_share(&self, acc: &mut [f64], light: usize, v: DVec3) {
        add(acc, self.at.per_light.map(|p| p + 3 * light), v);
    }

    /// The fraction of the lights reaching the ground (1 where there is no ground hit).
    pub fn add_shadow(&self, acc: &mut [f64], v: DVec3) {
        add(acc, self.at.shadow, v);
    }

    /// A visible ground plane's radiance reaching the camera.
    pub fn add_ground(&self, acc: &mut [f64], v: DVec3) {
        add(acc, self.at.ground, v);
    }

    /// Whether the volumes' alphas are written (a scene of several volumes).
    pub fn has_mattes(&self) -> bool {
        self.at.mattes.is_some()
    }

    /// Each volume's alpha times `weight`, in the volumes' order.
    pub fn add_mattes(&self, acc: &mut [f64], alphas: &[f64], weight: f64) {
        if let Some(at) = self.at.mattes {
            for (slot, a) in acc[at..].iter_mut().zip(alphas) {
                *slot += a * weight;
            }
        }
    }

    pub fn has_shadow(&self) -> bool {
        self.at.shadow.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn indirect_follows_scatter_and_counts_only_later_events() {
        let p = ScatterPasses::new(&ScatterPassSpec {
            emits: true,
            lights: vec!["sun0".into(), "env0".into()],
            indirect: true,
            ..Default::default()
        });
        let names: Vec<&str> = p
            .layout()
            .passes()
            .iter()
            .map(|p| p.name.as_str())
            .collect();
        assert_eq!(
            names,
            [
                "A",
                "Z",
                "emission",
                "scatter",
                "indirect",
                "scatter_sun0",
                "scatter_env0"
            ]
        );
        let mut acc = vec![0.0; p.layout().slots()];
        p.add_scattered(&mut acc, 0, 1, DVec3::splat(1.0));
        p.add_scattered(&mut acc, 1, 3, DVec3::splat(2.0));
        // scatter = 3, indirect = 2, sun0 = 1, env0 = 2.
        assert_eq!(&acc[6..9], &[3.0; 3]);
        assert_eq!(&acc[9..12], &[2.0; 3]);
        assert_eq!(&acc[12..15], &[1.0; 3]);
        assert_eq!(&acc[15..18], &[2.0; 3]);
        let single = ScatterPasses::new(&ScatterPassSpec {
            lights: vec!["sun0".into()],
            ..Default::default()
        });
        assert!(single.layout().find(pass_names::INDIRECT).is_none());
    }
}
