//! The lattice's phase helpers.

use super::*;

/// The mean over the sphere of `f(d)`, by a fine Fibonacci spiral.
fn sphere_mean(f: impl Fn(DVec3) -> f64) -> f64 {
    let n = 200_000;
    let dirs = fibonacci_sphere(n, 0);
    dirs.iter().map(|d| f(*d)).sum::<f64>() / n as f64
}

#[test]
fn henyey_greenstein_twice_is_henyey_greenstein_of_the_square() {
    // What `MsLattice::toward` takes for light scattered once and then into ω.
    let t = DVec3::new(0.3, -0.4, 0.866).normalize();
    for g in [0.0, 0.5, 0.8] {
        assert!(
            (sphere_mean(|d| hg(g, d.z)) - 1.0).abs() < 1e-3,
            "g {g}: not normalised"
        );
        for omega in [DVec3::Z, DVec3::X, -t, t, DVec3::new(0.6, 0.0, -0.8)] {
            let twice = sphere_mean(|d| hg(g, t.dot(d)) * hg(g, d.dot(omega)));
            let want = hg(g * g, t.dot(omega));
            assert!(
                (twice - want).abs() < 1e-2 * want.max(0.1),
                "g {g}, ω {omega}: {twice} against {want}"
            );
        }
    }
}
