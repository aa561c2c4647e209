//! Decoding VTK data arrays: scalar types, byte order, ASCII numbers, base64, the
//! XML binary header and zlib blocks. Every size a file declares is checked against the
//! bytes available before anything is allocated.

use base64::Engine;
use std::io::Read;

/// A VTK scalar type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl Scalar {
    /// From an XML `type` attribute (`Float32`, `Int64`…) or a legacy type word
    /// (`float`, `double`, `int`, `vtktypeint64`…).
    pub fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "Int8" | "char" | "signed_char" => Scalar::I8,
            "UInt8" | "unsigned_char" | "bit" => Scalar::U8,
            "Int16" | "short" => Scalar::I16,
            "UInt16" | "unsigned_short" => Scalar::U16,
            "Int32" | "int" | "vtktypeint32" => Scalar::I32,
            "UInt32" | "unsigned_int" | "vtktypeuint32" => Scalar::U32,
            "Int64" | "long" | "vtktypeint64" | "vtkIdType" => Scalar::I64,
            "UInt64" | "unsigned_long" | "vtktypeuint64" => Scalar::U64,
            "Float32" | "float" => Scalar::F32,
            "Float64" | "double" => Scalar::F64,
            _ => return None,
        })
    }
    pub fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::I64 | Scalar::U64 | Scalar::F64 => 8,
        }
    }
    pub fn is_float(self) -> bool {
        matches!(self, Scalar::F32 | Scalar::F64)
    }
}

/// Numbers decoded from a file: integers stay exact.
#[derive(Clone, Debug, PartialEq)]
pub enum Numbers {
    Int(Vec<i64>),
    Float(Vec<f64>),
}

impl Numbers {
    pub fn into_f64(self) -> Vec<f64> {
        match self {
            Numbers::Int(v) => v.into_iter().map(|x| x as f64).collect(),
            Numbers::Float(v) => v,
        }
    }
    /// Integers, or an error naming `what` for floating-point data.
    pub fn into_ints(self, what: &str) -> Result<Vec<i64>, String> {
        match self {
            Numbers::Int(v) => Ok(v),
            Numbers::Float(v) => {
                // Some writers store ids as floats; accept exact integers only.
                v.into_iter()
                    .map(|x| {
                        if x.fract() == 0.0 && x.abs() < 9.0e15 {
                            Ok(x as i64)
                        } else {
                            Err(format!("{what} holds the non-integer {x}"))
                        }
                    })
                    .collect()
            }
        }
    }
}

/// Decodes `count` values of `ty` from raw bytes (`big` endian or little).
pub fn decode_binary(
    bytes: &[u8],
    ty: Scalar,
    count: usize,
    big: bool,
    what: &str,
) -> Result<Numbers, String> {
    let need = count
        .checked_mul(ty.size())
        .ok_or_else(|| format!("{what}: {count} values overflow"))?;
    if bytes.len() < need {
        return Err(format!(
            "{what}: truncated ({} bytes where {count} {ty:?} values need {need})",
            bytes.len()
        ));
    }
    let chunks = bytes[..need].chunks_exact(ty.size());
    macro_rules! conv {
        ($t:ty, $n:expr) => {
            chunks.map(|c| {
                let a: [u8; $n] = c.try_into().unwrap_or([0; $n]);
                if big {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }
            })
        };
    }
    Ok(match ty {
        Scalar::I8 => Numbers::Int(conv!(i8, 1).map(i64::from).collect()),
        Scalar::U8 => Numbers::Int(conv!(u8, 1).map(i64::from).collect()),
        Scalar::I16 => Numbers::Int(conv!(i16, 2).map(i64::from).collect()),
        Scalar::U16 => Numbers::Int(conv!(u16, 2).map(i64::from).collect()),
        Scalar::I32 => Numbers::Int(conv!(i32, 4).map(i64::from).collect()),
        Scalar::U32 => Numbers::Int(conv!(u32, 4).map(i64::from).collect()),
        Scalar::I64 => Numbers::Int(conv!(i64, 8).collect()),
        Scalar::U64 => Numbers::Int(
            conv!(u64, 8)
                .map(|v| i64::try_from(v).unwrap_or(i64::MAX))
                .collect(),
        ),
        Scalar::F32 => Numbers::Float(conv!(f32, 4).map(f64::from).collect()),
        Scalar::F64 => Numbers::Float(conv!(f64, 8).collect()),
    })
}

/// Parses whitespace-separated ASCII numbers: exactly `count` of them from `tokens`.
pub fn parse_ascii<'a>(
    tokens: &mut impl Iterator<Item = &'a str>,
    ty: Scalar,
    count: usize,
    what: &str,
) -> Result<Numbers, String> {
    if ty.is_float() {
        let mut v = Vec::with_capacity(count.min(1 << 20));
        for i in 0..count {
            let t = tokens
                .next()
                .ok_or_else(|| format!("{what}: truncated ({i} of {count} values)"))?;
            let x =
                parse_float(t).ok_or_else(|| format!("{what}: '{}' is not a number", short(t)))?;
            v.push(x);
        }
        Ok(Numbers::Float(v))
    } else {
        let mut v = Vec::with_capacity(count.min(1 << 20));
        for i in 0..count {
            let t = tokens
                .next()
                .ok_or_else(|| format!("{what}: truncated ({i} of {count} values)"))?;
            let x: i64 = t
                .parse()
                .map_err(|_| format!("{what}: '{}' is not an integer", short(t)))?;
            v.push(x);
        }
        Ok(Numbers::Int(v))
    }
}

fn parse_float(t: &str) -> Option<f64> {
    match t {
        "nan" | "NaN" | "-nan" => Some(f64::NAN),
        "inf" | "Infinity" => Some(f64::INFINITY),
        "-inf" | "-Infinity" => Some(f64::NEG_INFINITY),
        _ => t.parse().ok(),
    }
}

/// The first characters of a token, for a message.
pub fn short(t: &str) -> String {
    t.chars().take(24).collect()
}

fn b64(text: &[u8], what: &str) -> Result<Vec<u8>, String> {
    base64::engine::general_purpose::STANDARD
        .decode(text)
        .map_err(|e| format!("{what}: bad base64 ({e})"))
}

/// Length in base64 characters of `n` bytes encoded on their own (with padding).
fn b64_len(n: usize) -> usize {
    n.div_ceil(3) * 4
}

/// How the binary payload of an XML array is laid out.
#[derive(Clone, Copy, Debug)]
pub struct BinaryLayout {
    /// Header integers are UInt64 (else UInt32).
    pub header64: bool,
    pub big: bool,
    pub zlib: bool,
}

impl BinaryLayout {
    fn word(&self) -> usize {
        if self.header64 { 8 } else { 4 }
    }
    fn read_words(&self, b: &[u8], n: usize, what: &str) -> Result<Vec<u64>, String> {
        let ty = if self.header64 {
            Scalar::U64
        } else {
            Scalar::U32
        };
        match decode_binary(b, ty, n, self.big, what)? {
            Numbers::Int(v) => Ok(v.into_iter().map(|x| x as u64).collect()),
            Numbers::Float(_) => Err(format!("{what}: bad header")),
        }
    }
}

/// Size of the header of a binary block: one word uncompressed, `3 + blocks` words
/// compressed (the block count is the first word).
fn header_len(layout: &BinaryLayout, first: &[u8], what: &str) -> Result<usize, String> {
    if !layout.zlib {
        return Ok(layout.word());
    }
    let nb = layout.read_words(first, 1, what)?[0];
    // A block holds at least one compressed byte: more blocks than bytes is a lie.
    if nb > (1 << 40) {
        return Err(format!(
            "{what}: header declares {nb} compressed blocks (wrong byte order or header type?)"
        ));
    }
    Ok((3 + nb as usize) * layout.word())
}

/// Decodes a raw binary block (header + data, appended raw encoding) into exactly
/// `expect` bytes of array data.
pub fn decode_raw_block(
    block: &[u8],
    layout: &BinaryLayout,
    expect: usize,
    what: &str,
) -> Result<Vec<u8>, String> {
    let h = header_len(layout, block, what)?;
    if block.len() < h {
        return Err(format!("{what}: truncated binary header"));
    }
    decode_payload(&block[..h], &block[h..], layout, expect, what)
}

/// Decodes a base64 block (inline binary or appended base64): the header may be
/// encoded on its own (VTK, meshio compressed) or together with the data (meshio
/// uncompressed); both are tried.
pub fn decode_base64_block(
    text: &[u8],
    layout: &BinaryLayout,
    expect: usize,
    what: &str,
) -> Result<Vec<u8>, String> {
    let text: Vec<u8> = text
        .iter()
        .copied()
        .filter(|c| !c.is_ascii_whitespace())
        .collect();
    // The first word decodes the same either way (it is within the first 12 chars).
    let lead = b64_len(layout.word()).min(text.len());
    let first = b64(&text[..lead], what)?;
    let h = header_len(layout, &first, what)?;
    let split = b64_len(h);
    if text.len() >= split && h % 3 != 0 && text[split - 1] == b'=' {
        // Header encoded on its own (it ends in padding).
        let header = b64(&text[..split], what)?;
        let data = b64(&text[split..], what)?;
        return decode_payload(&header, &data, layout, expect, what);
    }
    if h % 3 == 0 && text.len() >= split {
        // A header of whole base64 groups: try it as its own stream first.
        if let (Ok(header), Ok(data)) = (b64(&text[..split], what), b64(&text[split..], what))
            && let Ok(v) = decode_payload(&header, &data, layout, expect, what)
        {
            return Ok(v);
        }
    }
    let all = b64(&text, what)?;
    if all.len() < h {
        return Err(format!("{what}: truncated binary header"));
    }
    decode_payload(&all[..h], &all[h..], layout, expect, what)
}

fn decode_payload(
    header: &[u8],
    data: &[u8],
    layout: &BinaryLayout,
    expect: usize,
    what: &str,
) -> Result<Vec<u8>, String> {
    if !layout.zlib {
        let n = layout.read_words(header, 1, what)?[0];
        if n != expect as u64 {
            return Err(format!(
                "{what}: header declares {n} bytes, the array needs {expect} \
                 (wrong byte order or header type?)"
            ));
        }
        if data.len() < expect {
            return Err(format!(
                "{what}: truncated ({} of {expect} bytes)",
                data.len()
            ));
        }
        return Ok(data[..expect].to_vec());
    }
    let words = layout.read_words(header, header.len() / layout.word(), what)?;
    let (nb, bs, last) = (words[0], words[1], words[2]);
    let sizes = &words[3..];
    let total = if nb == 0 {
        0
    } else {
        let last_size = if last == 0 { bs } else { last };
        (nb - 1)
            .checked_mul(bs)
            .and_then(|v| v.checked_add(last_size))
            .unwrap_or(u64::MAX)
    };
    if total != expect as u64 {
        return Err(format!(
            "{what}: compressed header declares {total} bytes, the array needs {expect} \
             (wrong byte order or header type?)"
        ));
    }
    let compressed: u64 = sizes.iter().fold(0u64, |a, &s| a.saturating_add(s));
    if compressed > data.len() as u64 {
        return Err(format!(
            "{what}: truncated ({} of {compressed} compressed bytes)",
            data.len()
        ));
    }
    // zlib inflates at most ~1032:1: a larger claim is a corrupt header, refused
    // before allocating for it.
    if expect as u64 > compressed.saturating_mul(1100).saturating_add(4096) {
        return Err(format!(
            "{what}: {expect} bytes cannot come from {compressed} compressed bytes"
        ));
    }
    let mut out = Vec::with_capacity(expect);
    let mut at = 0usize;
    for (i, &s) in sizes.iter().enumerate() {
        let want = if i + 1 == sizes.len() && last != 0 {
            last
        } else {
            bs
        } as usize;
        let chunk = &data[at..at + s as usize];
        at += s as usize;
        let before = out.len();
        flate2::read::ZlibDecoder::new(chunk)
            .take(want as u64 + 1)
            .read_to_end(&mut out)
            .map_err(|e| format!("{what}: zlib block {i}: {e}"))?;
        if out.len() - before != want {
            return Err(format!(
                "{what}: zlib block {i} inflates to {} bytes, the header says {want}",
                out.len() - before
            ));
        }
    }
    Ok(out)
}
