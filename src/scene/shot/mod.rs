//! The shot's camera: from a USD stage (`usd.rs`), a Nuke `.chan` (`chan.rs`) or the
//! scene file's `[camera]` table (`table.rs`), evaluated at a frame into a world matrix
//! and a [`FilmBack`]. Frames outside a file's samples hold its first or last one.

mod chan;
mod keys;
pub mod table;
mod usd;

use super::camera::{Camera, Projection};
use super::film::FilmBack;
use glam::{DMat3, DMat4, DVec3};
pub use keys::{Key, Keys};
use std::path::{Path, PathBuf};
pub use usd::UsdCamera;

/// A camera file's problem: the file and what is wrong, one line.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{}: {problem}", path.display())]
pub struct ShotError {
    pub path: PathBuf,
    pub problem: String,
}

impl ShotError {
    pub fn new(path: &Path, problem: impl Into<String>) -> ShotError {
        ShotError {
            path: path.to_path_buf(),
            problem: problem.into(),
        }
    }
}

/// The order of Euler rotations: `Zxy` turns about z first, then x, then y (Nuke's
/// default, and USD's `xformOp:rotateZXY`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RotationOrder {
    Xyz,
    Xzy,
    Yxz,
    Yzx,
    #[default]
    Zxy,
    Zyx,
}

impl RotationOrder {
    pub fn parse(word: &str) -> Result<RotationOrder, String> {
        Ok(match word.trim().to_ascii_lowercase().as_str() {
            "xyz" => RotationOrder::Xyz,
            "xzy" => RotationOrder::Xzy,
            "yxz" => RotationOrder::Yxz,
            "yzx" => RotationOrder::Yzx,
            "zxy" => RotationOrder::Zxy,
            "zyx" => RotationOrder::Zyx,
            _ => {
                return Err(format!(
                    "\"{word}\": expected xyz, xzy, yxz, yzx, zxy or zyx"
                ));
            }
        })
    }

    /// The rotation by `deg` (degrees about x, y, z), each axis turned in this order.
    pub fn matrix(self, deg: DVec3) -> DMat3 {
        let (x, y, z) = (
            DMat3::from_rotation_x(deg.x.to_radians()),
            DMat3::from_rotation_y(deg.y.to_radians()),
            DMat3::from_rotation_z(deg.z.to_radians()),
        );
        // Column vectors: the first turn is the rightmost factor.
        match self {
            RotationOrder::Xyz => z * y * x,
            RotationOrder::Xzy => y * z * x,
            RotationOrder::Yxz => z * x * y,
            RotationOrder::Yzx => x * z * y,
            RotationOrder::Zxy => y * x * z,
            RotationOrder::Zyx => x * y * z,
        }
    }
}

/// The camera at one frame: camera → world (camera space looks down −z, y up) and its
/// film back; `held` when the frame is outside the file's samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShotCamera {
    pub camera_to_world: DMat4,
    pub film: FilmBack,
    pub held: bool,
}

/// A camera over time, read from a file or the scene's `[camera]` table.
pub enum CameraTrack {
    Usd(Box<UsdCamera>),
    Keys(Keys),
}

/// What a camera file is read with: the prim to take from a USD stage, the Euler order
/// of a `.chan`, and the film back a `.chan` (which holds only a field of view) uses.
#[derive(Clone, Debug, PartialEq)]
pub struct FileRequest {
    pub path: PathBuf,
    pub prim: Option<String>,
    pub rotation_order: RotationOrder,
    pub film: FilmBack,
}

impl CameraTrack {
    /// Reads the camera file `req.path`, by its extension.
    pub fn open(req: &FileRequest) -> Result<CameraTrack, ShotError> {
        let ext = req
            .path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("usd" | "usda" | "usdc" | "usdz") => {
                let opened =
                    crate::vdb::without_panics(|| UsdCamera::open(&req.path, req.prim.as_deref()))
                        .map_err(|e| ShotError::new(&req.path, e))??;
                Ok(CameraTrack::Usd(Box::new(opened)))
            }
            Some("chan") => Ok(CameraTrack::Keys(chan::read(
                &req.path,
                req.rotation_order,
                &req.film,
            )?)),
            _ => Err(ShotError::new(
                &req.path,
                "not a camera file murk reads: expected .usd, .usda, .usdc, .usdz or .chan",
            )),
        }
    }

    /// The camera at frame `time`.
    pub fn at(&self, time: f64) -> Result<ShotCamera, String> {
        match self {
            CameraTrack::Usd(u) => crate::vdb::without_panics(|| u.at(time))?,
            CameraTrack::Keys(k) => k.at(time),
        }
    }

    /// The first and last frame of the samples, if the camera moves at all.
    pub fn span(&self) -> Option<(f64, f64)> {
        match self {
            CameraTrack::Usd(u) => u.span(),
            CameraTrack::Keys(k) => k.span(),
        }
    }
}

/// `v` rounded to single precision: a camera from a file is quantised as the EXR header
/// stores it, so the same camera read from two files (a `.chan` written from a USD
/// stage) renders the same image whatever the last bits of each file's arithmetic.
fn single(v: DVec3) -> DVec3 {
    v.as_vec3().as_dvec3()
}

fn single_f(v: f64) -> f64 {
    v as f32 as f64
}

impl ShotCamera {
    /// The camera in units `k` times smaller (a stage in centimetres seen from a world
    /// in metres: `k` = 0.01): its position and clipping range scaled by `k`, and an
    /// orthographic film gate too (a perspective gate is in millimetres, whatever the
    /// scene's units).
    pub fn scaled(&self, k: f64) -> ShotCamera {
        let mut film = self.film;
        film.near *= k;
        film.far *= k;
        if film.orthographic {
            film.horizontal_aperture *= k;
            film.vertical_aperture *= k;
            film.horizontal_offset *= k;
            film.vertical_offset *= k;
        }
        ShotCamera {
            camera_to_world: DMat4::from_scale(DVec3::splat(k)) * self.camera_to_world,
            film,
            held: self.held,
        }
    }

    /// The render camera of an image `width` × `height`: the eye at the matrix's origin,
    /// looking down its −z with its y up (a scale or shear in the matrix is dropped).
    /// Refuses a singular or non-finite matrix and a film back that cannot image.
    pub fn camera(&self, width: usize, height: usize) -> Result<Camera, String> {
        let m = self.camera_to_world;
        let det = DMat3::from_mat4(m).determinant();
        if !m.is_finite() || !(det.abs() > 1e-12) {
            return Err("the camera's transform is singular (a zero scale?)".into());
        }
        self.film.check()?;
        let eye = single(m.transform_point3(DVec3::ZERO));
        let forward = single(m.transform_vector3(DVec3::NEG_Z).normalize());
        let up = single(m.transform_vector3(DVec3::Y).normalize());
        if forward.cross(up).length() < 1e-9 {
            return Err("the camera's transform has no up direction apart from its view".into());
        }
        let mut film = self.film;
        for v in [
            &mut film.focal_length,
            &mut film.horizontal_aperture,
            &mut film.vertical_aperture,
            &mut film.horizontal_offset,
            &mut film.vertical_offset,
            &mut film.near,
            &mut film.far,
        ] {
            *v = single_f(*v);
        }
        let camera = Camera {
            projection: Projection::Film(film.window(width, height)),
            eye,
            look_at: eye + forward,
            up,
            width,
            height,
        };
        camera.check()?;
        Ok(camera)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_orders_turn_the_first_axis_first() {
        // 90° about z then 90° about x: x → y → z.
        let m = RotationOrder::Zxy.matrix(DVec3::new(90.0, 0.0, 90.0));
        assert!((m * DVec3::X - DVec3::Z).length() < 1e-12);
        // The other way round: x stays x under the x turn, then z turns it to y.
        let m = RotationOrder::Xyz.matrix(DVec3::new(90.0, 0.0, 90.0));
        assert!((m * DVec3::X - DVec3::Y).length() < 1e-12);
        assert!(RotationOrder::parse("ZXY").is_ok() && RotationOrder::parse("xxy").is_err());
    }

    #[test]
    fn a_singular_transform_is_refused() {
        let shot = ShotCamera {
            camera_to_world: DMat4::from_scale(DVec3::new(1.0, 0.0, 1.0)),
            film: FilmBack::default(),
            held: false,
        };
        assert!(shot.camera(4, 4).unwrap_err().contains("singular"));
        let ok = ShotCamera {
            camera_to_world: DMat4::from_translation(DVec3::new(0.0, 0.0, 5.0)),
            ..shot
        };
        let cam = ok.camera(4, 4).unwrap();
        let f = cam.frame();
        let (o, d) = cam.ray(&f, 2.0, 2.0);
        assert!((o - DVec3::new(0.0, 0.0, 5.0)).length() < 1e-12);
        assert!((d - DVec3::NEG_Z).length() < 1e-12);
    }

    #[test]
    fn a_camera_in_centimetres_scales_into_metres() {
        let shot = ShotCamera {
            camera_to_world: DMat4::from_translation(DVec3::new(100.0, 0.0, 500.0))
                * DMat4::from_rotation_y(0.3),
            film: FilmBack {
                near: 10.0,
                far: 1e5,
                ..FilmBack::default()
            },
            held: false,
        };
        let m = shot.scaled(0.01);
        let eye = m.camera_to_world.transform_point3(DVec3::ZERO);
        assert!((eye - DVec3::new(1.0, 0.0, 5.0)).length() < 1e-12);
        assert!((m.film.near - 0.1).abs() < 1e-15 && (m.film.far - 1e3).abs() < 1e-9);
        assert_eq!(m.film.horizontal_aperture, shot.film.horizontal_aperture);
        // The view turns the same way: the rays are the same, from the scaled eye.
        let (a, b) = (shot.camera(8, 8).unwrap(), m.camera(8, 8).unwrap());
        let (ra, rb) = (a.ray(&a.frame(), 1.5, 6.5).1, b.ray(&b.frame(), 1.5, 6.5).1);
        assert!((ra - rb).length() < 1e-6);
        let mut ortho = shot;
        ortho.film.orthographic = true;
        assert!((ortho.scaled(0.01).film.horizontal_aperture - 0.20955).abs() < 1e-12);
    }
}
