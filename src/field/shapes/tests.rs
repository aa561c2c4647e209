//! Unit tests of `shapes.rs`, compiled only under #[cfg(test)].

use super::*;
use crate::field::test_support::assert_cell_holds;
use glam::Vec3;

use crate::field::random::SplitMix64 as Rng;

fn test_box() -> ConstantBox {
    ConstantBox::new(
        DVec3::new(-0.5, -0.25, 0.1),
        DVec3::new(0.75, 0.5, 0.9),
        2.5,
        1.0 / 32.0,
    )
    .unwrap()
}

fn test_sphere() -> ConstantSphere {
    ConstantSphere::new(DVec3::new(0.2, -0.1, 0.3), 0.7, 3.0, 1.0 / 40.0).unwrap()
}

#[test]
fn cells_align_towards_negative_infinity() {
    let s = test_sphere();
    let c = s.cell_at(IVec3::new(-1, -8, -9));
    // Away from the sphere the cell may be coarser, but always aligned and containing.
    assert_eq!(c.origin % c.size, IVec3::ZERO);
    let leaf = aligned_cell(IVec3::new(-1, -8, -9), 8).0;
    assert_eq!(leaf, IVec3::new(-8, -8, -16));
    assert_eq!(aligned_cell(IVec3::new(7, 8, 15), 8).0, IVec3::new(0, 8, 8));
    assert_eq!(
        aligned_cell(IVec3::new(-4097, 4095, 0), 4096).0,
        IVec3::new(-8192, 0, 0)
    );
    // Extreme indices neither overflow nor panic.
    let c = s.cell_at(IVec3::new(i32::MAX, i32::MIN, 0));
    assert!(c.range.is_zero());
}

#[test]
fn box_indicator_is_exact() {
    let b = test_box();
    let w = |x: f64, y: f64, z: f64| b.value_at_world(DVec3::new(x, y, z));
    assert_eq!(w(0.0, 0.0, 0.5), 2.5);
    assert_eq!(w(-0.5, -0.25, 0.1), 2.5); // corner: closed
    assert_eq!(w(0.75, 0.5, 0.9), 2.5);
    assert_eq!(w(-0.51, 0.0, 0.5), 0.0);
    assert_eq!(w(0.0, 0.0, 0.95), 0.0);
    // Hard edge in index space: just inside / just outside a face.
    let face = (0.75f64 * 32.0) as f32; // index x of the +x face = 24
    assert_eq!(b.value_at_index(Vec3::new(face, 0.0, 10.0).as_dvec3()), 2.5);
    assert_eq!(
        b.value_at_index(Vec3::new(face.next_up(), 0.0, 10.0).as_dvec3()),
        0.0
    );
    assert_eq!(
        b.value_at_index(Vec3::new(f32::NAN, 0.0, 10.0).as_dvec3()),
        0.0
    );
}

#[test]
fn sphere_indicator_is_exact() {
    let s = test_sphere();
    assert_eq!(s.value_at_world(s.center()), 3.0);
    assert_eq!(
        s.value_at_world(s.center() + DVec3::new(0.0, 0.69, 0.0)),
        3.0
    );
    assert_eq!(
        s.value_at_world(s.center() + DVec3::new(0.0, 0.71, 0.0)),
        0.0
    );
    assert_eq!(s.value_at_world(s.center() + DVec3::splat(0.5)), 0.0); // |.| = 0.866
}

/// Checks cell classification and range_over against point samples.
fn check_conservative(f: &dyn Field, lo: f64, hi: f64, density: f32, seed: u64) {
    let mut rng = Rng(seed);
    let (mut n_inside, mut n_outside, mut n_edge) = (0, 0, 0);
    for _ in 0..100_000 {
        let p = rng.vec(lo, hi).as_vec3();
        let (cell, v) = assert_cell_holds(f, p);
        match (cell.range.min, cell.range.max) {
            (a, b) if a == density && b == density => n_inside += 1,
            (0.0, 0.0) => n_outside += 1,
            _ => n_edge += 1,
        }
        if v != 0.0 {
            assert!(f.active_bounds().contains(p), "{p} outside active bounds");
        }
        // Random boxes around p.
        let ext = Vec3::new(
            rng.uniform(0.0, 12.0) as f32,
            rng.uniform(0.0, 3.0) as f32,
            5.0,
        );
        let r = f.range_over(&IndexBox::new(p - ext * 0.3, p + ext * 0.7));
        assert!(r.min <= v && v <= r.max, "{p}: {v} outside {r:?}");
    }
    assert!(
        n_inside > 1000 && n_outside > 1000 && n_edge > 1000,
        "{n_inside} {n_outside} {n_edge}"
    );
}

#[test]
fn box_cells_are_conservative() {
    let b = test_box();
    check_conservative(&b, -40.0, 45.0, 2.5, 1);
    // A leaf strictly inside is constant, one far away is a coarse zero cell.
    let c = b.cell_at(IVec3::new(2, 2, 12));
    assert_eq!(
        (c.origin, c.size, c.range),
        (IVec3::new(0, 0, 8), 8, ValueRange::point(2.5))
    );
    let c = b.cell_at(IVec3::new(5000, 0, 0));
    assert_eq!((c.size, c.range), (4096, ValueRange::ZERO));
    let c = b.cell_at(IVec3::new(200, 0, 0));
    assert_eq!((c.size, c.range), (128, ValueRange::ZERO));
    // A leaf touching the face x = 24 exactly: [16, 24] is inside, [24, 32] straddles.
    assert_eq!(
        b.cell_at(IVec3::new(17, 0, 8)).range,
        ValueRange::point(2.5)
    );
    assert_eq!(
        b.cell_at(IVec3::new(25, 0, 8)).range,
        ValueRange { min: 0.0, max: 2.5 }
    );
    assert_eq!(b.range_over(&IndexBox::EMPTY), ValueRange::ZERO);
}

#[test]
fn sphere_cells_are_conservative() {
    let s = test_sphere();
    check_conservative(&s, -40.0, 45.0, 3.0, 2);
    // Negative density: the straddling range is [ρ, 0].
    let neg = ConstantSphere::new(DVec3::ZERO, 1.0, -1.5, 0.05).unwrap();
    check_conservative(&neg, -30.0, 30.0, -1.5, 3);
}

#[test]
fn bounds_match_the_shape() {
    let b = test_box();
    let (lo, hi) = b.world_bounds();
    assert!((lo - DVec3::new(-0.5, -0.25, 0.1)).abs().max_element() < 1e-6);
    assert!((hi - DVec3::new(0.75, 0.5, 0.9)).abs().max_element() < 1e-6);
    let s = test_sphere();
    let (lo, hi) = s.world_bounds();
    assert!((lo - (s.center() - DVec3::splat(0.7))).abs().max_element() < 1e-6);
    assert!((hi - (s.center() + DVec3::splat(0.7))).abs().max_element() < 1e-6);
    assert!(ConstantBox::new(DVec3::ZERO, DVec3::ONE, 1.0, 0.0).is_none());
    assert!(ConstantBox::new(DVec3::ZERO, DVec3::NAN, 1.0, 0.1).is_none());
    assert!(ConstantSphere::new(DVec3::ZERO, -1.0, 1.0, 0.1).is_none());
    assert!(ConstantSphere::new(DVec3::ZERO, 1.0, f32::INFINITY, 0.1).is_none());
}

/// Chord by brute force: midpoint rule on the indicator along the segment.
fn numeric_chord(f: &dyn Field, o: DVec3, d: DVec3, t0: f64, t1: f64, density: f32) -> f64 {
    let n = 200_000;
    let dt = (t1 - t0) / n as f64;
    let hits = (0..n)
        .filter(|i| f.value_at_world(o + d * (t0 + (*i as f64 + 0.5) * dt)) == density)
        .count();
    hits as f64 * dt * d.length()
}

#[test]
fn chords_have_closed_forms() {
    let s = test_sphere();
    let c = s.center();
    // Through the centre: the diameter.
    let l = s.chord_length(c - DVec3::X * 5.0, DVec3::X, 0.0, 100.0);
    assert!((l - 1.4).abs() < 1e-12, "{l}");
    // Offset by h: 2√(r² − h²), with an unnormalised direction.
    let h = 0.3;
    let l = s.chord_length(c + DVec3::new(-5.0, h, 0.0), DVec3::X * 2.0, 0.0, 100.0);
    assert!((l - 2.0 * (0.49f64 - h * h).sqrt()).abs() < 1e-12, "{l}");
    // Starting inside at the centre: r.
    let l = s.chord_length(c, DVec3::new(1.0, 2.0, -1.0), 0.0, f64::INFINITY);
    assert!((l - 0.7).abs() < 1e-12, "{l}");
    // Missing and tangent rays.
    assert_eq!(
        s.chord_length(c + DVec3::new(-5.0, 0.71, 0.0), DVec3::X, 0.0, 100.0),
        0.0
    );
    // Far-away origin: no cancellation.
    let l = s.chord_length(c - DVec3::X * 1e8, DVec3::X, 0.0, 2e8);
    assert!((l - 1.4).abs() < 1e-7, "{l}");

    let b = test_box();
    let l = b.chord_length(DVec3::new(-3.0, 0.0, 0.5), DVec3::X, 0.0, 10.0);
    assert!((l - 1.25).abs() < 1e-12, "{l}");
    let l = b.chord_length(DVec3::new(-3.0, 0.0, 0.5), DVec3::X, 0.0, 3.0);
    assert!((l - 0.5).abs() < 1e-12, "{l}");
    // Diagonal, against the brute-force march.
    let (o, d) = (DVec3::new(-1.0, -1.0, -0.4), DVec3::new(1.0, 0.9, 0.8));
    for (f, dens, l) in [
        (&b as &dyn Field, 2.5, b.chord_length(o, d, 0.0, 3.0)),
        (&s as &dyn Field, 3.0, s.chord_length(o, d, 0.0, 3.0)),
    ] {
        let n = numeric_chord(f, o, d, 0.0, 3.0, dens);
        assert!(l > 0.3 && (l - n).abs() < 1e-4, "{l} vs {n}");
    }
    // Axis-parallel ray along a face (closed boundary) and a zero direction.
    let l = b.chord_length(DVec3::new(-3.0, 0.5, 0.5), DVec3::X, 0.0, 10.0);
    assert!((l - 1.25).abs() < 1e-12);
    assert_eq!(s.chord_length(c, DVec3::ZERO, 0.0, 1.0), 0.0);
}
