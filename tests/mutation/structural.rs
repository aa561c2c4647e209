//! Structural mutants: edits that keep a VDB file parseable up to a chosen field and then
//! lie in it (huge lengths, bad offsets, renamed grid types, cyclic instances, nested
//! frustum maps, corrupted Blosc frames), and the byte-level builders they use.

use super::layout::*;
use super::mutants::Edit;

pub(crate) fn p32(at: usize, v: u32) -> Edit {
    Edit::Patch(vec![(at, v.to_le_bytes().to_vec())])
}

pub(crate) fn p64(at: usize, v: i64) -> Edit {
    Edit::Patch(vec![(at, v.to_le_bytes().to_vec())])
}

pub(crate) fn p8(at: usize, v: u8) -> Edit {
    Edit::Patch(vec![(at, vec![v])])
}

pub(crate) fn put_i64(b: &mut [u8], at: usize, v: i64) {
    if at + 8 <= b.len() {
        b[at..at + 8].copy_from_slice(&v.to_le_bytes());
    }
}

pub(crate) fn vdb_string(s: &[u8]) -> Vec<u8> {
    let mut v = (s.len() as u32).to_le_bytes().to_vec();
    v.extend_from_slice(s);
    v
}

/// Replaces `b[at..at + remove]` by `insert` and shifts every descriptor offset that
/// points past `at`, so the rest of the file stays reachable.
pub(crate) fn splice(b: &[u8], l: &Layout, at: usize, remove: usize, insert: &[u8]) -> Vec<u8> {
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
pub(crate) fn frustum_head() -> Vec<u8> {
    let mut v = vdb_string(b"NonlinearFrustumMap");
    for x in [-1.0f64, -1.0, 0.0, 1.0, 1.0, 1.0, 0.5, 2.0] {
        v.extend_from_slice(&x.to_le_bytes());
    }
    v
}

pub(crate) fn uniform_scale_map() -> Vec<u8> {
    let mut v = vdb_string(b"UniformScaleMap");
    for x in [
        0.1f64, 0.1, 0.1, 0.1, 0.1, 0.1, 10.0, 10.0, 10.0, 100.0, 100.0, 100.0, 5.0, 5.0, 5.0,
    ] {
        v.extend_from_slice(&x.to_le_bytes());
    }
    v
}

pub(crate) fn one_splice(at: usize, remove: usize, insert: Vec<u8>) -> Edit {
    Edit::Splice(vec![(at, remove, insert)])
}

pub(crate) fn name_bytes(b: &[u8], s: Str) -> Vec<u8> {
    b[s.len_pos + 4..s.len_pos + 4 + s.len].to_vec()
}

/// Mutations that need to know the file's layout: huge lengths and counts, bad offsets,
/// renamed types, instance cycles, frustum maps, corrupted Blosc and zip chunks.
pub(crate) fn structural(b: &[u8], l: &Layout) -> Vec<(String, Edit)> {
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
