//! The scene file's `[camera]` table: a film back and a placement, keyable per frame
//! with `[[camera.keys]]`. With a camera file its film-back keys override the file's.

use super::{Key, Keys, RotationOrder};
use crate::scene::film::FilmBack;
use glam::DVec3;
use serde::Deserialize;

/// Declares the film-back and placement keys once: in [`CameraValues`], in the table
/// and in each of its keys (serde's `flatten` would lose `deny_unknown_fields`).
macro_rules! camera_values {
    ($(#[$m:meta])* $name:ident { $($extra:tt)* }) => {
        $(#[$m])*
        #[derive(Clone, Debug, Default, Deserialize, PartialEq)]
        #[serde(deny_unknown_fields)]
        pub struct $name {
            $($extra)*
            /// Millimetres.
            pub focal_length: Option<f64>,
            /// Millimetres (tenths of a scene unit for an orthographic camera).
            pub horizontal_aperture: Option<f64>,
            pub vertical_aperture: Option<f64>,
            /// Lens shift, in the apertures' units.
            pub horizontal_aperture_offset: Option<f64>,
            pub vertical_aperture_offset: Option<f64>,
            /// Near and far clipping distances.
            pub clipping_range: Option<[f64; 2]>,
            /// The camera's position.
            pub translate: Option<[f64; 3]>,
            /// Degrees about x, y and z, turned in `camera_rotation_order`.
            pub rotate: Option<[f64; 3]>,
        }

        impl $name {
            /// The film-back and placement values alone.
            pub fn values(&self) -> CameraValues {
                CameraValues {
                    focal_length: self.focal_length,
                    horizontal_aperture: self.horizontal_aperture,
                    vertical_aperture: self.vertical_aperture,
                    horizontal_aperture_offset: self.horizontal_aperture_offset,
                    vertical_aperture_offset: self.vertical_aperture_offset,
                    clipping_range: self.clipping_range,
                    translate: self.translate,
                    rotate: self.rotate,
                }
            }
        }
    };
}

camera_values!(
    /// The film-back and placement values of the table or of one key.
    CameraValues {}
);

camera_values!(
    /// `[camera]`.
    CameraTable {
        /// perspective or orthographic.
        pub projection: Option<String>,
        /// A pixel's width over its height.
        pub pixel_aspect: Option<f64>,
        /// `[[camera.keys]]`: `frame = N` and any of the values.
        #[serde(default)]
        pub keys: Vec<CameraKey>,
    }
);

camera_values!(
    /// One `[[camera.keys]]`.
    CameraKey {
        pub frame: f64,
    }
);

impl CameraValues {
    /// `film` with the film-back values given here.
    fn film_over(&self, mut film: FilmBack) -> FilmBack {
        let set = |v: Option<f64>, to: &mut f64| {
            if let Some(v) = v {
                *to = v;
            }
        };
        set(self.focal_length, &mut film.focal_length);
        set(self.horizontal_aperture, &mut film.horizontal_aperture);
        set(self.vertical_aperture, &mut film.vertical_aperture);
        set(self.horizontal_aperture_offset, &mut film.horizontal_offset);
        set(self.vertical_aperture_offset, &mut film.vertical_offset);
        if let Some([near, far]) = self.clipping_range {
            film.near = near;
            film.far = far;
        }
        film
    }

    fn places(&self) -> bool {
        self.translate.is_some() || self.rotate.is_some()
    }
}

impl CameraTable {
    /// `film` with the table's film-back keys (those given) over it.
    pub fn film_over(&self, film: FilmBack) -> Result<FilmBack, String> {
        let mut f = self.values().film_over(film);
        if let Some(p) = self.pixel_aspect {
            f.pixel_aspect = p;
        }
        match self.projection.as_deref() {
            None => {}
            Some("perspective" | "persp") => f.orthographic = false,
            Some("orthographic" | "ortho") => f.orthographic = true,
            Some(other) => {
                return Err(format!(
                    "[camera] projection \"{other}\": expected perspective or orthographic"
                ));
            }
        }
        Ok(f)
    }

    /// Whether the table says where the camera is (`translate`, `rotate` or keys).
    pub fn places(&self) -> bool {
        self.values().places() || !self.keys.is_empty()
    }

    /// Whether the table gives any film-back value a camera file's would yield to.
    pub fn has_film(&self) -> bool {
        self.film_over(FilmBack::default())
            .is_ok_and(|f| f != FilmBack::default())
            || self.projection.is_some()
    }

    /// The camera the table places: its keys (each over the table's values), or the
    /// table's values at every frame. `film` is the film back under the table's.
    pub fn keys(&self, film: FilmBack, order: RotationOrder) -> Result<Keys, String> {
        let base = self.film_over(film)?;
        let table = self.values();
        let v3 =
            |v: Option<[f64; 3]>, d: Option<[f64; 3]>| DVec3::from(v.or(d).unwrap_or([0.0; 3]));
        let key = |frame: f64, v: &CameraValues| -> Result<Key, String> {
            let film = v.film_over(base);
            film.check()
                .map_err(|e| format!("[camera] at frame {frame}: {e}"))?;
            let k = Key {
                frame,
                translate: v3(v.translate, table.translate),
                rotate: v3(v.rotate, table.rotate),
                film,
            };
            if !(frame.is_finite() && k.translate.is_finite() && k.rotate.is_finite()) {
                return Err(format!(
                    "[camera] at frame {frame}: a value is not a finite number"
                ));
            }
            Ok(k)
        };
        let mut keys = Vec::new();
        if self.keys.is_empty() {
            keys.push(key(0.0, &table)?);
        }
        for k in &self.keys {
            let next = key(k.frame, &k.values())?;
            if let Some(prev) = keys.last().map(|p: &Key| p.frame)
                && !(next.frame > prev)
            {
                return Err(format!(
                    "[[camera.keys]] frame {} does not follow frame {prev}",
                    next.frame
                ));
            }
            keys.push(next);
        }
        Ok(Keys { keys, order })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> CameraTable {
        toml::from_str(text).unwrap()
    }

    #[test]
    fn keys_take_the_table_values_they_do_not_give() {
        let t = table(
            "focal_length = 35\nhorizontal_aperture = 36\nvertical_aperture = 24\ntranslate = [0, 1, 5]\n[[keys]]\nframe = 1\n[[keys]]\nframe = 3\nfocal_length = 55\ntranslate = [2, 1, 5]\n",
        );
        let k = t.keys(FilmBack::default(), RotationOrder::Zxy).unwrap();
        let mid = k.at(2.0).unwrap();
        assert_eq!(mid.film.focal_length, 45.0);
        assert_eq!(mid.film.horizontal_aperture, 36.0);
        assert_eq!(
            mid.camera_to_world.w_axis.truncate(),
            DVec3::new(1.0, 1.0, 5.0)
        );
        assert!(t.places() && t.has_film());
    }

    #[test]
    fn bad_tables_are_refused_in_words() {
        let t = table("focal_length = -5\ntranslate = [0, 0, 1]\n");
        let e = t.keys(FilmBack::default(), RotationOrder::Zxy).unwrap_err();
        assert!(e.contains("focal length -5"), "{e}");
        let t = table("projection = \"fisheye\"\n");
        assert!(
            t.film_over(FilmBack::default())
                .unwrap_err()
                .contains("fisheye")
        );
        let t = table("[[keys]]\nframe = 2\n[[keys]]\nframe = 2\n");
        assert!(t.keys(FilmBack::default(), RotationOrder::Zxy).is_err());
        assert!(toml::from_str::<CameraTable>("focal = 3").is_err());
    }
}
