//! The pixel loop's tests: silhouettes' antialiasing, bands of rows.

use super::*;
use crate::integrate::pass::Pass;
use crate::scene::camera::Projection;
use crate::scene::progress::Silent;
use glam::DVec3;

/// An opaque disc of radius `r` about the origin in the z = 0 plane, seen straight on:
/// alpha 1 and a unit colour where the ray meets it.
struct Disc {
    r: f64,
    passes: PassLayout,
}

impl Integrator for Disc {
    type Scratch = ();
    fn passes(&self) -> &PassLayout {
        &self.passes
    }
    fn scratch(&self) {}
    fn sample(&self, c: &CameraSample, _: &mut SampleRng, _: &mut (), acc: &mut [f64]) -> u64 {
        let t = -c.ray.origin.z / c.ray.dir.z;
        let p = c.ray.origin + c.ray.dir * t;
        if p.truncate().length() < self.r {
            acc[..3].iter_mut().for_each(|v| *v += 1.0);
            acc[3] += 1.0;
        }
        1
    }
}

/// The disc's area inside pixel (x, y) of a `n`×`n` orthographic view of width 2,
/// by a fine midpoint sum.
fn coverage(r: f64, n: usize, x: usize, y: usize) -> f64 {
    let m = 64;
    let px = 2.0 / n as f64;
    let mut inside = 0;
    for j in 0..m {
        for i in 0..m {
            let u = -1.0 + (x as f64 + (i as f64 + 0.5) / m as f64) * px;
            let v = 1.0 - (y as f64 + (j as f64 + 0.5) / m as f64) * px;
            inside += (u * u + v * v < r * r) as usize;
        }
    }
    inside as f64 / (m * m) as f64
}

fn render(antialias: u32, rows: std::ops::Range<usize>, n: usize) -> PixelPasses {
    let disc = Disc {
        r: 0.71,
        passes: PassLayout::new(vec![Pass::beauty("beauty"), Pass::alpha()]),
    };
    let camera = Camera {
        projection: Projection::Orthographic { width: 2.0 },
        eye: DVec3::new(0.0, 0.0, 5.0),
        look_at: DVec3::ZERO,
        up: DVec3::Y,
        width: n,
        height: n,
    };
    let job = PixelJob {
        integrator: &disc,
        camera: &camera,
        spp: 1,
        seed: 3,
        rows,
        antialias,
        deep: None,
        deep_aovs: &[],
        holdout: None,
        shutter: None,
        camera_motion: None,
        centred: false,
        overscan: (0, 0),
    };
    render_pixels(&job, &Silent)
}

#[test]
fn silhouette_pixels_take_the_mean_over_the_pixel() {
    let n = 24;
    let (centres, edges) = (render(1, 0..n, n), render(4, 0..n, n));
    let a = |p: &PixelPasses| p.pass("A").map(|a| a[0].clone()).unwrap_or_default();
    let (a1, a4) = (a(&centres), a(&edges));
    let (mut err1, mut err4, mut resampled) = (0.0, 0.0, 0);
    for y in 0..n {
        for x in 0..n {
            let want = coverage(0.71, n, x, y);
            let i = y * n + x;
            err1 += (a1[i] as f64 - want).powi(2);
            err4 += (a4[i] as f64 - want).powi(2);
            if a4[i] != a1[i] {
                resampled += 1;
            }
            // Away from the edge, the centre is exact and kept.
            if want == 0.0 || want == 1.0 {
                assert_eq!(a4[i] as f64, want, "pixel ({x}, {y})");
            }
            // 16 stratified samples: within a few strata of the coverage.
            assert!(
                (a4[i] as f64 - want).abs() < 0.2,
                "pixel ({x}, {y}): {} against {want}",
                a4[i]
            );
        }
    }
    assert!(resampled > 20, "only {resampled} pixels were resampled");
    assert!(
        err4 < 0.1 * err1,
        "squared error {err4} with antialiasing, {err1} without"
    );
}

#[test]
fn a_band_of_rows_renders_as_the_whole_frame_does() {
    let n = 24;
    let whole = render(4, 0..n, n);
    for rows in [0..7, 7..8, 8..17, 17..24] {
        let band = render(4, rows.clone(), n);
        for (pw, pb) in whole.planes.iter().zip(&band.planes) {
            for (w, b) in pw.iter().zip(pb) {
                let (lo, hi) = (rows.start * n, rows.end * n);
                assert_eq!(&w[lo..hi], &b[lo..hi], "rows {rows:?}");
            }
        }
    }
}
