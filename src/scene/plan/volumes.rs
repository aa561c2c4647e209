//! The `[[volume]]` tables of a scene file as a plan: each volume's file, placement and
//! density role, and the one medium of their sum.
//!
//! Where volumes overlap their coefficients add: σt(x) = Σ σt,ᵢ·sᵢ·ρᵢ(x), σs likewise. The
//! renderer marches one scalar density in one medium, so the volumes' extinctions must
//! share one colour `S` (grey ones always do): then σt(x) = S·D(x) with the summed density
//! D = Σ wᵢρᵢ, wᵢ = σt,ᵢ·sᵢ / S. Volumes of one albedo keep it as the medium's; volumes of
//! different albedos scatter `S` tinted per point by the density-weighted mean albedo
//! (`field::sum::AlbedoMix`), which gives σs(x) = Σ σs,ᵢ·sᵢ·ρᵢ(x) exactly.

use super::look::{EmissionPlan, GridChoice, GridRoles, medium};
use super::volume_keys::{PlacementKeys, matrix_from_rows, rotation, scale_of};
use crate::integrate::Medium;
use crate::scene::options::RenderOptions;
use crate::scene::options::volume::VolumeTable;
use glam::{DMat4, DVec3};
use std::path::PathBuf;

/// Volumes a scene may place at most: each cell query of the summed density visits every
/// volume's bounds, so a scene of millions would crawl rather than fail.
pub const MAX_VOLUMES: usize = 4096;

/// One volume to place.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumePlan {
    pub name: String,
    pub file: PathBuf,
    /// World placement, applied after the file's own index→world map.
    pub placement: DMat4,
    /// The grids in their roles (the table's keys over the scene's).
    pub grids: GridRoles,
    /// How the volume glows (the table's keys over the scene's).
    pub emission: EmissionPlan,
    /// `temperature_scale` or `temperature_offset` given (table or scene): the Kelvin
    /// mapping is not detected.
    pub temperature_explicit: bool,
    /// Its density's weight in the summed density (σt·scale over the common extinction).
    pub weight: f64,
    /// σs/σt per channel (0 where σt is 0).
    pub albedo: DVec3,
    /// The placement keyed at frames (`[[volume.keys]]`): `placement` is its value at
    /// the volumes' frame.
    pub keys: Option<PlacementKeys>,
}

/// The volumes and the medium of their sum.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumesPlan {
    pub list: Vec<VolumePlan>,
    /// The volumes' albedos differ: scattering is tinted per point.
    pub tinted: bool,
    /// The frame the keyed placements are taken at: the sequence's frame, else the
    /// earliest key (`None`: nothing is keyed).
    pub frame: Option<f64>,
}

impl VolumesPlan {
    /// Every keyed volume placed as at `frame`.
    pub fn at_frame(&mut self, frame: f64) {
        let mut keyed = false;
        for v in &mut self.list {
            if let Some(k) = &v.keys {
                v.placement = k.at(frame);
                keyed = true;
            }
        }
        self.frame = keyed.then_some(frame);
    }
}

/// The placement a table asks for: `matrix`, or translate · rotate · scale.
fn placement(v: &VolumeTable, name: &str) -> Result<DMat4, String> {
    let at = format!("[[volume]] \"{name}\"");
    let m = match v.matrix {
        Some(rows) => {
            if v.translate.is_some() || v.rotate.is_some() || v.scale.is_some() {
                return Err(format!(
                    "{at}: `matrix` replaces translate/rotate/scale; give one or the other"
                ));
            }
            matrix_from_rows(rows, &at)?
        }
        None => {
            let scale = scale_of(v.scale);
            let rotation = rotation(v.rotate.unwrap_or([0.0; 3]));
            let t = DVec3::from_array(v.translate.unwrap_or([0.0; 3]));
            DMat4::from_scale_rotation_translation(scale, rotation, t)
        }
    };
    let det = m.determinant();
    if !m.is_finite() {
        return Err(format!("{at}: the transform is not finite"));
    }
    if det.abs() < 1e-12 {
        return Err(format!(
            "{at}: the transform is singular (determinant {det:e}): it flattens the volume"
        ));
    }
    Ok(m)
}

/// The plan of `o`'s `[[volume]]` tables (`None` without any), and the medium of their
/// sum, from the scene's medium `base` (each table's keys over the scene's).
pub(super) fn volumes(
    o: &RenderOptions,
    base: Medium,
) -> Result<Option<(VolumesPlan, Medium)>, String> {
    if o.volume.is_empty() {
        return Ok(None);
    }
    if o.input.is_some() {
        return Err(
            "a scene with [[volume]] tables lists its inputs there: remove `input` or list it as a [[volume]]"
                .into(),
        );
    }
    if o.volume.len() > MAX_VOLUMES {
        return Err(format!(
            "{} [[volume]] tables: murk places at most {MAX_VOLUMES}",
            o.volume.len()
        ));
    }
    let mut list = Vec::with_capacity(o.volume.len());
    let mut media = Vec::with_capacity(o.volume.len());
    for (i, v) in o.volume.iter().enumerate() {
        let name = v.name.clone().unwrap_or_else(|| format!("volume{}", i + 1));
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        {
            return Err(format!(
                "[[volume]] name \"{name}\" must be letters, digits, _ or - (it names an EXR layer)"
            ));
        }
        if list.iter().any(|p: &VolumePlan| p.name == name) {
            return Err(format!("two [[volume]] tables are named \"{name}\""));
        }
        let own = RenderOptions {
            sigma_a: v.sigma_a.clone().or_else(|| o.sigma_a.clone()),
            sigma_s: v.sigma_s.clone().or_else(|| o.sigma_s.clone()),
            density_scale: v.density_scale.or(o.density_scale),
            g: Some(base.g),
            density_grid: v.density_grid.clone().or_else(|| o.density_grid.clone()),
            emission_grid: v.emission_grid.clone().or_else(|| o.emission_grid.clone()),
            temperature_grid: v
                .temperature_grid
                .clone()
                .or_else(|| o.temperature_grid.clone()),
            color_grid: v.color_grid.clone().or_else(|| o.color_grid.clone()),
            emission_color: v
                .emission_color
                .clone()
                .or_else(|| o.emission_color.clone()),
            emission_intensity: v.emission_intensity.or(o.emission_intensity),
            temperature_scale: v.temperature_scale.or(o.temperature_scale),
            temperature_offset: v.temperature_offset.or(o.temperature_offset),
            blackbody_intensity: v.blackbody_intensity.or(o.blackbody_intensity),
            ..RenderOptions::default()
        };
        let at = |e: String| format!("[[volume]] \"{name}\": {e}");
        let m = medium(&own).map_err(at)?;
        let emission = EmissionPlan::from_options(&own).map_err(at)?;
        let placement = placement(v, &name)?;
        let keys = PlacementKeys::of_table(v, &name)?;
        let grids = GridRoles::from_options(&own);
        if grids.density == GridChoice::Off {
            return Err(at("a volume needs a density grid".into()));
        }
        list.push(VolumePlan {
            name,
            file: v.file.clone(),
            placement,
            grids,
            emission,
            temperature_explicit: own.temperature_scale.is_some()
                || own.temperature_offset.is_some(),
            weight: 0.0,
            albedo: DVec3::ZERO,
            keys,
        });
        media.push(m);
    }
    // The common extinction colour: the first volume's that extinguishes.
    let Some(first) = media.iter().find(|m| m.sigma_t().max_element() > 0.0) else {
        let none = Medium {
            sigma_a: DVec3::ZERO,
            sigma_s: DVec3::ZERO,
            density_scale: 1.0,
            g: base.g,
        };
        return Ok(Some((keyed(list, false), none)));
    };
    let s = first.sigma_a + first.sigma_s;
    let albedo_of = |m: &Medium| {
        let t = m.sigma_a + m.sigma_s;
        DVec3::select(t.cmpgt(DVec3::ZERO), m.sigma_s / t, DVec3::ZERO)
    };
    let first_albedo = albedo_of(first);
    let mut tinted = false;
    for (p, m) in list.iter_mut().zip(&media) {
        let e = m.sigma_t();
        let w = e.max_element() / s.max_element();
        if ((e - s * w).abs().max_element()) > 1e-9 * e.max_element() {
            return Err(format!(
                "[[volume]] \"{}\": its extinction σa+σs ({:.4},{:.4},{:.4}) is not of the first volume's colour ({:.4},{:.4},{:.4}); volumes that overlap share one extinction colour (give the colour in σs: their albedos may differ)",
                p.name, e.x, e.y, e.z, s.x, s.y, s.z
            ));
        }
        p.weight = w;
        p.albedo = albedo_of(m);
        if w > 0.0 && (p.albedo - first_albedo).abs().max_element() > 1e-12 {
            tinted = true;
        }
    }
    let summed = if tinted {
        Medium {
            sigma_a: DVec3::ZERO,
            sigma_s: s,
            density_scale: 1.0,
            g: base.g,
        }
    } else {
        Medium {
            sigma_a: first.sigma_a,
            sigma_s: first.sigma_s,
            density_scale: 1.0,
            g: base.g,
        }
    };
    Ok(Some((keyed(list, tinted), summed)))
}

/// The volumes placed as at the earliest key (as they are if none is keyed).
fn keyed(list: Vec<VolumePlan>, tinted: bool) -> VolumesPlan {
    let first = list
        .iter()
        .filter_map(|v| v.keys.as_ref().map(PlacementKeys::first_frame))
        .reduce(f64::min);
    let mut plan = VolumesPlan {
        list,
        tinted,
        frame: None,
    };
    if let Some(f) = first {
        plan.at_frame(f);
    }
    plan
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> Result<Option<(VolumesPlan, Medium)>, String> {
        let o: RenderOptions = toml::from_str(text).map_err(|e| e.to_string())?;
        let base = medium(&o)?;
        volumes(&o, base)
    }

    #[test]
    fn media_of_one_colour_sum_into_weights() {
        let (v, m) = table(
            "sigma_a = \"0.1\"\nsigma_s = \"2\"\n[[volume]]\nfile = \"a.vdb\"\n[[volume]]\nfile = \"a.vdb\"\nname = \"b\"\nsigma_a = \"1\"\nsigma_s = \"0.05\"\ndensity_scale = 2\ntranslate = [1, 0, 0]\n",
        )
        .unwrap()
        .unwrap();
        assert_eq!(v.list[0].name, "volume1");
        assert_eq!(v.list[0].weight, 1.0);
        assert!((v.list[1].weight - 2.0 * 1.05 / 2.1).abs() < 1e-12);
        assert!(v.tinted);
        assert_eq!(m.sigma_s, DVec3::splat(2.1));
        assert_eq!(m.sigma_a, DVec3::ZERO);
        assert!((v.list[1].albedo.x - 0.05 / 1.05).abs() < 1e-12);
        assert_eq!(v.list[1].placement.transform_point3(DVec3::ZERO), DVec3::X);
    }

    #[test]
    fn one_medium_is_kept_as_it_is() {
        let (v, m) = table("[[volume]]\nfile = \"a.vdb\"\ndensity_scale = 3\n")
            .unwrap()
            .unwrap();
        assert!(!v.tinted);
        assert_eq!(
            (m.sigma_a, m.sigma_s),
            (DVec3::splat(0.1), DVec3::splat(2.0))
        );
        assert_eq!(v.list[0].weight, 3.0);
    }

    #[test]
    fn bad_tables_are_refused_in_one_line() {
        for (text, want) in [
            ("[[volume]]\nfile = \"a\"\nscale = [1, 0, 1]\n", "singular"),
            (
                "[[volume]]\nfile = \"a\"\nmatrix = [[1,0,0,0],[0,1,0,0],[0,0,1,0],[2,3,4,1]]\n",
                "last row",
            ),
            (
                "[[volume]]\nfile = \"a\"\nmatrix = [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\nscale = 2\n",
                "one or the other",
            ),
            (
                "[[volume]]\nfile = \"a\"\n[[volume]]\nfile = \"b\"\nsigma_s = \"1,0,0\"\nsigma_a = \"0\"\n",
                "extinction colour",
            ),
            (
                "input = \"x.vdb\"\n[[volume]]\nfile = \"a\"\n",
                "remove `input`",
            ),
            ("[[volume]]\nfile = \"a\"\nname = \"x y\"\n", "letters"),
            (
                "[[volume]]\nfile = \"a\"\nname = \"x\"\n[[volume]]\nfile = \"a\"\nname = \"x\"\n",
                "two [[volume]]",
            ),
            ("[[volume]]\nname = \"x\"\n", "missing field `file`"),
            (
                "[[volume]]\nfile = \"a\"\nshift = [1, 2, 3]\n",
                "unknown field `shift`",
            ),
        ] {
            let e = table(text).unwrap_err();
            assert!(e.contains(want), "{text}: {e}");
        }
        let many = "[[volume]]\nfile = \"a\"\n".repeat(MAX_VOLUMES + 1);
        let e = table(&many).unwrap_err();
        assert!(e.contains("at most 4096"), "{e}");
    }
}
