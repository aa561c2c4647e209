//! Unit tests of `field::advect`.
use super::*;
use crate::field::shapes::ConstantBox;

fn unit_box() -> ConstantBox {
    ConstantBox::new(DVec3::ZERO, DVec3::ONE, 1.0, 0.05).unwrap()
}

#[test]
fn a_uniform_flow_moves_the_field_by_its_displacement() {
    let b = unit_box();
    let v = ConstantVelocity(DVec3::new(2.0, 0.0, 0.0));
    let moved = Advected::new(&b, &v, 0.25); // 0.5 world units along +x
    for x in [0.45, 0.55, 1.2, 1.45, 1.55] {
        let p = DVec3::new(x, 0.5, 0.5);
        let want = b.value_at_world(p - DVec3::new(0.5, 0.0, 0.0));
        assert_eq!(moved.value_at_world(p), want, "x {x}");
    }
}

#[test]
fn bounds_and_cells_cover_where_the_field_moves() {
    let b = unit_box();
    let v = ConstantVelocity(DVec3::new(0.0, -4.0, 0.0));
    let moved = Advected::new(&b, &v, 0.5); // 2 world units along −y
    let p = DVec3::new(0.5, -1.5, 0.5);
    assert_eq!(moved.value_at_world(p), 1.0);
    let i = moved.transform().world_to_index(p);
    assert!(moved.active_bounds().contains(i.as_vec3()));
    let cell = moved.cell_at(i.floor().as_ivec3());
    assert!(cell.range.max >= 1.0, "{cell:?}");
}

/// A shear: v = (0, x, 0), so the displacement along a ray across x is linear.
struct Shear;
impl VelocityField for Shear {
    fn velocity_at_world(&self, p: DVec3) -> DVec3 {
        DVec3::new(0.0, p.x, 0.0)
    }
    fn max_speed(&self) -> f64 {
        10.0
    }
    fn knot_spacing(&self) -> f64 {
        0.1
    }
}

#[test]
fn a_batch_of_pieces_follows_a_linearly_varying_displacement() {
    let b = unit_box();
    let moved = Advected::new(&b, &Shear, 0.3);
    let ray = IndexRay::new(&moved, DVec3::new(-0.5, 0.3, 0.5), DVec3::X);
    let ends: Vec<f64> = (1..=12).map(|k| 0.2 * k as f64).collect();
    let mut batch = vec![0.0; ends.len()];
    moved.piece_integrals(&ray, 0.0, &ends, &mut batch);
    let mut a = 0.0;
    for (&e, got) in ends.iter().zip(&batch) {
        let want = moved.integral(&ray, a, e);
        assert!((got - want).abs() < 1e-12, "[{a}, {e}]: {got} vs {want}");
        a = e;
    }
    // The ray meets the sheared box (y − 0.3·x in [0, 1] for x up to 1).
    assert!(batch.iter().sum::<f64>() > 0.5);
}

#[test]
fn no_shift_is_the_field_itself() {
    let b = unit_box();
    let v = ConstantVelocity(DVec3::new(3.0, 1.0, 0.0));
    let still = Advected::new(&b, &v, 0.0);
    assert_eq!(still.active_bounds(), b.active_bounds());
    let p = DVec3::new(0.99, 0.2, 0.7);
    assert_eq!(still.value_at_world(p), b.value_at_world(p));
}

/// Along its ray, a field looked up through a [`RayFlow`] (the displacement at knots,
/// linear between, the stored field walked along the sheared ray) integrates as the
/// advected field looked up point by point, where the flow is linear along the ray.
#[test]
fn a_ray_flow_walk_equals_the_pointwise_advection() {
    let b = unit_box();
    let origin = DVec3::new(-0.5, 0.3, 0.5);
    let flow = RayFlow::new(&Shear, 0.3, origin, DVec3::X);
    let plain = Advected::new(&b, &Shear, 0.3);
    let along = Advected::new(&b, &Shear, 0.3).along(&flow);
    let ray = IndexRay::new(&plain, origin, DVec3::X);
    let ends: Vec<f64> = (1..=40).map(|k| 0.05 * k as f64 + 0.013).collect();
    let mut got = vec![0.0; ends.len()];
    along.piece_integrals(&ray, 0.013, &ends, &mut got);
    let mut a = 0.013;
    for (&e, g) in ends.iter().zip(&got) {
        // The midpoint's displacement is exact for a displacement linear along the ray.
        let want = plain.integral(&ray, a, e);
        assert!((g - want).abs() < 1e-9, "[{a}, {e}]: {g} vs {want}");
        let p = ray.at(0.5 * (a + e));
        assert!((along.displacement(p) - plain.displacement(p)).length() < 1e-12);
        a = e;
    }
    assert!(got.iter().sum::<f64>() > 0.5);
}
