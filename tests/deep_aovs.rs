//! `--deep-aovs`: the flat file's layers (emission, scatter, indirect, each light's) as
//! channels of every deep sample, premultiplied like R,G,B. Flattened, each is its flat
//! layer (a closed form on an emitting slab, and every layer of several fixtures); in
//! every sample the layers add up to the colour, as the flat file's do; OpenImageIO
//! reads and flattens them; bad lists are refused in one line.

mod common;
use common::deep::{
    Deep, SLAB_VIEW, fixture, flat_channels, flatten_channel, read_deep, render_deep,
};
use common::frames::{MURK, refused, scratch};
use common::tools;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Renders `input` with `args` and `--deep-aovs all`: the flat EXR and the deep one.
fn render(dir: &Path, input: &str, args: &[&str]) -> (PathBuf, PathBuf) {
    render_deep(dir, input, &["--deep-aovs", "all"], args)
}

/// The flat file's layers (`name.R` …) other than the beauty's.
fn layer_channels(flat: &BTreeMap<String, Vec<f32>>) -> Vec<String> {
    flat.keys()
        .filter(|k| k.contains('.') && !k.ends_with(".A") && !k.starts_with("depth"))
        .cloned()
        .collect()
}

/// Largest difference between each deep AOV flattened and its flat layer, in units of
/// `abs + rel × |value|`.
fn worst_layer(d: &Deep, flat: &BTreeMap<String, Vec<f32>>, abs: f64, rel: f64) -> f64 {
    let mut worst: f64 = 0.0;
    for name in layer_channels(flat) {
        if name.starts_with("shadow") || name.starts_with("volume_") {
            continue;
        }
        assert!(d.channels.contains(&name), "no deep channel {name}");
        for (i, want) in flat[&name].iter().enumerate() {
            let (got, want) = (flatten_channel(d, i, &name), *want as f64);
            worst = worst.max((got - want).abs() / (abs + rel * want.abs()));
        }
    }
    worst
}

const CASES: &[(&str, &[&str])] = &[
    // Emission, scatter and indirect (the default fast mode).
    ("pyro.vdb", &[]),
    ("caches/mantaflow_fire.vdb", &[]),
    // Two lights: a layer each.
    (
        "cloud.vdb",
        &[
            "--light",
            "sun:0.6,1,0.5",
            "--light",
            "point:2,2,2:1,0.5,0.2:20",
        ],
    ),
    // Several rays a pixel (their curves' mean), single scattering.
    ("cloud.vdb", &["--spp", "4", "--scattering", "single"]),
    // A visible floor: in the beauty, in no layer.
    ("cloud.vdb", &["--ground", "-1", "--ground-visible"]),
    // Converted to ACEScg like the flat file's layers.
    ("blender_smoke.vdb", &["--colorspace", "acescg"]),
];

#[test]
fn flattened_each_aov_is_its_flat_layer() {
    for (k, (input, extra)) in CASES.iter().enumerate() {
        let dir = scratch(&format!("deep-aovs-{k}"));
        let args = [&["--res", "48x27", "--float"], *extra].concat();
        let (flat, deep) = render(&dir, &fixture(input), &args);
        let (d, f) = (read_deep(&deep), flat_channels(&flat));
        assert!(
            layer_channels(&f).iter().any(|c| c.starts_with("scatter")),
            "{input}: no scatter layer"
        );
        let worst = worst_layer(&d, &f, 1e-4, 0.0);
        assert!(worst < 1.0, "{input} {extra:?}: {worst}e-4");
        // At the default precision (half colour, each sample rounded against what the
        // samples before it flatten to): within the half floats' precision.
        let o = Command::new(MURK)
            .args(["render", &fixture(input), "-o"])
            .arg(dir.join("half.exr"))
            .arg("--deep")
            .arg(dir.join("half_deep.exr"))
            .args(["--deep-aovs", "all", "--quiet", "--res", "48x27"])
            .args(*extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let h = read_deep(&dir.join("half_deep.exr"));
        let worst = worst_layer(
            &h,
            &flat_channels(&dir.join("half.exr")),
            1e-4,
            1.0 / 1024.0,
        );
        assert!(worst < 1.0, "{input} {extra:?} at half: {worst}");
    }
}

#[test]
fn in_every_sample_the_layers_add_up_to_the_colour() {
    // emission + scatter is the beauty (without a floor): the samples are split so that
    // it holds in each, not only flattened; and the lights' layers add up to scatter.
    let dir = scratch("deep-aovs-sum");
    let (_, deep) = render(
        &dir,
        &fixture("pyro.vdb"),
        &[
            "--res",
            "48x27",
            "--float",
            "--spp",
            "2",
            "--light",
            "sun:0.6,1,0.5",
            "--light",
            "sun:-1,0.2,0.3:0.3,0.5,1:3",
        ],
    );
    let d = read_deep(&deep);
    let lights: Vec<String> = d
        .channels
        .iter()
        .filter(|c| c.starts_with("scatter_") && c.ends_with(".R"))
        .map(|c| c.trim_end_matches(".R").to_string())
        .collect();
    assert_eq!(lights.len(), 2, "{:?}", d.channels);
    let mut checked = 0;
    for i in 0..d.pixels.len() {
        for (c, ch) in ["R", "G", "B"].iter().enumerate() {
            let rgb = d.channel(i, ch);
            let (e, s) = (
                d.channel(i, &format!("emission.{ch}")),
                d.channel(i, &format!("scatter.{ch}")),
            );
            let per: Vec<Vec<f32>> = lights
                .iter()
                .map(|l| d.channel(i, &format!("{l}.{ch}")))
                .collect();
            for k in 0..rgb.len() {
                let scale = 1e-5 * (1.0 + rgb[k].abs() as f64);
                let sum = (e[k] + s[k]) as f64;
                assert!(
                    (sum - rgb[k] as f64).abs() < scale,
                    "pixel {i} sample {k} channel {c}: {sum} against {}",
                    rgb[k]
                );
                let lights: f64 = per.iter().map(|p| p[k] as f64).sum();
                assert!((lights - s[k] as f64).abs() < scale, "pixel {i} sample {k}");
                checked += 1;
            }
        }
    }
    assert!(checked > 1000, "{checked} samples");
}

#[test]
fn an_emitting_slab_places_its_emission_by_its_closed_form() {
    // The slab fixture seen straight down (as in tests/deep_output.rs): a pure absorber
    // of σt = 3 over depth 4.025 to 5.025 that emits ε = 4 × (1, 0.45, 0.12) per unit
    // length where the density is 1. In front of depth d it has emitted
    // ε/σt (1 − e^{−σt (d − 4.025)}): in proportion to its opacity, which is how a deep
    // sample's colour is split. Flattened: ε/σt (1 − e^{−3}).
    let dir = scratch("deep-aovs-slab");
    let (flat, deep) = render(
        &dir,
        &fixture("slab.vdb"),
        &[
            &SLAB_VIEW[..],
            &[
                "--emission-grid",
                "density",
                "--emission-intensity",
                "4",
                "--float",
            ],
        ]
        .concat(),
    );
    let (d, f) = (read_deep(&deep), flat_channels(&flat));
    let i = 8 * 16 + 8;
    let color = [1.0, 0.45, 0.12];
    for (c, ch) in ["R", "G", "B"].iter().enumerate() {
        let eps = 4.0 * color[c];
        let whole = eps / 3.0 * (1.0 - (-3.0f64).exp());
        let name = format!("emission.{ch}");
        let got = flatten_channel(&d, i, &name);
        // The ramps of half a voxel at either face: the march's own error there.
        assert!(
            (got - whole).abs() < 2e-3 * whole,
            "{name}: {got} against {whole}"
        );
        assert!(
            (got - f[&name][i] as f64).abs() < 1e-4,
            "{name} against the flat layer"
        );
        // Split at depth d by OpenEXR's rule: what is in front.
        let (z, zb, a, v) = (
            d.channel(i, "Z"),
            d.channel(i, "ZBack"),
            d.channel(i, "A"),
            d.channel(i, &name),
        );
        for k in 0..=87 {
            let depth = 4.08 + 0.01 * k as f64;
            let want = eps / 3.0 * (1.0 - (-3.0 * (depth - 4.025)).exp());
            let (mut sum, mut t) = (0.0f64, 1.0f64);
            for s in 0..z.len() {
                let (z, zb, a, v) = (z[s] as f64, zb[s] as f64, a[s] as f64, v[s] as f64);
                if depth <= z {
                    break;
                }
                let f = if zb > z {
                    ((depth - z) / (zb - z)).min(1.0)
                } else {
                    1.0
                };
                // The part of the sample in front of `depth`: its opacity's share.
                let part = 1.0 - (1.0 - a).powf(f);
                sum += t * v * if a > 0.0 { part / a } else { f };
                t *= 1.0 - part;
                if f < 1.0 {
                    break;
                }
            }
            // The deep tolerance (0.01) bounds colour relative to the pixel's.
            assert!(
                (sum - want).abs() <= 0.01 * whole + 2e-3 * whole,
                "{name} in front of {depth}: {sum} against {want}"
            );
        }
    }
}

#[test]
fn openimageio_reads_the_aovs_and_flattens_them_to_the_flat_layers() {
    need!(tools::EXRHEADER, tools::OIIOTOOL);
    let dir = scratch("deep-aovs-peers");
    let (flat, deep) = render(&dir, &fixture("pyro.vdb"), &["--res", "64x36", "--float"]);
    let header = common::exrheader(&deep);
    for ch in ["emission.R", "scatter.B", "indirect.G"] {
        assert!(header.contains(ch), "{ch} not in {header}");
    }
    let info = common::oiio_info(&deep);
    assert!(info.contains("deep"), "{info}");
    let peer = dir.join("oiio_flat.exr");
    common::tool(
        "oiiotool",
        &[
            deep.to_str().unwrap(),
            "--flatten",
            "-d",
            "float",
            "-o",
            peer.to_str().unwrap(),
        ],
        "openimageio-tools",
    );
    let (p, f) = (flat_channels(&peer), flat_channels(&flat));
    let mut worst: f64 = 0.0;
    for c in [
        "emission.R",
        "emission.G",
        "scatter.R",
        "scatter.B",
        "indirect.G",
    ] {
        assert!(
            p.contains_key(c),
            "OpenImageIO's flattening has no {c}: {:?}",
            p.keys()
        );
        for (a, b) in p[c].iter().zip(&f[c]) {
            worst = worst.max((a - b).abs() as f64);
        }
    }
    assert!(worst < 1e-4, "OpenImageIO's flattening differs by {worst}");
}

#[test]
fn bad_aov_lists_are_refused_in_one_line() {
    let dir = scratch("deep-aovs-refusals");
    let cloud = fixture("cloud.vdb");
    let base = ["render", &cloud, "-o", "a.exr", "--res", "16x9"];
    let with = |extra: &[&'static str]| [&base[..], extra].concat();
    refused(
        &dir,
        &with(&["--deep", "d.exr", "--deep-aovs", "emission,glow"]),
        "--deep-aovs",
    );
    refused(&dir, &with(&["--deep-aovs", "scatter"]), "--deep");
    // The cloud emits nothing, and one light writes no per-light layers.
    refused(
        &dir,
        &with(&["--deep", "d.exr", "--deep-aovs", "emission"]),
        "emission",
    );
    refused(
        &dir,
        &with(&["--deep", "d.exr", "--deep-aovs", "lights"]),
        "lights",
    );
    assert!(!dir.join("a.exr").exists() && !dir.join("d.exr").exists());
}
