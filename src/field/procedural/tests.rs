//! Unit tests of `procedural.rs`, compiled only under #[cfg(test)].

use super::*;
use crate::field::test_support::assert_cell_holds;
use glam::Vec3;

fn cloud(seed: Option<u64>) -> NoiseCloud {
    NoiseCloud::new(NoiseCloudParams {
        center: [0.3, -0.2, 0.1],
        radius: 0.8,
        frequency: 3.0,
        octaves: 4,
        lacunarity: 2.1,
        gain: 0.6,
        bias: 0.35,
        scale: 4.0,
        falloff_start: 0.6,
        seed,
        voxel_size: 1.0 / 40.0,
    })
    .unwrap()
}

#[test]
#[allow(clippy::approx_constant)] // 3.14 is the reference test point, not π
fn reference_permutation_and_value() {
    let t = PermutationTable::perlin();
    let mut sorted = t.permutation().to_vec();
    sorted.sort_unstable();
    assert!(sorted.iter().enumerate().all(|(i, v)| i == *v as usize));
    // Ken Perlin's Java reference implementation.
    let v = t.noise(DVec3::new(3.14, 42.0, 7.0));
    assert!((v - 0.136_919_958_784_000_12).abs() < 1e-15, "{v}");
    let v = t.noise(DVec3::new(-4.2, 10.0, 6.0));
    assert!((v - 0.142_080_000_000_000_43).abs() < 1e-15, "{v}");
}

#[test]
fn seeded_tables_are_deterministic_permutations() {
    let a = PermutationTable::seeded(42);
    assert_eq!(a, PermutationTable::seeded(42));
    assert_ne!(a, PermutationTable::seeded(43));
    assert_ne!(a, PermutationTable::perlin());
    let mut sorted = a.permutation().to_vec();
    sorted.sort_unstable();
    assert!(sorted.iter().enumerate().all(|(i, v)| i == *v as usize));
    // Same seed, same cloud, bit for bit; different seed, different values.
    let (c1, c2, c3) = (cloud(Some(7)), cloud(Some(7)), cloud(Some(8)));
    let mut rng = SplitMix64(5);
    let mut differ = 0;
    for _ in 0..1000 {
        let p = rng.vec(-20.0, 30.0).as_vec3();
        assert_eq!(
            c1.value_at_index(p.as_dvec3()).to_bits(),
            c2.value_at_index(p.as_dvec3()).to_bits()
        );
        differ += (c1.value_at_index(p.as_dvec3()) != c3.value_at_index(p.as_dvec3())) as u32;
    }
    assert!(differ > 100, "{differ}");
}

#[test]
fn noise_is_zero_on_the_lattice() {
    for t in [PermutationTable::perlin(), PermutationTable::seeded(3)] {
        for x in -5..5 {
            for y in [-300, -1, 0, 2, 255, 256, 1000] {
                for z in [-7, 0, 9] {
                    assert_eq!(t.noise(DVec3::new(x as f64, y as f64, z as f64)), 0.0);
                }
            }
        }
        assert_eq!(t.noise(DVec3::new(f64::NAN, 0.5, 0.5)), 0.0);
        assert!(t.noise(DVec3::new(1e300, -1e300, 0.5)).is_finite());
    }
}

#[test]
fn noise_is_continuous_and_bounded() {
    let t = PermutationTable::perlin();
    let mut rng = SplitMix64(11);
    let mut max_abs: f64 = 0.0;
    for _ in 0..200_000 {
        let p = rng.vec(-50.0, 50.0);
        let n = t.noise(p);
        max_abs = max_abs.max(n.abs());
        // Lipschitz: the gradient of improved noise is bounded by a small constant.
        let dp = rng.vec(-1e-6, 1e-6);
        let n2 = t.noise(p + dp);
        assert!(
            (n2 - n).abs() <= 10.0 * dp.length() + 1e-15,
            "{p}: {n} {n2}"
        );
    }
    // Crossing lattice planes is continuous too.
    for k in -3..3 {
        let x = k as f64;
        let a = t.noise(DVec3::new(x - 1e-12, 0.3, 0.7));
        let b = t.noise(DVec3::new(x + 1e-12, 0.3, 0.7));
        assert!((a - b).abs() < 1e-10, "{a} {b}");
    }
    assert!(max_abs < 1.0364 && max_abs > 0.5, "{max_abs}");
}

#[test]
fn noise_bound_majorant_is_below_bound() {
    // B(p) = Σ_c w_c(p) · (sum of two largest |p − c| components) bounds |noise|
    // for any gradient table (see NOISE_BOUND). Maximise it on a grid of the
    // fundamental domain [0, ½]³, then refine by pattern search.
    let b = |p: DVec3| -> f64 {
        let mut s = 0.0;
        for c in 0..8 {
            let corner = DVec3::new((c & 1) as f64, ((c >> 1) & 1) as f64, ((c >> 2) & 1) as f64);
            let wt = |t: f64, ci: f64| if ci == 1.0 { fade(t) } else { 1.0 - fade(t) };
            let w = wt(p.x, corner.x) * wt(p.y, corner.y) * wt(p.z, corner.z);
            let d = (p - corner).abs();
            let two_largest = d.x + d.y + d.z - d.min_element();
            s += w * two_largest;
        }
        s
    };
    let n = 50;
    let mut best = (0.0, DVec3::ZERO);
    for i in 0..=n {
        for j in 0..=n {
            for k in 0..=n {
                let p = DVec3::new(i as f64, j as f64, k as f64) * (0.5 / n as f64);
                let v = b(p);
                if v > best.0 {
                    best = (v, p);
                }
            }
        }
    }
    let mut h = 0.5 / n as f64;
    while h > 1e-9 {
        let mut improved = false;
        for d in 0..27 {
            let off = DVec3::new(
                (d % 3) as f64 - 1.0,
                ((d / 3) % 3) as f64 - 1.0,
                (d / 9) as f64 - 1.0,
            );
            let p = (best.1 + off * h).clamp(DVec3::ZERO, DVec3::ONE);
            let v = b(p);
            if v > best.0 {
                best = (v, p);
                improved = true;
            }
        }
        if !improved {
            h *= 0.5;
        }
    }
    assert!(best.0 > 1.036 && best.0 < 1.0364, "{best:?}");
    assert!(best.0 < NOISE_BOUND);
    // Sanity: B really bounds the noise pointwise.
    let t = PermutationTable::perlin();
    let mut rng = SplitMix64(2);
    for _ in 0..10_000 {
        let p = rng.vec(-9.0, 9.0);
        let f = p - p.floor();
        assert!(t.noise(p).abs() <= b(f) + 1e-12);
    }
}

#[test]
fn zero_outside_the_sphere() {
    let c = cloud(None);
    let center = DVec3::new(0.3, -0.2, 0.1);
    let mut rng = SplitMix64(3);
    let mut nonzero_inside = 0;
    for _ in 0..20_000 {
        let p = center + rng.vec(-1.2, 1.2);
        let v = c.value_at_world(p);
        assert!(v >= 0.0 && v.is_finite());
        if (p - center).length() >= 0.8 + 1e-6 {
            assert_eq!(v, 0.0, "{p}");
        } else if v > 0.0 {
            nonzero_inside += 1;
            let pi = c.transform().world_to_index(p);
            assert!(c.active_bounds().contains(pi.as_vec3()));
        }
    }
    assert!(nonzero_inside > 1000, "{nonzero_inside}");
    // The formula, at a world point well inside the falloff-free core.
    let p = center + DVec3::new(0.1, 0.05, -0.2);
    let want = 4.0 * (c.fbm_at_world(p) + 0.35).max(0.0);
    let pi = c.transform().world_to_index(p);
    assert!((c.density_at_index_f64(pi) - want).abs() < 1e-12);
}

#[test]
fn cell_ranges_are_never_exceeded() {
    for (seed, bias, scale) in [
        (None, 0.35, 4.0),
        (Some(99), 2.5, 1.0),
        (Some(5), -0.2, -2.0),
    ] {
        let c = NoiseCloud::new(NoiseCloudParams {
            bias,
            scale,
            seed,
            ..cloud(None).params().clone()
        })
        .unwrap();
        let mut rng = SplitMix64(1234);
        let mut max_seen: f32 = 0.0;
        let mut zero_cells = 0;
        for _ in 0..100_000 {
            // Index space: the ball is centred at (12, −8, 4), radius 32 voxels.
            let p = rng.vec(-45.0, 55.0).as_vec3();
            let (cell, v) = assert_cell_holds(&c, p);
            zero_cells += cell.range.is_zero() as u32;
            let r = c.range_over(&IndexBox::new(
                p - Vec3::splat(0.5),
                p + Vec3::new(3.0, 0.25, 9.0),
            ));
            assert!(r.min <= v && v <= r.max, "{p}: {v} outside {r:?}");
            max_seen = max_seen.max(v.abs());
        }
        assert!(
            zero_cells > 10_000 && max_seen > 0.0,
            "{zero_cells} {max_seen}"
        );
        // A large bias makes the cloud solid in its core: the minorant is positive there.
        if bias > c.fbm_bound() {
            let core = c.cell_at(IVec3::new(8, -8, 0));
            assert!(core.range.min > 0.0, "{core:?}");
        }
    }
}

#[test]
fn cells_outside_the_ball_are_zero_and_coarse() {
    let c = cloud(None);
    let far = c.cell_at(IVec3::new(-5000, 0, 0));
    assert_eq!((far.size, far.range), (4096, ValueRange::ZERO));
    let near = c.cell_at(IVec3::new(12, -8, 4));
    assert_eq!(near.size, 8);
    assert!(near.range.max > 0.0 && near.range.min == 0.0);
    // Upper bound: scale · (bias + F) at full falloff.
    let want = 4.0 * (0.35 + c.fbm_bound());
    assert!((near.range.max as f64 - want).abs() < 1e-5 * want);
    let expected_f = NOISE_BOUND * (1.0 + 0.6 + 0.36 + 0.216);
    assert!((c.fbm_bound() - expected_f).abs() < 1e-12);
    assert_eq!(c.range_over(&IndexBox::EMPTY), ValueRange::ZERO);
}

#[test]
fn invalid_parameters_are_rejected() {
    let base = NoiseCloudParams::default();
    assert!(NoiseCloud::new(base.clone()).is_some());
    assert!(
        NoiseCloud::new(NoiseCloudParams {
            radius: 0.0,
            ..base.clone()
        })
        .is_none()
    );
    assert!(
        NoiseCloud::new(NoiseCloudParams {
            voxel_size: -1.0,
            ..base.clone()
        })
        .is_none()
    );
    assert!(
        NoiseCloud::new(NoiseCloudParams {
            gain: f64::NAN,
            ..base.clone()
        })
        .is_none()
    );
    assert!(
        NoiseCloud::new(NoiseCloudParams {
            frequency: -1.0,
            ..base.clone()
        })
        .is_none()
    );
    // Hard edge and zero octaves are fine.
    let hard = NoiseCloud::new(NoiseCloudParams {
        falloff_start: 3.0,
        octaves: 0,
        bias: 0.5,
        ..base
    })
    .unwrap();
    assert_eq!(hard.value_at_world(DVec3::new(0.99, 0.0, 0.0)), 0.5);
    assert_eq!(hard.value_at_world(DVec3::new(1.01, 0.0, 0.0)), 0.0);
}
