//! The map written as a VDB cache and read back; linear, replaced and forgotten bricks.

use super::*;

/// A baked map written as a VDB cache reads back to the same values, opens in OpenVDB's
/// own `vdb_print`, and is refused for another light or another density grid.
#[test]
fn shadow_cache_round_trips_and_refuses_a_mismatch() {
    need!(tools::PYOPENVDB, tools::VDB_PRINT);
    let dir = std::env::temp_dir().join(format!("murk-cache-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("shadows.vdb");
    let cloud = fixture("cloud.vdb");
    let sun = Light::parse("sun:0.6,1,0.5:1,1,1:6", "sun0".into()).unwrap();
    let point = Light::parse("point:3,2,1:1,1,1:40", "point0".into()).unwrap();
    // Straight down: a voxel-aligned chart, blended linearly across.
    let overhead = Light::parse("sun:0,1,0:1,1,1:6", "sun1".into()).unwrap();
    let lights = vec![sun.clone(), point.clone(), overhead];
    let mut maps = Vec::new();
    let mut stats = Vec::new();
    for l in &lights {
        let (m, r) = bake(&cloud, l.geometry(), &settings());
        maps.push(m);
        stats.push(ShadowMapStats {
            light: l.name.clone(),
            bake: r,
            ..Default::default()
        });
    }
    let hash = cloud.content_hash();
    shadow_cache::write(
        &path,
        hash,
        &lights,
        &maps,
        &stats,
        TOL,
        DVec3::splat(SIGMA),
    )
    .unwrap();
    let back = shadow_cache::read(&path, &cloud, hash, &lights).unwrap();
    let mut rng = murk::field::random::SplitMix64(5);
    let (lo, hi) = cloud.world_bounds();
    for ((m, _), orig) in back.iter().zip(&maps) {
        for _ in 0..2000 {
            let p = lo + (hi - lo) * DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64());
            let (a, b) = (m.density_integral(p), orig.density_integral(p));
            assert!((a - b).abs() <= 1e-5 * (1.0 + b), "{p}: {a} vs {b}");
        }
    }
    // OpenVDB reads it.
    let out = tools::command(&tools::VDB_PRINT)
        .arg(&path)
        .output()
        .expect("vdb_print (Debian package libopenvdb-tools) is required");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && text.contains("dsm_sun0_c0_bricks"),
        "{text}"
    );
    // Another sun placement, another density: refused with a clear message.
    let moved = Light::parse("sun:0.6,1,0.6", "sun0".into()).unwrap();
    let e = shadow_cache::read(&path, &cloud, hash, &[moved])
        .unwrap_err()
        .to_string();
    assert!(e.contains("was baked for light sun0"), "{e}");
    let sphere = fixture("sphere.vdb");
    let e = shadow_cache::read(&path, &sphere, sphere.content_hash(), &[sun])
        .unwrap_err()
        .to_string();
    assert!(e.contains("different density grid"), "{e}");
    // A cache without the slope grids (as an older murk wrote them), rewritten by
    // OpenVDB itself: refused, with the way out.
    let old = dir.join("old.vdb");
    let script = format!(
        "import pyopenvdb as vdb\n\
         grids, meta = vdb.readAll({:?})\n\
         vdb.write({:?}, grids=[g for g in grids if not g.name.endswith(('_dx', '_dy', '_dxy'))], metadata=meta)\n",
        path.to_str().unwrap(),
        old.to_str().unwrap()
    );
    let py = tools::command(&tools::PYOPENVDB)
        .args(["-c", &script])
        .status()
        .expect("/usr/bin/python3 with pyopenvdb (Debian package python3-openvdb) is required");
    assert!(py.success());
    let e = shadow_cache::read(&old, &cloud, hash, &lights[..1])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("lacks grid dsm_sun0_c0_L") && e.contains("bake again"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Compact bricks: the demo cloud under the default sun: its smooth bricks hold τ alone, trilinear in 16 bits. The map is smaller than
/// with every brick Hermite, still meets the tolerance against marched rays, and the
/// cache gives the same map back. (Its bricks are never dark: the density's least value
/// over a brick of this sparse cloud is 0 almost everywhere, so the bound that makes a
/// brick dark stays 0; the generated all-active cloud of `scripts/bench.sh shadow` has
/// 14 % of its bricks dark.)
#[test]
fn linear_bricks_shrink_the_map_keep_the_tolerance_and_round_trip() {
    let block = fixture("cloud.vdb");
    let sigma = SIGMA;
    let sun = Light::parse("sun:0.6,1,0.5:1,1,1:6", "sun0".into()).unwrap();
    let light = sun.geometry();
    let (map, report) = bake(&block, light, &BakeSettings::new(TOL, DVec3::splat(sigma)));
    assert!(report.linear_bricks > 0, "{report:?}");
    let hermite_bytes: u64 = report.points_per_level.iter().sum::<u64>() * 12;
    assert!(
        (report.memory_bytes as u64) < hermite_bytes,
        "{} vs {hermite_bytes}: {report:?}",
        report.memory_bytes
    );
    let r = murk::shadow::verify(&map, &block, light, DVec3::splat(sigma), TOL, 10_000, 7);
    assert!(r.max_error <= TOL && r.over_tolerance == 0, "{r:?}");
    let mut rng = murk::field::random::SplitMix64(9);
    let dir = std::env::temp_dir().join(format!("murk-forms-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("shadows.vdb");
    let stats = vec![ShadowMapStats {
        light: "sun0".into(),
        bake: report,
        ..Default::default()
    }];
    let lights = vec![sun];
    let hash = block.content_hash();
    shadow_cache::write(
        &path,
        hash,
        &lights,
        std::slice::from_ref(&map),
        &stats,
        TOL,
        DVec3::splat(sigma),
    )
    .unwrap();
    let (back, _) = shadow_cache::read(&path, &block, hash, &lights)
        .unwrap()
        .remove(0);
    assert_eq!(back.bricks_per_form(), map.bricks_per_form());
    let (lo, hi) = block.world_bounds();
    for _ in 0..2000 {
        let p = lo + (hi - lo) * DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64());
        let (a, b) = (back.density_integral(p), map.density_integral(p));
        assert!((a - b).abs() <= 1e-5 * (1.0 + b), "{p}: {a} vs {b}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The bake packs a brick that may be refined at the level checked, then replaces it (a
/// later push at its position) or forgets it: once dropped, the map reads as if only the
/// bricks kept had been pushed, whether one by one or as a batch.
#[test]
fn replaced_and_forgotten_bricks_leave_no_trace() {
    use glam::IVec3;
    use murk::shadow::chart::Chart;
    use murk::shadow::map::{BakedBrick, BrickForm, BrickSamples, ChartMap, EncodedBrick, side};
    let chart = Chart::parallel(DVec3::Z, DVec3::ZERO, 1.0);
    let samples = |level: u8, base: f32, full: bool| {
        let n = side(level).pow(3);
        let mut s = BrickSamples::zeros(n);
        for (k, t) in s.tau.iter_mut().enumerate() {
            *t = base + 0.01 * k as f32;
        }
        if full {
            s.rho.fill(0.5);
            s.tau_x.fill(0.1);
            s.tau_y.fill(-0.2);
            s.tau_xy.fill(0.01);
            s
        } else {
            BrickSamples {
                tau: s.tau,
                ..Default::default()
            }
        }
    };
    let [a, b, c, d] = [
        IVec3::new(0, 0, 0),
        IVec3::new(1, 0, 0),
        IVec3::new(0, 0, 1),
        IVec3::new(1, 1, 1),
    ];
    let kept = [
        (a, 1, BrickForm::Hermite, samples(1, 1.0, true)),
        (b, 2, BrickForm::Linear, samples(2, 2.0, false)),
        (c, 2, BrickForm::Hermite, samples(2, 3.0, true)),
        (d, 0, BrickForm::Constant, samples(0, 4.0, false)),
    ];
    let bricks = kept
        .iter()
        .map(|(key, level, form, s)| BakedBrick {
            key: *key,
            level: *level,
            form: *form,
            samples: s.clone(),
        })
        .collect();
    let reference = ChartMap::new(chart, bricks, 1 << 10).unwrap();

    let mut map = ChartMap::empty(chart, [a, b, c, d].into_iter(), 1 << 10).unwrap();
    map.reserve(4, 4 * 27);
    map.push(c, 1, BrickForm::Hermite, &samples(1, 9.0, true))
        .unwrap();
    map.push(d, 1, BrickForm::Hermite, &samples(1, 8.0, true))
        .unwrap();
    let (key, level, form, s) = &kept[0];
    map.push(*key, *level, *form, s).unwrap();
    map.forget(d);
    map.drop_replaced();
    // The rest as a bake appends a batch: packed apart, then copied in on all threads.
    let encoded: Vec<(IVec3, EncodedBrick)> = kept[1..]
        .iter()
        .map(|(key, level, form, s)| (*key, EncodedBrick::new(*level, *form, s).unwrap()))
        .collect();
    let batch: Vec<(IVec3, &EncodedBrick)> = encoded.iter().map(|(k, b)| (*k, b)).collect();
    map.push_encoded_all(&batch).unwrap();
    map.drop_replaced();

    assert_eq!(map.bricks.len(), 4);
    assert_eq!(map.memory_bytes(), reference.memory_bytes());
    assert_eq!(map.points_per_level(), reference.points_per_level());
    assert_eq!(map.bricks_per_form(), reference.bricks_per_form());
    for i in 0..=40 {
        for j in 0..=40 {
            for k in 0..=40 {
                let q = DVec3::new(i as f64, j as f64, k as f64) * 0.4 + DVec3::splat(0.013);
                assert_eq!(
                    map.density_integral_at(q),
                    reference.density_integral_at(q),
                    "at {q}"
                );
            }
        }
    }
}
