//! Several volumes in one scene (a scene file's `[[volume]]` tables): overlapping media
//! add, against the closed form of the summed medium; a file placed many times is read
//! once; bad tables are refused in one line.
//!
//! Closed forms, for a ray straight down through layers `j` of constant σt,ⱼ and σs,ⱼ and
//! length ℓⱼ (optical depth τⱼ₀ above layer j), a sun straight behind the camera of
//! irradiance E and phase value p = p(−1):
//! - α = 1 − e^{−Σ σt,ⱼ ℓⱼ};
//! - single scattering L = p·E·Σⱼ σs,ⱼ e^{−2τⱼ₀} (1 − e^{−2σt,ⱼ ℓⱼ}) / (2σt,ⱼ);
//! - for media of one albedo a, whatever their profile, L = p·E·a·(1 − e^{−2τ})/2.

mod common;

use common::march::{Sun, rel};
use common::volumes::{channel, murk, scratch, slab};
use glam::DVec3;
use murk::field::albedo_mix::AlbedoMix;
use murk::field::shapes::ConstantBox;
use murk::field::sum::FieldSum;
use murk::field::{ColorField, Field};
use murk::integrate::phase::{HenyeyGreenstein, hg};
use murk::integrate::{ColorTint, MarchSettings, Volume};
use murk::render::{RenderOptions, RenderPlan};
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The plan of a scene file's text (its volumes named relative to nothing).
fn plan_of(text: &str) -> RenderPlan {
    let o: RenderOptions = toml::from_str(&format!("output = \"x.exr\"\n{text}")).unwrap();
    RenderPlan::new(&o, PathBuf::from("a.vdb")).unwrap()
}

/// Two constant boxes overlapping in z ∈ [0.6, 1]: A over z ∈ [0, 1] (σa 0.3, σs 0.9), B
/// over z ∈ [0.6, 1.6] (σa 0.6, σs 0.3, density scale 2), both wide in x and y. A ray
/// straight down crosses B alone (ℓ 0.6), both (0.4), A alone (0.6); the plan sums the
/// media, the march must give α and single scattering of the summed medium.
#[test]
fn overlapping_boxes_of_two_media_give_the_summed_medium() {
    let g = 0.3;
    let plan = plan_of(&format!(
        "g = {g}\n[[volume]]\nfile = \"a.vdb\"\nsigma_a = \"0.3\"\nsigma_s = \"0.9\"\n\
         [[volume]]\nfile = \"b.vdb\"\nsigma_a = \"0.6\"\nsigma_s = \"0.3\"\ndensity_scale = 2\n\
         translate = [0, 0, 0.6]\n"
    ));
    let volumes = plan.volumes.as_ref().unwrap();
    let unit: Arc<dyn Field> = Arc::new(
        ConstantBox::new(
            DVec3::new(-2.0, -2.0, 0.0),
            DVec3::new(2.0, 2.0, 1.0),
            1.0,
            0.05,
        )
        .unwrap(),
    );
    let sum = FieldSum::new(
        volumes
            .list
            .iter()
            .map(|v| (unit.clone(), v.placement, v.weight))
            .collect(),
    )
    .unwrap();
    assert!(volumes.tinted, "the albedos 0.75 and 1/3 differ");
    let mix = AlbedoMix::new(sum.clone(), volumes.list.iter().map(|v| v.albedo).collect()).unwrap();
    let vol = Volume {
        phase: Arc::new(HenyeyGreenstein::new(g)),
        color: Some(ColorTint::new(&mix as &dyn ColorField, &sum)),
        ..Volume::of(&sum, plan.medium)
    };
    // Layers from the top: B alone, both, A alone.
    let layers = [(1.8, 0.6, 0.6), (3.0, 1.5, 0.4), (1.2, 0.9, 0.6)];
    let tau: f64 = layers.iter().map(|(st, _, l)| st * l).sum();
    let alpha_want = -(-tau).exp_m1();
    let e = 2.5;
    let mut above: f64 = 0.0;
    let mut l_want: f64 = 0.0;
    for (st, ss, l) in layers {
        l_want += ss * (-2.0 * above).exp() * -(-2.0 * st * l).exp_m1() / (2.0 * st);
        above += st * l;
    }
    l_want *= hg(-1.0, g) * e;
    let sun = Sun {
        field: &sum,
        toward: DVec3::Z,
        irradiance: e,
    };
    for (x, y) in [(0.013, -0.021), (0.7, 0.4), (-1.3, 1.1)] {
        let o = DVec3::new(x, y, 4.0);
        let r = common::march::ray_with(
            &vol,
            Some(&sun),
            o,
            DVec3::NEG_Z,
            &MarchSettings::reference(),
            0.5,
        );
        assert!(
            rel(r.alpha(), alpha_want) <= 1e-9,
            "α {} vs {alpha_want}",
            r.alpha()
        );
        let l = r.scatter.x;
        assert!(rel(l, l_want) <= 1e-3, "L {l} vs {l_want}");
        let l = common::march::ray(&vol, Some(&sun), o, DVec3::NEG_Z, 0.5, 0.5)
            .scatter
            .x;
        assert!(rel(l, l_want) <= 1e-3, "default step: L {l} vs {l_want}");
    }
}

/// The slab fixture (∫ρ dz = 1 world unit straight down) placed twice, the second 0.5
/// higher, of one albedo (0.75) and σt 1.2 and 2.4: α = 1 − e^{−3.6} and single
/// scattering p·E·a(1 − e^{−7.2})/2 in every pixel of the EXR, whatever the overlap — with
/// marched shadows, and with the deep shadow map baked over both (its tolerance, 1e-3 of
/// transmittance, allowed).
#[test]
fn two_placed_slabs_render_the_summed_medium() {
    let dir = scratch("two-slabs");
    for (shadows, tol) in [("march", 2e-3), ("dsm", 6e-3)] {
        let scene = dir.join(format!("{shadows}.toml"));
        fs::write(
            &scene,
            format!(
                "res = \"8x6\"\ncamera = \"ortho\"\northo_width = 0.5\neye = \"0.01,0.02,4\"\n\
                 look_at = \"0.01,0.02,0\"\nup = \"0,1,0\"\nlight = [\"sun:0,0,1:1,1,1:2\"]\n\
                 scattering = \"single\"\nshadows = \"{shadows}\"\nfloat = true\nantialias = 1\n\
                 [[volume]]\nfile = \"{0}\"\nsigma_a = \"0.3\"\nsigma_s = \"0.9\"\n\
                 [[volume]]\nname = \"upper\"\nfile = \"{0}\"\nsigma_a = \"0.6\"\nsigma_s = \"1.8\"\n\
                 translate = [0, 0, 0.5]\n",
                slab()
            ),
        )
        .unwrap();
        let out = dir.join(format!("{shadows}.exr"));
        let stats = dir.join(format!("{shadows}.json"));
        let r = murk(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--stats",
            stats.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        let tau: f64 = 1.2 + 2.4;
        let alpha_want = -(-tau).exp_m1();
        let l_want = hg(-1.0, 0.0) * 2.0 * 0.75 * -(-2.0 * tau).exp_m1() / 2.0;
        for a in channel(&out, "A") {
            assert!(
                rel(a as f64, alpha_want) <= 1e-5,
                "{shadows}: α {a} vs {alpha_want}"
            );
        }
        for l in channel(&out, "R") {
            assert!(rel(l as f64, l_want) <= tol, "{shadows}: L {l} vs {l_want}");
        }
        let text = fs::read_to_string(&stats).unwrap();
        assert!(
            text.contains("2 volumes placed from 1 decoded density grid"),
            "{text}"
        );
    }
}

/// The fast multiple-scattering lattice over two placed slabs: the image has the summed
/// medium's alpha, and scattering at least the single-scattering closed form (the later
/// orders add to it) and below the albedo-1 bound p·E-free energy conservation allows.
#[test]
fn the_fast_lattice_covers_every_volume() {
    let dir = scratch("fast");
    let scene = dir.join("fast.toml");
    fs::write(
        &scene,
        format!(
            "res = \"8x6\"\ncamera = \"ortho\"\northo_width = 0.5\neye = \"0.01,0.02,4\"\n\
             look_at = \"0.01,0.02,0\"\nup = \"0,1,0\"\nlight = [\"sun:0,0,1:1,1,1:2\"]\n\
             float = true\nantialias = 1\n\
             [[volume]]\nfile = \"{0}\"\nsigma_a = \"0.3\"\nsigma_s = \"0.9\"\n\
             [[volume]]\nfile = \"{0}\"\nsigma_a = \"0.6\"\nsigma_s = \"1.8\"\n\
             translate = [0, 0, 0.5]\n",
            slab()
        ),
    )
    .unwrap();
    let out = dir.join("fast.exr");
    let r = murk(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let tau: f64 = 3.6;
    let alpha_want = -(-tau).exp_m1();
    let single = hg(-1.0, 0.0) * 2.0 * 0.75 * -(-2.0 * tau).exp_m1() / 2.0;
    for a in channel(&out, "A") {
        assert!(rel(a as f64, alpha_want) <= 1e-5, "α {a} vs {alpha_want}");
    }
    for l in channel(&out, "R") {
        let l = l as f64;
        // Reflected light cannot exceed the sun's irradiance over π (a white Lambertian).
        assert!(
            l > single * 1.05 && l < 2.0 / std::f64::consts::PI,
            "L {l}, single {single}"
        );
    }
}

/// A scene of one `[[volume]]` renders as the same file given as `input`, bit for bit.
#[test]
fn one_volume_renders_as_its_input() {
    let dir = scratch("one");
    let common = "res = \"24x16\"\nfloat = true\n";
    let a = dir.join("a.toml");
    let b = dir.join("b.toml");
    fs::write(&a, format!("{common}input = \"{}\"\n", slab())).unwrap();
    fs::write(&b, format!("{common}[[volume]]\nfile = \"{}\"\n", slab())).unwrap();
    for (scene, out) in [(&a, "a.exr"), (&b, "b.exr")] {
        let out = dir.join(out);
        let r = murk(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    }
    for c in ["R", "G", "B", "A"] {
        let (x, y) = (
            channel(&dir.join("a.exr"), c),
            channel(&dir.join("b.exr"), c),
        );
        assert!(x.iter().any(|v| *v > 0.0));
        assert_eq!(x, y, "channel {c}");
    }
}

/// One file placed 16 times is decoded once: the decoded grids' memory is one copy's, and
/// the summed density holds one copy and 16 placements.
#[test]
fn a_file_placed_many_times_is_read_once() {
    let dir = scratch("instances");
    let run = |n: usize| -> serde_json::Value {
        let mut text =
            String::from("res = \"16x12\"\nscattering = \"single\"\nshadows = \"none\"\n");
        for i in 0..n {
            text.push_str(&format!(
                "[[volume]]\nfile = \"{}\"\ntranslate = [{}, {}, 0]\n",
                slab(),
                0.25 * (i % 4) as f64,
                0.25 * (i / 4) as f64
            ));
        }
        let scene = dir.join(format!("scene{n}.toml"));
        fs::write(&scene, text).unwrap();
        let stats = dir.join(format!("stats{n}.json"));
        let out = dir.join(format!("out{n}.exr"));
        let r = murk(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--stats",
            stats.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        serde_json::from_str(&fs::read_to_string(&stats).unwrap()).unwrap()
    };
    let (one, many) = (run(1), run(16));
    let bytes =
        |s: &serde_json::Value, k: &str| s[k].as_u64().unwrap_or_else(|| panic!("{k}: {s}"));
    assert!(bytes(&one, "grid_memory_bytes") > 100_000);
    assert_eq!(
        bytes(&one, "grid_memory_bytes"),
        bytes(&many, "grid_memory_bytes")
    );
    // The density the render holds: one copy and a placement (a few hundred bytes) each.
    let (d1, d16) = (
        bytes(&one, "density_memory_bytes"),
        bytes(&many, "density_memory_bytes"),
    );
    assert!(d1 >= bytes(&one, "grid_memory_bytes"), "{d1}");
    assert!(d16 <= d1 + 16 * 512, "{d16} vs {d1}");
}

/// Bad tables: one line naming the scene file and the problem, exit 2.
#[test]
fn bad_volume_tables_are_refused_in_one_line() {
    let dir = scratch("bad");
    for (i, (table, want)) in [
        ("[[volume]]\nname = \"x\"\n", "missing field `file`"),
        ("[[volume]]\nfile = \"{}\"\nscale = [1, 0, 1]\n", "singular"),
        (
            "[[volume]]\nfile = \"{}\"\nshift = [1, 0, 1]\n",
            "unknown key `shift`",
        ),
        (
            "[[volume]]\nfile = \"{}\"\nrotate = [0, \"x\", 0]\n",
            "invalid type",
        ),
        ("[[volume]]\nfile = \"missing.vdb\"\n", "missing.vdb"),
        (
            "[[volume]]\nfile = \"{}\"\n[[volume]]\nfile = \"{}\"\nsigma_s = \"2,0,0\"\n",
            "extinction",
        ),
    ]
    .into_iter()
    .enumerate()
    {
        let scene = dir.join(format!("bad{i}.toml"));
        fs::write(&scene, table.replace("{}", &slab())).unwrap();
        let out = dir.join(format!("bad{i}.exr"));
        let r = murk(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{table}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{table}: {err}");
        assert!(err.contains(want), "{table}: {err}");
        assert!(!out.exists());
    }
}

/// Bad `[[volume.keys]]`: one line naming the scene file and the problem, exit 2.
#[test]
fn bad_volume_keys_are_refused_naming_the_scene_file() {
    let dir = scratch("bad-keys");
    let key = |frame: &str, rest: &str| format!("[[volume.keys]]\nframe = {frame}\n{rest}");
    for (i, (keys, want)) in [
        (
            key("2", "") + &key("1", ""),
            "frame 1 does not follow frame 2",
        ),
        (key("1", "") + &key("1", ""), "does not follow"),
        (key("nan", ""), "not a finite number"),
        (key("1", "translate = [0, inf, 0]\n"), "not a finite number"),
        (key("1", "scale = 0\n"), "flattens"),
        (
            key("1", "scale = [1, 1, 1]\n") + &key("2", "scale = [1, -1, 1]\n"),
            "changes sign",
        ),
        (key("1", "shear = 1\n"), "unknown key `shear`"),
        (
            "matrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n".to_string()
                + &key("1", "translate = [1, 0, 0]\n"),
            "keyed by `matrix`",
        ),
        (
            key(
                "1",
                "matrix = [[1, 0.5, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n",
            ),
            "shears the volume",
        ),
    ]
    .into_iter()
    .enumerate()
    {
        let name = format!("keys{i}.toml");
        let scene = dir.join(&name);
        let text = format!("[[volume]]\nfile = \"{}\"\n{keys}", slab());
        fs::write(&scene, &text).unwrap();
        let out = dir.join(format!("keys{i}.exr"));
        let r = murk(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--shutter",
            "-0.25,0.25",
            "--quiet",
        ]);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{text}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{text}: {err}");
        assert!(err.contains(want) && err.contains(&name), "{text}: {err}");
        assert!(!out.exists());
    }
}

/// A frame pattern in a volume's `file` is replaced frame by frame, as the input's is:
/// two frames of a pattern volume over a static one, each with the alpha of both.
#[test]
fn a_volume_pattern_is_replaced_per_frame() {
    let dir = scratch("frames");
    for f in [1, 2] {
        fs::copy(slab(), dir.join(format!("smoke_{f:04}.vdb"))).unwrap();
    }
    let scene = dir.join("shot.toml");
    fs::write(
        &scene,
        format!(
            "res = \"4x4\"\ncamera = \"ortho\"\northo_width = 0.5\neye = \"0,0,4\"\nlook_at = \"0,0,0\"\n\
             up = \"0,1,0\"\nno_lights = true\nfloat = true\nantialias = 1\noutput = \"out_####.exr\"\n\
             [[volume]]\nfile = \"smoke_####.vdb\"\n[[volume]]\nfile = \"{}\"\ntranslate = [0, 0, 0.3]\n",
            slab()
        ),
    )
    .unwrap();
    let r = murk(&[
        "render",
        scene.to_str().unwrap(),
        "--frames",
        "1-2",
        "--quiet",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let want = -(-2.0f64 * 2.1).exp_m1();
    for f in [1, 2] {
        for a in channel(&dir.join(format!("out_{f:04}.exr")), "A") {
            assert!(rel(a as f64, want) <= 1e-5, "frame {f}: α {a} vs {want}");
        }
    }
}

/// `murk bake-shadows` on a scene of volumes bakes the summed density's maps, which the
/// render then takes from the cache, giving the image it bakes for itself (to a float's
/// rounding).
#[test]
fn shadows_baked_for_a_scene_of_volumes_are_reused() {
    let dir = scratch("bake");
    let scene = dir.join("scene.toml");
    fs::write(
        &scene,
        format!(
            "res = \"12x8\"\nscattering = \"single\"\nfloat = true\n\
             [[volume]]\nfile = \"{0}\"\n[[volume]]\nfile = \"{0}\"\nrotate = [0, 0, 30]\ntranslate = [0.5, 0.2, 0.3]\n",
            slab()
        ),
    )
    .unwrap();
    let (cache, s) = (dir.join("shadows.vdb"), |p: &Path| {
        p.to_str().unwrap().to_owned()
    });
    let r = murk(&["bake-shadows", &s(&scene), "-o", &s(&cache), "--quiet"]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let (own, cached) = (dir.join("own.exr"), dir.join("cached.exr"));
    let stats = dir.join("stats.json");
    let r = murk(&["render", &s(&scene), "-o", &s(&own), "--quiet"]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let r = murk(&[
        "render",
        &s(&scene),
        "-o",
        &s(&cached),
        "--shadow-cache",
        &s(&cache),
        "--stats",
        &s(&stats),
        "--quiet",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let text = fs::read_to_string(&stats).unwrap();
    assert!(
        text.contains("\"source\":\"cache") || text.contains("\"source\": \"cache"),
        "{text}"
    );
    for c in ["R", "A"] {
        let (a, b) = (channel(&own, c), channel(&cached, c));
        assert!(a.iter().any(|v| *v > 0.0));
        // The cache stores the maps' samples as floats: a rounding at most.
        for (x, y) in a.iter().zip(&b) {
            assert!(
                (x - y).abs() <= 1e-6 * x.abs().max(1.0),
                "channel {c}: {x} vs {y}"
            );
        }
    }
}

/// Every volume's file is an input that no output may replace: `bake-shadows -o` naming
/// the second volume's file is refused and leaves it as it was.
#[test]
fn no_output_replaces_a_volume() {
    let dir = scratch("guard");
    let second = dir.join("second.vdb");
    fs::copy(slab(), &second).unwrap();
    let before = fs::read(&second).unwrap();
    let scene = dir.join("scene.toml");
    fs::write(
        &scene,
        format!(
            "res = \"8x6\"\n[[volume]]\nfile = \"{}\"\n[[volume]]\nname = \"dust\"\nfile = \"second.vdb\"\n",
            slab()
        ),
    )
    .unwrap();
    let r = murk(&[
        "bake-shadows",
        scene.to_str().unwrap(),
        "-o",
        second.to_str().unwrap(),
        "--quiet",
    ]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "{err}");
    assert!(err.contains("volume \"dust\""), "{err}");
    assert_eq!(fs::read(&second).unwrap(), before);
}
