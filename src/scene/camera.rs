//! Pinhole and orthographic cameras. Camera space is right-handed, y up, looking down
//! −z (as Nuke, Houdini and OpenGL); the EXR's `Z` is the distance along the view axis.

use super::film::Window;
use glam::{DMat4, DVec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Horizontal field of view in degrees (like `vdb_render -fov`).
    Perspective { fov_deg: f64 },
    /// Width of the view in world units.
    Orthographic { width: f64 },
    /// A film back's screen window (cameras from files and the scene's `[camera]`
    /// table), with its clipping planes.
    Film(Window),
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub projection: Projection,
    pub eye: DVec3,
    pub look_at: DVec3,
    pub up: DVec3,
    pub width: usize,
    pub height: usize,
}

/// A camera's rays as affine maps of the pixel position ([`Camera::ray_affine`]).
#[derive(Clone, Copy, Debug)]
pub struct RayAffine {
    pub origin: [DVec3; 3],
    pub dir: [DVec3; 3],
    /// Whether the direction is normalised (a pinhole's), else already unit length.
    pub diverge: bool,
}

/// An orthonormal camera frame.
#[derive(Clone, Copy, Debug)]
pub struct CameraFrame {
    pub forward: DVec3,
    pub right: DVec3,
    pub up: DVec3,
}

impl Camera {
    /// Checks the camera makes sense: a direction to look in, an up that is not along it,
    /// a field of view in (0, 180).
    pub fn validate(&self) -> Result<(), super::PlanError> {
        self.check().map_err(super::PlanError::Invalid)
    }

    pub fn check(&self) -> Result<(), String> {
        let f = self.look_at - self.eye;
        if !(f.length() > 0.0) || !f.is_finite() {
            return Err("the camera's eye and look-at are the same point".into());
        }
        if f.normalize().cross(self.up).length() < 1e-9 || !self.up.is_finite() {
            return Err("the camera's up vector is parallel to its view direction".into());
        }
        match self.projection {
            Projection::Perspective { fov_deg } if !(fov_deg > 0.0 && fov_deg < 180.0) => {
                Err(format!("{{fov}} {fov_deg} is outside (0, 180) degrees"))
            }
            Projection::Orthographic { width } if !(width > 0.0 && width.is_finite()) => {
                Err(format!("{{ortho_width}} {width} must be a positive number"))
            }
            Projection::Film(w)
                if !(w.right > w.left
                    && w.top > w.bottom
                    && [w.left, w.right, w.bottom, w.top]
                        .iter()
                        .all(|v| v.is_finite())) =>
            {
                Err("the camera's film window is empty".into())
            }
            _ => Ok(()),
        }
    }

    pub fn frame(&self) -> CameraFrame {
        let forward = (self.look_at - self.eye).normalize();
        let right = forward.cross(self.up).normalize();
        CameraFrame {
            forward,
            right,
            up: right.cross(forward),
        }
    }

    fn aspect(&self) -> f64 {
        self.height as f64 / self.width as f64
    }

    /// The ray through the continuous pixel position (px, py) (pixel centres at +0.5,
    /// top row first): origin and unit direction.
    pub fn ray(&self, frame: &CameraFrame, px: f64, py: f64) -> (DVec3, DVec3) {
        let (o, d) = self.ray_unnormalised(frame, px, py);
        (
            o,
            if self.rays_diverge() {
                d.normalize()
            } else {
                d
            },
        )
    }

    /// Whether rays leave one point (a pinhole: directions normalised), rather than run
    /// parallel along the view axis.
    fn rays_diverge(&self) -> bool {
        match self.projection {
            Projection::Perspective { .. } => true,
            Projection::Orthographic { .. } => false,
            Projection::Film(w) => !w.orthographic,
        }
    }

    /// [`Camera::ray`]'s origin and direction before the direction is normalised: both
    /// affine in (px, py).
    fn ray_unnormalised(&self, frame: &CameraFrame, px: f64, py: f64) -> (DVec3, DVec3) {
        let sx = px / self.width as f64 * 2.0 - 1.0;
        let sy = 1.0 - py / self.height as f64 * 2.0;
        match self.projection {
            Projection::Perspective { fov_deg } => {
                let t = (fov_deg.to_radians() * 0.5).tan();
                let d =
                    frame.forward + frame.right * (sx * t) + frame.up * (sy * t * self.aspect());
                (self.eye, d)
            }
            Projection::Orthographic { width } => {
                let half = width * 0.5;
                let o =
                    self.eye + frame.right * (sx * half) + frame.up * (sy * half * self.aspect());
                (o, frame.forward)
            }
            Projection::Film(w) => {
                let x = w.left + px / self.width as f64 * (w.right - w.left);
                let y = w.top - py / self.height as f64 * (w.top - w.bottom);
                if w.orthographic {
                    (self.eye + frame.right * x + frame.up * y, frame.forward)
                } else {
                    (self.eye, frame.forward + frame.right * x + frame.up * y)
                }
            }
        }
    }

    /// [`Camera::ray`] as affine maps of the pixel position, for a GPU to make the rays
    /// from: the ray through (px, py) leaves `origin[0] + origin[1]·px + origin[2]·py`
    /// along `dir[0] + dir[1]·px + dir[2]·py`, normalised where `diverge`.
    pub fn ray_affine(&self, frame: &CameraFrame) -> RayAffine {
        let (o0, d0) = self.ray_unnormalised(frame, 0.0, 0.0);
        let (ox, dx) = self.ray_unnormalised(frame, 1.0, 0.0);
        let (oy, dy) = self.ray_unnormalised(frame, 0.0, 1.0);
        RayAffine {
            origin: [o0, ox - o0, oy - o0],
            dir: [d0, dx - d0, dy - d0],
            diverge: self.rays_diverge(),
        }
    }

    /// The same camera seeing `ox` more pixels left and right and `oy` more above and
    /// below (overscan): its pixel `(x + ox, y + oy)` is this camera's pixel `(x, y)`, and
    /// its image `2·ox` wider and `2·oy` taller. A perspective or orthographic camera
    /// becomes the film window it is (without clipping planes).
    pub fn overscanned(&self, ox: usize, oy: usize) -> Camera {
        if (ox, oy) == (0, 0) {
            return *self;
        }
        let (w, h) = (self.width as f64, self.height as f64);
        let window = match self.projection {
            Projection::Perspective { fov_deg } => {
                let t = (fov_deg.to_radians() * 0.5).tan();
                Window {
                    orthographic: false,
                    left: -t,
                    right: t,
                    bottom: -t * self.aspect(),
                    top: t * self.aspect(),
                    near: 0.0,
                    far: f64::INFINITY,
                }
            }
            Projection::Orthographic { width } => {
                let half = width * 0.5;
                Window {
                    orthographic: true,
                    left: -half,
                    right: half,
                    bottom: -half * self.aspect(),
                    top: half * self.aspect(),
                    near: 0.0,
                    far: f64::INFINITY,
                }
            }
            Projection::Film(window) => window,
        };
        let (dx, dy) = (
            ox as f64 * (window.right - window.left) / w,
            oy as f64 * (window.top - window.bottom) / h,
        );
        Camera {
            projection: Projection::Film(Window {
                left: window.left - dx,
                right: window.right + dx,
                bottom: window.bottom - dy,
                top: window.top + dy,
                ..window
            }),
            width: self.width + 2 * ox,
            height: self.height + 2 * oy,
            ..*self
        }
    }

    /// A pixel's width over its height on the screen (1 but for a film back's pixel
    /// aspect ratio), rounded to single precision.
    pub fn pixel_aspect(&self) -> f32 {
        match self.projection {
            Projection::Film(w) => {
                let pixel_w = (w.right - w.left) / self.width as f64;
                let pixel_h = (w.top - w.bottom) / self.height as f64;
                let ratio = (pixel_w / pixel_h) as f32;
                // Square pixels through rounding stay square.
                if (ratio - 1.0).abs() < 1e-6 {
                    1.0
                } else {
                    ratio
                }
            }
            _ => 1.0,
        }
    }

    /// The clipping planes' depths `(near, far)` along the view direction: a film
    /// back's (none for the other projections, whose rays run whole).
    pub fn clip_planes(&self) -> Option<(f64, f64)> {
        match self.projection {
            Projection::Film(w) => Some((w.near, w.far)),
            _ => None,
        }
    }

    /// The stretch `[t_min, t_max]` of the ray along unit `dir` between the clipping
    /// planes, else the whole ray.
    pub fn clip(&self, frame: &CameraFrame, dir: DVec3) -> (f64, f64) {
        match self.clip_planes() {
            Some((near, far)) => {
                let cos = dir.dot(frame.forward).max(1e-300);
                (near / cos, far / cos)
            }
            None => (0.0, f64::INFINITY),
        }
    }

    /// World → camera (column-vector convention).
    pub fn world_to_camera(&self) -> DMat4 {
        glam::dcamera::rh::view::look_at_mat4(self.eye, self.look_at, self.up)
    }

    /// World → normalised device coordinates (OpenGL's [−1, 1] cube), near/far given.
    pub fn world_to_ndc(&self, near: f64, far: f64) -> DMat4 {
        let proj = match self.projection {
            Projection::Perspective { fov_deg } => {
                let fov_y = 2.0 * ((fov_deg.to_radians() * 0.5).tan() * self.aspect()).atan();
                glam::dcamera::rh::proj::opengl::perspective(fov_y, 1.0 / self.aspect(), near, far)
            }
            Projection::Orthographic { width } => {
                let (hw, hh) = (width * 0.5, width * 0.5 * self.aspect());
                glam::dcamera::rh::proj::opengl::orthographic(-hw, hw, -hh, hh, near, far)
            }
            Projection::Film(w) if w.orthographic => glam::dcamera::rh::proj::opengl::orthographic(
                w.left, w.right, w.bottom, w.top, w.near, w.far,
            ),
            Projection::Film(w) => {
                // A near plane at 0 (allowed for rays) has no frustum.
                let n = w.near.max(w.far * 1e-7);
                glam::dcamera::rh::proj::opengl::frustum(
                    w.left * n,
                    w.right * n,
                    w.bottom * n,
                    w.top * n,
                    n,
                    w.far,
                )
            }
        };
        proj * self.world_to_camera()
    }

    /// A camera that frames the world box `(lo, hi)` whole, looking from the front and a
    /// little above (−z view direction, y up): every corner of the box is inside the
    /// frame with a 4 % margin.
    pub fn framing(
        lo: DVec3,
        hi: DVec3,
        width: usize,
        height: usize,
        projection: Option<Projection>,
    ) -> Camera {
        let centre = (lo + hi) * 0.5;
        let back = DVec3::new(0.0, 0.3, 1.0).normalize();
        let aspect = height as f64 / width as f64;
        // The first eye only gives the frame's axes: one unit back, unless the box is
        // so far from the origin that a unit is lost in its coordinates' rounding (at
        // 5e17 a step of 0.95 in z rounds away, and the view would turn).
        let far = centre.abs().max_element();
        let reach = if far < 1e6 { 1.0 } else { far };
        let mut cam = Camera {
            projection: projection.unwrap_or(Projection::Perspective { fov_deg: 40.0 }),
            eye: centre + back * reach,
            look_at: centre,
            up: DVec3::Y,
            width,
            height,
        };
        let f = cam.frame();
        let corners = (0..8).map(|c| {
            let p = DVec3::new(
                if c & 1 == 0 { lo.x } else { hi.x },
                if c & 2 == 0 { lo.y } else { hi.y },
                if c & 4 == 0 { lo.z } else { hi.z },
            ) - centre;
            (p.dot(f.right).abs(), p.dot(f.up).abs(), p.dot(back))
        });
        let margin = 1.04;
        match cam.projection {
            Projection::Perspective { fov_deg } => {
                let tan_x = (fov_deg.to_radians() * 0.5).tan();
                let tan_y = tan_x * aspect;
                // Distance from the centre so that x/(d − z) ≤ tan for every corner.
                let dist = corners.fold(1e-6f64, |d, (x, y, z)| {
                    d.max(z + x * margin / tan_x).max(z + y * margin / tan_y)
                });
                cam.eye = centre + back * dist;
            }
            Projection::Orthographic { width: w } => {
                let (mut half_w, mut depth) = (1e-6f64, 1e-6f64);
                for (x, y, z) in corners {
                    half_w = half_w.max(x).max(y / aspect);
                    depth = depth.max(z);
                }
                let width = if w > 0.0 { w } else { 2.0 * half_w * margin };
                cam.projection = Projection::Orthographic { width };
                cam.eye = centre + back * (depth * 2.0 + 1e-3);
            }
            Projection::Film(_) => {}
        }
        cam
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_at_target_and_corners_span_fov() {
        let cam = Camera {
            projection: Projection::Perspective { fov_deg: 90.0 },
            eye: DVec3::new(0.0, 0.0, 5.0),
            look_at: DVec3::ZERO,
            up: DVec3::Y,
            width: 200,
            height: 100,
        };
        let f = cam.frame();
        let (_, d) = cam.ray(&f, 100.0, 50.0);
        assert!((d - DVec3::NEG_Z).length() < 1e-12);
        // The left edge of the image is 45° off axis for a 90° horizontal fov.
        let (_, d) = cam.ray(&f, 0.0, 50.0);
        assert!((d.dot(DVec3::NEG_Z) - (45f64).to_radians().cos()).abs() < 1e-12);
        // World → camera puts the target on −z at distance 5.
        let p = cam.world_to_camera().transform_point3(DVec3::ZERO);
        assert!((p - DVec3::new(0.0, 0.0, -5.0)).length() < 1e-12);
    }

    #[test]
    fn the_affine_rays_are_the_cameras_rays_for_every_projection() {
        let film = |orthographic| {
            Projection::Film(Window {
                orthographic,
                left: -0.3,
                right: 0.5,
                bottom: -0.2,
                top: 0.25,
                near: 0.1,
                far: 100.0,
            })
        };
        for projection in [
            Projection::Perspective { fov_deg: 40.0 },
            Projection::Orthographic { width: 3.0 },
            film(false),
            film(true),
        ] {
            let cam = Camera {
                projection,
                eye: DVec3::new(0.4, 1.0, 18.0),
                look_at: DVec3::new(0.0, -0.4, 0.0),
                up: DVec3::Y,
                width: 960,
                height: 540,
            };
            let f = cam.frame();
            let a = cam.ray_affine(&f);
            let at = |m: [DVec3; 3], px: f64, py: f64| m[0] + m[1] * px + m[2] * py;
            for (px, py) in [(0.0, 0.0), (959.5, 0.25), (480.5, 539.5), (13.7, 301.2)] {
                let (o, d) = cam.ray(&f, px, py);
                let d_affine = at(a.dir, px, py);
                let d_affine = if a.diverge {
                    d_affine.normalize()
                } else {
                    d_affine
                };
                // Within f64's rounding of an origin 18 units out, a thousand pixels
                // across (the GPU takes them in f32, 1e-6 apart).
                assert!(
                    (at(a.origin, px, py) - o).length() < 1e-10,
                    "{projection:?}"
                );
                assert!((d_affine - d).length() < 1e-12, "{projection:?}");
            }
        }
    }

    #[test]
    fn framing_a_box_far_from_the_origin_looks_at_it_from_the_front() {
        for (lo, hi) in [
            (DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 1.0, 1e18)),
            (DVec3::new(1e15, 0.0, 0.0), DVec3::new(1e15 + 1.0, 1.0, 1.0)),
            (DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 1.0, 3e38)),
        ] {
            let cam = Camera::framing(lo, hi, 32, 18, None);
            assert!(cam.validate().is_ok(), "{lo} {hi}: {cam:?}");
            let f = cam.frame();
            let back = DVec3::new(0.0, 0.3, 1.0).normalize();
            assert!(
                (f.forward + back).length() < 1e-9,
                "{lo} {hi}: {:?}",
                f.forward
            );
            // Every corner is in front of the eye.
            for c in [lo, hi] {
                assert!((c - cam.eye).dot(f.forward) > 0.0, "{lo} {hi}");
            }
        }
    }

    #[test]
    fn framing_keeps_the_box_in_view() {
        let (lo, hi) = (DVec3::new(-1.0, -2.0, -0.5), DVec3::new(3.0, 1.0, 0.5));
        let cam = Camera::framing(lo, hi, 320, 180, None);
        let ndc = cam.world_to_ndc(0.01, 100.0);
        for c in 0..8 {
            let p = DVec3::new(
                if c & 1 == 0 { lo.x } else { hi.x },
                if c & 2 == 0 { lo.y } else { hi.y },
                if c & 4 == 0 { lo.z } else { hi.z },
            );
            let q = ndc.project_point3(p);
            assert!(q.x.abs() <= 1.0 && q.y.abs() <= 1.0, "corner {p} at {q}");
        }
    }

    #[test]
    fn an_overscanned_camera_sees_the_same_pixels_and_more_around_them() {
        let eye = DVec3::new(0.3, 1.0, 6.0);
        let base = |projection| Camera {
            projection,
            eye,
            look_at: DVec3::ZERO,
            up: DVec3::Y,
            width: 40,
            height: 30,
        };
        let film = crate::scene::film::FilmBack {
            pixel_aspect: 2.0,
            horizontal_offset: 1.5,
            ..Default::default()
        };
        for cam in [
            base(Projection::Perspective { fov_deg: 50.0 }),
            base(Projection::Orthographic { width: 3.0 }),
            base(Projection::Film(film.window(40, 30))),
        ] {
            let wide = cam.overscanned(6, 4);
            assert_eq!((wide.width, wide.height), (52, 38));
            let (f, g) = (cam.frame(), wide.frame());
            for (x, y) in [(0.0, 0.0), (0.5, 0.5), (39.5, 29.5), (17.25, 3.75)] {
                let (o, d) = cam.ray(&f, x, y);
                let (o2, d2) = wide.ray(&g, x + 6.0, y + 4.0);
                assert!((o - o2).length() < 1e-12 && (d - d2).length() < 1e-12);
            }
            assert_eq!(wide.pixel_aspect(), cam.pixel_aspect());
            assert_eq!(cam.overscanned(0, 0), cam);
        }
        assert_eq!(
            base(Projection::Film(film.window(40, 30))).pixel_aspect(),
            2.0
        );
        assert_eq!(
            base(Projection::Perspective { fov_deg: 50.0 }).pixel_aspect(),
            1.0
        );
    }
}
