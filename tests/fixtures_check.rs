//! The committed fixtures still match what OpenVDB computes: regenerate them into a
//! temporary directory with `scripts/make_fixtures.py` (Debian's python3-openvdb and
//! libopenvdb-tools; meshio, vtk and miepython from PyPI) and compare with
//! `fixtures/reference.json`.

mod common;
use common::tools;

#[test]
fn fixtures_match_a_fresh_openvdb_run() {
    need!(
        tools::PYOPENVDB,
        tools::VDB_TOOL,
        tools::VDB_PRINT,
        tools::PYPI_REFERENCES
    );
    let root = env!("CARGO_MANIFEST_DIR");
    let out = tools::command(&tools::PYOPENVDB)
        .arg(format!("{root}/scripts/make_fixtures.py"))
        .arg("--check")
        .arg(format!("{root}/fixtures"))
        .output()
        .expect(
            "cannot run /usr/bin/python3: install Debian's python3-openvdb (see docs/testing.md)",
        );
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.status.success(),
        "scripts/make_fixtures.py --check failed:\n{text}"
    );
    assert!(text.contains("OK"), "unexpected output:\n{text}");
}
