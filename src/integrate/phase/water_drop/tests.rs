//! The water-drop tables: normalisation, colour, the bows where physics puts them,
//! and sampling by the pdf it reports. The 500 µm tables take ~30 s to build (once
//! per test binary: [`WaterDrop::cached`]); the 10 µm ones ~1 s.

use super::*;

const RAIN_UM: f64 = 500.0;
const FOG_UM: f64 = 10.0;

/// Scattering angle (radians) of a point `deg` degrees from the antisolar point.
fn from_antisolar(deg: f64) -> f64 {
    PI - deg.to_radians()
}

/// The angle from the antisolar point (degrees, stepping 0.01°) in `[lo, hi]` where
/// `f` is largest.
fn argmax(lo: f64, hi: f64, f: impl Fn(f64) -> f64) -> f64 {
    let n = ((hi - lo) / 0.01).round() as usize;
    (0..=n)
        .map(|i| lo + i as f64 * 0.01)
        .map(|a| (a, f(from_antisolar(a))))
        .fold(
            (lo, f64::NEG_INFINITY),
            |best, x| if x.1 > best.1 { x } else { best },
        )
        .0
}

/// Mean of `f` over angles from the antisolar point in `[lo, hi]` degrees.
fn mean(lo: f64, hi: f64, f: impl Fn(f64) -> f64) -> f64 {
    let n = 400;
    (0..n)
        .map(|i| f(from_antisolar(lo + (i as f64 + 0.5) * (hi - lo) / n as f64)))
        .sum::<f64>()
        / n as f64
}

/// `∫ f dΩ` by Simpson's rule inside every bin of the drop's grid (independent of
/// the exact bin weights the tables were normalised with).
fn simpson_over_bins(drop: &WaterDrop, f: impl Fn(f64) -> f64) -> f64 {
    let nodes = drop.angles();
    let mut total = 0.0;
    for w in nodes.windows(2) {
        let (a, b) = (w[0], w[1]);
        let g = |t: f64| f(t) * t.sin();
        let h = (b - a) / 4.0;
        total +=
            h / 3.0 * (g(a) + 4.0 * g(a + h) + 2.0 * g(a + 2.0 * h) + 4.0 * g(a + 3.0 * h) + g(b));
    }
    2.0 * PI * total
}

fn check_normalisation(drop: &WaterDrop, mie_tolerance: f64) {
    for (j, l) in WAVELENGTHS_NM.iter().enumerate() {
        let total = simpson_over_bins(drop, |t| drop.eval_spectral(j, t));
        assert!((total - 1.0).abs() < 1e-6, "{l} nm: ∫p dΩ = {total}");
        // The Mie table divided by Q_sca (not by its own integral) already integrates
        // to 1 within what the grid resolves.
        let mie = drop.mie_integral()[j];
        assert!((mie - 1.0).abs() < mie_tolerance, "{l} nm: Mie ∫ = {mie}");
    }
    for c in 0..3 {
        let total = simpson_over_bins(drop, |t| drop.eval(t.cos())[c]);
        // eval goes through acos(cos θ), which is coarse within ~1e-8 rad of θ = 0.
        assert!((total - 1.0).abs() < 1e-6, "channel {c}: {total}");
    }
}

#[test]
fn a_flat_spectrum_stays_white() {
    let w = channel_weights();
    for c in 0..3 {
        let sum: f64 = w.iter().map(|row| row[c]).sum();
        assert!((sum - 1.0).abs() < 1e-12, "channel {c}: {sum}");
    }
    // Red weighs long waves, blue short ones.
    assert!(w[13][0] > w[13][2] && w[3][2] > w[3][0]);
    assert!(WAVELENGTHS_NM.len() >= 16);
    assert_eq!((WAVELENGTHS_NM[0], WAVELENGTHS_NM[16]), (380.0, 780.0));
}

#[test]
fn bad_radii_are_refused() {
    for r in [0.0, -3.0, f64::NAN, f64::INFINITY, 1e4] {
        assert!(WaterDrop::new(r).is_err(), "{r}");
        assert!(WaterDrop::cached(r).is_err(), "{r}");
    }
    let e = WaterDrop::new(5000.0).unwrap_err().to_string();
    assert!(e.contains("5000") && e.contains("1000"), "{e}");
}

#[test]
fn fog_drops_give_a_broad_almost_white_bow() {
    let drop = WaterDrop::cached(FOG_UM).unwrap();
    check_normalisation(&drop, 2e-4);
    let lum = |t: f64| rec709_y(drop.eval(t.cos()));
    let peak = argmax(30.0, 45.0, lum);
    assert!((33.0..=42.0).contains(&peak), "fogbow at {peak}°");
    // Broad: above half its height (over the dark band's level) for several degrees.
    let floor = lum(from_antisolar(50.0));
    let half = floor + 0.5 * (lum(from_antisolar(peak)) - floor);
    let width = (0..=2000)
        .map(|i| 25.0 + i as f64 * 0.01)
        .filter(|a| lum(from_antisolar(*a)) > half)
        .count() as f64
        * 0.01;
    assert!(width > 4.0, "fogbow half width {width}°");
    // Almost white: the channels differ by less than 20 % across the bow...
    for a in [peak - 2.0, peak, peak + 2.0] {
        let v = drop.eval(from_antisolar(a).cos());
        let spread = v.max_element() / v.min_element();
        assert!(spread < 1.2, "{a}°: {v}");
    }
    // ...where a raindrop's bow is pure colours (checked in the rain test).
    // And the drops scatter mostly forward (diffraction): far more at 1° than 90°.
    assert!(lum(1f64.to_radians()) > 100.0 * lum(PI / 2.0));
}

fn rec709_y(v: DVec3) -> f64 {
    0.212_672_9 * v.x + 0.715_152_2 * v.y + 0.072_175 * v.z
}

#[test]
fn raindrops_give_primary_and_secondary_bows_with_the_dark_band() {
    let arc = WaterDrop::cached(RAIN_UM).unwrap();
    let drop: &WaterDrop = &arc;
    // The grid cannot follow diffraction rings beyond 2.9° (spacing 0.05° against
    // rings ~0.02° apart), which costs a few 1e-3 of the Mie integral.
    check_normalisation(drop, 5e-3);
    let spectral = |j: usize| move |t: f64| drop.eval_spectral(j, t);
    let channel = |c: usize| move |t: f64| drop.eval(t.cos())[c];
    // Primary bow: red light (705–780 nm) peaks 42.0–42.6° from the antisolar point
    // (Mie puts it inside the geometric 42.3–42.5°: 42.05° at 705 nm, 42.29° at 780
    // nm; 680 nm sits at 42.00°), blue (405–480 nm) inside it.
    for (j, l) in WAVELENGTHS_NM.iter().enumerate().take(17).skip(13) {
        let a = argmax(39.0, 45.0, spectral(j));
        assert!((42.0..=42.6).contains(&a), "{l} nm primary at {a}°");
    }
    for (j, l) in WAVELENGTHS_NM.iter().enumerate().take(5).skip(1) {
        let a = argmax(39.0, 45.0, spectral(j));
        assert!((40.0..41.6).contains(&a), "{l} nm primary at {a}°");
    }
    // In Rec.709 the R channel (weighted towards 600 nm) peaks just inside the red
    // light, the B channel well inside it.
    let (r1, b1) = (
        argmax(39.0, 45.0, channel(0)),
        argmax(39.0, 45.0, channel(2)),
    );
    assert!(
        (41.6..=42.6).contains(&r1) && b1 < r1 - 0.4,
        "R {r1}°, B {b1}°"
    );
    // Secondary bow: 50–54°, colours reversed (red inside, blue outside).
    let (r2, b2) = (
        argmax(49.0, 56.0, channel(0)),
        argmax(49.0, 56.0, channel(2)),
    );
    assert!(
        (50.0..=54.0).contains(&r2) && (50.0..=54.0).contains(&b2),
        "R {r2}°, B {b2}°"
    );
    assert!(b2 > r2 + 0.5, "secondary: R {r2}°, B {b2}°");
    for j in [12, 14] {
        let a = argmax(49.0, 56.0, spectral(j));
        assert!(
            (50.0..=52.0).contains(&a),
            "{} nm secondary at {a}°",
            WAVELENGTHS_NM[j]
        );
    }
    // Alexander's dark band between the bows is darker than the sky inside the
    // primary (which the primary's light fills) — several times, in every channel.
    for c in 0..3 {
        let band = mean(43.5, 49.0, channel(c));
        let inside = mean(30.0, 38.0, channel(c));
        assert!(
            band * 3.0 < inside,
            "channel {c}: band {band}, inside {inside}"
        );
    }
    // Raindrop bows are pure colours: some channel all but vanishes at the peak.
    let v = drop.eval(from_antisolar(r1).cos());
    assert!(v.min_element() < 0.05 * v.max_element(), "{v}");
    // Sampling is checked on the big drop too (the steepest table).
    check_sampling(drop);
}

#[test]
fn fog_sampling_follows_its_pdf() {
    check_sampling(&WaterDrop::cached(FOG_UM).unwrap());
}

/// Draws stratified samples, bins their scattering angles, and compares the counts
/// with the pdf integrated over each bin (chi-square); checks each sample's weight
/// and pdf against `eval` and `pdf`.
fn check_sampling(drop: &WaterDrop) {
    let incoming = DVec3::new(0.2, -0.3, 0.9).normalize();
    let n = 200_000;
    // Bins in θ: fine near the forward peak, 2° elsewhere.
    let mut edges: Vec<f64> = vec![0.0, 0.001, 0.003, 0.01, 0.03, 0.1];
    let mut e = 0.1;
    while e < PI - 1e-9 {
        e = (e + 2f64.to_radians()).min(PI);
        edges.push(e);
    }
    let mut counts = vec![0usize; edges.len() - 1];
    for i in 0..n {
        let u = [
            (i as f64 + 0.5) / n as f64,
            ((i * 7919) % n) as f64 / n as f64,
        ];
        let s = drop.sample(incoming, u);
        assert!((s.dir.length() - 1.0).abs() < 1e-9);
        let c = s.dir.dot(incoming).clamp(-1.0, 1.0);
        assert!(s.pdf > 0.0 && s.pdf.is_finite());
        assert!(
            (s.pdf - drop.pdf(c)).abs() <= 1e-6 * s.pdf,
            "{} vs {}",
            s.pdf,
            drop.pdf(c)
        );
        let w = drop.eval(c) / s.pdf;
        assert!((s.weight - w).abs().max_element() <= 1e-6 * w.max_element().max(1e-3));
        // Each channel's weight is near 1 where the channels agree with their mean.
        assert!(s.weight.is_finite() && s.weight.min_element() >= 0.0);
        let theta = c.acos();
        let k = edges
            .partition_point(|&x| x <= theta)
            .clamp(1, counts.len())
            - 1;
        counts[k] += 1;
    }
    // Expected probability per bin: ∫ pdf dΩ by Simpson on a fine θ grid.
    let mut chi2 = 0.0;
    let mut dof = 0;
    for k in 0..counts.len() {
        let (a, b) = (edges[k], edges[k + 1]);
        let m = 2000;
        let h = (b - a) / m as f64;
        let g = |t: f64| drop.pdf(t.cos()) * t.sin();
        let mut s = g(a) + g(b);
        for i in 1..m {
            s += if i % 2 == 1 { 4.0 } else { 2.0 } * g(a + i as f64 * h);
        }
        let expected = 2.0 * PI * s * h / 3.0 * n as f64;
        if expected > 20.0 {
            chi2 += (counts[k] as f64 - expected).powi(2) / expected;
            dof += 1;
        }
    }
    // Stratified samples fit better than random ones would: χ² well under its dof.
    assert!(dof > 50, "{dof}");
    assert!(chi2 < dof as f64, "χ² = {chi2} over {dof} bins");
    // The pdf, constant in each bin, integrates to 1 (looked up at each bin's middle).
    let total: f64 = drop
        .angles()
        .windows(2)
        .map(|w| drop.pdf((0.5 * (w[0] + w[1])).cos()) * 2.0 * PI * (w[0].cos() - w[1].cos()))
        .sum();
    assert!((total - 1.0).abs() < 1e-9, "∫pdf = {total}");
}

/// Run with `cargo test --release --lib eval_cost -- --ignored --nocapture`: the
/// per-call cost of `eval` and `sample` against Henyey–Greenstein's (timing, so not
/// in the default run).
#[test]
#[ignore]
fn eval_cost_against_hg() {
    use std::hint::black_box;
    use std::time::Instant;
    let drop = WaterDrop::cached(FOG_UM).unwrap();
    let hg = crate::integrate::phase::HenyeyGreenstein::new(0.8);
    let n = 10_000_000;
    let time = |p: &dyn PhaseFunction| {
        let t = Instant::now();
        let mut acc = DVec3::ZERO;
        for i in 0..n {
            acc += p.eval(black_box(-1.0 + 2.0 * (i as f64 + 0.5) / n as f64));
        }
        black_box(acc);
        let eval = t.elapsed().as_secs_f64() / n as f64;
        let t = Instant::now();
        for i in 0..n / 10 {
            let u = [(i as f64 + 0.5) / (n / 10) as f64, 0.3];
            acc += p.sample(black_box(DVec3::Z), u).weight;
        }
        black_box(acc);
        (eval, t.elapsed().as_secs_f64() / (n / 10) as f64)
    };
    let (e_hg, s_hg) = time(&hg);
    let (e_wd, s_wd) = time(drop.as_ref());
    eprintln!(
        "eval: HG {:.1} ns, water drop {:.1} ns; sample: HG {:.1} ns, water drop {:.1} ns",
        e_hg * 1e9,
        e_wd * 1e9,
        s_hg * 1e9,
        s_wd * 1e9
    );
    assert!(e_wd < 200e-9 && s_wd < 500e-9, "{e_wd} {s_wd}");
}

#[test]
fn disk_cache_round_trips_and_refuses_what_does_not_fit() {
    let dir = std::env::temp_dir().join(format!("murk-wd-cache-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let grid = AngleGrid::standard();
    let drop = WaterDrop::cached(FOG_UM).unwrap();
    let path = disk_cache::file(&dir, FOG_UM, &grid);
    let spectral: Vec<Vec<f64>> = (0..WAVELENGTHS_NM.len())
        .map(|j| drop.spectral_table(j).to_vec())
        .collect();
    assert!(disk_cache::store(
        &path,
        &grid,
        &spectral,
        drop.mie_integral()
    ));
    let (s, i) = disk_cache::load(&path, &grid).expect("stored tables load");
    assert_eq!(
        (s.as_slice(), i.as_slice()),
        (spectral.as_slice(), drop.mie_integral())
    );
    let again = WaterDrop::from_spectral(FOG_UM, grid.clone(), s, i);
    assert_eq!(again.rgb_table(), drop.rgb_table());
    assert_eq!(again.cdf, drop.cdf);
    // A truncated file, a corrupted magic or a NaN are not used.
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() - 8]).unwrap();
    assert!(disk_cache::load(&path, &grid).is_none());
    let mut bad = bytes.clone();
    bad[0] ^= 1;
    std::fs::write(&path, &bad).unwrap();
    assert!(disk_cache::load(&path, &grid).is_none());
    let mut nan = bytes.clone();
    let at = nan.len() - 8;
    nan[at..].copy_from_slice(&f64::NAN.to_le_bytes());
    std::fs::write(&path, &nan).unwrap();
    assert!(disk_cache::load(&path, &grid).is_none());
    assert!(disk_cache::load(&dir.join("missing.bin"), &grid).is_none());
    let _ = std::fs::remove_dir_all(&dir);
}

/// `disk_cache::load` on `path`, or `None` if it has not returned within 5 s.
fn load_within_seconds(path: &std::path::Path, grid: &AngleGrid) -> Option<bool> {
    let (tx, rx) = std::sync::mpsc::channel();
    let (p, g) = (path.to_owned(), grid.clone());
    std::thread::spawn(move || {
        let _ = tx.send(disk_cache::load(&p, &g).is_some());
    });
    rx.recv_timeout(std::time::Duration::from_secs(5)).ok()
}

#[test]
fn disk_cache_checks_a_files_kind_and_size_before_reading_it() {
    let dir = std::env::temp_dir().join(format!("murk-wd-hostile-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let grid = AngleGrid::standard();
    // A FIFO with no writer: opening it to read would block for ever.
    let fifo = dir.join("fifo.bin");
    let c = std::ffi::CString::new(fifo.as_os_str().as_encoded_bytes()).unwrap();
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    assert_eq!(load_within_seconds(&fifo, &grid), Some(false), "FIFO");
    // A symlink to an endless device: read whole, it fills the memory.
    let zero = dir.join("zero.bin");
    std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
    assert_eq!(load_within_seconds(&zero, &grid), Some(false), "/dev/zero");
    // A sparse 3 GB file: no disk used, 3 GB of memory if read whole.
    let huge = dir.join("huge.bin");
    std::fs::File::create(&huge)
        .unwrap()
        .set_len(3 << 30)
        .unwrap();
    assert_eq!(load_within_seconds(&huge, &grid), Some(false), "3 GB");
    let _ = std::fs::remove_dir_all(&dir);
}
