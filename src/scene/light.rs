//! Lights: suns (directional, given by the direction toward them), point lights, and a
//! uniform environment (dome) light.

use crate::shadow::LightGeometry;
use glam::DVec3;

#[derive(Clone, Debug, PartialEq)]
pub enum LightKind {
    /// Direction from the scene toward the sun (normalised); intensity is irradiance.
    Sun { toward: DVec3 },
    /// Position; intensity is radiant intensity (irradiance at distance r is I/r²).
    Point { position: DVec3 },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    pub name: String,
    pub kind: LightKind,
    pub color: DVec3,
    pub intensity: f64,
}

/// A vector value `x,y,z` (a flag's or a light's).
pub(super) fn parse_triple(s: &str, what: &str) -> Result<DVec3, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("{what} \"{s}\" is not three numbers x,y,z"))?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(DVec3::new(*x, *y, *z)),
        _ => Err(format!("{what} \"{s}\" is not three finite numbers x,y,z")),
    }
}

impl Light {
    /// The same light with its direction or position turned by `turn` (a rotation).
    pub fn rotate(&mut self, turn: impl Fn(DVec3) -> DVec3) {
        match &mut self.kind {
            LightKind::Sun { toward } => *toward = turn(*toward),
            LightKind::Point { position } => *position = turn(*position),
        }
    }

    /// Parses `sun:DX,DY,DZ[:R,G,B[:INTENSITY]]` or `point:X,Y,Z[:R,G,B[:INTENSITY]]`.
    pub fn parse(spec: &str, name: String) -> Result<Light, super::PlanError> {
        Self::parsed(spec, name).map_err(super::PlanError::Invalid)
    }

    fn parsed(spec: &str, name: String) -> Result<Light, String> {
        let parts: Vec<&str> = spec.split(':').collect();
        if parts.len() < 2 || parts.len() > 4 {
            return Err(format!(
                "{{light}} \"{spec}\": expected sun:DX,DY,DZ[:R,G,B[:INTENSITY]] or point:X,Y,Z[:R,G,B[:INTENSITY]]"
            ));
        }
        let v = parse_triple(parts[1], "light vector")?;
        let kind = match parts[0] {
            "sun" => {
                if !(v.length() > 0.0) {
                    return Err(format!("{{light}} \"{spec}\": the sun direction is zero"));
                }
                LightKind::Sun {
                    toward: v.normalize(),
                }
            }
            "point" => LightKind::Point { position: v },
            other => {
                return Err(format!(
                    "{{light}} \"{spec}\": unknown light type \"{other}\" (sun, point or env)"
                ));
            }
        };
        let color = match parts.get(2) {
            Some(c) => parse_triple(c, "light colour")?,
            None => DVec3::ONE,
        };
        let intensity = match parts.get(3) {
            Some(i) => i
                .trim()
                .parse::<f64>()
                .map_err(|_| format!("{{light}} \"{spec}\": intensity \"{i}\" is not a number"))?,
            None => 1.0,
        };
        if color.min_element() < 0.0 || !(intensity >= 0.0) || !intensity.is_finite() {
            return Err(format!(
                "{{light}} \"{spec}\": colour and intensity must be non-negative"
            ));
        }
        Ok(Light {
            name,
            kind,
            color,
            intensity,
        })
    }

    /// Unshadowed irradiance at `x` and the unit direction the light travels there.
    pub fn incident(&self, x: DVec3) -> (DVec3, DVec3) {
        match &self.kind {
            LightKind::Sun { toward } => (self.color * self.intensity, -*toward),
            LightKind::Point { position } => {
                let d = x - *position;
                let r2 = d.length_squared().max(1e-12);
                (self.color * (self.intensity / r2), d / r2.sqrt())
            }
        }
    }

    /// Unit direction from `x` toward the light, and the distance to it (∞ for a sun).
    pub fn toward(&self, x: DVec3) -> (DVec3, f64) {
        self.geometry().toward(x)
    }

    /// Where the light is, as the shadow code sees it.
    pub fn geometry(&self) -> LightGeometry {
        match self.kind {
            LightKind::Sun { toward } => LightGeometry::Sun { travel: -toward },
            LightKind::Point { position } => LightGeometry::Point { position },
        }
    }
}

/// A uniform environment (dome) light: radiance `color × intensity` arriving from every
/// direction, unshadowed only where nothing lies between (the path tracer finds what does).
#[derive(Clone, Debug, PartialEq)]
pub struct EnvLight {
    pub name: String,
    /// Radiance per steradian, RGB.
    pub radiance: DVec3,
}

impl EnvLight {
    /// True for a light spec of the environment kind (`env:…`).
    pub fn is_env_spec(spec: &str) -> bool {
        spec.split(':').next().map(str::trim) == Some("env")
    }

    /// Parses `env:R,G,B[:INTENSITY]`.
    pub fn parse(spec: &str, name: String) -> Result<EnvLight, super::PlanError> {
        let bad = |why: &str| {
            super::PlanError::Invalid(format!(
                "{{light}} \"{spec}\": {why} (expected env:R,G,B[:INTENSITY])"
            ))
        };
        let parts: Vec<&str> = spec.split(':').collect();
        if parts.len() < 2 || parts.len() > 3 || parts[0].trim() != "env" {
            return Err(bad("not an environment light"));
        }
        let color = parse_triple(parts[1], "environment colour")
            .map_err(|e| super::PlanError::Invalid(format!("{{light}} \"{spec}\": {e}")))?;
        let intensity = match parts.get(2) {
            Some(i) => i
                .trim()
                .parse::<f64>()
                .map_err(|_| bad(&format!("intensity \"{i}\" is not a number")))?,
            None => 1.0,
        };
        if color.min_element() < 0.0 || !(intensity >= 0.0) || !intensity.is_finite() {
            return Err(bad("colour and intensity must be non-negative"));
        }
        Ok(EnvLight {
            name,
            radiance: color * intensity,
        })
    }
}

impl crate::shadow::CachedLight for Light {
    fn name(&self) -> &str {
        &self.name
    }
    fn geometry(&self) -> LightGeometry {
        Light::geometry(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_suns_and_points() {
        let l = Light::parse("sun:0,2,0:1,0.5,0.25:3", "sun0".into()).unwrap();
        assert_eq!(l.kind, LightKind::Sun { toward: DVec3::Y });
        assert_eq!(
            l.incident(DVec3::ZERO),
            (DVec3::new(3.0, 1.5, 0.75), DVec3::NEG_Y)
        );
        let p = Light::parse("point:0,0,2", "point0".into()).unwrap();
        let (e, dir) = p.incident(DVec3::ZERO);
        assert!((e - DVec3::splat(0.25)).length() < 1e-15 && (dir - DVec3::NEG_Z).length() < 1e-15);
        for bad in [
            "sun",
            "sun:0,0,0",
            "spot:1,2,3",
            "sun:1,2",
            "sun:1,2,3:1,1",
            "point:1,2,3:1,1,1:-1",
            "sun:nan,1,1",
        ] {
            assert!(Light::parse(bad, "x".into()).is_err(), "{bad}");
        }
    }

    #[test]
    fn parses_environment_lights() {
        let e = EnvLight::parse("env:1,0.5,0.25:2", "env0".into()).unwrap();
        assert_eq!(e.radiance, DVec3::new(2.0, 1.0, 0.5));
        assert_eq!(
            EnvLight::parse("env:1,1,1", "e".into()).unwrap().radiance,
            DVec3::ONE
        );
        assert!(EnvLight::is_env_spec("env:1,1,1") && !EnvLight::is_env_spec("sun:0,1,0"));
        for bad in [
            "env",
            "env:1,1",
            "env:1,1,1:-1",
            "env:1,1,1:x",
            "env:-1,1,1",
            "env:1,1,1:1:1",
        ] {
            assert!(EnvLight::parse(bad, "x".into()).is_err(), "{bad}");
        }
    }
}
