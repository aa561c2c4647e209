//! Determinism: the same seed gives the same image, another seed another one.

use super::*;

#[test]
fn renders_are_deterministic_and_the_seed_matters() {
    let dir = scratch("determinism");
    let flags = ["--spp", "2", "--float"];
    let a = Exr::read(&render(&dir, "cloud.vdb", "a", &flags));
    let b = Exr::read(&render(&dir, "cloud.vdb", "b", &flags));
    let one_thread: Vec<&str> = flags.iter().copied().chain(["--threads", "1"]).collect();
    let c = Exr::read(&render(&dir, "cloud.vdb", "c", &one_thread));
    for other in [&b, &c] {
        assert_eq!(a.window, other.window);
        assert_eq!(a.names(), other.names());
        for (name, (_, v)) in &a.channels {
            let w = other.get(name);
            let same = v
                .iter()
                .zip(w)
                .all(|(x, y)| x == y || (x.is_nan() && y.is_nan()));
            assert!(same, "{name} differs between identical renders");
        }
    }

    // Another seed: at one sample per pixel only the march's step offsets move, so
    // the image changes slightly; at two, the pixel jitter moves too, and the
    // image as a whole stays the same.
    let full = |e: &Exr, name: &str| -> Vec<f32> {
        let mut out = vec![0.0; W * H];
        for (i, v) in e.get(name).iter().enumerate() {
            let (x, y) = e.xy(i);
            out[y * W + x] = *v;
        }
        out
    };
    let seeded: Vec<&str> = flags.iter().copied().chain(["--seed", "12345"]).collect();
    let d = Exr::read(&render(&dir, "cloud.vdb", "d", &seeded));
    let (ra, rd) = (full(&a, "R"), full(&d, "R"));
    assert!(
        ra.iter().zip(&rd).any(|(x, y)| x != y),
        "--seed changes nothing at --spp 2"
    );
    let (sa, sd) = (ra.iter().sum::<f32>(), rd.iter().sum::<f32>());
    assert!(
        (sa - sd).abs() < 0.02 * sa,
        "--seed changes the total of R from {sa} to {sd}"
    );

    // At one sample a pixel with pixel centres only (the silhouette's resampling jitters
    // its samples by the seed too), the seed moves the march's step offsets alone.
    let e = Exr::read(&render(
        &dir,
        "cloud.vdb",
        "e",
        &["--float", "--antialias", "1"],
    ));
    let f = Exr::read(&render(
        &dir,
        "cloud.vdb",
        "f",
        &["--float", "--antialias", "1", "--seed", "12345"],
    ));
    let (re, rf) = (full(&e, "R"), full(&f, "R"));
    let changed = re.iter().zip(&rf).filter(|(x, y)| x != y).count();
    assert!(changed > 0, "--seed changes nothing in R at --spp 1");
    let max = re
        .iter()
        .zip(&rf)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max);
    let peak = re.iter().copied().fold(0.0, f32::max);
    assert!(
        max < 0.02 * peak,
        "--seed changes R by up to {max} (peak {peak})"
    );
    // Opacity comes from the exact optical depth, whatever the step offsets: the seed
    // cannot move it (beyond the last bits of the sum).
    let (ae, af) = (full(&e, "A"), full(&f, "A"));
    let max = ae
        .iter()
        .zip(&af)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max);
    assert!(max <= 1e-6, "--seed changes A by up to {max}");
}
