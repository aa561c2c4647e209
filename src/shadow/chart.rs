//! Light space: the lattice a deep shadow map is stored on.
//!
//! A chart maps world points to lattice coordinates `(x, y, z)` in which every line of
//! constant `(x, y)` is a ray of the light (a *column*) and `z` grows along it, away from
//! the light, in units of the lattice spacing. Baking then marches each column once and
//! every point on it reuses the sum of the points before it.
//!
//! - A sun has one parallel chart: an orthonormal frame with `e3` the direction the light
//!   travels; `(x, y, z) = ((p − o)·e1, (p − o)·e2, (p − o)·e3) / unit`.
//! - A point light has perspective charts: `x = S·(d·e1)/(d·e3)`, `y = S·(d·e2)/(d·e3)`,
//!   `z = |d| / unit` with `d = p − light` and `S = r_max / unit`, so one lattice step
//!   across is at most one `unit` anywhere within `r_max` of the light. One chart looking
//!   at the volume when the light is well outside it, else the six faces of a cube.

use glam::DVec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ChartKind {
    /// Sun: columns are parallel, starting from the plane through `origin`.
    Parallel { origin: DVec3 },
    /// Point light: columns leave `light` radially; `scale` is S.
    Perspective { light: DVec3, scale: f64 },
}

/// How a map blends τ across the light, between its columns, along one lateral axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LateralBlend {
    /// Bicubic Hermite from τ and its stored slopes: for columns at any angle to the
    /// density's voxels, where τ is C¹ across the light.
    Hermite,
    /// Linear: along a lateral axis that is a voxel axis perpendicular to the light, with
    /// the columns through the voxel centres. The light then never crosses that axis's
    /// voxel faces, so τ is exactly linear along it between the centres and has kinks at
    /// them, which Hermite slopes would blur.
    Linear,
}

impl LateralBlend {
    /// The name a shadow cache stores it under.
    pub fn name(self) -> &'static str {
        match self {
            LateralBlend::Hermite => "hermite",
            LateralBlend::Linear => "linear",
        }
    }

    /// The blend a stored name stands for.
    pub fn from_name(name: &str) -> Option<Self> {
        [LateralBlend::Hermite, LateralBlend::Linear]
            .into_iter()
            .find(|b| b.name() == name)
    }
}

/// One light-space chart. `e3` points along the columns (away from the light).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chart {
    pub kind: ChartKind,
    /// The blend along `e1` and along `e2`.
    pub lateral: [LateralBlend; 2],
    pub e1: DVec3,
    pub e2: DVec3,
    pub e3: DVec3,
    /// World length of one lattice step.
    pub unit: f64,
}

/// A column of the lattice as a world ray: lattice depth `z` is at `t = z · unit`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Column {
    pub origin: DVec3,
    pub dir: DVec3,
}

/// An orthonormal frame whose third axis is `w` (normalised).
pub fn frame_around(w: DVec3) -> (DVec3, DVec3, DVec3) {
    let e3 = w.normalize();
    let helper = if e3.x.abs() < 0.6 { DVec3::X } else { DVec3::Y };
    let e1 = helper.cross(e3).normalize();
    let e2 = e3.cross(e1);
    (e1, e2, e3)
}

impl Chart {
    /// The chart of a sun whose light travels along `travel`, centred on `origin`.
    pub fn parallel(travel: DVec3, origin: DVec3, unit: f64) -> Chart {
        let (e1, e2, e3) = frame_around(travel);
        Chart {
            kind: ChartKind::Parallel { origin },
            lateral: [LateralBlend::Hermite; 2],
            e1,
            e2,
            e3,
            unit,
        }
    }

    /// The chart of a sun whose light is parallel to the faces of the density's voxels
    /// along one or two of their axes: those axes become lateral axes with columns
    /// through the voxel centres, one lattice step per voxel, blended linearly (along
    /// both when the light travels along a voxel axis). `None` unless the index→world map
    /// is a rotation and a uniform scale of `unit` and the light is parallel to some
    /// voxel faces.
    pub fn voxel_aligned(
        travel: DVec3,
        transform: &crate::field::IndexToWorld,
        near: DVec3,
        unit: f64,
    ) -> Option<Chart> {
        let o = transform.index_to_world(DVec3::ZERO);
        let axes = [DVec3::X, DVec3::Y, DVec3::Z].map(|a| transform.index_to_world(a) - o);
        let uniform = axes
            .iter()
            .all(|a| (a.length() - unit).abs() <= 1e-9 * unit);
        let orthogonal = (0..3).all(|i| axes[i].dot(axes[(i + 1) % 3]).abs() <= 1e-9 * unit * unit);
        if !(uniform && orthogonal) {
            return None;
        }
        let e3 = travel.normalize();
        let across: Vec<usize> = (0..3)
            .filter(|&k| (axes[k].dot(e3) / unit).abs() <= 1e-12)
            .collect();
        let (e1, lateral) = match across.as_slice() {
            [k] => (
                axes[*k] / unit,
                [LateralBlend::Linear, LateralBlend::Hermite],
            ),
            [k, _] => (axes[*k] / unit, [LateralBlend::Linear; 2]),
            _ => return None,
        };
        let e2 = e3.cross(e1);
        // A voxel centre near `near`, so lattice coordinates stay small.
        let origin = transform.index_to_world(transform.world_to_index(near).round());
        Some(Chart {
            kind: ChartKind::Parallel { origin },
            lateral,
            e1,
            e2,
            e3,
            unit,
        })
    }

    /// A perspective chart from `light` looking along `axis`, one step ≤ `unit` within `r_max`.
    pub fn perspective(light: DVec3, axis: DVec3, r_max: f64, unit: f64) -> Chart {
        let (e1, e2, e3) = frame_around(axis);
        Chart {
            lateral: [LateralBlend::Hermite; 2],
            kind: ChartKind::Perspective {
                light,
                scale: (r_max / unit).max(1.0),
            },
            e1,
            e2,
            e3,
            unit,
        }
    }

    /// The six cube-face charts around a point light (face `k` looks along ±axis k/2).
    pub fn cube_faces(light: DVec3, r_max: f64, unit: f64) -> Vec<Chart> {
        let axes = [DVec3::X, DVec3::Y, DVec3::Z];
        let mut charts = Vec::with_capacity(6);
        for a in axes {
            for s in [1.0, -1.0] {
                let e3 = a * s;
                let e1 = axes[(axes.iter().position(|&b| b == a).unwrap_or(0) + 1) % 3];
                let e2 = e3.cross(e1);
                charts.push(Chart {
                    e1,
                    e2,
                    ..Chart::perspective(light, e3, r_max, unit)
                });
            }
        }
        charts
    }

    /// Lattice coordinates of a world point; `None` behind a perspective chart's eye.
    #[inline]
    pub fn to_lattice(&self, p: DVec3) -> Option<DVec3> {
        match self.kind {
            ChartKind::Parallel { origin } => {
                let d = (p - origin) / self.unit;
                Some(DVec3::new(d.dot(self.e1), d.dot(self.e2), d.dot(self.e3)))
            }
            ChartKind::Perspective { light, scale } => {
                let d = p - light;
                let w = d.dot(self.e3);
                let r = d.length();
                if !(w > 1e-9 * r) {
                    return None;
                }
                Some(DVec3::new(
                    scale * d.dot(self.e1) / w,
                    scale * d.dot(self.e2) / w,
                    r / self.unit,
                ))
            }
        }
    }

    /// The world ray of column `(x, y)`.
    pub fn column(&self, x: f64, y: f64) -> Column {
        match self.kind {
            ChartKind::Parallel { origin } => Column {
                origin: origin + (self.e1 * x + self.e2 * y) * self.unit,
                dir: self.e3,
            },
            ChartKind::Perspective { light, scale } => Column {
                origin: light,
                dir: (self.e3 + (self.e1 * x + self.e2 * y) / scale).normalize(),
            },
        }
    }

    /// The world point at lattice coordinates `q` (the inverse of [`Chart::to_lattice`]).
    pub fn to_world(&self, q: DVec3) -> DVec3 {
        let c = self.column(q.x, q.y);
        c.origin + c.dir * (q.z * self.unit)
    }

    /// The light-facing lattice extent of a world box given by its corners: the lattice
    /// box containing every point of the box that this chart serves, or `None` when the
    /// box is out of the chart's view. For perspective charts, `lateral_limit` bounds |x|,
    /// |y| (the cube face's square); boxes that cross the eye plane take the whole limit.
    pub fn lattice_bounds(
        &self,
        corners: &[DVec3; 8],
        lateral_limit: f64,
    ) -> Option<(DVec3, DVec3)> {
        match self.kind {
            ChartKind::Parallel { .. } => {
                let mut lo = DVec3::INFINITY;
                let mut hi = DVec3::NEG_INFINITY;
                for &c in corners {
                    let q = self.to_lattice(c)?;
                    lo = lo.min(q);
                    hi = hi.max(q);
                }
                Some((lo, hi))
            }
            ChartKind::Perspective { light, scale } => {
                let ds: Vec<DVec3> = corners.iter().map(|&c| c - light).collect();
                // Separating planes of the face's frustum (|x|, |y| ≤ limit · w / S).
                let k = lateral_limit / scale;
                let outside = |f: &dyn Fn(DVec3) -> bool| ds.iter().all(|&d| f(d));
                let w = |d: DVec3| d.dot(self.e3);
                if outside(&|d| w(d) <= 0.0)
                    || outside(&|d| d.dot(self.e1) > k * w(d))
                    || outside(&|d| d.dot(self.e1) < -k * w(d))
                    || outside(&|d| d.dot(self.e2) > k * w(d))
                    || outside(&|d| d.dot(self.e2) < -k * w(d))
                {
                    return None;
                }
                // Depth: from the box's nearest point (its world AABB) to its farthest corner.
                let (bmin, bmax) = ds
                    .iter()
                    .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(a, b), &d| {
                        (a.min(d), b.max(d))
                    });
                let nearest = DVec3::ZERO.clamp(bmin, bmax).length();
                let farthest = ds.iter().map(|d| d.length()).fold(0.0, f64::max);
                let (zlo, zhi) = (nearest / self.unit, farthest / self.unit);
                let all_front = ds.iter().all(|&d| w(d) > 1e-9 * d.length());
                let (mut lo, mut hi) = (
                    DVec3::new(-lateral_limit, -lateral_limit, zlo),
                    DVec3::new(lateral_limit, lateral_limit, zhi),
                );
                if all_front {
                    // A ratio of linear functions takes its extremes at the box's corners.
                    let (mut xl, mut xh) = (f64::INFINITY, f64::NEG_INFINITY);
                    let (mut yl, mut yh) = (f64::INFINITY, f64::NEG_INFINITY);
                    for &d in &ds {
                        let (x, y) = (scale * d.dot(self.e1) / w(d), scale * d.dot(self.e2) / w(d));
                        (xl, xh, yl, yh) = (xl.min(x), xh.max(x), yl.min(y), yh.max(y));
                    }
                    lo.x = xl.max(-lateral_limit);
                    hi.x = xh.min(lateral_limit);
                    lo.y = yl.max(-lateral_limit);
                    hi.y = yh.min(lateral_limit);
                }
                (lo.x <= hi.x && lo.y <= hi.y).then_some((lo, hi))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lattice_round_trips_and_columns_follow_the_light() {
        let sun = Chart::parallel(
            DVec3::new(-0.6, -1.0, -0.5),
            DVec3::new(1.0, 2.0, 3.0),
            0.05,
        );
        let pers = Chart::perspective(
            DVec3::new(5.0, 1.0, 0.0),
            DVec3::new(-1.0, 0.1, 0.0),
            7.0,
            0.05,
        );
        for chart in [sun, pers] {
            for p in [DVec3::new(0.1, 0.2, 0.3), DVec3::new(-0.7, 0.5, 0.9)] {
                let q = chart.to_lattice(p).unwrap();
                assert!((chart.to_world(q) - p).length() < 1e-9, "{chart:?} {p}");
                // Moving along the column changes only z, by the distance / unit.
                let c = chart.column(q.x, q.y);
                let q2 = chart.to_lattice(p + c.dir * 0.5).unwrap();
                assert!((q2.x - q.x).abs() < 1e-9 && (q2.y - q.y).abs() < 1e-9);
                assert!((q2.z - q.z - 0.5 / 0.05).abs() < 1e-9);
            }
        }
        // Behind the eye there is no lattice point.
        assert!(pers.to_lattice(DVec3::new(6.0, 1.0, 0.0)).is_none());
    }

    #[test]
    fn lattice_bounds_contain_every_point_of_the_box() {
        let light = DVec3::new(0.3, 0.2, 0.1);
        let faces = Chart::cube_faces(light, 4.0, 0.1);
        let (lo, hi) = (DVec3::new(-0.5, -0.4, -0.3), DVec3::new(0.6, 0.5, 0.4));
        let corners: [DVec3; 8] = std::array::from_fn(|i| {
            DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            )
        });
        let bounds: Vec<_> = faces
            .iter()
            .map(|f| f.lattice_bounds(&corners, 40.0 * 1.02))
            .collect();
        let mut rng = crate::field::random::SplitMix64(3);
        for _ in 0..2000 {
            let p = lo + (hi - lo) * DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64());
            let d = p - light;
            let a = d.abs();
            let face = if a.x >= a.y && a.x >= a.z {
                if d.x > 0.0 { 0 } else { 1 }
            } else if a.y >= a.z {
                if d.y > 0.0 { 2 } else { 3 }
            } else if d.z > 0.0 {
                4
            } else {
                5
            };
            let q = faces[face].to_lattice(p).unwrap();
            let (blo, bhi) = bounds[face].expect("the face sees the point");
            assert!(
                q.cmpge(blo - 1e-9).all() && q.cmple(bhi + 1e-9).all(),
                "{p} {q} {blo} {bhi}"
            );
        }
    }
}
