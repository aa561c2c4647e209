//! A minimal reader of single-part deep scanline EXRs (as the OpenEXR file layout gives
//! them; NONE and ZIPS compression), for the deep tests, and the
//! flat channels of an EXR through the `exr` crate. Half and float channels. And the
//! deep tests' render: a fixture into a flat file and a deep one.

use exr::prelude::{FlatSamples, read_all_flat_layers_from_file};
use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A deep image as read: per pixel, per channel name, the samples.
pub struct Deep {
    pub width: usize,
    pub height: usize,
    pub channels: Vec<String>,
    /// `pixels[y * width + x][sample][channel]`.
    pub pixels: Vec<Vec<Vec<f32>>>,
    pub attributes: BTreeMap<String, (String, Vec<u8>)>,
}

impl Deep {
    /// The value of channel `name` in each sample of pixel `i`.
    pub fn channel(&self, i: usize, name: &str) -> Vec<f32> {
        let c = self.channels.iter().position(|n| n == name).unwrap();
        self.pixels[i].iter().map(|s| s[c]).collect()
    }
}

fn i32_at(b: &[u8], at: usize) -> i32 {
    i32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}
fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().unwrap())
}
fn cstr(b: &[u8], at: &mut usize) -> String {
    let end = *at + b[*at..].iter().position(|&c| c == 0).unwrap();
    let s = String::from_utf8(b[*at..end].to_vec()).unwrap();
    *at = end + 1;
    s
}

/// Undoes OpenEXR's ZIP transform: zlib, the delta predictor, the even/odd split.
fn unzip(packed: &[u8], size: usize) -> Vec<u8> {
    if packed.len() >= size {
        return packed.to_vec();
    }
    let mut t = Vec::new();
    flate2::read::ZlibDecoder::new(packed)
        .read_to_end(&mut t)
        .unwrap();
    assert_eq!(t.len(), size);
    for i in 1..t.len() {
        t[i] = t[i - 1].wrapping_add(t[i]).wrapping_sub(128);
    }
    let half = size.div_ceil(2);
    (0..size)
        .map(|i| {
            if i % 2 == 0 {
                t[i / 2]
            } else {
                t[half + i / 2]
            }
        })
        .collect()
}

pub fn read_deep(path: &Path) -> Deep {
    let b = std::fs::read(path).unwrap();
    assert_eq!(i32_at(&b, 0), 20000630, "not an EXR");
    assert_ne!(i32_at(&b, 4) & 0x800, 0, "no deep (non-image) bit");
    let mut at = 8;
    let mut attributes = BTreeMap::new();
    while b[at] != 0 {
        let name = cstr(&b, &mut at);
        let kind = cstr(&b, &mut at);
        let size = i32_at(&b, at) as usize;
        at += 4;
        attributes.insert(name, (kind, b[at..at + size].to_vec()));
        at += size;
    }
    at += 1;
    let dw = &attributes["dataWindow"].1;
    let (x0, y0, x1, y1) = (i32_at(dw, 0), i32_at(dw, 4), i32_at(dw, 8), i32_at(dw, 12));
    let (width, height) = ((x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize);
    let mut channels = Vec::new();
    // Bytes per sample of each channel: 2 (half) or 4 (float).
    let mut sizes = Vec::new();
    let ch = &attributes["channels"].1;
    let mut c = 0;
    while ch[c] != 0 {
        channels.push(cstr(ch, &mut c));
        let kind = i32_at(ch, c);
        assert!(kind == 1 || kind == 2, "half and float channels only");
        sizes.push(if kind == 1 { 2 } else { 4 });
        c += 16;
    }
    let per_sample: usize = sizes.iter().sum();
    let mut pixels = vec![Vec::new(); width * height];
    for row in 0..height {
        let mut p = u64_at(&b, at + 8 * row) as usize;
        let y = (i32_at(&b, p) - y0) as usize;
        let (count_size, data_size, unpacked) =
            (u64_at(&b, p + 4), u64_at(&b, p + 12), u64_at(&b, p + 20));
        p += 28;
        let counts = unzip(&b[p..p + count_size as usize], 4 * width);
        p += count_size as usize;
        let data = unzip(&b[p..p + data_size as usize], unpacked as usize);
        let cum: Vec<usize> = (0..width)
            .map(|x| i32_at(&counts, 4 * x) as usize)
            .collect();
        let total = cum.last().copied().unwrap_or(0);
        assert_eq!(data.len(), total * per_sample);
        for x in 0..width {
            let first = if x == 0 { 0 } else { cum[x - 1] };
            let samples = (first..cum[x])
                .map(|s| {
                    (0..channels.len())
                        .map(|c| {
                            let start: usize = sizes[..c].iter().sum::<usize>() * total;
                            let o = start + sizes[c] * s;
                            if sizes[c] == 2 {
                                let bits = u16::from_le_bytes(data[o..o + 2].try_into().unwrap());
                                exr::prelude::f16::from_bits(bits).to_f32()
                            } else {
                                f32::from_le_bytes(data[o..o + 4].try_into().unwrap())
                            }
                        })
                        .collect()
                })
                .collect();
            pixels[y * width + x] = samples;
        }
    }
    Deep {
        width,
        height,
        channels,
        pixels,
        attributes,
    }
}

/// Channel name → values of a flat EXR (its data window is the whole image).
pub fn flat_channels(path: &Path) -> BTreeMap<String, Vec<f32>> {
    let image = read_all_flat_layers_from_file(path).unwrap();
    image.layer_data[0]
        .channel_data
        .list
        .iter()
        .map(|c| {
            let v = match &c.sample_data {
                FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
                FlatSamples::F32(v) => v.clone(),
                FlatSamples::U32(v) => v.iter().map(|&u| u as f32).collect(),
            };
            (c.name.to_string(), v)
        })
        .collect()
}

/// Flattens pixel `i` front to back with "over": `(R, G, B, A)`.
pub fn flatten(d: &Deep, i: usize) -> [f64; 4] {
    let (r, g, bl, a) = (
        d.channel(i, "R"),
        d.channel(i, "G"),
        d.channel(i, "B"),
        d.channel(i, "A"),
    );
    let (mut out, mut t) = ([0.0f64; 4], 1.0f64);
    for s in 0..a.len() {
        out[0] += t * r[s] as f64;
        out[1] += t * g[s] as f64;
        out[2] += t * bl[s] as f64;
        t *= 1.0 - a[s] as f64;
    }
    out[3] = 1.0 - t;
    out
}

/// Pixel `i`'s channel `name` flattened front to back ("over" with the samples' A).
pub fn flatten_channel(d: &Deep, i: usize, name: &str) -> f64 {
    let (v, a) = (d.channel(i, name), d.channel(i, "A"));
    let (mut sum, mut t) = (0.0f64, 1.0f64);
    for s in 0..a.len() {
        sum += t * v[s] as f64;
        t *= 1.0 - a[s] as f64;
    }
    sum
}

/// `fixtures/NAME` of this checkout.
pub fn fixture(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
        .display()
        .to_string()
}

/// Renders `input` with `--quiet`, `flags` then `args` into `dir`: the flat EXR
/// (`flat.exr`) and the deep one (`deep.exr`). A failed render fails the test.
pub fn render_deep(dir: &Path, input: &str, flags: &[&str], args: &[&str]) -> (PathBuf, PathBuf) {
    let (flat, deep) = (dir.join("flat.exr"), dir.join("deep.exr"));
    let out = Command::new(super::frames::MURK)
        .args(["render", input, "-o"])
        .arg(&flat)
        .arg("--deep")
        .arg(&deep)
        .arg("--quiet")
        .args(flags)
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "murk render {input} {flags:?} {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    (flat, deep)
}

/// The slab fixture (run from the checkout's root) seen from above, orthographic, absorbing
/// only: inside it α(d) = 1 − e^{−3 (d − 4.025)}. 16×16; the default (half) file, so a
/// test that wants float values adds `--float`.
pub const SLAB_VIEW: [&str; 17] = [
    "--res",
    "16x16",
    "--camera",
    "ortho",
    "--eye",
    "0,0,5",
    "--look-at",
    "0,0,0",
    "--up",
    "0,1,0",
    "--ortho-width",
    "1",
    "--no-lights",
    "--sigma-a",
    "3",
    "--sigma-s",
    "0",
];
