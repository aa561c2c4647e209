//! Mutants: a name and an edit, applied to a fixture's bytes only when the mutant runs;
//! the deterministic random stream that picks them.

use super::layout::*;
use super::structural::{name_bytes, p8, p32, splice, structural, vdb_string};
use murk::field::random::SplitMix64;
use std::path::{Path, PathBuf};

// ------------------------------------------------------------------------------------
// A small deterministic PRNG over the crate's SplitMix64.

pub(crate) struct Rng(SplitMix64);

impl Rng {
    pub(crate) fn new(seed: u64) -> Self {
        Rng(SplitMix64(seed))
    }
    pub(crate) fn next(&mut self) -> u64 {
        self.0.next_u64()
    }
    /// Uniform in `0..n` (`n > 0`).
    pub(crate) fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    pub(crate) fn byte(&mut self) -> u8 {
        self.next() as u8
    }
    pub(crate) fn pick<'a, T>(&mut self, v: &'a [T]) -> &'a T {
        &v[self.below(v.len())]
    }
}

pub(crate) fn seed_of(name: &str, base: u64) -> u64 {
    // FNV-1a of the fixture name, mixed with the base seed.
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for b in name.bytes() {
        h = (h ^ b as u64).wrapping_mul(0x100_0000_01b3);
    }
    h ^ base
}

pub(crate) enum Edit {
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

pub(crate) struct Mutant {
    pub(crate) fixture: usize,
    pub(crate) name: String,
    pub(crate) edit: Edit,
}

pub(crate) struct Fixture {
    pub(crate) stem: String,
    pub(crate) bytes: Vec<u8>,
}

pub(crate) fn apply(b: &[u8], edit: &Edit) -> Vec<u8> {
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

pub(crate) fn instance_bomb(b: &[u8], grid: usize, copies: usize, stream: bool) -> Vec<u8> {
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

/// Offsets worth truncating at: region boundaries and their neighbours.
pub(crate) fn boundaries(l: &Layout) -> Vec<usize> {
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
pub(crate) fn hot_ranges(l: &Layout) -> Vec<(usize, usize)> {
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

pub(crate) fn random_pos(rng: &mut Rng, l: &Layout, hot: &[(usize, usize)]) -> usize {
    if rng.below(2) == 0 {
        let (a, b) = *rng.pick(hot);
        a + rng.below(b - a)
    } else {
        rng.below(l.len)
    }
}

pub(crate) fn random_mutant(
    rng: &mut Rng,
    b: &[u8],
    l: &Layout,
    hot: &[(usize, usize)],
) -> (String, Edit) {
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

pub(crate) fn fixtures() -> Vec<Fixture> {
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
pub(crate) fn mutants(
    fixtures: &[Fixture],
    total: usize,
    structural_step: usize,
    seed: u64,
) -> Vec<Mutant> {
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
