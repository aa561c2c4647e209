//! Volumes that move while the shutter is open, by their keyed placements
//! (`[[volume.keys]]`) or their files' velocity grids: each camera sample sees every
//! volume as it is at its time — placed as then, and advected back along its own velocity
//! in its file's frame — in the summed density, the glowing volumes' emission, the colour
//! tint and the per-volume alphas; the path tracer's majorants bound the density at every
//! time at once, each moving volume's ranges grown by the farthest any of its points
//! moves within the shutter.

use super::plan::{PlacementKeys, VolumesPlan};
use crate::field::advect::index_pad;
use crate::field::advect_shared::{AdvectedShared, AdvectedSharedColor, SharedFlow};
use crate::field::albedo_mix::{AlbedoMix, PlacedColor};
use crate::field::padded_cells::Grown;
use crate::field::sum::FieldSum;
use crate::field::union::FieldUnion;
use crate::field::{ColorField, Field, IndexToWorld};
use crate::integrate::{ColorTint, Companion, Emission, Mattes, TimedVolume, Volume};
use glam::{DMat4, DVec3};
use std::sync::Arc;

/// Times a key interval of the shutter is sampled at to bound a volume's motion (the
/// ends and the keys between are sampled too; the bound is then taken 5 % wider).
const MOTION_SAMPLES: usize = 32;

/// One volume as the scene placed it at the frame, and its keys.
pub struct KeyedMember {
    pub density: Arc<dyn Field>,
    pub weight: f64,
    /// Its placement at the frame.
    pub placement: DMat4,
    pub keys: Option<PlacementKeys>,
    /// Its colour grid, unplaced.
    pub color: Option<Arc<dyn ColorField>>,
    pub albedo: DVec3,
    /// Its file's velocity, and how many of its time units a frame is.
    pub flow: Option<(SharedFlow, f64)>,
}

/// A glowing volume: which member, and its emission and temperature fields unplaced.
pub struct KeyedEmitter {
    pub member: usize,
    pub emission: Option<Arc<dyn Field>>,
    pub temperature: Option<Arc<dyn Field>>,
}

/// The scene's volumes as they move; see the module's documentation.
pub struct KeyedVolumes {
    members: Vec<KeyedMember>,
    emitters: Vec<KeyedEmitter>,
    /// The frame the keys are read at, and the sum's local index space (the still
    /// density's: every time is marched on its lattice).
    frame: f64,
    index: IndexToWorld,
    tinted: bool,
    swept: FieldSum,
}

/// The placement of `m` at `frame`.
fn placement_at(m: &KeyedMember, frame: f64) -> DMat4 {
    m.keys.as_ref().map_or(m.placement, |k| k.at(frame))
}

/// The farthest (world units) a point of `m`'s placed density moves from where it is at
/// `frame` within frames `[a, b]`: over its bounds' corners (the motion of a point is
/// affine in it, so its extremes are at corners) and sampled times.
fn reach(m: &KeyedMember, keys: &PlacementKeys, a: f64, b: f64) -> f64 {
    let own = m.density.transform();
    let bounds = m.density.active_bounds();
    if bounds.is_empty() {
        return 0.0;
    }
    let (lo, hi) = own.index_box_to_world(&bounds);
    let back = m.placement.inverse();
    let mut far: f64 = 0.0;
    for t in keys.sample_frames(a, b, MOTION_SAMPLES) {
        let moved = keys.at(t) * back;
        for c in 0..8 {
            let x = m.placement.transform_point3(DVec3::new(
                if c & 1 == 0 { lo.x } else { hi.x },
                if c & 2 == 0 { lo.y } else { hi.y },
                if c & 4 == 0 { lo.z } else { hi.z },
            ));
            far = far.max((moved.transform_point3(x) - x).length());
        }
    }
    far * 1.05
}

impl KeyedVolumes {
    /// The volumes of `plan` as they move within the shutter `(open, close)`, with the
    /// still sum's local index space `index`; `None` where none moves then (a still scene
    /// renders as without keys, bit for bit).
    pub fn new(
        plan: &VolumesPlan,
        shutter: (f64, f64),
        members: Vec<KeyedMember>,
        emitters: Vec<KeyedEmitter>,
        index: IndexToWorld,
    ) -> Option<KeyedVolumes> {
        let frame = plan.frame.unwrap_or(0.0);
        let (a, b) = (frame + shutter.0, frame + shutter.1);
        let keyed: Vec<bool> = members
            .iter()
            .map(|m| m.keys.as_ref().is_some_and(|k| k.moves_between(a, b)))
            .collect();
        if !keyed
            .iter()
            .zip(&members)
            .any(|(k, m)| *k || m.flow.is_some())
        {
            return None;
        }
        let swept = members
            .iter()
            .zip(&keyed)
            .map(|(m, keyed)| {
                let own = m.density.transform();
                let mut pad = DVec3::ZERO;
                if let (Some(k), true) = (&m.keys, keyed) {
                    let far = reach(m, k, a, b);
                    pad += IndexToWorld::new(m.placement * own.matrix(), own.origin)
                        .map_or(DVec3::splat(f64::INFINITY), |t| index_pad(&t, far));
                }
                if let Some((flow, _)) = &m.flow {
                    pad += index_pad(own, flow.reach);
                }
                let field = if pad == DVec3::ZERO {
                    m.density.clone()
                } else {
                    Arc::new(Grown::new(m.density.clone(), pad)) as Arc<dyn Field>
                };
                (field, m.placement, m.weight)
            })
            .collect();
        let swept = FieldSum::in_frame(swept, index).ok()?;
        Some(KeyedVolumes {
            members,
            emitters,
            frame,
            index,
            tinted: plan.tinted,
            swept,
        })
    }
}

impl TimedVolume for KeyedVolumes {
    fn at_time(&self, base: &Volume, time: f64, f: &mut dyn FnMut(&Volume)) {
        let frame = self.frame + time;
        let placements: Vec<DMat4> = self
            .members
            .iter()
            .map(|m| placement_at(m, frame))
            .collect();
        // A field of member `m` as it is at `time`: moved back along its velocity.
        let moved = |f: &Arc<dyn Field>, m: &KeyedMember| match &m.flow {
            Some((flow, per_frame)) if time != 0.0 => Arc::new(AdvectedShared::new(
                f.clone(),
                flow.clone(),
                per_frame * time,
            )) as Arc<dyn Field>,
            _ => f.clone(),
        };
        let members = self
            .members
            .iter()
            .zip(&placements)
            .map(|(m, p)| (moved(&m.density, m), *p, m.weight))
            .collect();
        let Ok(sum) = FieldSum::in_frame(members, self.index) else {
            return f(base);
        };
        let place = |field: &Option<Arc<dyn Field>>, i: usize| {
            field.as_ref().and_then(|g| {
                let g = moved(g, &self.members[i]);
                FieldSum::in_frame(vec![(g, placements[i], 1.0)], self.index).ok()
            })
        };
        let glowing: Vec<(Option<FieldSum>, Option<FieldSum>)> = self
            .emitters
            .iter()
            .map(|e| {
                (
                    place(&e.emission, e.member),
                    place(&e.temperature, e.member),
                )
            })
            .collect();
        let colors = self
            .members
            .iter()
            .zip(&placements)
            .map(|(m, p)| {
                m.color.as_ref().and_then(|c| {
                    let c = match &m.flow {
                        Some((flow, per_frame)) if time != 0.0 => Arc::new(AdvectedSharedColor {
                            inner: c.clone(),
                            velocity: flow.velocity.clone(),
                            shift: per_frame * time,
                        })
                            as Arc<dyn ColorField>,
                        _ => c.clone(),
                    };
                    PlacedColor::new(c, *p).map(|c| Arc::new(c) as Arc<dyn ColorField>)
                })
            })
            .collect();
        let albedo = self.members.iter().map(|m| m.albedo).collect();
        let color = tint(&sum, self.tinted, albedo, colors);
        let density: &dyn Field = &sum;
        let mut traversal = FieldUnion::new(density);
        for (e, t) in &glowing {
            for g in [e, t].into_iter().flatten() {
                if let Some(o) = Companion::new(g, density).offset() {
                    traversal = traversal.with(g, o.as_ivec3());
                }
            }
        }
        fn companion<'g>(g: &'g Option<FieldSum>, density: &dyn Field) -> Option<Companion<'g>> {
            g.as_ref().map(|g| Companion::new(g as &dyn Field, density))
        }
        let emission = base.emission.as_ref().map(|e| match glowing.split_first() {
            None => e.clone(),
            Some(((g, t), rest)) => Emission {
                grid: companion(g, density),
                temperature: companion(t, density),
                more: e
                    .more
                    .iter()
                    .zip(rest)
                    .map(|(m, (g, t))| Emission {
                        grid: companion(g, density),
                        temperature: companion(t, density),
                        ..m.clone()
                    })
                    .collect(),
                ..e.clone()
            },
        });
        let volume = Volume {
            density,
            medium: base.medium,
            phase: base.phase.clone(),
            emission,
            color: color.as_ref().map(|c| ColorTint::new(c.as_ref(), density)),
            traversal: &traversal,
            sampled_means: base.sampled_means,
            mattes: base.mattes.map(|m| Mattes {
                sum: &sum,
                names: m.names,
            }),
            motion: None,
            keyed: None,
        };
        f(&volume)
    }

    fn swept(&self) -> &dyn Field {
        &self.swept
    }
}

/// The scattering tint: the albedos' mix where they differ (`tinted`: the plan's medium
/// then scatters its whole extinction), each volume's colour grid on its own share; one
/// untinted volume's colour grid as it is.
pub(super) fn tint(
    sum: &FieldSum,
    tinted: bool,
    albedo: Vec<DVec3>,
    mut colors: Vec<Option<Arc<dyn ColorField>>>,
) -> Option<Box<dyn ColorField>> {
    let coloured = colors.iter().any(Option::is_some);
    if !tinted && !coloured {
        return None;
    }
    if !tinted && colors.len() == 1 {
        return colors
            .pop()
            .flatten()
            .map(|c| Box::new(Shared(c)) as Box<dyn ColorField>);
    }
    let albedo = if tinted {
        albedo
    } else {
        vec![DVec3::ONE; albedo.len()]
    };
    AlbedoMix::with_colors(sum.clone(), albedo, colors).map(|m| Box::new(m) as Box<dyn ColorField>)
}

/// A shared colour field as a boxed one.
struct Shared(Arc<dyn ColorField>);

impl ColorField for Shared {
    fn transform(&self) -> &IndexToWorld {
        self.0.transform()
    }
    fn color_at_index(&self, p: DVec3) -> glam::Vec3 {
        self.0.color_at_index(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::shapes::ConstantBox;
    use crate::field::{IndexBox, ValueRange};
    use crate::integrate::Medium;
    use glam::Vec3;

    /// A unit box keyed to slide 2 units along x and turn a quarter turn about y between
    /// frames 0 and 2, seen at frame 1 through a one-frame shutter: at every time its
    /// centre has density 1 in the sum `at_time` gives, and the swept density's range
    /// around that point holds 1 (the majorants skip nothing it moves through), while
    /// far from its path the swept range is 0.
    #[test]
    fn the_swept_density_bounds_the_volume_at_every_time() {
        let cube: Arc<dyn Field> =
            Arc::new(ConstantBox::new(DVec3::ZERO, DVec3::ONE, 1.0, 0.05).unwrap());
        let table: crate::scene::options::volume::VolumeTable = toml::from_str(
            "file = \"a\"\n[[keys]]\nframe = 0\n[[keys]]\nframe = 2\ntranslate = [2, 0, 0]\nrotate = [0, 90, 0]\n",
        )
        .unwrap();
        let keys = PlacementKeys::of_table(&table, "a").unwrap().unwrap();
        let placement = keys.at(1.0);
        let member = || KeyedMember {
            density: cube.clone(),
            weight: 1.0,
            placement,
            keys: Some(keys.clone()),
            color: None,
            albedo: DVec3::ONE,
            flow: None,
        };
        let still = FieldSum::new(vec![(cube.clone(), placement, 1.0)]).unwrap();
        let plan = VolumesPlan {
            list: Vec::new(),
            tinted: false,
            frame: Some(1.0),
        };
        let keyed = KeyedVolumes::new(
            &plan,
            (-0.5, 0.5),
            vec![member()],
            Vec::new(),
            *still.transform(),
        )
        .unwrap();
        let medium = Medium {
            sigma_a: DVec3::ONE,
            sigma_s: DVec3::ZERO,
            density_scale: 1.0,
            g: 0.0,
        };
        let base = Volume::of(&still, medium);
        let swept = keyed.swept();
        let around = |w: DVec3| {
            let p = swept.transform().world_to_index(w).as_vec3();
            swept.range_over(&IndexBox::new(p - Vec3::splat(0.5), p + Vec3::splat(0.5)))
        };
        for k in 0..=40 {
            let t = -0.5 + k as f64 / 40.0;
            let centre = keys.at(1.0 + t).transform_point3(DVec3::splat(0.5));
            let mut value = f32::NAN;
            keyed.at_time(&base, t, &mut |v| value = v.density.value_at_world(centre));
            assert_eq!(value, 1.0, "t {t}: centre {centre}");
            assert!(around(centre).max >= 1.0, "t {t}: {:?}", around(centre));
        }
        assert_eq!(around(DVec3::new(0.5, 5.0, 0.5)), ValueRange::ZERO);
        // Keys that do not move within the shutter: nothing is keyed.
        let late = VolumesPlan {
            frame: Some(9.0),
            ..plan
        };
        let index = *still.transform();
        assert!(KeyedVolumes::new(&late, (-0.5, 0.5), vec![member()], Vec::new(), index).is_none());
    }
}
