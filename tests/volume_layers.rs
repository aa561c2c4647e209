//! Scenes of several volumes, as a compositor receives them: each volume's alpha layer
//! `volume_<name>.A` (its share `⟨∫ T σt,ᵢ dt⟩` of the ray's opacity, against closed
//! forms; the layers add up to `A`), and each volume's own emission (emission grids,
//! fire), added where volumes overlap. Rays run straight down through slabs of
//! `fixtures/slab.vdb` (∫ρ dz = 1 world unit), so a volume of extinction σ has optical
//! depth τ = σ and, glowing with ε = I·c·ρ, gives L = (I·c/σ)(1 − e^{−σ}) whatever its
//! density's profile.

mod common;

use common::march::rel;
use common::volumes::{channel, channel_names, fixture, murk, render, scratch, slab};
use std::fs;

/// An orthographic camera looking straight down at the slab's middle, no lights, float
/// channels.
const DOWN: &str = "res = \"6x4\"\ncamera = \"ortho\"\northo_width = 0.5\neye = \"0.01,0.02,6\"\n\
                    look_at = \"0.01,0.02,0\"\nup = \"0,1,0\"\nno_lights = true\nfloat = true\n\
                    antialias = 1\n";

fn one_minus_exp(tau: f64) -> f64 {
    -(-tau).exp_m1()
}

/// Two slabs one above the other (σt 1.2 on top, 2.4 below, a unit gap between): the top
/// one's alpha is 1 − e^{−1.2}, the lower one's e^{−1.2}(1 − e^{−2.4}), in the march's
/// modes and the path tracer's; they add up to `A`.
#[test]
fn stacked_volumes_have_the_closed_form_alphas() {
    let dir = scratch("layers-stacked");
    let top = one_minus_exp(1.2);
    let bottom = (-1.2f64).exp() * one_minus_exp(2.4);
    for mode in ["single", "path"] {
        let out = render(
            &dir,
            mode,
            &format!(
                "{DOWN}scattering = \"{mode}\"\n\
                 [[volume]]\nname = \"top\"\nfile = \"{0}\"\nsigma_a = \"0.3\"\nsigma_s = \"0.9\"\n\
                 translate = [0, 0, 2]\n\
                 [[volume]]\nname = \"bottom\"\nfile = \"{0}\"\nsigma_a = \"0.6\"\nsigma_s = \"1.8\"\n",
                slab()
            ),
        );
        let names = channel_names(&out);
        assert!(
            names.contains(&"volume_top.A".to_string())
                && names.contains(&"volume_bottom.A".to_string()),
            "{mode}: {names:?}"
        );
        let (a, t, b) = (
            channel(&out, "A"),
            channel(&out, "volume_top.A"),
            channel(&out, "volume_bottom.A"),
        );
        for i in 0..a.len() {
            let (t, b) = (t[i] as f64, b[i] as f64);
            assert!(rel(t, top) <= 1e-6, "{mode}: top {t} vs {top}");
            assert!(rel(b, bottom) <= 1e-6, "{mode}: bottom {b} vs {bottom}");
            assert!(
                (t + b - a[i] as f64).abs() <= 1e-6,
                "{mode}: {t} + {b} vs {}",
                a[i]
            );
        }
    }
}

/// Overlapping volumes: where they coincide each takes its extinction's share of the
/// alpha, σᵢ/Σσ · (1 − e^{−Σσ}); shifted by half a slab and lit (so scattering runs
/// too), the layers still add up to `A`.
#[test]
fn overlapping_volumes_share_the_alpha() {
    let dir = scratch("layers-overlap");
    let table = |shift: f64| {
        format!(
            "[[volume]]\nname = \"thin\"\nfile = \"{0}\"\nsigma_a = \"0.3\"\nsigma_s = \"0.9\"\n\
             [[volume]]\nname = \"thick\"\nfile = \"{0}\"\nsigma_a = \"0.6\"\nsigma_s = \"1.8\"\n\
             translate = [0, 0, {shift}]\n",
            slab()
        )
    };
    let out = render(&dir, "same", &format!("{DOWN}{}", table(0.0)));
    let all = one_minus_exp(3.6);
    for (name, sigma) in [("thin", 1.2), ("thick", 2.4)] {
        let want = sigma / 3.6 * all;
        for v in channel(&out, &format!("volume_{name}.A")) {
            assert!(rel(v as f64, want) <= 1e-6, "{name}: {v} vs {want}");
        }
    }
    let lit = DOWN.replace(
        "no_lights = true\n",
        "light = [\"sun:0.3,0.2,1:1,1,1:2\"]\nscattering = \"single\"\n",
    );
    let out = render(&dir, "shifted", &format!("{lit}{}", table(0.5)));
    let (a, thin, thick) = (
        channel(&out, "A"),
        channel(&out, "volume_thin.A"),
        channel(&out, "volume_thick.A"),
    );
    for i in 0..a.len() {
        assert!(thin[i] > 0.0 && thick[i] > 0.0);
        let sum = thin[i] as f64 + thick[i] as f64;
        assert!((sum - a[i] as f64).abs() <= 1e-6, "{sum} vs {}", a[i]);
    }
}

/// One `[[volume]]` writes the channels of the same file given as `input`: no layer of
/// its own.
#[test]
fn one_volume_writes_no_volume_layer() {
    let dir = scratch("layers-one");
    let a = render(&dir, "input", &format!("{DOWN}input = \"{}\"\n", slab()));
    let b = render(
        &dir,
        "table",
        &format!("{DOWN}[[volume]]\nname = \"only\"\nfile = \"{}\"\n", slab()),
    );
    let names = channel_names(&b);
    assert_eq!(channel_names(&a), names);
    assert!(!names.iter().any(|n| n.starts_with("volume_")), "{names:?}");
}

/// Two volumes glowing through their density grids (ε = I·c·ρ, σs = 0): placed on each
/// other, the summed medium (Σ Iᵢcᵢ / Σ σᵢ)(1 − e^{−Σσ}); one above the other, the top
/// one's light plus the lower one's seen through it.
#[test]
fn glowing_volumes_add_their_emission() {
    let dir = scratch("glow");
    let (ca, cb) = ([1.0, 0.5, 0.25], [0.2, 1.0, 0.6]);
    let (ia, ib, sa, sb) = (2.0, 3.0, 1.2, 2.4);
    let scene = |shift: f64| {
        format!(
            "{DOWN}[[volume]]\nname = \"a\"\nfile = \"{0}\"\nsigma_a = \"{sa}\"\nsigma_s = \"0\"\n\
             emission_grid = \"density\"\nemission_intensity = {ia}\nemission_color = \"1,0.5,0.25\"\n\
             [[volume]]\nname = \"b\"\nfile = \"{0}\"\nsigma_a = \"{sb}\"\nsigma_s = \"0\"\n\
             emission_grid = \"density\"\nemission_intensity = {ib}\nemission_color = \"0.2,1,0.6\"\n\
             translate = [0, 0, {shift}]\n",
            slab()
        )
    };
    let same = render(&dir, "same", &scene(0.0));
    let stacked = render(&dir, "stacked", &scene(2.0));
    for (c, name) in ["R", "G", "B"].into_iter().enumerate() {
        let summed = (ia * ca[c] + ib * cb[c]) / (sa + sb) * one_minus_exp(sa + sb);
        let over =
            ib * cb[c] / sb * one_minus_exp(sb) + (-sb).exp() * ia * ca[c] / sa * one_minus_exp(sa);
        for (out, want) in [(&same, summed), (&stacked, over)] {
            for layer in [name.to_string(), format!("emission.{name}")] {
                for v in channel(out, &layer) {
                    assert!(rel(v as f64, want) <= 1e-5, "{layer}: {v} vs {want}");
                }
            }
        }
    }
}

/// A fire (the pyro fixture's flame and temperature) beside a smoke slab: light is
/// emitted where the fire is and nowhere over the smoke, which is there (its alpha).
#[test]
fn fire_glows_and_smoke_beside_it_does_not() {
    let dir = scratch("fire-smoke");
    // 36×12 pixels of 0.25 over x ∈ [−3.9, 5.1]: the fire at x ∈ [−3.3, −0.8], the
    // smoke at x ∈ [0.5, 4.5].
    let out = render(
        &dir,
        "shot",
        &format!(
            "res = \"36x12\"\ncamera = \"ortho\"\northo_width = 9\neye = \"0.6,0.9,6\"\n\
             look_at = \"0.6,0.9,0\"\nup = \"0,1,0\"\nno_lights = true\nfloat = true\nantialias = 1\n\
             [[volume]]\nname = \"fire\"\nfile = \"{}\"\ntranslate = [-2, 0, 0]\n\
             [[volume]]\nname = \"smoke\"\nfile = \"{}\"\ntranslate = [2.5, 0, 0]\n",
            fixture("pyro.vdb"),
            slab()
        ),
    );
    let (e, smoke, fire) = (
        channel(&out, "emission.R"),
        channel(&out, "volume_smoke.A"),
        channel(&out, "volume_fire.A"),
    );
    let x_of = |i: usize| 0.6 - 4.5 + ((i % 36) as f64 + 0.5) * 0.25;
    let fire_side: Vec<usize> = (0..e.len()).filter(|&i| x_of(i) < -0.9).collect();
    let smoke_side: Vec<usize> = (0..e.len()).filter(|&i| x_of(i) > 0.6).collect();
    assert!(fire_side.iter().any(|&i| e[i] > 1e-3), "no fire");
    assert!(fire_side.iter().all(|&i| smoke[i] == 0.0));
    assert!(smoke_side.iter().any(|&i| smoke[i] > 0.5), "no smoke");
    for &i in &smoke_side {
        assert_eq!((e[i], fire[i]), (0.0, 0.0), "pixel {i} over the smoke");
    }
}

/// Bad values of a volume's grid and emission keys: one line naming the scene file and
/// the key, exit 2, no image.
#[test]
fn bad_volume_emission_keys_are_refused_in_one_line() {
    let dir = scratch("glow-bad");
    for (i, (key, want)) in [
        ("emission_intensity = -1", "emission_intensity"),
        ("emission_color = \"1,x,0\"", "emission_color"),
        ("temperature_offset = nan", "temperature_offset"),
        ("blackbody_intensity = \"hot\"", "invalid type"),
        ("color_grid = 3", "invalid type"),
        (
            "emission_grid = \"nosuch\"",
            "[[volume]] \"hot\": no grid named \"nosuch\"",
        ),
        (
            "temperature_grid = \"nosuch\"",
            "[[volume]] \"hot\": no grid named \"nosuch\"",
        ),
    ]
    .into_iter()
    .enumerate()
    {
        let scene = dir.join(format!("bad{i}.toml"));
        fs::write(
            &scene,
            format!(
                "res = \"4x4\"\n[[volume]]\nfile = \"{0}\"\n[[volume]]\nname = \"hot\"\nfile = \"{0}\"\n{key}\n",
                slab()
            ),
        )
        .unwrap();
        let out = dir.join(format!("bad{i}.exr"));
        let r = murk(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{key}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{key}: {err}");
        assert!(err.contains(want), "{key}: {err}");
        assert!(
            err.contains(&format!("bad{i}.toml")) || err.contains("slab.vdb"),
            "{key}: {err}"
        );
        assert!(!out.exists());
    }
}

/// A fire cache (flame, temperature and `Cd` grids) given as one `[[volume]]` renders
/// as it does given as `input`, glow and colour included, bit for bit.
#[test]
fn a_fire_as_one_volume_renders_as_its_input() {
    let dir = scratch("fire-one");
    let common = "res = \"24x16\"\nfloat = true\n";
    let pyro = fixture("pyro.vdb");
    let a = render(&dir, "input", &format!("{common}input = \"{pyro}\"\n"));
    let b = render(
        &dir,
        "table",
        &format!("{common}[[volume]]\nfile = \"{pyro}\"\n"),
    );
    assert!(channel(&a, "emission.R").iter().any(|v| *v > 0.0));
    assert_eq!(channel_names(&a), channel_names(&b));
    for c in channel_names(&a) {
        assert_eq!(channel(&a, &c), channel(&b, &c), "channel {c}");
    }
}
