//! `--holdout-deep FILE.exr`: a deep image from the render's own camera as the holdout.
//! Read here (the `exr` crate reads no deep data): single-part deep scanline OpenEXR,
//! NONE, RLE, ZIPS or ZIP compression (the ones OpenEXR allows deep data), channels
//! `A` and `Z` (and `ZBack`) of any pixel type. Each pixel's holdout depth is the front
//! (`Z`) of the sample at which its accumulated alpha, front to back, reaches
//! [`OPAQUE`]: rays stop there, as at a `--holdout-depth` depth. Partly transparent
//! samples in front of it (a CG edge, glass, hair) do not cut.

use flate2::read::ZlibDecoder;
use std::io::Read;
use std::path::Path;

/// The accumulated alpha at which a deep holdout is opaque.
pub const OPAQUE: f64 = 0.999;

/// Most samples a holdout may hold in all (2³⁰: 16 GiB of float `A` and `Z` alone).
const MOST_SAMPLES: u64 = 1 << 30;

/// Most bytes of samples one chunk may unpack to (1 GiB: a 16-line chunk of an 8K deep
/// render at 200 samples a pixel of 10 channels is a fifth of it). A chunk is unpacked
/// whole, so this bounds what a small file that claims much can make murk allocate.
const MOST_CHUNK_BYTES: u64 = 1 << 30;

fn i32_at(b: &[u8], at: usize) -> Result<i32, String> {
    b.get(at..at + 4)
        .map(|s| i32::from_le_bytes([s[0], s[1], s[2], s[3]]))
        .ok_or_else(|| "truncated".to_string())
}

fn u64_at(b: &[u8], at: usize) -> Result<u64, String> {
    let s = b.get(at..at + 8).ok_or("truncated")?;
    let mut v = [0u8; 8];
    v.copy_from_slice(s);
    Ok(u64::from_le_bytes(v))
}

fn cstr<'b>(b: &'b [u8], at: &mut usize) -> Result<&'b str, String> {
    let rest = b.get(*at..).ok_or("truncated header")?;
    let end = rest
        .iter()
        .position(|&c| c == 0)
        .ok_or("truncated header")?;
    *at += end + 1;
    std::str::from_utf8(&rest[..end]).map_err(|_| "a header name that is not UTF-8".into())
}

/// A channel of the file: name, pixel type (0 uint, 1 half, 2 float).
struct Channel {
    name: String,
    kind: i32,
}

impl Channel {
    fn size(&self) -> usize {
        if self.kind == 1 { 2 } else { 4 }
    }
}

/// What of the header a holdout needs.
struct Header {
    channels: Vec<Channel>,
    compression: u8,
    data: [i32; 4],
    display: [i32; 4],
    end: usize,
}

fn header(b: &[u8]) -> Result<Header, String> {
    if i32_at(b, 0)? != 20000630 {
        return Err("not an EXR".into());
    }
    let version = i32_at(b, 4)?;
    if version & 0x1000 != 0 {
        return Err(
            "a multi-part EXR; --holdout-deep takes a single-part deep scanline image".into(),
        );
    }
    if version & 0x800 == 0 {
        return Err("not a deep image; --holdout-deep takes a deep scanline EXR (--holdout-depth takes a flat depth image)".into());
    }
    let mut at = 8;
    let (mut channels, mut compression, mut data, mut display, mut kind) =
        (None, None, None, None, None);
    loop {
        let name = cstr(b, &mut at)?;
        if name.is_empty() {
            break;
        }
        let ty = cstr(b, &mut at)?;
        let size = usize::try_from(i32_at(b, at)?).map_err(|_| "a negative attribute size")?;
        at += 4;
        let value = b.get(at..at + size).ok_or("truncated header")?;
        at += size;
        let box2i = |v: &[u8]| -> Result<[i32; 4], String> {
            Ok([i32_at(v, 0)?, i32_at(v, 4)?, i32_at(v, 8)?, i32_at(v, 12)?])
        };
        match (name, ty) {
            ("channels", "chlist") => {
                let mut list = Vec::new();
                let mut p = 0;
                loop {
                    let n = cstr(value, &mut p)?;
                    if n.is_empty() {
                        break;
                    }
                    let k = i32_at(value, p)?;
                    if !(0..=2).contains(&k) {
                        return Err(format!("channel `{n}` has an unknown pixel type {k}"));
                    }
                    list.push(Channel {
                        name: n.to_string(),
                        kind: k,
                    });
                    p += 16;
                }
                channels = Some(list);
            }
            ("compression", "compression") => compression = value.first().copied(),
            ("dataWindow", "box2i") => data = Some(box2i(value)?),
            ("displayWindow", "box2i") => display = Some(box2i(value)?),
            ("type", "string") => kind = Some(String::from_utf8_lossy(value).into_owned()),
            _ => {}
        }
    }
    if kind.as_deref() != Some("deepscanline") {
        return Err(format!(
            "a {} image; --holdout-deep takes a deep scanline EXR",
            kind.as_deref().unwrap_or("untyped")
        ));
    }
    let (Some(channels), Some(compression), Some(data), Some(display)) =
        (channels, compression, data, display)
    else {
        return Err("a header without channels, compression or windows".into());
    };
    if !matches!(compression, 0..=3) {
        let name = [
            "", "", "", "", "PIZ", "PXR24", "B44", "B44A", "DWAA", "DWAB",
        ]
        .get(compression as usize)
        .copied()
        .unwrap_or("unknown");
        return Err(format!(
            "{name} compression ({compression}); deep images take NONE, RLE, ZIPS or ZIP"
        ));
    }
    Ok(Header {
        channels,
        compression,
        data,
        display,
        end: at,
    })
}

/// Undoes OpenEXR's predictor and even/odd split (after zlib or RLE).
fn unpredict(mut t: Vec<u8>) -> Vec<u8> {
    for i in 1..t.len() {
        t[i] = t[i - 1].wrapping_add(t[i]).wrapping_sub(128);
    }
    let half = t.len().div_ceil(2);
    (0..t.len())
        .map(|i| {
            if i % 2 == 0 {
                t[i / 2]
            } else {
                t[half + i / 2]
            }
        })
        .collect()
}

/// OpenEXR's run-length code: a negative count −n then n bytes as they are, a count n
/// then one byte n + 1 times.
fn unrle(packed: &[u8], size: usize) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(size.min(packed.len().saturating_mul(128)));
    let mut i = 0;
    while i < packed.len() && out.len() < size {
        let n = packed[i] as i8;
        i += 1;
        if n < 0 {
            let run = packed
                .get(i..i + (-(n as i32)) as usize)
                .ok_or("a truncated RLE run")?;
            out.extend_from_slice(run);
            i += run.len();
        } else {
            let v = *packed.get(i).ok_or("a truncated RLE run")?;
            out.extend(std::iter::repeat_n(v, n as usize + 1));
            i += 1;
        }
    }
    Ok(out)
}

/// One packed block of `size` bytes unpacked (stored as is where packing did not help).
fn unpack(packed: &[u8], size: usize, compression: u8) -> Result<Vec<u8>, String> {
    let out = if packed.len() >= size || compression == 0 {
        packed.to_vec()
    } else if compression == 1 {
        unpredict(unrle(packed, size)?)
    } else {
        let mut t = Vec::new();
        ZlibDecoder::new(packed)
            .take(size as u64 + 1)
            .read_to_end(&mut t)
            .map_err(|e| format!("corrupt ZIP data: {e}"))?;
        unpredict(t)
    };
    if out.len() != size {
        return Err(format!(
            "a block of {} bytes where {size} were due",
            out.len()
        ));
    }
    Ok(out)
}

fn value(bytes: &[u8], kind: i32) -> f64 {
    match kind {
        1 => exr::prelude::f16::from_bits(u16::from_le_bytes([bytes[0], bytes[1]])).to_f64(),
        2 => f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f64,
        _ => u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f64,
    }
}

/// Reads the holdout depth of every pixel of a `width`×`height` frame, `overscan`
/// (x, y) of it beyond the image on each side (`+inf`: none): the holdout's
/// displayWindow is the image, its data window may cover the overscan too.
pub fn load(
    path: &Path,
    width: usize,
    height: usize,
    overscan: (usize, usize),
) -> Result<Vec<f32>, String> {
    let b = std::fs::read(path).map_err(|e| e.to_string())?;
    let h = header(&b)?;
    let [dx0, dy0, dx1, dy1] = h.display;
    let (dw, dh) = (dx1 as i64 - dx0 as i64 + 1, dy1 as i64 - dy0 as i64 + 1);
    let image = (
        width.saturating_sub(2 * overscan.0) as i64,
        height.saturating_sub(2 * overscan.1) as i64,
    );
    if (dw, dh) != image {
        return Err(format!(
            "its image is {dw}x{dh}, the render {}x{}: a holdout comes from the same camera at the same size",
            image.0, image.1
        ));
    }
    let find = |n: &str| h.channels.iter().position(|c| c.name == n);
    let (Some(ca), Some(cz)) = (find("A"), find("Z")) else {
        return Err("a deep image without `A` and `Z` channels".into());
    };
    let [x0, y0, x1, y1] = h.data;
    let w = (x1 as i64 - x0 as i64 + 1).max(0) as usize;
    let rows = (y1 as i64 - y0 as i64 + 1).max(0) as usize;
    if w == 0 || rows == 0 {
        return Ok(vec![f32::INFINITY; width * height]);
    }
    if w > 1 << 24 || rows > 1 << 24 {
        return Err(format!("a data window of {w}x{rows} pixels"));
    }
    let lines = if h.compression == 3 { 16 } else { 1 };
    let chunks = rows.div_ceil(lines);
    let mut depths = vec![f32::INFINITY; width * height];
    let mut total: u64 = 0;
    let per_sample: usize = h.channels.iter().map(Channel::size).sum();
    for c in 0..chunks {
        let at = usize::try_from(u64_at(&b, h.end + 8 * c)?)
            .ok()
            .filter(|&at| at < b.len())
            .ok_or("a chunk offset past the file's end")?;
        let y = i32_at(&b, at)?;
        let first = y as i64 - y0 as i64;
        if first < 0 || first as usize >= rows {
            return Err(format!("a chunk at row {y}, outside the data window"));
        }
        let n_lines = lines.min(rows - first as usize);
        let (pc, pd, ud) = (
            u64_at(&b, at + 4)?,
            u64_at(&b, at + 12)?,
            u64_at(&b, at + 20)?,
        );
        let counts_at = at + 28;
        let data_at = counts_at.checked_add(pc as usize).ok_or("truncated")?;
        let packed_counts = b.get(counts_at..data_at).ok_or("truncated")?;
        let packed_data = b
            .get(data_at..data_at.checked_add(pd as usize).ok_or("truncated")?)
            .ok_or("truncated")?;
        let table = unpack(packed_counts, n_lines * w * 4, h.compression)?;
        // Per line, cumulative counts across it.
        let mut counts = Vec::with_capacity(n_lines * w);
        for line in 0..n_lines {
            let mut last = 0i64;
            for x in 0..w {
                let cum = i32_at(&table, (line * w + x) * 4)? as i64;
                if cum < last {
                    return Err(format!(
                        "sample counts that decrease, at row {}",
                        y as i64 + line as i64
                    ));
                }
                counts.push((cum - last) as usize);
                last = cum;
            }
        }
        let n: usize = counts.iter().sum();
        total += n as u64;
        if total > MOST_SAMPLES {
            return Err(format!("more than {MOST_SAMPLES} samples"));
        }
        if ud > MOST_CHUNK_BYTES {
            return Err(format!(
                "a chunk of {ud} bytes of samples, more than murk unpacks ({MOST_CHUNK_BYTES})"
            ));
        }
        if ud != (n * per_sample) as u64 {
            return Err(format!(
                "a chunk whose sample data is {ud} bytes for {n} samples"
            ));
        }
        let data = unpack(packed_data, n * per_sample, h.compression)?;
        // Channel c's samples start after those of the channels before it.
        let start = |c: usize| -> usize { h.channels[..c].iter().map(|ch| ch.size() * n).sum() };
        let (sa, sz) = (start(ca), start(cz));
        let (ka, kz) = (h.channels[ca].kind, h.channels[cz].kind);
        let (na, nz) = (h.channels[ca].size(), h.channels[cz].size());
        let mut s = 0;
        let mut px: Vec<(f64, f64)> = Vec::new();
        for (i, &k) in counts.iter().enumerate() {
            px.clear();
            for j in s..s + k {
                let z = value(&data[sz + j * nz..], kz);
                let a = value(&data[sa + j * na..], ka);
                if z.is_nan() || a.is_nan() {
                    let (x, yy) = (x0 as i64 + (i % w) as i64, y as i64 + (i / w) as i64);
                    return Err(format!(
                        "NaN depths or alphas (the first at pixel {x},{yy}); give every sample a depth"
                    ));
                }
                px.push((z, a));
            }
            s += k;
            px.sort_by(|p, q| p.0.total_cmp(&q.0));
            let mut t = 1.0;
            let cut = px.iter().find(|(_, a)| {
                t *= 1.0 - a.clamp(0.0, 1.0);
                1.0 - t >= OPAQUE
            });
            let (x, yy) = (
                x0 as i64 + (i % w) as i64 - dx0 as i64 + overscan.0 as i64,
                y as i64 + (i / w) as i64 - dy0 as i64 + overscan.1 as i64,
            );
            if let Some((z, _)) = cut
                && (0..width as i64).contains(&x)
                && (0..height as i64).contains(&yy)
            {
                depths[yy as usize * width + x as usize] = *z as f32;
            }
        }
    }
    Ok(depths)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn run_length_code_as_openexr_writes_it() {
        // −3 then three bytes as they are; 4 then one byte five times.
        let packed = [(-3i8) as u8, 7, 8, 9, 4, 1];
        assert_eq!(unrle(&packed, 8).unwrap(), vec![7, 8, 9, 1, 1, 1, 1, 1]);
        assert!(unrle(&[(-3i8) as u8, 7], 3).is_err(), "a truncated run");
    }

    #[test]
    fn predictor_and_split_undone() {
        // Bytes 10, 20, 30, 40: split to 10, 30 | 20, 40; differences + 128 after the
        // first: 10, 148, 118, 148.
        assert_eq!(unpredict(vec![10, 148, 118, 148]), vec![10, 20, 30, 40]);
    }
}
