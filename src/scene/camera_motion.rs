//! A camera that moves while the shutter is open: the shot's camera evaluated at evenly
//! spaced times across the shutter, and linearly interpolated between them for each
//! camera sample's time.

use super::camera::{Camera, Projection};
use super::film::Window;
use super::{PlanError, RenderPlan};

/// How many intervals the shutter is cut into: a camera keyed per frame moves linearly
/// within a 1-frame shutter, so any count is exact there; curved motion (a USD stage's
/// spline, a rotation) is followed to 1/32 of the shutter.
pub const SHUTTER_INTERVALS: usize = 32;

/// The camera at evenly spaced times from `open` to `close` (frames from the frame).
#[derive(Clone, Debug, PartialEq)]
pub struct CameraMotion {
    pub open: f64,
    pub close: f64,
    /// `SHUTTER_INTERVALS + 1` cameras, the first at `open`, the last at `close`.
    pub cameras: Vec<Camera>,
}

impl CameraMotion {
    /// The motion of `cameras` (taken at evenly spaced times from `open` to `close`);
    /// `None` where they are all the same (a still camera renders as without a shutter)
    /// or not all of one size and kind.
    pub fn new(open: f64, close: f64, cameras: Vec<Camera>) -> Option<CameraMotion> {
        let first = *cameras.first()?;
        let same_kind = cameras.iter().all(|c| {
            (c.width, c.height) == (first.width, first.height)
                && std::mem::discriminant(&c.projection)
                    == std::mem::discriminant(&first.projection)
        });
        let moves = cameras.iter().any(|c| *c != first);
        (same_kind && moves && cameras.len() >= 2 && close > open).then_some(CameraMotion {
            open,
            close,
            cameras,
        })
    }

    /// The plan's shot camera while its shutter is open, where it moves.
    pub fn of_plan(plan: &RenderPlan) -> Result<Option<CameraMotion>, PlanError> {
        let (Some(shot), Some((open, close))) = (&plan.camera.request.shot, plan.motion.shutter)
        else {
            return Ok(None);
        };
        if !(close > open) {
            return Ok(None);
        }
        let n = SHUTTER_INTERVALS;
        let offsets: Vec<f64> = (0..=n)
            .map(|k| open + (close - open) * k as f64 / n as f64)
            .collect();
        let (ox, oy) = plan.camera.overscan;
        let cameras = shot
            .cameras_at(plan.camera.width, plan.camera.height, &offsets)
            .map_err(PlanError::Invalid)?
            .iter()
            .map(|c| c.overscanned(ox, oy))
            .collect();
        Ok(CameraMotion::new(open, close, cameras))
    }

    /// The camera at `time` (frames from the frame), clamped to the shutter.
    pub fn at(&self, time: f64) -> Camera {
        let n = self.cameras.len() - 1;
        let f = ((time - self.open) / (self.close - self.open)).clamp(0.0, 1.0) * n as f64;
        let i = (f.floor() as usize).min(n - 1);
        lerp(&self.cameras[i], &self.cameras[i + 1], f - i as f64)
    }
}

fn mix(a: f64, b: f64, u: f64) -> f64 {
    a + (b - a) * u
}

/// The camera `u` of the way from `a` to `b`: position, aim, up and film window each
/// linearly (the projection's kind, and the image size, are `a`'s).
fn lerp(a: &Camera, b: &Camera, u: f64) -> Camera {
    let projection = match (a.projection, b.projection) {
        (Projection::Film(p), Projection::Film(q)) => Projection::Film(Window {
            orthographic: p.orthographic,
            left: mix(p.left, q.left, u),
            right: mix(p.right, q.right, u),
            bottom: mix(p.bottom, q.bottom, u),
            top: mix(p.top, q.top, u),
            near: mix(p.near, q.near, u),
            far: mix(p.far, q.far, u),
        }),
        (Projection::Perspective { fov_deg: p }, Projection::Perspective { fov_deg: q }) => {
            Projection::Perspective {
                fov_deg: mix(p, q, u),
            }
        }
        (Projection::Orthographic { width: p }, Projection::Orthographic { width: q }) => {
            Projection::Orthographic {
                width: mix(p, q, u),
            }
        }
        (p, _) => p,
    };
    Camera {
        projection,
        eye: a.eye.lerp(b.eye, u),
        look_at: a.look_at.lerp(b.look_at, u),
        up: a.up.lerp(b.up, u),
        width: a.width,
        height: a.height,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn camera(x: f64) -> Camera {
        Camera {
            projection: Projection::Orthographic { width: 2.0 },
            eye: DVec3::new(x, 0.0, 5.0),
            look_at: DVec3::new(x, 0.0, 0.0),
            up: DVec3::Y,
            width: 4,
            height: 4,
        }
    }

    #[test]
    fn a_camera_moving_linearly_is_followed_exactly_and_a_still_one_is_none() {
        let n = SHUTTER_INTERVALS;
        let cams: Vec<Camera> = (0..=n).map(|k| camera(k as f64 / n as f64)).collect();
        let m = CameraMotion::new(-0.5, 0.5, cams).unwrap();
        for t in [-0.5, -0.123, 0.0, 0.31, 0.5] {
            assert!((m.at(t).eye.x - (t + 0.5)).abs() < 1e-12, "t {t}");
        }
        assert_eq!(m.at(2.0).eye.x, 1.0);
        assert!(CameraMotion::new(-0.5, 0.5, vec![camera(0.0); n + 1]).is_none());
    }
}
