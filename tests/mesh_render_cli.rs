//! `murk render` on a mesh (fixtures/plume.vtu: hexahedra with point data density,
//! temperature and Cd): every layer (beauty, alpha, depth, emission, scatter, the
//! ground's shadow), the deep shadow map baked through the mesh, and the same image
//! with marched shadow rays within the map's tolerance.

use exr::prelude::{FlatSamples, read_all_flat_layers_from_file};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A directory of the test's own: tests run in parallel and each removes its own at the
/// end (a shared one was removed under the other test's feet).
fn dir(test: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("mesh-render-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn render(out: &Path, extra: &[&str]) -> Value {
    let plume = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/plume.vtu");
    let stats = out.with_extension("json");
    let o = Command::new(env!("CARGO_BIN_EXE_murk"))
        .arg("render")
        .arg(&plume)
        .arg("-o")
        .arg(out)
        .args(["--res", "48x36", "--float", "--quiet", "--eye", "6,5,1.5"])
        .args([
            "--look-at",
            "0,0,1.5",
            "--ground",
            "-1.05",
            "--temperature-grid",
            "temperature",
        ])
        .args(["--blackbody-intensity", "0.2", "--stats"])
        .arg(&stats)
        .args(extra)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap()
}

/// Channel name → values over the data window.
fn channels(path: &Path) -> BTreeMap<String, Vec<f32>> {
    let image = read_all_flat_layers_from_file(path).unwrap();
    let layer = &image.layer_data[0];
    layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            let v = match &c.sample_data {
                FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
                FlatSamples::F32(v) => v.clone(),
                FlatSamples::U32(_) => panic!("u32 channel"),
            };
            (c.name.to_string(), v)
        })
        .collect()
}

fn max(v: &[f32]) -> f32 {
    v.iter().cloned().fold(f32::MIN, f32::max)
}

#[test]
fn a_mesh_renders_with_shadows_and_every_layer() {
    let d = dir("shadows");
    let dsm = d.join("dsm.exr");
    let stats = render(&dsm, &["--dsm-tolerance", "1e-2"]);
    assert_eq!(stats["grid_roles"]["density"], "density");
    assert_eq!(stats["grid_roles"]["temperature"], "temperature");
    assert_eq!(stats["grid_roles"]["color"], "Cd");
    assert_eq!(stats["shadows"], "dsm");
    assert_eq!(stats["shadow_maps"][0]["source"], "baked");
    assert!(stats["density_memory_bytes"].as_u64().unwrap() > 0);
    let c = channels(&dsm);
    for name in [
        "R",
        "G",
        "B",
        "A",
        "Z",
        "emission.R",
        "emission.G",
        "emission.B",
        "scatter.R",
        "scatter.G",
        "scatter.B",
        "shadow.R",
        "shadow.G",
        "shadow.B",
    ] {
        assert!(c.contains_key(name), "no {name}: {:?}", c.keys());
        // Depth is +inf where nothing is (the EXR convention here), finite elsewhere.
        let ok = |v: &f32| v.is_finite() || (name == "Z" && *v == f32::INFINITY);
        assert!(c[name].iter().all(ok), "{name} not finite");
    }
    let z_where_dense = c["A"].iter().zip(&c["Z"]).filter(|(a, _)| **a > 0.5);
    assert!(z_where_dense.clone().count() > 0);
    for (_, z) in z_where_dense {
        // The plume is 5–11 units from the eye (6,5,1.5).
        assert!(z.is_finite() && *z > 4.0 && *z < 12.0, "depth {z}");
    }
    let a = &c["A"];
    assert!(max(a) > 0.2 && max(a) <= 1.0, "alpha max {}", max(a));
    assert!(
        a.iter().any(|&v| v < 1e-3),
        "no pixel (of the data window) misses the plume: min {}",
        a.iter().cloned().fold(f32::MAX, f32::min)
    );
    assert!(max(&c["emission.R"]) > 0.0 && max(&c["scatter.G"]) > 0.0);
    // The plume (y ∈ [-1, 1]) shadows the ground y = -1.05 below it somewhere (the
    // default sun shines from +y), and the sun reaches the ground elsewhere.
    let sh = &c["shadow.G"];
    let smin = sh.iter().cloned().fold(f32::MAX, f32::min);
    assert!(
        smin < 0.9 && max(sh) > 0.99,
        "shadow layer {smin}..{}",
        max(sh)
    );

    // Marched shadow rays through the mesh: the map's answer within its tolerance.
    let march = d.join("march.exr");
    render(&march, &["--shadows", "march"]);
    let m = channels(&march);
    let (s1, s2) = (&c["scatter.G"], &m["scatter.G"]);
    let peak = max(s2);
    let worst = s1
        .iter()
        .zip(s2)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(
        peak > 0.0 && worst <= 0.03 * peak,
        "dsm vs march: {worst} of {peak}"
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// The same image for any thread count: every channel bit for bit.
#[test]
fn a_mesh_render_does_not_depend_on_the_thread_count() {
    let d = dir("threads");
    let one = d.join("one.exr");
    let two = d.join("two.exr");
    render(&one, &["--shadows", "march", "--threads", "1"]);
    render(&two, &["--shadows", "march", "--threads", "2"]);
    let (a, b) = (channels(&one), channels(&two));
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    for (name, v) in &a {
        let w = &b[name];
        assert!(
            v.iter().zip(w).all(|(x, y)| x.to_bits() == y.to_bits()),
            "{name} differs between 1 and 2 threads"
        );
    }
    let _ = std::fs::remove_dir_all(&d);
}
