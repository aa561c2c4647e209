//! One option's value, checked: the parsers the parts of the plan are built from, each
//! returning the one-line error a user sees.

use super::defaults::{self, MIN_STEP_VOXELS};
use crate::integrate::phase::water_drop::RADIUS_RANGE_UM;
use crate::scene::light::parse_triple;
use glam::DVec3;

pub(super) fn up_axis_choice(
    v: &Option<String>,
) -> Result<crate::scene::conventions::UpAxisChoice, String> {
    use crate::scene::conventions::{UpAxis, UpAxisChoice};
    match v.as_deref() {
        None | Some("auto") => Ok(UpAxisChoice::Auto),
        Some("y") | Some("Y") => Ok(UpAxisChoice::Fixed(UpAxis::Y)),
        Some("z") | Some("Z") => Ok(UpAxisChoice::Fixed(UpAxis::Z)),
        Some(o) => Err(format!("{{up_axis}} \"{o}\": expected y, z or auto")),
    }
}

/// `--z-empty`: a finite non-negative depth or `inf` (default 1e10).
pub(super) fn z_empty(v: &Option<String>) -> Result<f32, String> {
    let Some(s) = v else {
        return Ok(defaults::Z_EMPTY);
    };
    let t = s.trim();
    if t.eq_ignore_ascii_case("inf") || t.eq_ignore_ascii_case("+inf") {
        return Ok(f32::INFINITY);
    }
    match t.parse::<f32>() {
        Ok(z) if z.is_finite() && z >= 0.0 => Ok(z),
        _ => Err(format!(
            "{{z_empty}} \"{s}\": expected a non-negative number or inf"
        )),
    }
}

pub(super) fn positive(v: Option<f64>, default: f64, what: &str) -> Result<f64, String> {
    let v = v.unwrap_or(default);
    if v > 0.0 && v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{what} must be a positive number, not {v}"))
    }
}

/// A step in voxels: positive, finite and at least [`MIN_STEP_VOXELS`].
pub(super) fn step_voxels(v: Option<f64>, default: f64, what: &str) -> Result<f64, String> {
    let v = positive(v, default, what)?;
    if v < MIN_STEP_VOXELS {
        return Err(format!(
            "{what} {v:e} is below the shortest step murk takes, 1/1024 voxel"
        ));
    }
    Ok(v)
}

pub(super) fn non_negative(v: Option<f64>, default: f64, what: &str) -> Result<f64, String> {
    let v = v.unwrap_or(default);
    if v >= 0.0 && v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{what} must be a non-negative number, not {v}"))
    }
}

pub(super) fn colour(v: &Option<String>, default: DVec3, what: &str) -> Result<DVec3, String> {
    let c = match v {
        // One number is a grey: --sigma-a 0.2 is 0.2,0.2,0.2.
        Some(s) if !s.contains(',') => match s.trim().parse::<f64>() {
            Ok(g) if g.is_finite() => DVec3::splat(g),
            _ => return Err(format!("{what} \"{s}\" is not a number or r,g,b")),
        },
        Some(s) => parse_triple(s, what)?,
        None => default,
    };
    if c.min_element() < 0.0 {
        return Err(format!("{what} must not be negative"));
    }
    Ok(c)
}

pub(super) fn resolution(v: &Option<String>) -> Result<(usize, usize), String> {
    let Some(s) = v else { return Ok(defaults::RES) };
    let bad = || format!("{{res}} \"{s}\" is not WxH with sizes from 1 to 16384");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: usize = w.trim().parse().map_err(|_| bad())?;
    let h: usize = h.trim().parse().map_err(|_| bad())?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(bad());
    }
    Ok((w, h))
}

/// `--overscan X[,Y]` in pixels (one number: the same on every side), each at most the
/// image's own size along it.
pub(super) fn overscan(
    v: &Option<String>,
    (w, h): (usize, usize),
) -> Result<(usize, usize), String> {
    let Some(s) = v else { return Ok((0, 0)) };
    let bad = || format!("{{overscan}} \"{s}\" is not X or X,Y: whole numbers of pixels");
    let (x, y) = match s.split_once(',') {
        Some((x, y)) => (x, y),
        None => (s.as_str(), s.as_str()),
    };
    let x: usize = x.trim().parse().map_err(|_| bad())?;
    let y: usize = y.trim().parse().map_err(|_| bad())?;
    if x > w || y > h {
        return Err(format!(
            "{{overscan}} {x},{y} is more than the {w}x{h} image itself on a side"
        ));
    }
    Ok((x, y))
}

/// `--drop-radius` in µm (default [`defaults::DROP_RADIUS_UM`]), within [`RADIUS_RANGE_UM`].
pub(super) fn drop_radius(r: Option<f64>) -> Result<f64, String> {
    let r = r.unwrap_or(defaults::DROP_RADIUS_UM);
    if r >= RADIUS_RANGE_UM.0 && r <= RADIUS_RANGE_UM.1 {
        Ok(r)
    } else {
        Err(format!(
            "{{drop_radius}} {r} is outside {}–{} µm",
            RADIUS_RANGE_UM.0, RADIUS_RANGE_UM.1
        ))
    }
}
