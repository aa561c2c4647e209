//! A `UsdGeomCamera` from a USD stage (`.usda`, `.usdc`, `.usdz`, `.usd`), read with the
//! pure-Rust `openusd` crate: its lens and film attributes and its world transform (the
//! composed `xformOp`s of the camera and its ancestors, up to a `!resetXformStack!`),
//! each attribute resolved at the frame as USD does (linear between samples, the first
//! and last held outside).

use super::{ShotCamera, ShotError};
use crate::scene::film::{FilmBack, FilmFit};
use glam::{DMat4, DQuat, DVec3};
use openusd::sdf::{self, Value};
use openusd::usd::{PrimPredicate, Stage, TimeCode};
use std::path::Path;

/// A camera prim of an open stage.
pub struct UsdCamera {
    stage: Stage,
    /// The camera prim, then each ancestor whose transform it inherits.
    chain: Vec<sdf::Path>,
    pub prim: String,
    /// The stage's `upAxis` is Z.
    pub up_z: bool,
    /// The stage's `metersPerUnit` (USD's fallback 0.01 where unauthored).
    pub meters_per_unit: f64,
    span: Option<(f64, f64)>,
}

/// `e` on one line.
fn line(e: impl std::fmt::Display) -> String {
    e.to_string()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

impl UsdCamera {
    /// Opens `file` and picks the camera `prim` (by default the stage's only camera).
    pub fn open(file: &Path, prim: Option<&str>) -> Result<UsdCamera, ShotError> {
        let bad = |p: String| ShotError::new(file, p);
        if let Err(e) = std::fs::metadata(file) {
            return Err(bad(e.to_string()));
        }
        let name = file
            .to_str()
            .ok_or_else(|| bad("the path is not UTF-8, which the USD reader needs".into()))?;
        let stage = Stage::open(name)
            .map_err(|e| bad(format!("not a USD stage murk can read: {}", line(e))))?;
        let mut cameras = Vec::new();
        let mut failure = None;
        stage
            .traverse(PrimPredicate::DEFAULT, |p| {
                match stage.prim(p.clone()).type_name() {
                    Ok(Some(t)) if t.as_str() == "Camera" => cameras.push(p.as_str().to_string()),
                    Ok(_) => {}
                    Err(e) => failure = Some(line(e)),
                }
            })
            .map_err(|e| bad(format!("not a USD stage murk can read: {}", line(e))))?;
        if let Some(e) = failure {
            return Err(bad(format!("not a USD stage murk can read: {e}")));
        }
        let listed = || cameras.join(", ");
        let chosen = match prim {
            Some(p) => {
                let path =
                    sdf::Path::new(p).map_err(|e| bad(format!("prim \"{p}\": {}", line(e))))?;
                let kind = stage
                    .prim(path)
                    .type_name()
                    .map_err(|e| bad(format!("prim {p}: {}", line(e))))?;
                match kind {
                    Some(t) if t.as_str() == "Camera" => p.to_string(),
                    other => {
                        let what = match other {
                            Some(t) => format!("a {}", t.as_str()),
                            None => "not in the stage".into(),
                        };
                        return Err(bad(format!(
                            "prim {p} is not a camera ({what}); the stage's cameras: {}",
                            if cameras.is_empty() {
                                "none".into()
                            } else {
                                listed()
                            }
                        )));
                    }
                }
            }
            None => match cameras.len() {
                0 => {
                    return Err(bad(
                        "the stage holds no camera (no prim of type Camera)".into()
                    ));
                }
                1 => cameras[0].clone(),
                n => {
                    return Err(bad(format!(
                        "the stage holds {n} cameras; choose one with --camera-prim: {}",
                        listed()
                    )));
                }
            },
        };
        let mut cam = UsdCamera {
            chain: Vec::new(),
            prim: chosen.clone(),
            up_z: matches!(stage.stage_metadata("upAxis"), Ok(Some(Value::Token(t))) if t.as_str() == "Z"),
            meters_per_unit: match stage.stage_metadata("metersPerUnit") {
                Ok(Some(Value::Double(m))) => m,
                Ok(Some(Value::Float(m))) => m as f64,
                _ => 0.01,
            },
            span: None,
            stage,
        };
        cam.chain = cam.chain_of(&chosen).map_err(bad)?;
        cam.span = cam.sample_span().map_err(bad)?;
        Ok(cam)
    }

    /// The prim at `prim` and the ancestors whose transforms compose with it.
    fn chain_of(&self, prim: &str) -> Result<Vec<sdf::Path>, String> {
        let mut chain = Vec::new();
        let mut at = Some(sdf::Path::new(prim).map_err(line)?);
        while let Some(p) = at {
            if p.as_str() == "/" {
                break;
            }
            let order = self.op_order(&p)?;
            at = p.parent();
            let resets = order.first().is_some_and(|o| o == "!resetXformStack!");
            chain.push(p);
            if resets {
                break;
            }
        }
        Ok(chain)
    }

    fn op_order(&self, prim: &sdf::Path) -> Result<Vec<String>, String> {
        let attr = self.stage.prim(prim.clone()).attribute("xformOpOrder");
        Ok(match attr.get::<Value>().map_err(line)? {
            Some(Value::TokenVec(v)) => v.iter().map(|t| t.as_str().to_string()).collect(),
            Some(Value::StringVec(v)) => v,
            Some(Value::TokenListOp(op)) => op
                .flatten()
                .iter()
                .map(|t| t.as_str().to_string())
                .collect(),
            _ => Vec::new(),
        })
    }

    /// The first and last time sample over the camera's attributes and every op.
    fn sample_span(&self) -> Result<Option<(f64, f64)>, String> {
        let mut attrs: Vec<sdf::Path> = Vec::new();
        let cam = sdf::Path::new(&self.prim).map_err(line)?;
        for a in ATTRS {
            attrs.push(cam.append_property(a).map_err(line)?);
        }
        for p in &self.chain {
            for op in self.op_order(p)? {
                let name = op.strip_prefix("!invert!").unwrap_or(&op);
                if name != "!resetXformStack!" {
                    attrs.push(p.append_property(name).map_err(line)?);
                }
            }
        }
        let mut span: Option<(f64, f64)> = None;
        for a in attrs {
            for t in self.stage.attribute(a).time_sample_times().map_err(line)? {
                span = Some(span.map_or((t, t), |(lo, hi)| (lo.min(t), hi.max(t))));
            }
        }
        Ok(span)
    }

    pub fn span(&self) -> Option<(f64, f64)> {
        self.span
    }

    /// The attribute's value at `time`. Scalar time samples are interpolated here:
    /// openusd 0.6 reads a `.usda` sample written as a whole number (`1: 32`, as
    /// usd-core writes a float of 32) as an integer, and holds integers between
    /// samples where USD interpolates the float.
    fn value(&self, prim: &sdf::Path, name: &str, time: f64) -> Result<Option<Value>, String> {
        let attr = self.stage.prim(prim.clone()).attribute(name);
        let failed = |e: String| format!("{}.{name}: {e}", prim.as_str());
        if let Some(samples) = attr.time_samples().map_err(|e| failed(line(e)))? {
            let numbers: Option<Vec<(f64, f64)>> = samples
                .iter()
                .map(|(t, v)| number(v).map(|x| (*t, x)))
                .collect();
            if let Some(n) = numbers.filter(|n| !n.is_empty()) {
                return Ok(Some(Value::Double(lerp_samples(&n, time))));
            }
        }
        attr.get_at::<Value>(Some(TimeCode::new(time)))
            .map_err(|e| failed(line(e)))
    }

    /// The camera at frame `time`.
    pub fn at(&self, time: f64) -> Result<ShotCamera, String> {
        let cam = self.chain.first().ok_or("no camera prim")?;
        let scalar = |name: &str, fallback: f64| -> Result<f64, String> {
            match self.value(cam, name, time)? {
                None => Ok(fallback),
                Some(v) => {
                    number(&v).ok_or_else(|| format!("{}.{name} is not a number", self.prim))
                }
            }
        };
        let (near, far) = match self.value(cam, "clippingRange", time)? {
            Some(Value::Vec2f(v)) => (v.x as f64, v.y as f64),
            Some(Value::Vec2d(v)) => (v.x, v.y),
            _ => (1.0, 1e6),
        };
        let orthographic = match self.value(cam, "projection", time)? {
            Some(Value::Token(t)) => t.as_str() == "orthographic",
            _ => false,
        };
        let film = FilmBack {
            orthographic,
            focal_length: scalar("focalLength", 50.0)?,
            horizontal_aperture: scalar("horizontalAperture", 20.955)?,
            vertical_aperture: scalar("verticalAperture", 15.2908)?,
            horizontal_offset: scalar("horizontalApertureOffset", 0.0)?,
            vertical_offset: scalar("verticalApertureOffset", 0.0)?,
            fit: FilmFit::Horizontal,
            pixel_aspect: 1.0,
            near,
            far,
        };
        film.check()
            .map_err(|e| format!("camera {}: {e}", self.prim))?;
        let mut world = DMat4::IDENTITY;
        for p in &self.chain {
            world = self.local(p, time)? * world;
        }
        let held = self.span.is_some_and(|(lo, hi)| time < lo || time > hi);
        Ok(ShotCamera {
            camera_to_world: world,
            film,
            held,
        })
    }

    /// The prim's local transform: its ops composed in `xformOpOrder` (the first listed
    /// outermost).
    fn local(&self, prim: &sdf::Path, time: f64) -> Result<DMat4, String> {
        let mut m = DMat4::IDENTITY;
        for op in self.op_order(prim)? {
            if op == "!resetXformStack!" {
                continue;
            }
            let (invert, name) = match op.strip_prefix("!invert!") {
                Some(n) => (true, n),
                None => (false, op.as_str()),
            };
            let Some(v) = self.value(prim, name, time)? else {
                return Err(format!(
                    "{}: {name} is listed but has no value",
                    prim.as_str()
                ));
            };
            let unreadable = || {
                format!(
                    "{}.{name}: a value murk cannot read as this op",
                    prim.as_str()
                )
            };
            let kind = name.strip_prefix("xformOp:").unwrap_or(name);
            let kind = kind.split(':').next().unwrap_or(kind);
            let deg = |x: f64| x.to_radians();
            let o = match kind {
                "translate" => DMat4::from_translation(vec3(&v).ok_or_else(unreadable)?),
                "scale" => DMat4::from_scale(vec3(&v).ok_or_else(unreadable)?),
                "translateX" | "translateY" | "translateZ" | "scaleX" | "scaleY" | "scaleZ" => {
                    let x = number(&v).ok_or_else(unreadable)?;
                    let axis = match kind.as_bytes()[kind.len() - 1] {
                        b'X' => DVec3::X,
                        b'Y' => DVec3::Y,
                        _ => DVec3::Z,
                    };
                    if kind.starts_with("translate") {
                        DMat4::from_translation(axis * x)
                    } else {
                        DMat4::from_scale(DVec3::ONE + axis * (x - 1.0))
                    }
                }
                "rotateX" => DMat4::from_rotation_x(deg(number(&v).ok_or_else(unreadable)?)),
                "rotateY" => DMat4::from_rotation_y(deg(number(&v).ok_or_else(unreadable)?)),
                "rotateZ" => DMat4::from_rotation_z(deg(number(&v).ok_or_else(unreadable)?)),
                "rotateXYZ" | "rotateXZY" | "rotateYXZ" | "rotateYZX" | "rotateZXY"
                | "rotateZYX" => {
                    let a = vec3(&v).ok_or_else(unreadable)?;
                    let order =
                        super::RotationOrder::parse(&kind[6..]).map_err(|_| unreadable())?;
                    DMat4::from_mat3(order.matrix(a))
                }
                "orient" => DMat4::from_quat(quat(&v).ok_or_else(unreadable)?),
                "transform" => match v {
                    // Row vectors, row by row: the same numbers as glam's columns.
                    Value::Matrix4d(m) => DMat4::from_cols_array(&m.0),
                    _ => return Err(unreadable()),
                },
                _ => {
                    return Err(format!(
                        "{}: xformOp {name} is not one murk reads",
                        prim.as_str()
                    ));
                }
            };
            let o = if invert {
                if !(o.determinant().abs() > 1e-300) {
                    return Err(format!("{}: {op} inverts a singular op", prim.as_str()));
                }
                o.inverse()
            } else {
                o
            };
            m *= o;
        }
        Ok(m)
    }
}

/// The camera's attributes that may be animated.
const ATTRS: [&str; 7] = [
    "focalLength",
    "horizontalAperture",
    "verticalAperture",
    "horizontalApertureOffset",
    "verticalApertureOffset",
    "clippingRange",
    "projection",
];

fn number(v: &Value) -> Option<f64> {
    match v {
        Value::Double(x) => Some(*x),
        Value::Float(x) => Some(*x as f64),
        Value::Half(x) => Some(x.to_f64()),
        Value::Int(x) => Some(*x as f64),
        Value::Int64(x) => Some(*x as f64),
        Value::Uint(x) => Some(*x as f64),
        Value::Uint64(x) => Some(*x as f64),
        _ => None,
    }
}

/// Samples `(time, value)` (sorted by time, at least one) at `time`: linear between
/// samples, the first and last held outside them.
fn lerp_samples(samples: &[(f64, f64)], time: f64) -> f64 {
    let i = samples.partition_point(|(t, _)| *t <= time);
    match (i.checked_sub(1).map(|j| samples[j]), samples.get(i)) {
        (Some((t0, v0)), Some(&(t1, v1))) if time > t0 => {
            v0 + (v1 - v0) * ((time - t0) / (t1 - t0))
        }
        (Some((_, v0)), _) => v0,
        (None, Some(&(_, v1))) => v1,
        (None, None) => 0.0,
    }
}

fn vec3(v: &Value) -> Option<DVec3> {
    match v {
        Value::Vec3d(a) => Some(DVec3::new(a.x, a.y, a.z)),
        Value::Vec3f(a) => Some(DVec3::new(a.x as f64, a.y as f64, a.z as f64)),
        Value::Vec3h(a) => Some(DVec3::new(a.x.to_f64(), a.y.to_f64(), a.z.to_f64())),
        _ => None,
    }
}

fn quat(v: &Value) -> Option<DQuat> {
    let q = match v {
        Value::Quatd(q) => DQuat::from_xyzw(q.x, q.y, q.z, q.w),
        Value::Quatf(q) => DQuat::from_xyzw(q.x as f64, q.y as f64, q.z as f64, q.w as f64),
        Value::Quath(q) => DQuat::from_xyzw(q.x.to_f64(), q.y.to_f64(), q.z.to_f64(), q.w.to_f64()),
        _ => return None,
    };
    (q.length() > 0.0).then(|| q.normalize())
}

#[cfg(test)]
mod tests {
    #[test]
    fn samples_are_linear_between_and_held_outside() {
        let s = [(1.0, 32.0), (3.0, 40.0)];
        assert_eq!(super::lerp_samples(&s, 0.0), 32.0);
        assert_eq!(super::lerp_samples(&s, 1.0), 32.0);
        assert_eq!(super::lerp_samples(&s, 2.0), 36.0);
        assert_eq!(super::lerp_samples(&s, 3.0), 40.0);
        assert_eq!(super::lerp_samples(&s, 9.0), 40.0);
        assert_eq!(super::lerp_samples(&[(5.0, 1.0)], 2.0), 1.0);
    }
}
