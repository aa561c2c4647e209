//! A camera from a file or the scene's `[camera]` table, as planned: `camera_file`,
//! `camera_prim`, `camera_rotation_order`, `film_fit` and the table; evaluated at a
//! frame ([`ShotPlan::camera`]) when the scene is built.

use crate::scene::camera::Camera;
use crate::scene::film::{FilmBack, FilmFit};
use crate::scene::options::{CameraSetting, RenderOptions};
use crate::scene::shot::table::CameraTable;
use crate::scene::shot::{CameraTrack, FileRequest, RotationOrder, ShotCamera};
use std::path::PathBuf;

/// The shot's camera before it is read.
#[derive(Clone, Debug, PartialEq)]
pub struct ShotPlan {
    pub file: Option<PathBuf>,
    pub prim: Option<String>,
    pub rotation_order: RotationOrder,
    pub fit: Option<FilmFit>,
    pub table: Option<CameraTable>,
    /// The frame the camera is taken at: the sequence's frame, else its first sample.
    pub time: Option<f64>,
    /// `scene_meters_per_unit`: the volumes' unit in metres, into which a USD stage's
    /// camera is scaled from its `metersPerUnit`.
    pub scene_meters_per_unit: Option<f64>,
}

/// The camera at the plan's frame, with what the file says of the world.
#[derive(Clone, Debug)]
pub struct ShotCameraAt {
    pub camera: Camera,
    /// A note for the render's report (the frame held, the stage's units).
    pub notes: Vec<String>,
    /// The USD stage's `upAxis` is Z (`None`: not a USD stage).
    pub up_z: Option<bool>,
}

impl ShotPlan {
    /// The shot camera the options ask for, if any.
    pub fn from_options(o: &RenderOptions) -> Result<Option<ShotPlan>, String> {
        let table = match &o.camera {
            Some(CameraSetting::Table(t)) => Some((**t).clone()),
            _ => None,
        };
        if o.camera_file.is_none() && table.is_none() {
            for key in [
                "camera_prim",
                "camera_rotation_order",
                "film_fit",
                "scene_meters_per_unit",
            ] {
                if o.is_given(key) {
                    return Err(format!(
                        "{{{key}}} needs a camera: {{camera_file}} or a [camera] table"
                    ));
                }
            }
            return Ok(None);
        }
        if let Some(t) = &table {
            if o.camera_file.is_some() && t.places() {
                return Err("the [camera] table's translate, rotate or keys and {camera_file} both place the camera; give one".into());
            }
            if o.camera_file.is_none() && !t.places() {
                return Err("the [camera] table says nowhere where the camera is: give translate and rotate, [[camera.keys]], or {camera_file}".into());
            }
            t.film_over(FilmBack::default())?;
        }
        for (key, given) in [
            ("eye", o.eye.is_some()),
            ("look_at", o.look_at.is_some()),
            ("fov", o.fov.is_some()),
            ("ortho_width", o.ortho_width.is_some()),
        ] {
            if given {
                return Err(format!(
                    "{{{key}}} places the default camera; the shot's camera ({}) is placed by its file or table",
                    if o.camera_file.is_some() {
                        "{camera_file}"
                    } else {
                        "[camera]"
                    }
                ));
            }
        }
        let rotation_order = match &o.camera_rotation_order {
            Some(s) => {
                RotationOrder::parse(s).map_err(|e| format!("{{camera_rotation_order}} {e}"))?
            }
            None => RotationOrder::default(),
        };
        let fit = o
            .film_fit
            .as_deref()
            .map(FilmFit::parse)
            .transpose()
            .map_err(|e| format!("{{film_fit}} {e}"))?;
        if let Some(m) = o.scene_meters_per_unit {
            if !(m > 0.0 && m.is_finite()) {
                return Err(format!(
                    "{{scene_meters_per_unit}} {m} must be a positive number of metres"
                ));
            }
            let usd = o
                .camera_file
                .as_ref()
                .and_then(|f| f.extension())
                .is_some_and(|e| {
                    ["usd", "usda", "usdc", "usdz"]
                        .iter()
                        .any(|u| e.eq_ignore_ascii_case(u))
                });
            if !usd {
                return Err("{scene_meters_per_unit} scales a USD stage's camera by its metersPerUnit; a .chan or a [camera] table has no units (it is in the volumes')".into());
            }
        }
        Ok(Some(ShotPlan {
            file: o.camera_file.clone(),
            prim: o.camera_prim.clone(),
            rotation_order,
            fit,
            table,
            time: None,
            scene_meters_per_unit: o.scene_meters_per_unit,
        }))
    }

    fn is_chan(&self) -> bool {
        self.file
            .as_ref()
            .and_then(|f| f.extension())
            .is_some_and(|e| e.eq_ignore_ascii_case("chan"))
    }

    /// The film back under the table's keys and a `.chan`'s field of view.
    fn base_film(&self) -> FilmBack {
        FilmBack {
            fit: self.fit.unwrap_or(if self.is_chan() {
                FilmFit::Vertical
            } else {
                FilmFit::Horizontal
            }),
            ..FilmBack::default()
        }
    }

    /// The camera (file or table) over time.
    pub fn track(&self) -> Result<CameraTrack, String> {
        let base = self.base_film();
        let film = match &self.table {
            Some(t) => t.film_over(base)?,
            None => base,
        };
        match (&self.file, &self.table) {
            (Some(path), _) => CameraTrack::open(&FileRequest {
                path: path.clone(),
                prim: self.prim.clone(),
                rotation_order: self.rotation_order,
                film,
            })
            .map_err(|e| e.to_string()),
            (None, Some(t)) => Ok(CameraTrack::Keys(t.keys(base, self.rotation_order)?)),
            (None, None) => Err("no camera file or [camera] table".into()),
        }
    }

    /// The track's camera at frame `time`, with the plan's film settings over a USD
    /// camera's, scaled into the volumes' units.
    fn shot_at(&self, track: &CameraTrack, time: f64) -> Result<ShotCamera, String> {
        let mut shot = track.at(time).map_err(|e| self.named(e))?;
        if let CameraTrack::Usd(u) = track {
            if let Some(t) = &self.table {
                shot.film = t.film_over(shot.film)?;
            }
            shot.film.fit = self.fit.unwrap_or(FilmFit::Horizontal);
            if let Some(m) = self.scene_meters_per_unit {
                shot = shot.scaled(u.meters_per_unit / m);
            }
        }
        Ok(shot)
    }

    /// `e` naming the camera file (or the `[camera]` table).
    fn named(&self, e: String) -> String {
        match &self.file {
            Some(f) => format!("{}: {e}", f.display()),
            None => format!("[camera]: {e}"),
        }
    }

    /// The cameras of an image `width` × `height` at the plan's frame plus each of
    /// `offsets` (frames): where the camera is while the shutter is open.
    pub fn cameras_at(
        &self,
        width: usize,
        height: usize,
        offsets: &[f64],
    ) -> Result<Vec<Camera>, String> {
        let track = self.track()?;
        let time = self.time.or(track.span().map(|s| s.0)).unwrap_or(0.0);
        offsets
            .iter()
            .map(|dt| {
                self.shot_at(&track, time + dt)?
                    .camera(width, height)
                    .map_err(|e| self.named(e))
            })
            .collect()
    }

    /// The camera of an image `width` × `height` at the plan's frame.
    pub fn camera(&self, width: usize, height: usize) -> Result<ShotCameraAt, String> {
        let track = self.track()?;
        let span = track.span();
        let time = self.time.or(span.map(|s| s.0)).unwrap_or(0.0);
        let shot = self.shot_at(&track, time)?;
        let mut notes = Vec::new();
        let mut up_z = None;
        if let CameraTrack::Usd(u) = &track {
            up_z = Some(u.up_z);
            let scaled = match self.scene_meters_per_unit {
                Some(m) => {
                    let k = u.meters_per_unit / m;
                    format!(", scaled by {k} into the volumes' {m} m units")
                }
                None => String::new(),
            };
            notes.push(format!(
                "camera {} of {} (upAxis {}, metersPerUnit {}{scaled})",
                u.prim,
                self.file
                    .as_deref()
                    .unwrap_or(std::path::Path::new(""))
                    .display(),
                if u.up_z { "Z" } else { "Y" },
                u.meters_per_unit
            ));
        }
        if shot.held
            && let Some((lo, hi)) = span
        {
            notes.push(format!(
                "camera: frame {time} is outside the camera's frames {lo} to {hi}; the nearest is held"
            ));
        }
        let camera = shot.camera(width, height).map_err(|e| self.named(e))?;
        Ok(ShotCameraAt {
            camera,
            notes,
            up_z,
        })
    }
}
