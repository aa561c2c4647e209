//! Robustness against malformed files: every fixture is mutated (truncations, bit flips,
//! byte overwrites and structural edits such as huge length fields, bad offsets, renamed
//! grid types, cyclic instances, nested frustum maps and corrupted Blosc frames) and
//! `murk info --stats --json` is run on each mutant in a child process, under a time
//! limit and an address-space limit; every 16th mutant (every 4th in the long run) is
//! also rendered (`murk render`, a small image, default flags) under its own limits. Every run must end cleanly: exit 0 with JSON on
//! stdout, or exit 2 with exactly one line `murk: error: <path>: ...` on stderr. A panic,
//! abort (stack overflow, failed allocation), signal or hang fails the test; the failing
//! mutants are kept in `target/tmp/mutation-failures-<run>/` and named in the message.
//!
//! `cargo test --test mutation -- --nocapture` runs the default set (a few thousand
//! mutants) and prints the summary; `-- --ignored` runs the long one. Set
//! `MUTATION_FILTER=<text>` to run only the mutants whose names contain `<text>` (names
//! are `<fixture>-<index>-<mutation>`, as in the failure list).

use murk::field::random::SplitMix64;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// Mutants in the default test (the requirement is at least 2,000).
const DEFAULT_MUTANTS: usize = 3000;
/// The default test runs every n-th structural mutant (the long test runs all of them).
const DEFAULT_STRUCTURAL_STEP: usize = 2;
/// Mutants in the ignored long test (the requirement is at least 20,000).
const LONG_MUTANTS: usize = 24000;
/// A child running longer than this is a hang.
const TIMEOUT: Duration = Duration::from_secs(10);
/// Address-space limit for each child, in KiB (`ulimit -v`). The fixtures are at most
/// half a megabyte and murk needs well under 64 MiB for any of them, so an allocation
/// that does not fit into 512 MiB is out of all proportion to the input.
const MEMORY_LIMIT_KIB: u64 = 512 * 1024;
/// Concurrent children (the machine has few cores; the children are short).
const WORKERS: usize = 3;
/// Every n-th mutant is also rendered (`murk render`, default flags but a small image:
/// the shadow bake, the march and the EXR writer see the mutant too); the long test
/// renders every `LONG_RENDER_STEP`-th.
const DEFAULT_RENDER_STEP: usize = 16;
const LONG_RENDER_STEP: usize = 4;
/// A render may take this long (a bake of a mutant is bounded by the bake's budgets,
/// which a loaded machine runs in well under a minute).
const RENDER_TIMEOUT: Duration = Duration::from_secs(60);
/// Address space for a render: its worker threads' stacks and the frame need more than
/// `info` does, but nothing near this for a half-megabyte fixture.
const RENDER_MEMORY_LIMIT_KIB: u64 = 2048 * 1024;

// ------------------------------------------------------------------------------------
// A small deterministic PRNG over the crate's SplitMix64.

struct Rng(SplitMix64);

impl Rng {
    fn new(seed: u64) -> Self {
        Rng(SplitMix64(seed))
    }
    fn next(&mut self) -> u64 {
        self.0.next_u64()
    }
    /// Uniform in `0..n` (`n > 0`).
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn byte(&mut self) -> u8 {
        self.next() as u8
    }
    fn pick<'a, T>(&mut self, v: &'a [T]) -> &'a T {
        &v[self.below(v.len())]
    }
}

fn seed_of(name: &str, base: u64) -> u64 {
    // FNV-1a of the fixture name, mixed with the base seed.
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for b in name.bytes() {
        h = (h ^ b as u64).wrapping_mul(0x100_0000_01b3);
    }
    h ^ base
}

// ------------------------------------------------------------------------------------
// The layout of a (valid) fixture, as far as the mutations need it.

#[derive(Debug, Clone, Copy)]
struct Str {
    /// Position of the u32 length.
    len_pos: usize,
    len: usize,
}

#[derive(Debug, Clone)]
struct MetaEntry {
    name: Str,
    type_name: Str,
    size_pos: usize,
    end: usize,
}

#[derive(Debug, Clone)]
struct Desc {
    start: usize,
    unique_name: Str,
    grid_type: Str,
    type_text: String,
    parent: Str,
    /// Position of the three i64 offsets.
    offsets_pos: usize,
    grid_pos: usize,
    /// Where the leaf buffers start (after the tree topology).
    block_pos: usize,
    end_pos: usize,
    /// Where the tree starts (after the grid head).
    tree_pos: usize,
    /// Grid head: compression u32, metadata, map type, map data.
    meta_count_pos: usize,
    meta: Vec<MetaEntry>,
    map_type: Str,
    map_data: usize,
    value_size: usize,
}

#[derive(Debug, Clone)]
struct Layout {
    len: usize,
    header_end: usize,
    meta_count_pos: usize,
    meta: Vec<MetaEntry>,
    grid_count_pos: usize,
    descs: Vec<Desc>,
    /// Byte-size field positions of Blosc frames found in the trees (`i64` chunk size).
    blosc_frames: Vec<usize>,
    /// Byte-size field positions of zip chunks (`i64`, positive or negative).
    zip_chunks: Vec<usize>,
}

struct Cur<'a> {
    b: &'a [u8],
    p: usize,
}

impl Cur<'_> {
    fn u32(&mut self) -> u32 {
        let v = u32::from_le_bytes(self.b[self.p..self.p + 4].try_into().unwrap());
        self.p += 4;
        v
    }
    fn i64(&mut self) -> i64 {
        let v = i64::from_le_bytes(self.b[self.p..self.p + 8].try_into().unwrap());
        self.p += 8;
        v
    }
    fn string(&mut self) -> (Str, String) {
        let len_pos = self.p;
        let len = self.u32() as usize;
        let s = String::from_utf8_lossy(&self.b[self.p..self.p + len]).into_owned();
        self.p += len;
        (Str { len_pos, len }, s)
    }
    fn meta_map(&mut self) -> (usize, Vec<MetaEntry>) {
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

fn value_size(type_text: &str) -> usize {
    match type_text.trim_end_matches("_HalfFloat") {
        "Tree_double_5_4_3" | "Tree_int64_5_4_3" => 8,
        "Tree_vec3s_5_4_3" | "Tree_vec3i_5_4_3" => 12,
        "Tree_vec3d_5_4_3" => 24,
        "Tree_bool_5_4_3" | "Tree_mask_5_4_3" => 1,
        _ => 4,
    }
}

fn parse_layout(b: &[u8]) -> Layout {
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

// ------------------------------------------------------------------------------------
// Mutants: a name and an edit, applied to the fixture's bytes only when the mutant runs.

enum Edit {
    Truncate(usize),
    /// Overwrite bytes (positions past the end are ignored).
    Patch(Vec<(usize, Vec<u8>)>),
    /// Replace `remove` bytes at `at` by `insert`, fixing the descriptor offsets; applied
    /// in order, each to the result of the previous one.
    Splice(Vec<(usize, usize, Vec<u8>)>),
    /// Raw edits that shift the rest of the file without fixing offsets.
    Duplicate {
        at: usize,
        n: usize,
    },
    Delete {
        at: usize,
        n: usize,
    },
    CopyOver {
        from: usize,
        to: usize,
        n: usize,
    },
    /// `copies` extra grids, each an instance of grid `grid` with a copy of its head;
    /// optionally without grid offsets (the reader then loads everything when opening).
    InstanceBomb {
        grid: usize,
        copies: usize,
        stream: bool,
    },
}

struct Mutant {
    fixture: usize,
    name: String,
    edit: Edit,
}

struct Fixture {
    stem: String,
    bytes: Vec<u8>,
}

fn apply(b: &[u8], edit: &Edit) -> Vec<u8> {
    match edit {
        Edit::Truncate(n) => b[..(*n).min(b.len())].to_vec(),
        Edit::Patch(patches) => {
            let mut m = b.to_vec();
            for (at, bytes) in patches {
                for (k, v) in bytes.iter().enumerate() {
                    if let Some(x) = m.get_mut(at + k) {
                        *x = *v;
                    }
                }
            }
            m
        }
        Edit::Splice(steps) => {
            let mut m = b.to_vec();
            for (at, remove, insert) in steps {
                let l = parse_layout(&m);
                m = splice(&m, &l, *at, *remove, insert);
            }
            m
        }
        Edit::Duplicate { at, n } => {
            let mut m = b.to_vec();
            let end = (at + n).min(m.len());
            let region = m[*at..end].to_vec();
            m.splice(end..end, region);
            m
        }
        Edit::Delete { at, n } => {
            let mut m = b.to_vec();
            let end = (at + n).min(m.len());
            m.drain(*at..end);
            m
        }
        Edit::CopyOver { from, to, n } => {
            let mut m = b.to_vec();
            let region = m[*from..from + n].to_vec();
            m[*to..to + n].copy_from_slice(&region);
            m
        }
        Edit::InstanceBomb {
            grid,
            copies,
            stream,
        } => instance_bomb(b, *grid, *copies, *stream),
    }
}

fn instance_bomb(b: &[u8], grid: usize, copies: usize, stream: bool) -> Vec<u8> {
    let l = parse_layout(b);
    let d = &l.descs[grid];
    let name = name_bytes(b, d.unique_name);
    let type_name = name_bytes(b, d.grid_type);
    // The copies' heads: compression, no metadata, the transform.
    let mut head = b[d.grid_pos..d.grid_pos + 4].to_vec();
    head.extend(0u32.to_le_bytes());
    head.extend_from_slice(&b[d.map_type.len_pos..d.tree_pos]);
    let mut m = b[..l.grid_count_pos].to_vec();
    m.extend((l.descs.len() as u32 + copies as u32).to_le_bytes());
    m.extend_from_slice(&b[l.grid_count_pos + 4..]);
    // The count grows but nothing moves: the copies are appended after the last grid.
    for k in 0..copies {
        m.extend(vdb_string(format!("copy{k}").as_bytes()));
        m.extend(vdb_string(&type_name));
        m.extend(vdb_string(&name));
        let grid_pos = m.len() as i64 + 24;
        let end_pos = grid_pos + head.len() as i64;
        for v in [grid_pos, end_pos, end_pos] {
            m.extend(v.to_le_bytes());
        }
        m.extend_from_slice(&head);
    }
    if stream {
        m[20] = 0;
    }
    m
}

fn p32(at: usize, v: u32) -> Edit {
    Edit::Patch(vec![(at, v.to_le_bytes().to_vec())])
}

fn p64(at: usize, v: i64) -> Edit {
    Edit::Patch(vec![(at, v.to_le_bytes().to_vec())])
}

fn p8(at: usize, v: u8) -> Edit {
    Edit::Patch(vec![(at, vec![v])])
}

fn put_i64(b: &mut [u8], at: usize, v: i64) {
    if at + 8 <= b.len() {
        b[at..at + 8].copy_from_slice(&v.to_le_bytes());
    }
}

fn vdb_string(s: &[u8]) -> Vec<u8> {
    let mut v = (s.len() as u32).to_le_bytes().to_vec();
    v.extend_from_slice(s);
    v
}

/// Replaces `b[at..at + remove]` by `insert` and shifts every descriptor offset that
/// points past `at`, so the rest of the file stays reachable.
fn splice(b: &[u8], l: &Layout, at: usize, remove: usize, insert: &[u8]) -> Vec<u8> {
    let delta = insert.len() as i64 - remove as i64;
    let mut out = Vec::with_capacity(b.len() + insert.len());
    out.extend_from_slice(&b[..at]);
    out.extend_from_slice(insert);
    out.extend_from_slice(&b[at + remove..]);
    for d in &l.descs {
        if d.offsets_pos >= at && d.offsets_pos < at + remove {
            continue; // the edit replaced these offsets
        }
        let pos = if d.offsets_pos >= at + remove {
            (d.offsets_pos as i64 + delta) as usize
        } else {
            d.offsets_pos
        };
        for k in 0..3 {
            let f = pos + 8 * k;
            let v = i64::from_le_bytes(out[f..f + 8].try_into().unwrap());
            if v as usize > at {
                put_i64(&mut out, f, v + delta);
            }
        }
    }
    out
}

/// The fields of a frustum map before its second map (bbox, taper, depth).
fn frustum_head() -> Vec<u8> {
    let mut v = vdb_string(b"NonlinearFrustumMap");
    for x in [-1.0f64, -1.0, 0.0, 1.0, 1.0, 1.0, 0.5, 2.0] {
        v.extend_from_slice(&x.to_le_bytes());
    }
    v
}

fn uniform_scale_map() -> Vec<u8> {
    let mut v = vdb_string(b"UniformScaleMap");
    for x in [
        0.1f64, 0.1, 0.1, 0.1, 0.1, 0.1, 10.0, 10.0, 10.0, 100.0, 100.0, 100.0, 5.0, 5.0, 5.0,
    ] {
        v.extend_from_slice(&x.to_le_bytes());
    }
    v
}

fn one_splice(at: usize, remove: usize, insert: Vec<u8>) -> Edit {
    Edit::Splice(vec![(at, remove, insert)])
}

fn name_bytes(b: &[u8], s: Str) -> Vec<u8> {
    b[s.len_pos + 4..s.len_pos + 4 + s.len].to_vec()
}

/// Mutations that need to know the file's layout: huge lengths and counts, bad offsets,
/// renamed types, instance cycles, frustum maps, corrupted Blosc and zip chunks.
fn structural(b: &[u8], l: &Layout) -> Vec<(String, Edit)> {
    let mut out: Vec<(String, Edit)> = Vec::new();
    let mut add = |name: String, edit: Edit| out.push((name, edit));
    const HUGE32: [u32; 5] = [
        0xFFFF_FFFF,
        0x7FFF_FFFF,
        0x8000_0000,
        0x00FF_FFFF,
        0x0001_0000,
    ];

    // Header.
    add("no-grid-offsets".into(), p8(20, 0));
    for v in [0u32, 219, 220, 221, 222, 223, 225, 226, 0xFFFF_FFFF] {
        add(format!("file-version-{v}"), p32(8, v));
    }
    for v in [220u32, 221] {
        // Old versions without grid offsets: the whole file is read sequentially.
        add(
            format!("file-version-{v}-stream"),
            Edit::Patch(vec![(8, v.to_le_bytes().to_vec()), (20, vec![0])]),
        );
    }
    add("magic".into(), p8(0, b[0] ^ 1));
    add("library-version".into(), p32(12, 0xFFFF_FFFF));

    // File metadata.
    for v in HUGE32 {
        add(format!("file-meta-count-{v:x}"), p32(l.meta_count_pos, v));
    }
    for (i, e) in l.meta.iter().enumerate().take(3) {
        for v in HUGE32 {
            add(
                format!("file-meta{i}-name-len-{v:x}"),
                p32(e.name.len_pos, v),
            );
            add(
                format!("file-meta{i}-type-len-{v:x}"),
                p32(e.type_name.len_pos, v),
            );
            add(format!("file-meta{i}-size-{v:x}"), p32(e.size_pos, v));
        }
        add(format!("file-meta{i}-size-0"), p32(e.size_pos, 0));
    }

    // Grid count.
    let n = l.descs.len() as u32;
    for v in [
        0u32,
        0xFFFF_FFFF,
        0x7FFF_FFFF,
        0x8000_0000,
        n + 1,
        n.saturating_sub(1),
    ] {
        add(format!("grid-count-{v:x}"), p32(l.grid_count_pos, v));
    }

    // Descriptors and grid heads.
    for (i, d) in l.descs.iter().enumerate() {
        for v in HUGE32 {
            add(
                format!("g{i}-name-len-{v:x}"),
                p32(d.unique_name.len_pos, v),
            );
            add(format!("g{i}-type-len-{v:x}"), p32(d.grid_type.len_pos, v));
            add(format!("g{i}-parent-len-{v:x}"), p32(d.parent.len_pos, v));
            add(format!("g{i}-meta-count-{v:x}"), p32(d.meta_count_pos, v));
            add(
                format!("g{i}-map-type-len-{v:x}"),
                p32(d.map_type.len_pos, v),
            );
        }
        let other = &l.descs[(i + 1) % l.descs.len()];
        let len = l.len as i64;
        let values = [
            0,
            -1,
            i64::MIN,
            i64::MAX,
            len,
            len - 1,
            len + 4096,
            l.header_end as i64,
            d.start as i64,
            other.grid_pos as i64,
            other.block_pos as i64,
            d.block_pos as i64,
            d.end_pos as i64,
            d.grid_pos as i64 + 1,
            d.tree_pos as i64,
        ];
        for (k, field) in ["grid-pos", "block-pos", "end-pos"].iter().enumerate() {
            for v in values {
                add(format!("g{i}-{field}-{v}"), p64(d.offsets_pos + 8 * k, v));
            }
        }
        // All three offsets of the next grid.
        let next = b[other.offsets_pos..other.offsets_pos + 24].to_vec();
        add(
            format!("g{i}-offsets-of-next"),
            Edit::Patch(vec![(d.offsets_pos, next)]),
        );
        for v in [0u32, 1, 2, 3, 4, 5, 6, 7, 0x10, 0xFFFF_FFFF] {
            add(format!("g{i}-compression-{v:x}"), p32(d.grid_pos, v));
        }
        for (k, e) in d.meta.iter().enumerate().take(2) {
            for v in HUGE32 {
                add(format!("g{i}-meta{k}-size-{v:x}"), p32(e.size_pos, v));
                add(
                    format!("g{i}-meta{k}-type-len-{v:x}"),
                    p32(e.type_name.len_pos, v),
                );
            }
        }
        // Root table: tile and child counts.
        let counts = d.tree_pos + 4 + d.value_size;
        for v in [0u32, 1, 0xFFFF_FFFF, 0x7FFF_FFFF, 0x0010_0000, 1000] {
            add(format!("g{i}-root-tiles-{v:x}"), p32(counts, v));
            add(format!("g{i}-root-children-{v:x}"), p32(counts + 4, v));
        }
        add(format!("g{i}-buffer-count"), p32(d.tree_pos, 0xFFFF_FFFF));
        // Map data garbage (zero, NaN and huge scales).
        for (tag, x) in [
            ("zero", 0.0f64),
            ("nan", f64::NAN),
            ("inf", f64::INFINITY),
            ("tiny", 1e-310),
            ("big", 1e300),
        ] {
            let patches = (0..16)
                .map(|k| d.map_data + 8 * k)
                .filter(|at| at + 8 <= d.tree_pos)
                .map(|at| (at, x.to_le_bytes().to_vec()))
                .collect();
            add(format!("g{i}-map-{tag}"), Edit::Patch(patches));
        }

        // Grid types, spliced in (same-length renames keep the layout).
        let (tstart, tlen) = (d.grid_type.len_pos, 4 + d.grid_type.len);
        for t in [
            "Tree_float_5_4_3",
            "Tree_vec3s_5_4_3",
            "Tree_vec3d_5_4_3",
            "Tree_double_5_4_3",
            "Tree_int32_5_4_3",
            "Tree_int64_5_4_3",
            "Tree_vec3i_5_4_3",
            "Tree_bool_5_4_3",
            "Tree_mask_5_4_3",
            "Tree_ptdataidx32_5_4_3",
            "Tree_ptidx32_5_4_3",
            "Tree_float_5_4_3_HalfFloat",
            "Tree_vec3s_5_4_3_HalfFloat",
            "Tree_float_5_5_3",
            "",
        ] {
            if t != d.type_text {
                add(
                    format!("g{i}-type-{t}"),
                    one_splice(tstart, tlen, vdb_string(t.as_bytes())),
                );
            }
        }
        let toggled = match d.type_text.strip_suffix("_HalfFloat") {
            Some(t) => t.to_string(),
            None => format!("{}_HalfFloat", d.type_text),
        };
        add(
            format!("g{i}-type-toggle-half"),
            one_splice(tstart, tlen, vdb_string(toggled.as_bytes())),
        );

        // Instances: own parent, a missing parent, the previous grid, a cycle of two.
        let name = name_bytes(b, d.unique_name);
        let (pstart, plen) = (d.parent.len_pos, 4 + d.parent.len);
        add(
            format!("g{i}-instance-of-self"),
            one_splice(pstart, plen, vdb_string(&name)),
        );
        add(
            format!("g{i}-instance-of-missing"),
            one_splice(pstart, plen, vdb_string(b"nope")),
        );
        for (copies, stream) in [(3, false), (3, true), (2000, false), (2000, true)] {
            let tag = if stream { "-stream" } else { "" };
            add(
                format!("g{i}-instances-{copies}{tag}"),
                Edit::InstanceBomb {
                    grid: i,
                    copies,
                    stream,
                },
            );
        }
        if l.descs.len() > 1 {
            let j = (i + l.descs.len() - 1) % l.descs.len();
            let o = &l.descs[j];
            let oname = name_bytes(b, o.unique_name);
            add(
                format!("g{i}-instance-of-g{j}"),
                one_splice(pstart, plen, vdb_string(&oname)),
            );
            // A float grid (renamed type) sharing the tree of grid j, whatever j's type.
            add(
                format!("g{i}-float-instance-of-g{j}"),
                Edit::Splice(vec![
                    (pstart, plen, vdb_string(&oname)),
                    (tstart, tlen, vdb_string(b"Tree_float_5_4_3")),
                ]),
            );
            // Splice the later descriptor first so the earlier position stays valid.
            let (first, second) = if o.start > d.start {
                (
                    (o.parent.len_pos, 4 + o.parent.len, vdb_string(&name)),
                    (pstart, plen, vdb_string(&oname)),
                )
            } else {
                (
                    (pstart, plen, vdb_string(&oname)),
                    (o.parent.len_pos, 4 + o.parent.len, vdb_string(&name)),
                )
            };
            add(
                format!("g{i}-instance-cycle-g{j}"),
                Edit::Splice(vec![first, second]),
            );
        }

        // Frustum maps: a huge second-map name, a plain one, nested ones, a deep chain.
        let (mstart, mlen) = (d.map_type.len_pos, d.tree_pos - d.map_type.len_pos);
        let mut huge_name = frustum_head();
        huge_name.extend(0xFFFF_FFF0u32.to_le_bytes());
        add(
            format!("g{i}-frustum-huge-name"),
            one_splice(mstart, mlen, huge_name),
        );
        let mut plain = frustum_head();
        plain.extend(uniform_scale_map());
        add(format!("g{i}-frustum"), one_splice(mstart, mlen, plain));
        if i == 0 {
            for depth in [2usize, 100, 20_000] {
                let mut chain = frustum_head().repeat(depth);
                chain.extend(uniform_scale_map());
                add(
                    format!("g{i}-frustum-depth-{depth}"),
                    one_splice(mstart, mlen, chain),
                );
            }
        }
        add(
            format!("g{i}-map-unknown"),
            one_splice(mstart, 4 + d.map_type.len, vdb_string(b"FooMap")),
        );
    }

    // Blosc frames: sizes, block sizes, flags, type sizes; and zip chunk sizes.
    for (k, &p) in l
        .blosc_frames
        .iter()
        .enumerate()
        .filter(|(k, _)| k % 7 == 0)
        .take(6)
    {
        let h = p + 8;
        let nbytes = u32::from_le_bytes(b[h + 4..h + 8].try_into().unwrap());
        for v in [
            0u32,
            1,
            3,
            nbytes + 1,
            nbytes * 2,
            0x4000_0000,
            0x7FFF_FFFF,
            0xFFFF_FFFF,
        ] {
            add(format!("blosc{k}-blocksize-{v:x}"), p32(h + 8, v));
            add(format!("blosc{k}-nbytes-{v:x}"), p32(h + 4, v));
            add(format!("blosc{k}-ctbytes-{v:x}"), p32(h + 12, v));
            let both = [v.to_le_bytes(), v.to_le_bytes()].concat();
            add(
                format!("blosc{k}-nbytes-blocksize-{v:x}"),
                Edit::Patch(vec![(h + 4, both)]),
            );
        }
        for f in [
            0u8, 0x02, 0x04, 0x10, 0x11, 0x20, 0x40, 0x60, 0x80, 0xE0, 0xFF,
        ] {
            add(format!("blosc{k}-flags-{f:x}"), p8(h + 2, f));
        }
        for t in [0u8, 1, 3, 8, 17, 255] {
            add(format!("blosc{k}-typesize-{t}"), p8(h + 3, t));
        }
        for v in [0u8, 1, 3, 0xFF] {
            add(format!("blosc{k}-version-{v}"), p8(h, v));
        }
        for v in [0i64, -1, -2048, 1, i64::MAX, i64::MIN, 0x1_0000_0000] {
            add(format!("blosc{k}-chunk-size-{v}"), p64(p, v));
        }
        for v in [0u32, 0xFFFF_FFFF, 0x7FFF_FFFF, 0x8000_0000] {
            add(format!("blosc{k}-start-{v:x}"), p32(h + 16, v));
            add(format!("blosc{k}-stream-size-{v:x}"), p32(h + 20, v));
        }
    }
    for (k, &p) in l
        .zip_chunks
        .iter()
        .enumerate()
        .filter(|(k, _)| k % 5 == 0)
        .take(4)
    {
        for v in [0i64, -1, 1, i64::MAX, i64::MIN, 0x7FFF_FFFF, -0x7FFF_FFFF] {
            add(format!("zip{k}-chunk-size-{v}"), p64(p, v));
        }
    }
    out
}

/// Offsets worth truncating at: region boundaries and their neighbours.
fn boundaries(l: &Layout) -> Vec<usize> {
    let mut v = vec![
        0,
        1,
        4,
        8,
        11,
        12,
        16,
        20,
        21,
        30,
        l.header_end - 1,
        l.header_end,
        l.meta_count_pos + 2,
    ];
    for e in &l.meta {
        v.extend([
            e.name.len_pos + 2,
            e.type_name.len_pos + 1,
            e.size_pos + 3,
            e.end,
        ]);
    }
    v.extend([l.grid_count_pos, l.grid_count_pos + 2]);
    for d in &l.descs {
        v.extend([
            d.start,
            d.start + 3,
            d.unique_name.len_pos + 4,
            d.grid_type.len_pos + 2,
            d.grid_type.len_pos + 4 + d.grid_type.len / 2,
            d.parent.len_pos,
            d.offsets_pos,
            d.offsets_pos + 8,
            d.offsets_pos + 20,
            d.grid_pos,
            d.grid_pos + 2,
            d.meta_count_pos + 4,
            d.map_type.len_pos,
            d.map_type.len_pos + 6,
            d.map_data,
            d.map_data + 40,
            d.tree_pos - 1,
            d.tree_pos,
            d.tree_pos + 4,
            d.tree_pos + 8,
            d.tree_pos + 12,
            d.tree_pos + 20,
            d.tree_pos + 40,
            d.tree_pos + 1000,
            d.tree_pos + 5000,
            d.tree_pos + 9000,
            (d.tree_pos + d.end_pos) / 2,
            d.block_pos,
            d.block_pos + 1,
            d.block_pos + 70,
            d.end_pos - 1,
            d.end_pos,
        ]);
        for e in d.meta.iter().take(3) {
            v.extend([e.size_pos, e.size_pos + 4, e.end - 1]);
        }
    }
    for &p in l.blosc_frames.iter().take(3) {
        v.extend([p, p + 8, p + 12, p + 24, p + 30]);
    }
    v.push(l.len - 1);
    v.retain(|&p| p < l.len);
    v.sort_unstable();
    v.dedup();
    v
}

/// "Interesting" bytes for flips and overwrites: everything up to the first tree, each
/// grid head and the first bytes of each tree (root table, first node masks and values),
/// and the Blosc headers.
fn hot_ranges(l: &Layout) -> Vec<(usize, usize)> {
    let mut v = vec![(0, l.descs.first().map_or(l.len, |d| d.grid_pos.min(l.len)))];
    for d in &l.descs {
        v.push((d.start, d.offsets_pos + 24));
        v.push((d.grid_pos, d.tree_pos));
        v.push((d.tree_pos, (d.tree_pos + 12_000).min(d.end_pos)));
        v.push((d.block_pos, (d.block_pos + 4_000).min(d.end_pos)));
    }
    for &p in l.blosc_frames.iter().take(50) {
        v.push((p, (p + 32).min(l.len)));
    }
    v.retain(|(a, b)| a < b && *b <= l.len);
    v
}

fn random_pos(rng: &mut Rng, l: &Layout, hot: &[(usize, usize)]) -> usize {
    if rng.below(2) == 0 {
        let (a, b) = *rng.pick(hot);
        a + rng.below(b - a)
    } else {
        rng.below(l.len)
    }
}

fn random_mutant(rng: &mut Rng, b: &[u8], l: &Layout, hot: &[(usize, usize)]) -> (String, Edit) {
    let kind = rng.below(100);
    let at = random_pos(rng, l, hot);
    if kind < 12 {
        (format!("trunc-{at}"), Edit::Truncate(at))
    } else if kind < 40 {
        let bit = rng.below(8);
        (format!("flip-{at}.{bit}"), p8(at, b[at] ^ (1 << bit)))
    } else if kind < 58 {
        let n = 2 + rng.below(15);
        let mut flips: Vec<(usize, u8)> = vec![(at, 1 << rng.below(8))];
        for _ in 1..n {
            flips.push((random_pos(rng, l, hot), 1 << rng.below(8)));
        }
        // Flips of the same byte combine.
        let mut bytes = std::collections::BTreeMap::new();
        for (p, mask) in flips {
            *bytes.entry(p).or_insert(b[p]) ^= mask;
        }
        let patches = bytes.into_iter().map(|(p, v)| (p, vec![v])).collect();
        (format!("flips{n}-{at}"), Edit::Patch(patches))
    } else if kind < 82 {
        let n = 1 + rng.below(8);
        let fill = rng.below(3);
        let bytes: Vec<u8> = (0..n)
            .map(|_| match fill {
                0 => 0x00,
                1 => 0xFF,
                _ => rng.byte(),
            })
            .collect();
        (
            format!("{}-{at}x{n}", ["zero", "ones", "rand"][fill]),
            Edit::Patch(vec![(at, bytes)]),
        )
    } else if kind < 88 {
        // A 4-byte field with a huge or negative value.
        let v = *rng.pick(&[
            0xFFFF_FFFFu32,
            0x7FFF_FFFF,
            0x8000_0000,
            0x00FF_FFFF,
            0x4000_0000,
        ]);
        (format!("u32-{at}-{v:x}"), p32(at, v))
    } else if kind < 94 {
        let max = if rng.below(2) == 0 { 64 } else { 4096 };
        let n = 1 + rng.below(max);
        (format!("dup-{at}x{n}"), Edit::Duplicate { at, n })
    } else if kind < 97 {
        let n = 1 + rng.below(256);
        (format!("del-{at}x{n}"), Edit::Delete { at, n })
    } else {
        let to = random_pos(rng, l, hot);
        let n = (1 + rng.below(512)).min(l.len - at).min(l.len - to);
        (
            format!("copy-{at}-to-{to}x{n}"),
            Edit::CopyOver { from: at, to, n },
        )
    }
}

fn fixtures() -> Vec<Fixture> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("fixtures/")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "vdb"))
        .collect();
    v.sort();
    assert!(v.len() >= 10, "expected the fixtures in {}", dir.display());
    v.into_iter()
        .map(|p| Fixture {
            stem: p.file_stem().unwrap().to_string_lossy().into_owned(),
            bytes: std::fs::read(&p).unwrap(),
        })
        .collect()
}

/// All mutants for a run: per fixture, the boundary truncations and random mutants up to
/// an equal share of `total`, plus the structural mutants (every `structural_step`-th).
fn mutants(fixtures: &[Fixture], total: usize, structural_step: usize, seed: u64) -> Vec<Mutant> {
    let share = total.div_ceil(fixtures.len());
    let mut all = Vec::new();
    for (fi, f) in fixtures.iter().enumerate() {
        let b = &f.bytes;
        let l = parse_layout(b);
        let hot = hot_ranges(&l);
        let mut rng = Rng::new(seed_of(&f.stem, seed));
        let mut mine: Vec<(String, Edit)> = boundaries(&l)
            .into_iter()
            .map(|at| (format!("trunc-{at}"), Edit::Truncate(at)))
            .collect();
        while mine.len() < share {
            mine.push(random_mutant(&mut rng, b, &l, &hot));
        }
        mine.extend(structural(b, &l).into_iter().step_by(structural_step));
        for (k, (name, edit)) in mine.into_iter().enumerate() {
            all.push(Mutant {
                fixture: fi,
                name: format!("{}-{k:05}-{name}", f.stem),
                edit,
            });
        }
    }
    all
}

// ------------------------------------------------------------------------------------
// Running murk on a file.

#[derive(Debug)]
enum Outcome {
    Ok,
    /// The error message, without `murk: error: <path>: `.
    Err(String),
    Bad(String),
}

/// Runs `murk info --stats --json path` under the time and memory limits and judges it.
fn run_murk(path: &Path, scratch: &Path) -> Outcome {
    run_limited(path, scratch, None)
}

/// Runs `murk render path -o <scratch>.exr` (a small image, default flags otherwise)
/// under the render's limits and judges it: exit 0 must leave the EXR, exit 2 one line.
fn render_murk(path: &Path, scratch: &Path) -> Outcome {
    let exr = scratch.with_extension("exr");
    let outcome = run_limited(path, scratch, Some(&exr));
    let wrote = exr.exists();
    let _ = std::fs::remove_file(&exr);
    match outcome {
        Outcome::Ok if !wrote => Outcome::Bad("render: exit 0 but no EXR".to_string()),
        Outcome::Err(_) if wrote => Outcome::Bad("render: exit 2 but an EXR".to_string()),
        Outcome::Bad(why) => Outcome::Bad(format!("render: {why}")),
        other => other,
    }
}

/// Runs murk on `path`: `info --stats --json`, or with `render`, a render to that EXR.
fn run_limited(path: &Path, scratch: &Path, render: Option<&Path>) -> Outcome {
    let out_path = scratch.with_extension("out");
    let err_path = scratch.with_extension("err");
    let stdout = std::fs::File::create(&out_path).unwrap();
    let stderr = std::fs::File::create(&err_path).unwrap();
    let (memory, timeout) = match render {
        Some(_) => (RENDER_MEMORY_LIMIT_KIB, RENDER_TIMEOUT),
        None => (MEMORY_LIMIT_KIB, TIMEOUT),
    };
    let mut command = Command::new("sh");
    command
        .arg("-c")
        .arg(format!("ulimit -v {memory} || exit 99; exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_murk"));
    match render {
        Some(exr) => command.arg("render").arg(path).arg("-o").arg(exr).args([
            "--res",
            "48x27",
            "--quiet",
            "--threads",
            "2",
        ]),
        None => command.args(["info", "--stats", "--json"]).arg(path),
    };
    let mut child = command
        .stdin(Stdio::null())
        .stdout(stdout)
        .stderr(stderr)
        .spawn()
        .expect("spawn sh");
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > timeout {
            let _ = child.kill();
            let _ = child.wait();
            return Outcome::Bad(format!("hang (killed after {timeout:?})"));
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    let out = std::fs::read(&out_path).unwrap_or_default();
    let err = String::from_utf8_lossy(&std::fs::read(&err_path).unwrap_or_default()).into_owned();
    let _ = std::fs::remove_file(&out_path);
    let _ = std::fs::remove_file(&err_path);
    judge(status, &out, &err, path, render.is_some())
}

fn judge(
    status: std::process::ExitStatus,
    out: &[u8],
    err: &str,
    path: &Path,
    render: bool,
) -> Outcome {
    use std::os::unix::process::ExitStatusExt;
    let first = err
        .lines()
        .next()
        .unwrap_or("")
        .chars()
        .take(300)
        .collect::<String>();
    if let Some(sig) = status.signal() {
        let what = match sig {
            6 => "abort (SIGABRT: failed allocation, stack overflow or abort)",
            9 => "killed (SIGKILL)",
            11 => "segfault (SIGSEGV)",
            _ => "signal",
        };
        return Outcome::Bad(format!("{what} {sig}: {first}"));
    }
    match status.code() {
        Some(0) => {
            if err.contains("panicked") {
                return Outcome::Bad(format!("exit 0 but a panic was printed: {first}"));
            }
            if render {
                return Outcome::Ok;
            }
            match serde_json::from_slice::<serde_json::Value>(out) {
                Ok(_) => Outcome::Ok,
                Err(e) => Outcome::Bad(format!("exit 0 but stdout is not JSON: {e}")),
            }
        }
        Some(2) => {
            let p = path.display().to_string();
            let prefix = "murk: error: ";
            let body = err.strip_suffix('\n').unwrap_or(err);
            if body.contains('\n') {
                let n = body.lines().count();
                return Outcome::Bad(format!(
                    "exit 2 with {n} lines on stderr: {:?}",
                    err.chars().take(400).collect::<String>()
                ));
            }
            if !body.starts_with(prefix) || !body.contains(&p) {
                return Outcome::Bad(format!(
                    "exit 2 but stderr is not `murk: error: <path>: ...`: {body:?}"
                ));
            }
            let rest = body[prefix.len()..].replacen(&p, "<file>", 1);
            Outcome::Err(rest.strip_prefix("<file>: ").unwrap_or(&rest).to_string())
        }
        Some(101) => Outcome::Bad(format!("panic (exit 101): {first}")),
        Some(134) => Outcome::Bad(format!("abort (exit 134): {first}")),
        Some(99) => panic!("`ulimit -v` is not available in sh"),
        Some(c) => Outcome::Bad(format!("exit code {c}: {first}")),
        None => Outcome::Bad("no exit code".to_string()),
    }
}

fn work_dir(tag: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("mutation-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Where a run keeps its failing mutants (emptied when the run starts).
fn failure_dir(tag: &str) -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("mutation-failures-{tag}"))
}

/// An error message's first 60 characters, numbers replaced by `N` so that messages
/// differing only in sizes and offsets count together.
fn message_kind(msg: &str) -> String {
    let mut out = String::new();
    for c in msg.chars() {
        if c.is_ascii_digit() {
            if !out.ends_with('N') {
                out.push('N');
            }
        } else {
            out.push(c);
        }
    }
    out.chars().take(60).collect()
}

/// Runs every mutant (and renders every `render_step`-th, but not those of fixtures
/// whose own render takes tens of seconds), prints a summary and fails listing the bad
/// ones.
fn run_all(tag: &str, fixtures: &[Fixture], mutants: Vec<Mutant>, render_step: usize) {
    // MUTATION_FILTER=text runs only the mutants whose names contain `text`.
    let filter = std::env::var("MUTATION_FILTER").ok();
    let mutants: Vec<Mutant> = match &filter {
        Some(f) => mutants
            .into_iter()
            .filter(|m| m.name.contains(f.as_str()))
            .collect(),
        None => {
            assert!(mutants.len() >= 2000, "only {} mutants", mutants.len());
            mutants
        }
    };
    let started = Instant::now();
    let _ = std::fs::remove_dir_all(failure_dir(tag));
    let dir = work_dir(tag);
    let next = AtomicUsize::new(0);
    let renders = AtomicUsize::new(0);
    let results: Mutex<Vec<(usize, Outcome)>> = Mutex::new(Vec::with_capacity(mutants.len()));
    std::thread::scope(|s| {
        for _ in 0..WORKERS {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(m) = mutants.get(i) else { break };
                    let path = dir.join(format!("{}.vdb", m.name));
                    std::fs::write(&path, apply(&fixtures[m.fixture].bytes, &m.edit)).unwrap();
                    let scratch = dir.join(format!("run-{i}"));
                    let mut outcome = run_murk(&path, &scratch);
                    let slow = SLOW_TO_RENDER.contains(&fixtures[m.fixture].stem.as_str());
                    if i.is_multiple_of(render_step) && !slow && !matches!(outcome, Outcome::Bad(_))
                    {
                        let rendered = render_murk(&path, &scratch);
                        if let Outcome::Bad(_) = rendered {
                            outcome = rendered;
                        }
                        renders.fetch_add(1, Ordering::Relaxed);
                    }
                    if let Outcome::Bad(_) = outcome {
                        let keep = failure_dir(tag);
                        std::fs::create_dir_all(&keep).unwrap();
                        std::fs::copy(&path, keep.join(format!("{}.vdb", m.name))).unwrap();
                    }
                    let _ = std::fs::remove_file(&path);
                    results.lock().unwrap().push((i, outcome));
                }
            });
        }
    });
    let _ = std::fs::remove_dir_all(&dir);
    let mut results = results.into_inner().unwrap();
    results.sort_by_key(|(i, _)| *i);

    let (mut ok, mut err) = (0, 0);
    let mut messages: BTreeMap<String, usize> = BTreeMap::new();
    let mut bad = Vec::new();
    for (i, o) in &results {
        match o {
            Outcome::Ok => ok += 1,
            Outcome::Err(msg) => {
                err += 1;
                *messages.entry(message_kind(msg)).or_default() += 1;
            }
            Outcome::Bad(why) => bad.push(format!("{}.vdb: {why}", mutants[*i].name)),
        }
    }
    let mut by_count: Vec<_> = messages.into_iter().collect();
    by_count.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    println!(
        "mutation ({tag}): {} mutants ({} also rendered) in {:.1} s: {ok} clean Ok, {err} clean Err, {} bad",
        results.len(),
        renders.load(Ordering::Relaxed),
        started.elapsed().as_secs_f64(),
        bad.len()
    );
    println!("distinct error messages (first 60 chars, numbers as N), by count:");
    for (msg, n) in &by_count {
        println!("{n:>7}  {msg}");
    }
    assert_eq!(results.len(), mutants.len());
    assert!(
        bad.is_empty(),
        "{} of {} mutants did not end cleanly (copies in {}):\n{}",
        bad.len(),
        results.len(),
        failure_dir(tag).display(),
        bad.iter().take(60).cloned().collect::<Vec<_>>().join("\n")
    );
}

/// Fixtures whose sound render takes tens of seconds (tiles.vdb: 2^28 voxels of tiles):
/// their mutants are inspected, not rendered.
const SLOW_TO_RENDER: &[&str] = &["tiles"];

#[test]
fn mutated_fixtures_end_cleanly() {
    let f = fixtures();
    let m = mutants(&f, DEFAULT_MUTANTS, DEFAULT_STRUCTURAL_STEP, 0x6d75_726b);
    run_all("default", &f, m, DEFAULT_RENDER_STEP);
}

/// The long run (docs/testing.md says how long it takes).
#[test]
#[ignore = "long: tens of thousands of mutants; run with --ignored"]
fn mutated_fixtures_end_cleanly_long() {
    let f = fixtures();
    let m = mutants(&f, LONG_MUTANTS, 1, 0x1000_0000_6d75_726b);
    assert!(m.len() >= 20_000, "only {} mutants", m.len());
    run_all("long", &f, m, LONG_RENDER_STEP);
}

// ------------------------------------------------------------------------------------
// Plain bad inputs.

fn expect_clean_error(path: &Path, what: &str) {
    // One directory per case: the cases run in parallel and each removes its own.
    let dir = work_dir(&format!("plain-{}", what.replace(' ', "-")));
    let o = run_murk(path, &dir.join("run"));
    let _ = std::fs::remove_dir_all(&dir);
    match o {
        Outcome::Err(msg) => assert!(!msg.is_empty(), "{what}: empty message"),
        other => panic!(
            "{what}: expected exit 2 with one `murk: error: <path>: ...` line, got {other:?}"
        ),
    }
}

fn plain_file(name: &str, bytes: &[u8]) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("mutation-plain");
    std::fs::create_dir_all(&d).unwrap();
    let p = d.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn empty_file_is_a_clean_error() {
    expect_clean_error(&plain_file("empty.vdb", b""), "empty file");
}

#[test]
fn directory_is_a_clean_error() {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("mutation-plain")
        .join("a-directory.vdb");
    std::fs::create_dir_all(&d).unwrap();
    expect_clean_error(&d, "directory");
}

#[test]
fn missing_file_is_a_clean_error() {
    let p = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("mutation-plain")
        .join("does-not-exist.vdb");
    let _ = std::fs::remove_file(&p);
    expect_clean_error(&p, "missing file");
}

#[test]
fn non_vdb_files_are_clean_errors() {
    let png = [
        0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n', 0, 0, 0, 13, b'I', b'H', b'D', b'R', 0,
        0, 1, 0,
    ];
    expect_clean_error(&plain_file("image.png.vdb", &png), "PNG header");
    expect_clean_error(
        &plain_file("text.vdb", b"this is not a volume\nat all\n"),
        "text file",
    );
    expect_clean_error(&plain_file("one-byte.vdb", b"V"), "one byte");
}

#[test]
fn file_truncated_to_ten_bytes_is_a_clean_error() {
    let b =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/cloud.vdb")).unwrap();
    expect_clean_error(
        &plain_file("cloud-10-bytes.vdb", &b[..10]),
        "truncated to 10 bytes",
    );
}

#[test]
fn unsupported_grid_types_are_fine_for_info() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/bad_types.vdb");
    for args in [
        &["info"][..],
        &["info", "--json"],
        &["info", "--stats", "--json"],
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_murk"))
            .args(args)
            .arg(&p)
            .output()
            .unwrap();
        assert_eq!(
            out.status.code(),
            Some(0),
            "murk {args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            out.stderr.is_empty(),
            "murk {args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let dir = work_dir("bad-types");
    let o = run_murk(&p, &dir.join("bad-types"));
    let _ = std::fs::remove_dir_all(&dir);
    assert!(matches!(o, Outcome::Ok), "{o:?}");
}
