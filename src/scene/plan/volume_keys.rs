//! A `[[volume]]`'s placement keyed at frames (`[[volume.keys]]`), as the `[camera]`
//! table keys the camera: each key's translate, rotate and scale over the table's (or,
//! for a volume placed by `matrix`, each key's matrix taken apart into those three), the
//! placement between two keys translated and scaled linearly and turned along the
//! shortest arc between the keys' rotations, held before the first key and after the last.

use crate::scene::options::volume::{Scale, VolumeKey, VolumeTable};
use glam::{DMat4, DQuat, DVec3, EulerRot};

/// The placement at one frame, in parts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlacementKey {
    pub frame: f64,
    pub translate: DVec3,
    pub rotate: DQuat,
    pub scale: DVec3,
}

impl PlacementKey {
    /// scale, then rotate, then translate.
    pub fn matrix(&self) -> DMat4 {
        DMat4::from_scale_rotation_translation(self.scale, self.rotate, self.translate)
    }
}

/// Keys in increasing frame order (at least two).
#[derive(Clone, Debug, PartialEq)]
pub struct PlacementKeys {
    keys: Vec<PlacementKey>,
}

/// The rotation of `rotate` degrees about the world's x, y and z axes, in that order.
pub fn rotation(rotate: [f64; 3]) -> DQuat {
    let r = DVec3::from_array(rotate) * (std::f64::consts::PI / 180.0);
    DQuat::from_euler(EulerRot::ZYX, r.z, r.y, r.x)
}

/// A scale as per-axis factors.
pub fn scale_of(s: Option<Scale>) -> DVec3 {
    match s {
        None => DVec3::ONE,
        Some(Scale::Uniform(s)) => DVec3::splat(s),
        Some(Scale::Axes(a)) => DVec3::from_array(a),
    }
}

/// The matrix given as four rows, the translation in the last column; one line saying
/// what is wrong with it otherwise.
pub fn matrix_from_rows(rows: [[f64; 4]; 4], at: &str) -> Result<DMat4, String> {
    if rows[3] != [0.0, 0.0, 0.0, 1.0] {
        return Err(format!(
            "{at}: the matrix's last row must be [0, 0, 0, 1] (rows, the translation in the last column; a matrix written by rows of a row-vector convention is its transpose)"
        ));
    }
    Ok(DMat4::from_cols_array_2d(&rows).transpose())
}

/// A keyed matrix as translate, rotate and scale, which keys interpolate; one line
/// saying why not where it has a shear (which they cannot carry) or is singular.
fn decomposed(m: DMat4, at: &str) -> Result<(DVec3, DQuat, DVec3), String> {
    if !m.is_finite() {
        return Err(format!("{at}: a value is not a finite number"));
    }
    if m.determinant().abs() < 1e-12 {
        return Err(format!(
            "{at}: the matrix is singular: it flattens the volume"
        ));
    }
    let (scale, rotate, translate) = m.to_scale_rotation_translation();
    let again = DMat4::from_scale_rotation_translation(scale, rotate, translate);
    let size = m
        .to_cols_array()
        .iter()
        .fold(1.0_f64, |a, v| a.max(v.abs()));
    let off = (again - m)
        .to_cols_array()
        .iter()
        .fold(0.0_f64, |a, v| a.max(v.abs()));
    if !(off <= 1e-9 * size) {
        return Err(format!(
            "{at}: the matrix shears the volume; keys are interpolated as scale, rotation and translation, which cannot hold a shear"
        ));
    }
    Ok((translate, rotate, scale))
}

impl PlacementKeys {
    /// The keys of table `v` (named `name`), `None` without any; one line saying what is
    /// wrong with them otherwise.
    pub fn of_table(v: &VolumeTable, name: &str) -> Result<Option<PlacementKeys>, String> {
        if v.keys.is_empty() {
            return Ok(None);
        }
        let at = format!("[[volume]] \"{name}\"");
        let key = |k: &VolumeKey| -> Result<PlacementKey, String> {
            let frame = k.frame;
            let key_at = format!("{at}: [[volume.keys]] at frame {frame}");
            let moved = k.translate.is_some() || k.rotate.is_some() || k.scale.is_some();
            let rows = match (k.matrix, v.matrix) {
                (Some(_), _) if moved => {
                    return Err(format!(
                        "{key_at}: `matrix` replaces translate/rotate/scale; give one or the other"
                    ));
                }
                (Some(rows), _) => Some(rows),
                (None, Some(_)) if moved => {
                    return Err(format!(
                        "{key_at}: a volume placed by `matrix` is keyed by `matrix`, not translate/rotate/scale"
                    ));
                }
                (None, table) => table,
            };
            if !frame.is_finite() {
                return Err(format!("{key_at}: a value is not a finite number"));
            }
            if let Some(rows) = rows {
                let (translate, rotate, scale) =
                    decomposed(matrix_from_rows(rows, &key_at)?, &key_at)?;
                return Ok(PlacementKey {
                    frame,
                    translate,
                    rotate,
                    scale,
                });
            }
            let translate = DVec3::from_array(k.translate.or(v.translate).unwrap_or([0.0; 3]));
            let degrees = k.rotate.or(v.rotate).unwrap_or([0.0; 3]);
            let scale = scale_of(k.scale.or(v.scale));
            let finite =
                translate.is_finite() && degrees.iter().all(|d| d.is_finite()) && scale.is_finite();
            if !finite {
                return Err(format!("{key_at}: a value is not a finite number"));
            }
            if scale.abs().min_element() < 1e-9 {
                return Err(format!("{key_at}: a scale of 0 flattens the volume"));
            }
            Ok(PlacementKey {
                frame,
                translate,
                rotate: rotation(degrees),
                scale,
            })
        };
        let mut keys: Vec<PlacementKey> = Vec::with_capacity(v.keys.len());
        for k in &v.keys {
            let next = key(k)?;
            if let Some(prev) = keys.last() {
                if !(next.frame > prev.frame) {
                    return Err(format!(
                        "{at}: [[volume.keys]] frame {} does not follow frame {} (keys in increasing frame order)",
                        next.frame, prev.frame
                    ));
                }
                let flips = (next.scale * prev.scale).min_element() < 0.0;
                if flips {
                    return Err(format!(
                        "{at}: [[volume.keys]] the scale changes sign between frames {} and {}: it would flatten the volume in between",
                        prev.frame, next.frame
                    ));
                }
            }
            keys.push(next);
        }
        if keys.len() == 1 {
            // One key: the placement at every frame.
            keys.push(PlacementKey {
                frame: keys[0].frame + 1.0,
                ..keys[0]
            });
        }
        Ok(Some(PlacementKeys { keys }))
    }

    /// The first keyed frame.
    pub fn first_frame(&self) -> f64 {
        self.keys[0].frame
    }

    /// The placement at `frame`.
    pub fn at(&self, frame: f64) -> DMat4 {
        self.key_at(frame).matrix()
    }

    fn key_at(&self, frame: f64) -> PlacementKey {
        let (first, last) = (self.keys[0], self.keys[self.keys.len() - 1]);
        if !(frame > first.frame) {
            return first;
        }
        if frame >= last.frame {
            return last;
        }
        let i = self.keys.partition_point(|k| k.frame <= frame);
        let (a, b) = (self.keys[i - 1], self.keys[i]);
        let u = (frame - a.frame) / (b.frame - a.frame);
        PlacementKey {
            frame,
            translate: a.translate.lerp(b.translate, u),
            rotate: a.rotate.slerp(b.rotate, u),
            scale: a.scale.lerp(b.scale, u),
        }
    }

    /// Whether the placement changes between frames `a` and `b`.
    pub fn moves_between(&self, a: f64, b: f64) -> bool {
        let (ka, kb) = (self.key_at(a), self.key_at(b));
        let inner = self.keys.iter().filter(|k| k.frame > a && k.frame < b);
        inner
            .chain([&kb])
            .any(|k| (k.translate, k.rotate, k.scale) != (ka.translate, ka.rotate, ka.scale))
    }

    /// The frames between `a` and `b` at which the motion's extremes may lie: the ends,
    /// every key between them and `n` evenly spaced frames between each two of those.
    pub fn sample_frames(&self, a: f64, b: f64, n: usize) -> Vec<f64> {
        let mut knots = vec![a];
        knots.extend(
            self.keys
                .iter()
                .map(|k| k.frame)
                .filter(|f| *f > a && *f < b),
        );
        knots.push(b);
        let mut out = Vec::with_capacity(knots.len() * (n + 1));
        for w in knots.windows(2) {
            for j in 0..n {
                out.push(w[0] + (w[1] - w[0]) * j as f64 / n as f64);
            }
        }
        out.push(b);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> VolumeTable {
        toml::from_str(text).unwrap()
    }

    #[test]
    fn keys_translate_linearly_turn_along_the_arc_and_hold_outside() {
        let t = table(
            "file = \"a.vdb\"\nscale = 2\n[[keys]]\nframe = 1\ntranslate = [0, 0, 0]\n[[keys]]\nframe = 3\ntranslate = [4, 0, 0]\nrotate = [0, 90, 0]\n",
        );
        let k = PlacementKeys::of_table(&t, "v").unwrap().unwrap();
        let p = |f: f64| k.at(f).transform_point3(DVec3::X);
        // Frame 2: halfway, translate 2, turned 45° about y, scaled by the table's 2.
        let h = std::f64::consts::FRAC_1_SQRT_2 * 2.0;
        assert!(
            (p(2.0) - DVec3::new(2.0 + h, 0.0, -h)).length() < 1e-12,
            "{}",
            p(2.0)
        );
        assert_eq!(p(0.0), DVec3::new(2.0, 0.0, 0.0));
        assert!((p(9.0) - DVec3::new(4.0, 0.0, -2.0)).length() < 1e-12);
        assert!(k.moves_between(1.5, 1.6) && !k.moves_between(3.0, 5.0));
        assert_eq!(k.sample_frames(0.0, 2.0, 2), vec![0.0, 0.5, 1.0, 1.5, 2.0]);
    }

    /// Keys given as matrices move the volume as the same keys given as translate,
    /// rotate and scale: each matrix is taken apart into those, a mirrored one included.
    #[test]
    fn matrix_keys_move_as_their_translate_rotate_and_scale() {
        let rows = |t: [f64; 3], degrees: [f64; 3], s: [f64; 3]| {
            let m = DMat4::from_scale_rotation_translation(
                DVec3::from_array(s),
                rotation(degrees),
                DVec3::from_array(t),
            );
            format!("{:?}", m.transpose().to_cols_array_2d())
        };
        for s in [[2.0, 2.0, 2.0], [-1.0, 3.0, 0.5]] {
            let (t0, r0, t1, r1) = (
                [0.0, 1.0, 0.0],
                [10.0, 0.0, 0.0],
                [4.0, 0.0, 2.0],
                [0.0, 90.0, 30.0],
            );
            let by_matrix = table(&format!(
                "file = \"a\"\nmatrix = {}\n[[keys]]\nframe = 1\n[[keys]]\nframe = 3\nmatrix = {}\n",
                rows(t0, r0, s),
                rows(t1, r1, s)
            ));
            let by_parts = table(&format!(
                "file = \"a\"\nscale = {s:?}\n[[keys]]\nframe = 1\ntranslate = {t0:?}\nrotate = {r0:?}\n[[keys]]\nframe = 3\ntranslate = {t1:?}\nrotate = {r1:?}\n"
            ));
            let a = PlacementKeys::of_table(&by_matrix, "v").unwrap().unwrap();
            let b = PlacementKeys::of_table(&by_parts, "v").unwrap().unwrap();
            for f in [0.0, 1.0, 1.5, 2.0, 2.75, 3.0, 9.0] {
                for p in [DVec3::X, DVec3::new(0.3, -2.0, 1.0)] {
                    let (pa, pb) = (a.at(f).transform_point3(p), b.at(f).transform_point3(p));
                    assert!(
                        (pa - pb).length() < 1e-9,
                        "scale {s:?} frame {f}: {pa} != {pb}"
                    );
                }
            }
        }
    }

    #[test]
    fn bad_keys_are_refused_saying_why() {
        let e = |text: &str| PlacementKeys::of_table(&table(text), "v").unwrap_err();
        assert!(
            e("file = \"a\"\n[[keys]]\nframe = 2\n[[keys]]\nframe = 1\n")
                .contains("does not follow")
        );
        assert!(
            e("file = \"a\"\n[[keys]]\nframe = 2\n[[keys]]\nframe = 2\n")
                .contains("does not follow")
        );
        assert!(e("file = \"a\"\n[[keys]]\nframe = nan\n").contains("not a finite"));
        assert!(
            e("file = \"a\"\n[[keys]]\nframe = 1\ntranslate = [inf, 0, 0]\n")
                .contains("not a finite")
        );
        assert!(e("file = \"a\"\n[[keys]]\nframe = 1\nscale = 0\n").contains("flattens"));
        assert!(
            e("file = \"a\"\n[[keys]]\nframe = 1\nscale = 1\n[[keys]]\nframe = 2\nscale = -1\n")
                .contains("changes sign")
        );
        let m = "matrix = [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]";
        assert!(
            e(&format!(
                "file = \"a\"\n{m}\n[[keys]]\nframe = 1\ntranslate = [1, 0, 0]\n"
            ))
            .contains("keyed by `matrix`")
        );
        assert!(
            e(&format!(
                "file = \"a\"\n[[keys]]\nframe = 1\nscale = 2\n{m}\n"
            ))
            .contains("replaces translate/rotate/scale")
        );
        let shear = "matrix = [[1,0.5,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]";
        assert!(e(&format!("file = \"a\"\n[[keys]]\nframe = 1\n{shear}\n")).contains("shears"));
        let flat = "matrix = [[1,0,0,0],[0,0,0,0],[0,0,1,0],[0,0,0,1]]";
        assert!(e(&format!("file = \"a\"\n[[keys]]\nframe = 1\n{flat}\n")).contains("singular"));
        let row = "matrix = [[1,0,0,0],[0,1,0,0],[0,0,1,0],[1,0,0,1]]";
        assert!(e(&format!("file = \"a\"\n[[keys]]\nframe = 1\n{row}\n")).contains("last row"));
        assert!(
            toml::from_str::<VolumeTable>("file = \"a\"\n[[keys]]\nframe = 1\nshear = 2\n")
                .is_err()
        );
    }
}
