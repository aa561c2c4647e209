//! The sum of placed fields: integrals, placements, refusals and shared memory.

use super::*;
use crate::field::shapes::ConstantBox;
use glam::DMat4;

fn unit_box(density: f32) -> Arc<dyn Field> {
    Arc::new(ConstantBox::new(DVec3::ZERO, DVec3::ONE, density, 0.05).unwrap())
}

#[test]
fn the_integral_is_the_members_and_placements_move_them() {
    let b = unit_box(2.0);
    let sum = FieldSum::new(vec![
        (b.clone(), DMat4::IDENTITY, 1.0),
        (
            b.clone(),
            DMat4::from_translation(DVec3::new(0.0, 0.0, 0.5)),
            3.0,
        ),
    ])
    .unwrap();
    // Along z through x = y = 0.5: [0,1] at 2 and [0.5,1.5] at 2·3.
    let ray = IndexRay::new(&sum, DVec3::new(0.5, 0.5, -1.0), DVec3::Z);
    let got = sum.integral(&ray, 0.0, 4.0);
    assert!((got - (2.0 + 6.0)).abs() < 1e-9, "{got}");
    // Values: overlap 2 + 6, first alone 2, second alone 6.
    let at = |z: f64| sum.value_at_world(DVec3::new(0.5, 0.5, z));
    assert_eq!(
        (at(0.25), at(0.75), at(1.25), at(2.0)),
        (2.0, 8.0, 6.0, 0.0)
    );
    assert_eq!(sum.distinct_fields(), 1);
    // The hierarchy: the cell holding the overlap bounds 8; far away is empty.
    let mid = sum.transform().world_to_index(DVec3::new(0.5, 0.5, 0.75));
    let c = sum.cell_at(mid.floor().as_ivec3());
    assert!(c.range.max >= 8.0, "{c:?}");
    let far = sum.transform().world_to_index(DVec3::new(50.0, 0.5, 0.75));
    assert!(sum.cell_at(far.floor().as_ivec3()).range.is_zero());
    let (lo, hi) = sum.world_bounds();
    assert!(lo.z <= 0.0 && hi.z >= 1.5 && hi.z < 1.7, "{lo} {hi}");
}

#[test]
fn a_singular_placement_and_a_negative_weight_are_refused() {
    let b = unit_box(1.0);
    let flat = DMat4::from_scale(DVec3::new(1.0, 0.0, 1.0));
    assert_eq!(
        FieldSum::new(vec![(b.clone(), flat, 1.0)]).err(),
        Some(SumError::Singular)
    );
    assert_eq!(
        FieldSum::new(vec![(b, DMat4::IDENTITY, -1.0)]).err(),
        Some(SumError::Weight(-1.0))
    );
    assert_eq!(FieldSum::new(vec![]).err(), Some(SumError::Empty));
}

#[test]
fn placing_one_field_many_times_holds_it_once() {
    let b = unit_box(1.0);
    let one = FieldSum::new(vec![(b.clone(), DMat4::IDENTITY, 1.0)]).unwrap();
    let many: Vec<_> = (0..64)
        .map(|i| {
            let t = DMat4::from_translation(DVec3::new(2.0 * i as f64, 0.0, 0.0));
            (b.clone(), t, 1.0)
        })
        .collect();
    let many = FieldSum::new(many).unwrap();
    let per = std::mem::size_of::<Member>();
    assert!(many.memory_bytes() <= one.memory_bytes() + 64 * per);
    assert_eq!(many.distinct_fields(), 1);
}
