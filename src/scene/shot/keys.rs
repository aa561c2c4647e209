//! A camera keyed at frames (a `.chan`'s rows, the `[camera]` table's keys): translate
//! and Euler rotation with a film back at each key, linear in between, the first and
//! last key held outside.

use super::{RotationOrder, ShotCamera};
use crate::scene::film::FilmBack;
use glam::{DMat4, DVec3};

/// The camera at one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Key {
    pub frame: f64,
    pub translate: DVec3,
    /// Degrees about x, y and z.
    pub rotate: DVec3,
    pub film: FilmBack,
}

/// Keys in increasing frame order (at least one).
#[derive(Clone, Debug, PartialEq)]
pub struct Keys {
    pub keys: Vec<Key>,
    pub order: RotationOrder,
}

fn lerp(a: f64, b: f64, u: f64) -> f64 {
    if u == 0.0 { a } else { a + (b - a) * u }
}

impl Keys {
    /// The camera at frame `time`.
    pub fn at(&self, time: f64) -> Result<ShotCamera, String> {
        let (first, last) = match (self.keys.first(), self.keys.last()) {
            (Some(f), Some(l)) => (f, l),
            _ => return Err("the camera has no keys".into()),
        };
        let (key, held) = if time <= first.frame {
            (*first, time < first.frame)
        } else if time >= last.frame {
            (*last, time > last.frame)
        } else {
            let i = self.keys.partition_point(|k| k.frame <= time);
            let (a, b) = (&self.keys[i - 1], &self.keys[i]);
            let u = (time - a.frame) / (b.frame - a.frame);
            let mut film = a.film;
            let (fa, fb) = (&a.film, &b.film);
            film.focal_length = lerp(fa.focal_length, fb.focal_length, u);
            film.horizontal_aperture = lerp(fa.horizontal_aperture, fb.horizontal_aperture, u);
            film.vertical_aperture = lerp(fa.vertical_aperture, fb.vertical_aperture, u);
            film.horizontal_offset = lerp(fa.horizontal_offset, fb.horizontal_offset, u);
            film.vertical_offset = lerp(fa.vertical_offset, fb.vertical_offset, u);
            film.near = lerp(fa.near, fb.near, u);
            film.far = lerp(fa.far, fb.far, u);
            let v = |p: DVec3, q: DVec3| {
                DVec3::new(lerp(p.x, q.x, u), lerp(p.y, q.y, u), lerp(p.z, q.z, u))
            };
            (
                Key {
                    frame: time,
                    translate: v(a.translate, b.translate),
                    rotate: v(a.rotate, b.rotate),
                    film,
                },
                false,
            )
        };
        let r = self.order.matrix(key.rotate);
        Ok(ShotCamera {
            camera_to_world: DMat4::from_translation(key.translate) * DMat4::from_mat3(r),
            film: key.film,
            held,
        })
    }

    /// The first and last keyed frame.
    pub fn span(&self) -> Option<(f64, f64)> {
        Some((self.keys.first()?.frame, self.keys.last()?.frame))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_linear_between_and_held_outside() {
        let key = |frame: f64, x: f64, focal: f64| Key {
            frame,
            translate: DVec3::new(x, 0.0, 0.0),
            rotate: DVec3::ZERO,
            film: FilmBack {
                focal_length: focal,
                ..FilmBack::default()
            },
        };
        let keys = Keys {
            keys: vec![key(1.0, 0.0, 20.0), key(3.0, 4.0, 40.0)],
            order: RotationOrder::Zxy,
        };
        let at = |t: f64| keys.at(t).unwrap();
        assert_eq!(at(2.0).camera_to_world.w_axis.x, 2.0);
        assert_eq!(at(2.0).film.focal_length, 30.0);
        assert!(!at(2.0).held && !at(3.0).held);
        assert!(at(0.0).held && at(7.0).held);
        assert_eq!(at(7.0).camera_to_world.w_axis.x, 4.0);
        assert_eq!(keys.span(), Some((1.0, 3.0)));
    }
}
