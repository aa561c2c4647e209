//! The affine map between a field's local index space and world space.

use super::IndexBox;
use glam::{DMat3, DMat4, DVec3, IVec3, Vec3};

/// Index → world as a full affine map, built in f64.
///
/// `world = linear · (local + origin) + translation`, where `local` is the local index
/// point the samplers use and `origin` an integer shift (usually the centre of the
/// grid's active voxels). The translation stored is the one for local coordinates, so
/// points far from the world origin lose no precision before the subtraction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IndexToWorld {
    /// Integer offset of local index space from the file's index space.
    pub origin: IVec3,
    linear: DMat3,
    inverse: DMat3,
    /// World position of local index (0,0,0).
    local_translation: DVec3,
}

impl IndexToWorld {
    /// From the file's index→world matrix (column-vector convention: `world = m · [ijk,1]`)
    /// and the origin of local index space. Returns `None` if the matrix is singular or
    /// not finite.
    pub fn new(m: DMat4, origin: IVec3) -> Option<Self> {
        let linear = DMat3::from_mat4(m);
        let translation = m.w_axis.truncate();
        let det = linear.determinant();
        if !det.is_finite() || det.abs() < 1e-300 || !translation.is_finite() {
            return None;
        }
        let inverse = linear.inverse();
        if !inverse.is_finite() {
            return None;
        }
        Some(IndexToWorld {
            origin,
            linear,
            inverse,
            local_translation: linear * origin.as_dvec3() + translation,
        })
    }

    /// A uniform scale `voxel_size` with the given origin of local index space.
    pub fn uniform(voxel_size: f64, origin: IVec3) -> Self {
        Self::new(DMat4::from_scale(DVec3::splat(voxel_size)), origin)
            .unwrap_or_else(Self::identity)
    }

    pub fn identity() -> Self {
        IndexToWorld {
            origin: IVec3::ZERO,
            linear: DMat3::IDENTITY,
            inverse: DMat3::IDENTITY,
            local_translation: DVec3::ZERO,
        }
    }

    /// The file's index→world matrix (global index space).
    pub fn matrix(&self) -> DMat4 {
        let t = self.local_translation - self.linear * self.origin.as_dvec3();
        DMat4::from_cols(
            self.linear.x_axis.extend(0.0),
            self.linear.y_axis.extend(0.0),
            self.linear.z_axis.extend(0.0),
            t.extend(1.0),
        )
    }

    pub fn linear(&self) -> DMat3 {
        self.linear
    }
    pub fn inverse_linear(&self) -> DMat3 {
        self.inverse
    }

    /// World position of a local index point.
    pub fn index_to_world(&self, p: DVec3) -> DVec3 {
        self.linear * p + self.local_translation
    }

    /// Local index point of a world position.
    pub fn world_to_index(&self, w: DVec3) -> DVec3 {
        self.inverse * (w - self.local_translation)
    }

    /// A world direction expressed in local index space (not normalised).
    pub fn world_dir_to_index(&self, d: DVec3) -> DVec3 {
        self.inverse * d
    }

    /// Global (file) index coordinate of a local one.
    pub fn to_global(&self, local: IVec3) -> IVec3 {
        local + self.origin
    }

    /// Length of each index axis in world units.
    pub fn voxel_size(&self) -> DVec3 {
        DVec3::new(
            self.linear.x_axis.length(),
            self.linear.y_axis.length(),
            self.linear.z_axis.length(),
        )
    }

    /// World-space axis-aligned bounds of a local-index box (its eight corners mapped).
    pub fn index_box_to_world(&self, b: &IndexBox) -> (DVec3, DVec3) {
        if b.is_empty() {
            return (DVec3::ZERO, DVec3::ZERO);
        }
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for c in 0..8 {
            let p = Vec3::new(
                if c & 1 == 0 { b.min.x } else { b.max.x },
                if c & 2 == 0 { b.min.y } else { b.max.y },
                if c & 4 == 0 { b.min.z } else { b.max.z },
            );
            let w = self.index_to_world(p.as_dvec3());
            lo = lo.min(w);
            hi = hi.max(w);
        }
        (lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn far_from_origin_round_trips_exactly() {
        // A grid 1e5 world units away, voxel 0.01: local points must round-trip to 1e-6 voxel.
        let m = DMat4::from_scale_rotation_translation(
            DVec3::new(0.01, 0.02, 0.01),
            glam::DQuat::from_rotation_y(0.3),
            DVec3::new(1e5, -2e5, 3e5),
        );
        let origin = IVec3::new(1_000_000, -1_000_000, 7);
        let t = IndexToWorld::new(m, origin).unwrap();
        let p = Vec3::new(0.25, -3.5, 7.125);
        let w = t.index_to_world(p.as_dvec3());
        let back = t.world_to_index(w);
        assert!((back.as_vec3() - p).abs().max_element() < 1e-5, "{back:?}");
        // The global matrix maps global index (local + origin) to the same point.
        let g = t
            .matrix()
            .transform_point3(p.as_dvec3() + origin.as_dvec3());
        assert!((g - w).abs().max_element() < 1e-6 * 4e5);
    }

    #[test]
    fn singular_matrix_is_rejected() {
        assert!(
            IndexToWorld::new(DMat4::from_scale(DVec3::new(1.0, 0.0, 1.0)), IVec3::ZERO).is_none()
        );
        assert!(
            IndexToWorld::new(DMat4::from_scale(DVec3::splat(f64::NAN)), IVec3::ZERO).is_none()
        );
    }
}
