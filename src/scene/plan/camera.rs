//! The image and the camera, as far as they can be known before the input's bounds are:
//! `res`, `overscan`, `camera`, `fov`, `ortho_width`, `eye`, `look_at`, `up`.

use super::defaults;
use super::shot::ShotPlan;
use super::values::{overscan, positive, resolution};
use crate::scene::camera::Projection;
use crate::scene::light::parse_triple;
use crate::scene::options::{CameraSetting, RenderOptions};
use glam::DVec3;

/// The camera as far as it can be known before the grid's bounds are.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraRequest {
    pub projection: Option<Projection>,
    pub eye: Option<DVec3>,
    pub look_at: Option<DVec3>,
    pub up: DVec3,
    /// The shot's camera, from a file or the `[camera]` table: it replaces the rest.
    pub shot: Option<ShotPlan>,
}

/// The image and the camera.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraPlan {
    /// The frame rendered: the image of `res` and its overscan on each side.
    pub width: usize,
    pub height: usize,
    /// Pixels rendered beyond each edge of the image (x, y): `--overscan`.
    pub overscan: (usize, usize),
    pub request: CameraRequest,
}

impl CameraPlan {
    /// The image of `res`: the frame less its overscan.
    pub fn plate(&self) -> (usize, usize) {
        (
            self.width - 2 * self.overscan.0,
            self.height - 2 * self.overscan.1,
        )
    }

    pub(super) fn from_options(o: &RenderOptions) -> Result<CameraPlan, String> {
        let (width, height) = resolution(&o.res)?;
        let overscan = overscan(&o.overscan, (width, height))?;
        let perspective = || Projection::Perspective {
            fov_deg: o.fov.unwrap_or(defaults::FOV_DEG),
        };
        let kind = match &o.camera {
            Some(CameraSetting::Kind(k)) => Some(k.as_str()),
            _ => None,
        };
        let projection = match kind {
            None if o.ortho_width.is_some() => Projection::Orthographic {
                width: positive(o.ortho_width, 1.0, "{ortho_width}")?,
            },
            None | Some("persp") | Some("perspective") => perspective(),
            Some("ortho") | Some("orthographic") => Projection::Orthographic {
                // 0: the width that frames the bounds, found once they are known.
                width: match o.ortho_width {
                    Some(w) => positive(Some(w), 1.0, "{ortho_width}")?,
                    None => 0.0,
                },
            },
            Some(other) => return Err(format!("{{camera}} \"{other}\": expected persp or ortho")),
        };
        if let Projection::Perspective { fov_deg } = projection
            && !(fov_deg > 0.0 && fov_deg < 180.0)
        {
            return Err(format!("{{fov}} {fov_deg} is outside (0, 180) degrees"));
        }
        let vec =
            |v: &Option<String>, what: &str| v.as_ref().map(|s| parse_triple(s, what)).transpose();
        Ok(CameraPlan {
            width: width + 2 * overscan.0,
            height: height + 2 * overscan.1,
            overscan,
            request: CameraRequest {
                projection: Some(projection),
                eye: vec(&o.eye, "{eye}")?,
                look_at: vec(&o.look_at, "{look_at}")?,
                up: vec(&o.up, "{up}")?.unwrap_or(DVec3::Y),
                shot: match ShotPlan::from_options(o)? {
                    Some(shot) => {
                        // Read now, so that a bad file stops the render before it starts.
                        shot.camera(width, height)?;
                        Some(shot)
                    }
                    None => None,
                },
            },
        })
    }
}
