//! What the bake reports when a budget stops it and where its time went, and the thread
//! count it keeps to.

use super::*;

/// When the sample budget stops refinement the map says so, with how many bricks and
/// what error to expect, and the error it names is honest: marched shadow rays find no
/// larger error than about that. (At production scale, the benchmarks measured 125,745 bricks
/// stopped this way with nothing said.) With the default budget and tolerance, the cloud's
/// map meets the tolerance and says nothing.
#[test]
fn a_budget_that_stops_refinement_is_reported_with_the_error_to_expect() {
    let g = fixture("cloud.vdb");
    let light = LightGeometry::Sun {
        travel: -DVec3::new(0.6, 1.0, 0.5).normalize(),
    };
    let tol = 1e-4;
    let full = bake(&g, light, &BakeSettings::new(tol, DVec3::splat(SIGMA))).1;
    let default = bake(&g, light, &settings()).1;
    let stats = |bake| ShadowMapStats {
        light: "sun".into(),
        bake,
        ..Default::default()
    };
    let mut tight = BakeSettings::new(tol, DVec3::splat(SIGMA));
    tight.max_values = full.points_per_level.iter().sum::<u64>() as usize / 4;
    let (map, report) = bake(&g, light, &tight);
    assert!(report.bricks_stopped_by_budget > 0, "{report:?}");
    assert!(report.bricks_over_tolerance >= report.bricks_stopped_by_budget);
    let line = stats(report.clone())
        .shortfall(tol)
        .expect("a budget stop is said");
    assert!(
        line.contains(&format!(
            "{} of {} bricks",
            report.bricks_over_tolerance, report.bricks
        )) && line.contains("budget"),
        "{line}"
    );
    let r = murk::shadow::verify(&map, &g, light, DVec3::splat(SIGMA), tol, 20_000, 3);
    assert!(r.max_error > tol, "the budget did cost accuracy: {r:?}");
    assert!(
        r.max_error <= 2.0 * report.over_tolerance_error,
        "the error named ({:e}) is about what marched rays find: {r:?}",
        report.over_tolerance_error
    );
    assert!(
        report.over_tolerance_error <= 20.0 * r.max_error,
        "and not a uselessly loose bound: {r:?}"
    );
    assert_eq!(stats(default.clone()).shortfall(TOL), None, "{default:?}");
}

/// `--threads N` holds for the whole render, not the pixel loop alone: the shadow bake,
/// the multiple-scattering lattice and the pixel loop each see N worker threads
/// (recorded by a progress sink as each stage starts), for N = 1, 2, 3 and 8 on a
/// 2-core machine alike; and the image is the same for all (8 threads sweep the
/// lattice's directions in waves that cut across its groups of four, 3 in waves of
/// three, and each sweep's planes are split in as many runs of rows as there are
/// threads).
#[test]
fn every_stage_keeps_to_the_thread_count() {
    struct Threads(std::sync::Mutex<Vec<(String, usize)>>);
    impl murk::scene::progress::Progress for Threads {
        fn start(&self, what: &str, _total: u64, _unit: &str) {
            let n = rayon::current_num_threads();
            self.0.lock().unwrap().push((what.to_owned(), n));
        }
    }
    let mut frames = Vec::new();
    for n in [1, 2, 3, 8] {
        let o = RenderOptions {
            output: Some(std::env::temp_dir().join("murk-unused.exr")),
            res: Some("32x18".into()),
            threads: Some(n),
            quiet: true,
            ..Default::default()
        };
        let plan = RenderPlan::new(&o, fixture_path("cloud.vdb")).unwrap();
        let seen = Threads(Default::default());
        frames.push(murk::render::render_image_with(&plan, &seen).unwrap().frame);
        let seen = seen.0.into_inner().unwrap();
        let stages: Vec<&str> = seen.iter().map(|(w, _)| w.as_str()).collect();
        assert!(
            stages.contains(&"baking shadow maps") && stages.contains(&"rendering"),
            "{seen:?}"
        );
        assert!(seen.iter().all(|&(_, t)| t == n), "--threads {n}: {seen:?}");
    }
    assert!(
        frames.iter().all(|f| *f == frames[0]),
        "the image depends on the thread count"
    );
}

/// The finest level is a cap too: where one sample per voxel still misses a dense
/// medium's tolerance (σt 32 per unit on the fixtures' voxels), the bricks kept there
/// unchecked are counted, and the error named for them is their two-voxel error over
/// the measured gain of one more halving — about what marched rays find there, not the
/// two-voxel error itself, which was 5–15× what they find.
#[test]
fn bricks_kept_at_one_voxel_over_the_tolerance_name_the_error_to_expect() {
    let light = LightGeometry::Sun {
        travel: -DVec3::new(0.6, 1.0, 0.5).normalize(),
    };
    let (tol, sigma) = (5e-3, DVec3::splat(32.0));
    for name in ["cloud.vdb", "houdini_pyro.vdb", "blender_smoke.vdb"] {
        let g = fixture(name);
        let (map, report) = bake(&g, light, &BakeSettings::new(tol, sigma));
        assert_eq!(report.bricks_stopped_by_budget, 0, "{name}: {report:?}");
        assert!(report.bricks_over_tolerance > 0, "{name}: {report:?}");
        let r = murk::shadow::verify(&map, &g, light, sigma, tol, 10_000, 5);
        assert!(
            r.max_error > tol,
            "{name}: over the tolerance indeed: {r:?}"
        );
        let named = report.over_tolerance_error;
        assert!(
            r.max_error <= 2.0 * named && named <= 5.0 * r.max_error,
            "{name}: named {named:e} against {r:?}"
        );
    }
}

/// The bake says where its time went, and its parts add up: the stretches that are each
/// their own (finding the bricks, their bounds, deciding, packing, waiting for columns,
/// compacting between levels) fit in the bake's wall time, and so do the columns (which
/// overlap the decisions). A cloud at a tight tolerance takes several levels and
/// batches, and each part takes some time.
#[test]
fn the_bakes_phases_fit_in_its_time() {
    let g = fixture("cloud.vdb");
    let light = LightGeometry::Sun {
        travel: -DVec3::new(0.6, 1.0, 0.5).normalize(),
    };
    let clock = std::time::Instant::now();
    let report = bake(&g, light, &BakeSettings::new(1e-4, DVec3::splat(SIGMA))).1;
    let wall = clock.elapsed().as_secs_f64();
    let p = report.phases.expect("a bake says where its time went");
    let own = [
        p.marking_seconds,
        p.bounds_seconds,
        p.decisions_seconds,
        p.packing_seconds,
        p.waiting_seconds,
        p.compacting_seconds,
    ];
    for t in own.iter().chain([&p.columns_seconds]) {
        assert!(t.is_finite() && *t >= 0.0, "{p:?}");
    }
    assert!(own.iter().sum::<f64>() <= wall, "{p:?} in {wall} s");
    assert!(p.columns_seconds <= wall, "{p:?} in {wall} s");
    for t in [
        p.marking_seconds,
        p.bounds_seconds,
        p.columns_seconds,
        p.decisions_seconds,
        p.packing_seconds,
    ] {
        assert!(t > 0.0, "{p:?}");
    }
    // The columns are most of a CPU bake: the waits are for them, and they are at least
    // as long as the waits.
    assert!(p.columns_seconds >= p.waiting_seconds, "{p:?}");
}
