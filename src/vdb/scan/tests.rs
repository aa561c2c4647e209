//! Unit tests of `scan/mod.rs`, compiled only under #[cfg(test)].

use super::*;

fn fixtures() -> Vec<std::path::PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "vdb"))
        .collect();
    v.sort();
    v
}

#[test]
fn every_fixture_scans_and_each_tree_ends_at_its_end_offset() {
    let mut trees = 0;
    for path in fixtures() {
        let f = scan_file(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(f.has_offsets);
        for g in &f.grids {
            TREE_END.with(|t| t.set(None));
            let r = f.check_tree(&path, &g.unique_name);
            if g.grid_type.starts_with("Tree_pt") {
                assert!(r.is_err(), "point grids are never decoded");
                continue;
            }
            r.unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            if let Some((end, end_pos)) = TREE_END.with(|t| t.get()) {
                assert_eq!(end, end_pos, "{}: {}", path.display(), g.unique_name);
                trees += 1;
            }
        }
    }
    assert!(trees >= 15, "{trees} trees checked");
}

#[test]
fn blosc_block_larger_than_its_data_is_refused() {
    // A tree with one 32³ node whose values are one Blosc chunk with a 4 GiB block.
    let mut t = Vec::new();
    t.extend(1i32.to_le_bytes());
    t.extend(0f32.to_le_bytes());
    t.extend(0u32.to_le_bytes());
    t.extend(1u32.to_le_bytes());
    t.extend([0u8; 12]);
    t.extend([0u8; 2 * 4096]); // child and value masks
    t.push(6); // all values stored
    let frame_len = 32u64;
    t.extend((frame_len as i64).to_le_bytes());
    let mut frame = vec![2u8, 1, 0x01, 4];
    frame.extend((32768u32 * 4).to_le_bytes());
    frame.extend(u32::MAX.to_le_bytes());
    frame.extend((frame_len as u32).to_le_bytes());
    frame.resize(frame_len as usize, 0);
    t.extend(frame);
    let v = value_layout("Tree_float_5_4_3").unwrap();
    let len = t.len() as u64;
    let mut b = Bytes {
        r: std::io::Cursor::new(t),
        pos: 0,
        len,
        what: "the file",
    };
    let e = TreeScan { version: 224 }
        .tree(&mut b, v, BLOSC | ACTIVE_MASK, false)
        .unwrap_err();
    assert!(e.contains("block size"), "{e}");
}
