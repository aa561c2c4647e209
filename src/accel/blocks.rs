//! The non-empty blocks of a field: aligned cubes of local index space where the trilinear
//! reconstruction is not zero everywhere, found coarse to fine so empty space costs one
//! range query per empty region.

use crate::field::{Field, IndexBox};
use glam::{IVec3, Vec3};

/// Calls `visit` with every aligned cube of edge `size` (a power of two, in voxels; as an
/// [`IndexBox`] of points, both faces included) over which `field` is not zero. Returns
/// `false`, having stopped, once `limit` cubes were visited.
pub fn nonzero_blocks(
    field: &dyn Field,
    size: i32,
    limit: usize,
    visit: &mut dyn FnMut(IndexBox),
) -> bool {
    let b = field.active_bounds();
    if b.is_empty() {
        return true;
    }
    let size = size.max(1);
    // Whole blocks covering the bounds, the trilinear stencil included.
    let lo = (b.min.floor().as_ivec3() - IVec3::ONE).div_euclid(IVec3::splat(size));
    let hi = (b.max.floor().as_ivec3() + IVec3::ONE).div_euclid(IVec3::splat(size));
    let mut count = 0usize;
    // Start from the coarsest power-of-two multiple that keeps the root count small.
    let mut top = size as i64;
    while ((hi - lo + IVec3::ONE).as_i64vec3() * size as i64 / top).max_element() > 4
        && top < (1 << 30)
    {
        top *= 2;
    }
    let top = top as i32;
    let origin_lo = (lo * size).div_euclid(IVec3::splat(top)) * top;
    let origin_hi = (hi * size).div_euclid(IVec3::splat(top)) * top;
    let mut stack = Vec::new();
    let mut z = origin_lo.z;
    while z <= origin_hi.z {
        let mut y = origin_lo.y;
        while y <= origin_hi.y {
            let mut x = origin_lo.x;
            while x <= origin_hi.x {
                stack.push((IVec3::new(x, y, z), top));
                x += top;
            }
            y += top;
        }
        z += top;
    }
    while let Some((o, s)) = stack.pop() {
        let cube = IndexBox::new(o.as_vec3(), (o + IVec3::splat(s)).as_vec3());
        let clipped = IndexBox::new(
            cube.min.max(b.min - Vec3::ONE),
            cube.max.min(b.max + Vec3::ONE),
        );
        if clipped.is_empty() || field.range_over(&cube).is_zero() {
            continue;
        }
        if s <= size {
            count += 1;
            if count > limit {
                return false;
            }
            visit(cube);
        } else {
            let h = s / 2;
            for c in 0..8 {
                let d = IVec3::new(c & 1, (c >> 1) & 1, (c >> 2) & 1) * h;
                stack.push((o + d, h));
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::shapes::ConstantSphere;
    use glam::DVec3;

    #[test]
    fn blocks_cover_every_nonzero_point_and_nothing_far_away() {
        let s = ConstantSphere::new(DVec3::new(0.3, -0.2, 0.1), 1.0, 2.0, 0.05).unwrap();
        let mut blocks = Vec::new();
        assert!(nonzero_blocks(&s, 16, 1 << 20, &mut |b| blocks.push(b)));
        assert!(!blocks.is_empty());
        let mut rng = crate::field::random::SplitMix64(9);
        for _ in 0..5000 {
            let p = DVec3::new(0.3, -0.2, 0.1) + rng.vec(-1.0, 1.0);
            let q = s.transform().world_to_index(p);
            if s.value_at_index(q) > 0.0 {
                let qf = q.as_vec3();
                assert!(blocks.iter().any(|b| b.contains(qf)), "{p} not covered");
            }
        }
        // Every block touches the sphere (radius 20 voxels, plus one for the stencil).
        let c = s
            .transform()
            .world_to_index(DVec3::new(0.3, -0.2, 0.1))
            .as_vec3();
        for b in &blocks {
            let nearest = c.clamp(b.min, b.max);
            assert!((nearest - c).length() <= 21.5, "{b:?}");
        }
        // A limit stops the walk.
        let mut n = 0;
        assert!(!nonzero_blocks(&s, 16, 3, &mut |_| n += 1));
        assert_eq!(n, 3);
    }
}
