//! Nuke's `.chan`: one line per frame, `frame tx ty tz rx ry rz [vfov]`, separated by
//! spaces or tabs; rotations in degrees in the given Euler order, the optional vertical
//! field of view in degrees (it sets the focal length on the film back's gate).

use super::{Key, Keys, RotationOrder, ShotError};
use crate::scene::film::FilmBack;
use glam::DVec3;
use std::io::Read;
use std::path::Path;

/// The most a `.chan` may hold: 64 MiB (a million frames of 64 characters).
const MAX_BYTES: u64 = 64 << 20;

pub fn read(path: &Path, order: RotationOrder, film: &FilmBack) -> Result<Keys, ShotError> {
    let bad = |p: String| ShotError::new(path, p);
    let file = std::fs::File::open(path).map_err(|e| bad(e.to_string()))?;
    let mut text = String::new();
    file.take(MAX_BYTES + 1)
        .read_to_string(&mut text)
        .map_err(|e| bad(format!("not a text .chan ({e})")))?;
    if text.len() as u64 > MAX_BYTES {
        return Err(bad(format!(
            "larger than {} MiB: not a .chan",
            MAX_BYTES >> 20
        )));
    }
    parse(&text, order, film).map_err(bad)
}

fn parse(text: &str, order: RotationOrder, film: &FilmBack) -> Result<Keys, String> {
    let mut keys: Vec<Key> = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let at = n + 1;
        let cols: Vec<&str> = line.split_whitespace().collect();
        if !(7..=8).contains(&cols.len()) {
            return Err(format!(
                "line {at}: {} columns; a .chan line is frame tx ty tz rx ry rz, and optionally the vertical field of view",
                cols.len()
            ));
        }
        let mut v = [0f64; 8];
        for (i, c) in cols.iter().enumerate() {
            v[i] = c
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("line {at}: \"{c}\" is not a number"))?;
        }
        let mut f = *film;
        if cols.len() == 8 {
            let fov = v[7];
            if !(fov > 0.0 && fov < 180.0) {
                return Err(format!(
                    "line {at}: the vertical field of view {fov} is outside (0, 180) degrees"
                ));
            }
            f.focal_length = film.focal_for_vertical_fov(fov);
        }
        if let Some(prev) = keys.last()
            && !(v[0] > prev.frame)
        {
            return Err(format!(
                "line {at}: frame {} does not follow frame {}",
                v[0], prev.frame
            ));
        }
        keys.push(Key {
            frame: v[0],
            translate: DVec3::new(v[1], v[2], v[3]),
            rotate: DVec3::new(v[4], v[5], v[6]),
            film: f,
        });
    }
    if keys.is_empty() {
        return Err("no frames: a .chan line is frame tx ty tz rx ry rz [vfov]".into());
    }
    Ok(Keys { keys, order })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_become_keys_and_bad_rows_are_named() {
        let film = FilmBack::default();
        let k = parse(
            "1 0 0 5 0 0 0 40\n2\t1 0 5 0 90 0 40\n",
            RotationOrder::Zxy,
            &film,
        )
        .unwrap();
        assert_eq!(k.keys.len(), 2);
        let c = k.at(1.0).unwrap();
        assert!((c.film.vertical_fov_deg() - 40.0).abs() < 1e-12);
        let m = k.at(2.0).unwrap().camera_to_world;
        // Turned 90° about y: the camera's −z looks along −x.
        assert!((m.transform_vector3(DVec3::NEG_Z) - DVec3::NEG_X).length() < 1e-12);
        let e = parse("1 0 0 5 0 0\n", RotationOrder::Zxy, &film).unwrap_err();
        assert!(e.starts_with("line 1: 6 columns"), "{e}");
        let e = parse("1 0 0 5 0 0 x\n", RotationOrder::Zxy, &film).unwrap_err();
        assert!(e.contains("\"x\" is not a number"), "{e}");
        let e = parse("2 0 0 5 0 0 0\n1 0 0 5 0 0 0\n", RotationOrder::Zxy, &film).unwrap_err();
        assert!(e.starts_with("line 2: frame 1"), "{e}");
        assert!(parse("", RotationOrder::Zxy, &film).is_err());
        assert!(parse("1 0 0 5 0 0 0 0\n", RotationOrder::Zxy, &film).is_err());
    }
}
