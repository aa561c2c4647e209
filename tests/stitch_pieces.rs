//! `murk stitch` reads a piece's rows where their own chunks say they are, not where the
//! file's offset table points, and takes pieces whose data windows were cropped or not.

mod common;
use common::frames::*;
use common::tools;

use exr::prelude::read_all_flat_layers_from_file;
use std::fs;
use std::path::Path;

fn cloud() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/cloud.vdb")
        .display()
        .to_string()
}

fn render(dir: &Path, out: &str, extra: &[&str]) {
    let c = cloud();
    let mut args = vec!["render", c.as_str(), "-o", out, "--res", "32x18", "--quiet"];
    args.extend(extra);
    ok(dir, &args);
}

fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().unwrap())
}

/// Points entry `from` of a single-part scanline EXR's offset table at entry `to`'s
/// chunk. The table is found as the run of `n` offsets whose first points just past it.
fn misdirect_row(path: &Path, from: usize, to: usize) {
    let meta = exr::meta::MetaData::read_from_file(path, false).unwrap();
    let n = meta.headers[0].chunk_count;
    let mut b = fs::read(path).unwrap();
    let table = (0..b.len() - 8 * n)
        .find(|&p| u64_at(&b, p) == (p + 8 * n) as u64)
        .expect("the offset table");
    let target = u64_at(&b, table + 8 * to).to_le_bytes();
    b[table + 8 * from..table + 8 * from + 8].copy_from_slice(&target);
    fs::write(path, b).unwrap();
}

#[test]
fn a_piece_s_rows_are_read_by_their_own_y_not_its_offset_table() {
    need!(tools::IDIFF);
    let d = scratch("stitch-offsets");
    for i in 1..=3 {
        render(&d, &format!("p{i}.exr"), &["--tile", &format!("{i}/3")]);
    }
    ok(
        &d,
        &["stitch", "p1.exr", "p2.exr", "p3.exr", "-o", "good.exr"],
    );
    // The middle piece, where the cloud is: its row 1 pointed at its row 4.
    fs::copy(d.join("p2.exr"), d.join("bad2.exr")).unwrap();
    misdirect_row(&d.join("bad2.exr"), 1, 4);
    // The damage bites a reader that trusts the table: the exr crate's own reader.
    let (good, bad) = (
        read_all_flat_layers_from_file(d.join("p2.exr")).unwrap(),
        read_all_flat_layers_from_file(d.join("bad2.exr")).unwrap(),
    );
    assert_ne!(
        good.layer_data[0].channel_data.list,
        bad.layer_data[0].channel_data.list
    );
    ok(
        &d,
        &["stitch", "p1.exr", "bad2.exr", "p3.exr", "-o", "s.exr"],
    );
    same_image(&d.join("s.exr"), &d.join("good.exr"));
}

#[test]
fn cropped_and_uncropped_pieces_stitch_into_the_cropped_frame() {
    need!(tools::IDIFF);
    let d = scratch("stitch-crop");
    render(&d, "whole.exr", &["--crop-data-window"]);
    render(&d, "p1.exr", &["--tile", "1/3", "--crop-data-window"]);
    render(&d, "p2.exr", &["--tile", "2/3"]);
    render(&d, "p3.exr", &["--tile", "3/3", "--crop-data-window"]);
    ok(&d, &["stitch", "p2.exr", "p1.exr", "p3.exr", "-o", "s.exr"]);
    same_image(&d.join("s.exr"), &d.join("whole.exr"));
}
