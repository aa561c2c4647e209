//! Pixel values: the passes add up, depth agrees with alpha.

use super::*;

fn close(got: f32, want: f32, scale: f32) -> bool {
    (got - want).abs() <= HALF_REL * scale + HALF_ABS
}

/// Beauty = emission + scatter, scatter = Σ per-light scatter, 0 ≤ A ≤ 1, finite
/// non-negative colours, and Z consistent with A.
pub(super) fn check_values(e: &Exr, lights: &[&str]) {
    let what = format!("{:?}", e.names());
    for (name, (_, v)) in &e.channels {
        for (i, x) in v.iter().enumerate() {
            let (px, py) = e.xy(i);
            if name == "Z" {
                assert!(!x.is_nan(), "Z is NaN at ({px},{py})");
                assert!(
                    *x > 0.0,
                    "Z {x} at ({px},{py}) is not in front of the camera"
                );
            } else {
                assert!(x.is_finite(), "{name} = {x} at ({px},{py})");
                assert!(*x >= 0.0, "{name} = {x} < 0 at ({px},{py})");
            }
        }
    }
    let a = e.get("A");
    assert!(
        a.iter().all(|a| (0.0..=1.0).contains(a)),
        "A outside [0, 1]"
    );
    assert!(
        a.iter().any(|a| *a > 0.5),
        "nothing opaque: a poor test image"
    );
    for (k, c) in ["R", "G", "B"].iter().enumerate() {
        let beauty = e.get(c);
        let em = e.get_or_zero(&rgb("emission")[k]);
        let sc = e.get_or_zero(&rgb("scatter")[k]);
        for i in 0..beauty.len() {
            let (x, y) = e.xy(i);
            assert!(
                close(beauty[i], em[i] + sc[i], beauty[i].max(em[i] + sc[i])),
                "{c} = {} but emission.{c} + scatter.{c} = {} + {} at ({x},{y}) [{what}]",
                beauty[i],
                em[i],
                sc[i]
            );
        }
        if lights.len() > 1 {
            let per: Vec<&[f32]> = lights
                .iter()
                .map(|l| e.get(&rgb(&format!("scatter_{l}"))[k]))
                .collect();
            for i in 0..sc.len() {
                let sum: f32 = per.iter().map(|p| p[i]).sum();
                let (x, y) = e.xy(i);
                assert!(
                    close(sc[i], sum, sc[i].max(sum)),
                    "scatter.{c} = {} but the lights' layers sum to {sum} at ({x},{y})",
                    sc[i]
                );
            }
        }
    }
    check_depth(e, 1e-3);
}

/// Z is a depth where A reached 0.5 and 1e10 (`--z-empty`'s default, as Cycles writes)
/// where it did not.
fn check_depth(e: &Exr, tol: f32) {
    let (a, z) = (e.get("A"), e.get("Z"));
    let mut finite = 0;
    for i in 0..a.len() {
        let (x, y) = e.xy(i);
        if z[i] < 1e10 {
            finite += 1;
            assert!(
                a[i] >= 0.5 - tol,
                "Z = {} at ({x},{y}) but A = {} < 0.5",
                z[i],
                a[i]
            );
        } else {
            assert_eq!(z[i], 1e10, "Z at ({x},{y})");
            assert!(
                a[i] <= 0.5 + tol,
                "Z = 1e10 (empty) at ({x},{y}) but A = {} > 0.5",
                a[i]
            );
        }
    }
    assert!(finite > 0, "no finite depth at all");
}

#[test]
fn cloud_values_are_consistent() {
    let dir = scratch("values-cloud");
    let e = Exr::read(&render(&dir, "cloud.vdb", "x", &[]));
    check_values(&e, &["sun0"]);
    assert!(!e.channels.contains_key("emission.R"));
}

#[test]
fn cloud_values_with_two_lights_are_consistent() {
    let dir = scratch("values-cloud-2");
    let e = Exr::read(&render(
        &dir,
        "cloud.vdb",
        "x",
        &[
            "--light",
            "sun:1,1,0:1,0.9,0.8:4",
            "--light",
            "point:0,3,3:0.3,0.4,1:40",
        ],
    ));
    check_values(&e, &["sun0", "point0"]);
}

#[test]
fn pyro_values_with_emission_and_scatter_are_consistent() {
    let dir = scratch("values-pyro");
    let e = Exr::read(&render(
        &dir,
        "pyro.vdb",
        "x",
        &[
            "--light",
            "sun:0.6,1,0.5:1,1,1:3",
            "--light",
            "sun:-1,0.2,0:0.3,0.4,1:2",
        ],
    ));
    for layer in ["emission", "scatter", "scatter_sun0", "scatter_sun1"] {
        for c in rgb(layer) {
            assert!(e.get(&c).iter().any(|v| *v > 0.0), "{c} is black");
        }
    }
    check_values(&e, &["sun0", "sun1"]);
}

#[test]
fn pyro_float_beauty_is_exactly_emission_plus_scatter() {
    let dir = scratch("values-pyro-float");
    let e = Exr::read(&render(
        &dir,
        "pyro.vdb",
        "x",
        &[
            "--float",
            "--light",
            "sun:0.6,1,0.5",
            "--light",
            "sun:-1,0,0",
        ],
    ));
    for (k, c) in ["R", "G", "B"].iter().enumerate() {
        let (b, em, sc) = (
            e.get(c),
            e.get(&rgb("emission")[k]),
            e.get(&rgb("scatter")[k]),
        );
        let (l0, l1) = (
            e.get(&rgb("scatter_sun0")[k]),
            e.get(&rgb("scatter_sun1")[k]),
        );
        for i in 0..b.len() {
            let (x, y) = e.xy(i);
            assert_eq!(b[i], em[i] + sc[i], "{c} at ({x},{y})");
            let sum = l0[i] + l1[i];
            assert!(
                (sc[i] - sum).abs() <= 1e-5 * sc[i].max(sum) + 1e-12,
                "scatter.{c} {} vs {sum} at ({x},{y})",
                sc[i]
            );
        }
    }
    check_depth(&e, 1e-6);
}

#[test]
fn depth_is_consistent_with_alpha_with_several_samples_per_pixel() {
    // With --spp 4 the pixel's alpha is the mean of the samples'; the depth rule
    // ("where accumulated alpha first reaches 0.5; 1e10 where it never does")
    // must still agree with the alpha that is written.
    let dir = scratch("values-spp");
    let e = Exr::read(&render(&dir, "cloud.vdb", "x", &["--spp", "4", "--float"]));
    check_depth(&e, 1e-6);
}
