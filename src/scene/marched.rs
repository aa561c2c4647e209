//! What the integrators march: the scene's fields as an integrate::Volume (density,
//! medium, emission of the input or of every volume, colour tint, the volumes' parts for
//! their alpha layers) and the fields a camera ray visits.

use super::Scene;
use super::plan::EmissionPlan;
use crate::field::union::FieldUnion;
use crate::field::{ColorField, Field};
use crate::integrate::blackbody::BlackbodyTable;
use crate::integrate::{ColorTint, Companion, Emission, Mattes, Volume};

impl Scene {
    /// Something moves while the shutter is open: the density by its velocity, a keyed
    /// or advected `[[volume]]`, or the camera.
    pub fn moves(&self) -> bool {
        self.motion.is_some() || self.fields.keyed.is_some() || self.camera_motion.is_some()
    }

    /// The fields whose non-zero cells a camera ray visits: the density, and the emission
    /// and temperature fields on its lattice (elsewhere they are sampled only where the
    /// density is non-zero, which the report notes).
    pub fn traversal(&self) -> FieldUnion<'_> {
        let density = self.fields.density.as_ref();
        let mut traversal = FieldUnion::new(density);
        for f in self.emission_fields() {
            if let Some(o) = Companion::new(f, density).offset() {
                traversal = traversal.with(f, o.as_ivec3());
            }
        }
        traversal
    }

    /// The emission and temperature fields of the input or of every volume.
    pub(super) fn emission_fields(&self) -> impl Iterator<Item = &dyn Field> {
        let own = [&self.fields.emission, &self.fields.temperature];
        let volumes = self
            .fields
            .emitters
            .iter()
            .flat_map(|e| [&e.emission, &e.temperature]);
        own.into_iter()
            .chain(volumes)
            .flatten()
            .map(|f| f.as_ref() as &dyn Field)
    }

    /// The volume the integrators march, traversed over `traversal`
    /// ([`Scene::traversal`]).
    pub fn volume<'a>(&'a self, traversal: &'a FieldUnion<'a>) -> Volume<'a> {
        let density = self.fields.density.as_ref();
        let companion =
            |f: &'a Option<Box<dyn Field>>| f.as_ref().map(|g| Companion::new(g.as_ref(), density));
        let emission = |e: &EmissionPlan,
                        grid: &'a Option<Box<dyn Field>>,
                        temperature: &'a Option<Box<dyn Field>>,
                        table: &BlackbodyTable| Emission {
            grid: companion(grid),
            color: e.color,
            intensity: e.intensity,
            temperature: companion(temperature),
            temperature_scale: e.temperature_scale,
            temperature_offset: e.temperature_offset,
            blackbody_intensity: e.blackbody_intensity,
            table: table.clone(),
            more: Vec::new(),
        };
        // Several volumes: the first glowing one's emission, the others' added to it.
        let emission =
            self.emission
                .as_ref()
                .map(|(e, table)| match self.fields.emitters.split_first() {
                    None => emission(e, &self.fields.emission, &self.fields.temperature, table),
                    Some((first, rest)) => Emission {
                        more: rest
                            .iter()
                            .map(|r| emission(&r.plan, &r.emission, &r.temperature, table))
                            .collect(),
                        ..emission(&first.plan, &first.emission, &first.temperature, table)
                    },
                });
        Volume {
            density,
            medium: self.medium,
            phase: self.phase.clone(),
            emission,
            mattes: self.fields.parts.as_ref().map(|p| Mattes {
                sum: &p.sum,
                names: &p.names,
            }),
            color: self
                .fields
                .color
                .as_ref()
                .map(|c| ColorTint::new(c.as_ref() as &dyn ColorField, density)),
            // The density alone where nothing else is traversed: the march then knows
            // its cells' ranges for the density's (a constant cell needs no integral).
            traversal: traversal.alone().unwrap_or(traversal),
            // A coarse level's steps span several of its voxels: two samples a step.
            sampled_means: self.density_level.as_ref().is_some_and(|l| l.level > 0),
            motion: self.motion.as_ref().map(|m| m.motion()),
            keyed: self
                .fields
                .keyed
                .as_deref()
                .map(|k| k as &dyn crate::integrate::TimedVolume),
        }
    }
}
