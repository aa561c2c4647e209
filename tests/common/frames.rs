//! Helpers of the sequence and farm tests: the four-frame cache `fixtures/seq`, the
//! murk binary, and exact image comparison (OpenImageIO's `idiff -fail 0` and the samples'
//! bits read by the `exr` crate).

use exr::prelude::{FlatSamples, read_all_flat_layers_from_file};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub const MURK: &str = env!("CARGO_BIN_EXE_murk");
/// Small and quick; jittered samples (spp 3) so the per-pixel random streams matter.
pub const LOOK: [&str; 8] = [
    "--res",
    "48x36",
    "--spp",
    "3",
    "--light",
    "point:0.3,1.5,0.5",
    "--ground",
    "-0.6",
];

pub fn seq(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/seq")
        .join(name)
}

pub fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("frames-{name}"));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

pub fn murk(dir: &Path, args: &[&str]) -> Output {
    Command::new(MURK)
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

pub fn ok(dir: &Path, args: &[&str]) -> String {
    let out = murk(dir, args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "murk {}: {err}", args.join(" "));
    err
}

/// A bad-input case: exit code 2 and one line naming `needle`.
pub fn refused(dir: &Path, args: &[&str], needle: &str) {
    let out = murk(dir, args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "murk {}: {err}", args.join(" "));
    assert_eq!(
        err.lines().count(),
        1,
        "murk {}: not one line: {err}",
        args.join(" ")
    );
    assert!(
        err.contains(needle),
        "murk {}: {err} (wanted {needle})",
        args.join(" ")
    );
    assert!(!err.contains("panicked"), "{err}");
}

/// A direct, one-file render of frame `frame`.
pub fn direct(dir: &Path, frame: u32) -> PathBuf {
    let out = dir.join(format!("direct_{frame}.exr"));
    let input = seq(&format!("fluid_{frame:04}.vdb"));
    let mut args = vec![
        "render",
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--quiet",
    ];
    args.extend(LOOK);
    ok(dir, &args);
    out
}

/// The two images are the same: idiff with no tolerance, and every sample, channel,
/// storage type and window equal as read by the `exr` crate.
pub fn same_image(a: &Path, b: &Path) {
    let out = super::tools::command(&super::tools::IDIFF)
        .args(["-fail", "0", "-warn", "0"])
        .args([a, b])
        .output()
        .expect("idiff (Debian openimageio-tools) is required");
    assert!(
        out.status.success(),
        "idiff {} {}: {}",
        a.display(),
        b.display(),
        String::from_utf8_lossy(&out.stdout)
    );
    let (ia, ib) = (
        read_all_flat_layers_from_file(a).unwrap(),
        read_all_flat_layers_from_file(b).unwrap(),
    );
    assert_eq!(ia.attributes.display_window, ib.attributes.display_window);
    let (la, lb) = (&ia.layer_data[0], &ib.layer_data[0]);
    assert_eq!(la.size, lb.size, "{} {}", a.display(), b.display());
    assert_eq!(la.attributes.layer_position, lb.attributes.layer_position);
    assert_eq!(la.channel_data.list.len(), lb.channel_data.list.len());
    for (ca, cb) in la.channel_data.list.iter().zip(&lb.channel_data.list) {
        assert_eq!(ca.name, cb.name);
        let bits = |s: &FlatSamples| -> Vec<u32> {
            match s {
                FlatSamples::F16(v) => v.iter().map(|h| h.to_bits() as u32 | 1 << 31).collect(),
                FlatSamples::F32(v) => v.iter().map(|f| f.to_bits()).collect(),
                FlatSamples::U32(v) => v.clone(),
            }
        };
        assert!(
            bits(&ca.sample_data) == bits(&cb.sample_data),
            "channel {} differs: {} {}",
            ca.name,
            a.display(),
            b.display()
        );
    }
}

pub fn differs(a: &Path, b: &Path) -> bool {
    !super::tools::command(&super::tools::IDIFF)
        .args(["-fail", "0", "-warn", "0", "-q"])
        .args([a, b])
        .status()
        .unwrap()
        .success()
}

/// Every fixture murk renders: the volumes and meshes in fixtures/ and fixtures/caches/.
/// Those it refuses as input (no density grid, a level set) must still be refused.
pub fn every_fixture() -> Vec<String> {
    const REFUSED: [&str; 2] = ["bad_types.vdb", "caches/levelset_sphere.vdb"];
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let mut out = Vec::new();
    for sub in ["", "caches"] {
        for e in std::fs::read_dir(root.join(sub)).unwrap() {
            let name = e.unwrap().file_name().to_string_lossy().into_owned();
            let ext = name.rsplit('.').next().unwrap_or("");
            if ["vdb", "vtu", "vtk"].contains(&ext) {
                let rel = if sub.is_empty() {
                    name
                } else {
                    format!("{sub}/{name}")
                };
                if !REFUSED.contains(&rel.as_str()) {
                    out.push(rel);
                }
            }
        }
    }
    out.sort();
    let dir = scratch("deep-refused-fixtures");
    for f in REFUSED {
        let out = Command::new(MURK)
            .arg("render")
            .arg(root.join(f))
            .arg("-o")
            .arg(dir.join("r.exr"))
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{f} is rendered now: add it");
    }
    out
}
