//! The layout of a (valid) VDB fixture, as far as the mutations need it.

#[derive(Debug, Clone, Copy)]
pub(crate) struct Str {
    /// Position of the u32 length.
    pub(crate) len_pos: usize,
    pub(crate) len: usize,
}

#[derive(Debug, Clone)]
pub(crate) struct MetaEntry {
    pub(crate) name: Str,
    pub(crate) type_name: Str,
    pub(crate) size_pos: usize,
    pub(crate) end: usize,
}

#[derive(Debug, Clone)]
pub(crate) struct Desc {
    pub(crate) start: usize,
    pub(crate) unique_name: Str,
    pub(crate) grid_type: Str,
    pub(crate) type_text: String,
    pub(crate) parent: Str,
    /// Position of the three i64 offsets.
    pub(crate) offsets_pos: usize,
    pub(crate) grid_pos: usize,
    /// Where the leaf buffers start (after the tree topology).
    pub(crate) block_pos: usize,
    pub(crate) end_pos: usize,
    /// Where the tree starts (after the grid head).
    pub(crate) tree_pos: usize,
    /// Grid head: compression u32, metadata, map type, map data.
    pub(crate) meta_count_pos: usize,
    pub(crate) meta: Vec<MetaEntry>,
    pub(crate) map_type: Str,
    pub(crate) map_data: usize,
    pub(crate) value_size: usize,
}

#[derive(Debug, Clone)]
pub(crate) struct Layout {
    pub(crate) len: usize,
    pub(crate) header_end: usize,
    pub(crate) meta_count_pos: usize,
    pub(crate) meta: Vec<MetaEntry>,
    pub(crate) grid_count_pos: usize,
    pub(crate) descs: Vec<Desc>,
    /// Byte-size field positions of Blosc frames found in the trees (`i64` chunk size).
    pub(crate) blosc_frames: Vec<usize>,
    /// Byte-size field positions of zip chunks (`i64`, positive or negative).
    pub(crate) zip_chunks: Vec<usize>,
}

pub(crate) struct Cur<'a> {
    pub(crate) b: &'a [u8],
    pub(crate) p: usize,
}

impl Cur<'_> {
    pub(crate) fn u32(&mut self) -> u32 {
        let v = u32::from_le_bytes(self.b[self.p..self.p + 4].try_into().unwrap());
        self.p += 4;
        v
    }
    pub(crate) fn i64(&mut self) -> i64 {
        let v = i64::from_le_bytes(self.b[self.p..self.p + 8].try_into().unwrap());
        self.p += 8;
        v
    }
    pub(crate) fn string(&mut self) -> (Str, String) {
        let len_pos = self.p;
        let len = self.u32() as usize;
        let s = String::from_utf8_lossy(&self.b[self.p..self.p + len]).into_owned();
        self.p += len;
        (Str { len_pos, len }, s)
    }
    pub(crate) fn meta_map(&mut self) -> (usize, Vec<MetaEntry>) {
        let count_pos = self.p;
        let n = self.u32();
        let mut v = Vec::new();
        for _ in 0..n {
            let (name, _) = self.string();
            let (type_name, _) = self.string();
            let size_pos = self.p;
            let size = self.u32() as usize;
            self.p += size;
            v.push(MetaEntry {
                name,
                type_name,
                size_pos,
                end: self.p,
            });
        }
        (count_pos, v)
    }
}

pub(crate) fn value_size(type_text: &str) -> usize {
    match type_text.trim_end_matches("_HalfFloat") {
        "Tree_double_5_4_3" | "Tree_int64_5_4_3" => 8,
        "Tree_vec3s_5_4_3" | "Tree_vec3i_5_4_3" => 12,
        "Tree_vec3d_5_4_3" => 24,
        "Tree_bool_5_4_3" | "Tree_mask_5_4_3" => 1,
        _ => 4,
    }
}

pub(crate) fn parse_layout(b: &[u8]) -> Layout {
    let mut c = Cur { b, p: 8 };
    let version = c.u32();
    assert!(
        version >= 222,
        "the fixtures are written in format 222 or later"
    );
    c.p += 4 + 4 + 1 + 36;
    let header_end = c.p;
    let (meta_count_pos, meta) = c.meta_map();
    let grid_count_pos = c.p;
    let count = c.u32();
    let mut descs = Vec::new();
    for _ in 0..count {
        let start = c.p;
        let (unique_name, _) = c.string();
        let (grid_type, type_text) = c.string();
        let (parent, _) = c.string();
        let offsets_pos = c.p;
        let grid_pos = c.i64() as usize;
        let block_pos = c.i64() as usize;
        let end_pos = c.i64() as usize;
        let mut h = Cur { b, p: grid_pos + 4 };
        let (gm_count_pos, gmeta) = h.meta_map();
        let (map_type, map_text) = h.string();
        let map_data = h.p;
        let map_len = match map_text.as_str() {
            "AffineMap" | "UnitaryMap" => 128,
            "ScaleMap" | "UniformScaleMap" => 120,
            "TranslationMap" => 24,
            "ScaleTranslateMap" | "UniformScaleTranslateMap" => 144,
            other => panic!("fixture map type {other}"),
        };
        descs.push(Desc {
            start,
            unique_name,
            grid_type,
            value_size: value_size(&type_text),
            type_text,
            parent,
            offsets_pos,
            grid_pos,
            block_pos,
            end_pos,
            tree_pos: map_data + map_len,
            meta_count_pos: gm_count_pos,
            meta: gmeta,
            map_type,
            map_data,
        });
        c.p = end_pos;
    }
    let (mut blosc_frames, mut zip_chunks) = (Vec::new(), Vec::new());
    for d in &descs {
        // Heuristic: an i64 chunk size followed by a Blosc 1.x header (version 2, LZ4 1)
        // whose total size field equals the chunk size.
        let mut p = d.tree_pos;
        while p + 24 <= d.end_pos {
            let n = i64::from_le_bytes(b[p..p + 8].try_into().unwrap());
            if n > 16 && (n as usize) < 1 << 20 {
                let h = &b[p + 8..];
                let ct = u32::from_le_bytes(h[12..16].try_into().unwrap()) as i64;
                if h[0] == 2 && h[1] == 1 && ct == n {
                    blosc_frames.push(p);
                    p += 8 + n as usize;
                    continue;
                }
                if h[0] == 0x78 && matches!(h[1], 0x01 | 0x5e | 0x9c | 0xda) {
                    zip_chunks.push(p);
                }
            } else if (-65536..-16).contains(&n) && (-n) % 4 == 0 && zip_chunks.len() < 10_000 {
                zip_chunks.push(p);
            }
            p += 1;
        }
    }
    Layout {
        len: b.len(),
        header_end,
        meta_count_pos,
        meta,
        grid_count_pos,
        descs,
        blosc_frames,
        zip_chunks,
    }
}
