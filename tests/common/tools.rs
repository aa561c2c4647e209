//! Tools nobody here wrote that some tests compare murk with, and the one way a test
//! asks for them: `need!(tools::EXRHEADER, ...)` as the test's first line.
//!
//! Where every tool is there, `need!` does nothing and the test runs in full. Where one
//! is missing, it prints one line, `SKIPPED <binary>::<test>: needs <tool> (<package>)`,
//! notes the skip for the run's count (`tests/zz_skipped_tools.rs`, the last binary cargo
//! runs, prints it) and returns from the test. Under `MURK_REQUIRE_TOOLS=1` (set by
//! `.ci/run`) a missing tool fails the test instead, so CI skips nothing.
//!
//! The tools are run through `command` (or `common::tool`), which fails a test that did
//! not ask for its tool with `need!`: a test that forgets it fails where the tool is
//! installed, in CI, and not only on a machine without it.

use std::cell::RefCell;
use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Mutex, OnceLock};

/// How a tool is found.
enum Probe {
    /// An executable on `PATH`.
    OnPath(&'static str),
    /// Python modules that import under one of these interpreters.
    Python(&'static [&'static str], &'static str),
    /// `openjd`: `MURK_OPENJD`, then /opt/murk-venv/bin/openjd, then `PATH`.
    Openjd,
    /// Files that all exist.
    Files(&'static [&'static str]),
}

pub struct Tool {
    /// What the skip line says is needed.
    pub name: &'static str,
    /// Where it comes from, as the skip line says it.
    pub package: &'static str,
    probe: Probe,
}

pub const EXRHEADER: Tool = Tool {
    name: "exrheader",
    package: "Debian package openexr",
    probe: Probe::OnPath("exrheader"),
};
pub const OIIOTOOL: Tool = Tool {
    name: "oiiotool",
    package: "Debian package openimageio-tools",
    probe: Probe::OnPath("oiiotool"),
};
pub const IDIFF: Tool = Tool {
    name: "idiff",
    package: "Debian package openimageio-tools",
    probe: Probe::OnPath("idiff"),
};
pub const VDB_PRINT: Tool = Tool {
    name: "vdb_print",
    package: "Debian package libopenvdb-tools",
    probe: Probe::OnPath("vdb_print"),
};
pub const VDB_TOOL: Tool = Tool {
    name: "vdb_tool",
    package: "Debian package libopenvdb-tools",
    probe: Probe::OnPath("vdb_tool"),
};
pub const BLENDER: Tool = Tool {
    name: "blender",
    package: "Debian package blender",
    probe: Probe::OnPath("blender"),
};
/// Debian's pyopenvdb (built against Debian's numpy), under /usr/bin/python3.
pub const PYOPENVDB: Tool = Tool {
    name: "pyopenvdb and numpy in /usr/bin/python3",
    package: "Debian package python3-openvdb",
    probe: Probe::Python(&["/usr/bin/python3"], "numpy, pyopenvdb"),
};
/// The PyPI references of `scripts/make_fixtures.py`, which runs itself again under
/// /opt/murk-venv/bin/python where /usr/bin/python3 lacks them.
pub const PYPI_REFERENCES: Tool = Tool {
    name: "meshio, vtk and miepython",
    package: "pip packages meshio vtk miepython, in /opt/murk-venv as .ci/run makes it",
    probe: Probe::Python(
        &["/usr/bin/python3", "/opt/murk-venv/bin/python"],
        "meshio, vtk, miepython",
    ),
};
/// Pixar's USD (`from pxr import Usd`), the reference of the USD camera reader.
pub const USD_CORE: Tool = Tool {
    name: "usd-core",
    package: "pip package usd-core, in /opt/murk-venv as .ci/run makes it",
    probe: Probe::Python(
        &["/opt/murk-venv/bin/python", "/usr/bin/python3"],
        "pxr.Usd, pxr.UsdGeom",
    ),
};
pub const OPENJD: Tool = Tool {
    name: "openjd",
    package: "pip package openjd-cli in /opt/murk-venv, or MURK_OPENJD",
    probe: Probe::Openjd,
};
/// Mesa's lavapipe (Vulkan on the CPU) and the Vulkan loader: the GPU backend's tests run
/// on it (`LAVAPIPE_ICD`), so they need no GPU.
pub const LAVAPIPE: Tool = Tool {
    name: "lavapipe",
    package: "Debian packages mesa-vulkan-drivers and libvulkan1",
    probe: Probe::Files(&[LAVAPIPE_ICD, "/usr/lib/x86_64-linux-gnu/libvulkan.so.1"]),
};
/// lavapipe's Vulkan driver manifest, for `VK_DRIVER_FILES`.
pub const LAVAPIPE_ICD: &str = "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json";

/// Skips the calling test (see the module's doc) unless every tool named is there.
#[macro_export]
macro_rules! need {
    ($($tool:expr),+ $(,)?) => {
        if !$crate::common::tools::present(&[$(&$tool),+]) {
            return;
        }
    };
}

const ALL: [&Tool; 11] = [
    &EXRHEADER,
    &OIIOTOOL,
    &IDIFF,
    &VDB_PRINT,
    &VDB_TOOL,
    &BLENDER,
    &PYOPENVDB,
    &PYPI_REFERENCES,
    &OPENJD,
    &USD_CORE,
    &LAVAPIPE,
];

thread_local! {
    /// The tools the running test asked for (libtest runs each test on its own thread).
    static NEEDED: RefCell<Vec<&'static str>> = const { RefCell::new(Vec::new()) };
}

/// True where every tool is there; otherwise the skip (or, under
/// `MURK_REQUIRE_TOOLS=1`, the failure) that `need!` describes.
pub fn present(tools: &[&Tool]) -> bool {
    let missing: Vec<&&Tool> = tools.iter().filter(|t| found(t).is_none()).collect();
    if missing.is_empty() {
        NEEDED.with(|n| n.borrow_mut().extend(tools.iter().map(|t| t.name)));
        return true;
    }
    let needs = missing
        .iter()
        .map(|t| format!("{} ({})", t.name, t.package))
        .collect::<Vec<_>>()
        .join(", ");
    let line = format!("SKIPPED {}: needs {needs}", test_name());
    if std::env::var_os("MURK_REQUIRE_TOOLS").is_some_and(|v| v == "1") {
        panic!("MURK_REQUIRE_TOOLS=1, and {line}");
    }
    // Straight to the file descriptor: the test harness captures `eprintln!` of a test
    // that passes, and a skip passes.
    let _ = writeln!(std::io::stderr().lock(), "{line}");
    record(&line);
    false
}

/// A command that runs `tool` (for a Python module, its interpreter). Fails the test
/// unless it began with `need!` for the tool.
pub fn command(tool: &Tool) -> Command {
    assert!(
        NEEDED.with(|n| n.borrow().contains(&tool.name)),
        "{} runs {} without asking for it: start the test with `need!(tools::...)` \
         (tests/common/tools.rs) so that it is skipped where the tool is missing",
        test_name(),
        tool.name
    );
    Command::new(found(tool).unwrap_or_else(|| PathBuf::from(tool.name)))
}

/// `command` for a tool given by the name of its executable, e.g. `"exrheader"`.
pub fn command_named(exe: &str) -> Command {
    let tool = ALL
        .iter()
        .find(|t| matches!(t.probe, Probe::OnPath(e) if e == exe))
        .unwrap_or_else(|| panic!("`{exe}` is not a tool of tests/common/tools.rs: add it"));
    command(tool)
}

/// Where the tool is, looked up once per test binary.
fn found(tool: &Tool) -> Option<PathBuf> {
    static SEEN: OnceLock<Mutex<HashMap<&'static str, Option<PathBuf>>>> = OnceLock::new();
    let seen = SEEN.get_or_init(Default::default);
    if let Some(hit) = seen.lock().unwrap().get(tool.name) {
        return hit.clone();
    }
    let hit = match tool.probe {
        Probe::OnPath(exe) => on_path(exe),
        Probe::Python(pythons, modules) => pythons
            .iter()
            .find(|python| {
                Command::new(python)
                    .args(["-c", &format!("import {modules}")])
                    .stdout(Stdio::null())
                    .stderr(Stdio::null())
                    .status()
                    .is_ok_and(|s| s.success())
            })
            .map(PathBuf::from),
        Probe::Openjd => std::env::var_os("MURK_OPENJD")
            .map(PathBuf::from)
            .into_iter()
            .chain([PathBuf::from("/opt/murk-venv/bin/openjd")])
            .find(|p| executable(p))
            .or_else(|| on_path("openjd")),
        Probe::Files(files) => files
            .iter()
            .all(|f| Path::new(f).is_file())
            .then(|| PathBuf::from(files[0])),
    };
    seen.lock().unwrap().insert(tool.name, hit.clone());
    hit
}

fn on_path(exe: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|dir| dir.join(exe))
        .find(|p| executable(p))
}

fn executable(p: &Path) -> bool {
    use std::os::unix::fs::PermissionsExt;
    std::fs::metadata(p).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
}

/// `binary::test`, e.g. `render_output::exr_header_per_exrheader`.
fn test_name() -> String {
    let exe = std::env::args().next().unwrap_or_default();
    let stem = Path::new(&exe)
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("?");
    // Cargo names a test binary `<name>-<hash>`.
    let binary = stem.rsplit_once('-').map_or(stem, |(name, _)| name);
    let thread = std::thread::current();
    format!("{binary}::{}", thread.name().unwrap_or("?"))
}

/// The folder that holds one file of skip lines per `cargo test` run.
pub fn skip_dir() -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join("murk-skipped")
}

/// The file of this run's skips. Cargo starts every test binary of one `cargo test`
/// itself, so the parent process (its id and, on Linux, its start time, which tells a
/// reused id apart) names the run.
pub fn skip_file() -> PathBuf {
    let cargo = std::os::unix::process::parent_id();
    let started = std::fs::read_to_string(format!("/proc/{cargo}/stat"))
        .ok()
        .and_then(|stat| {
            // Field 22 (start time), counted after the parenthesised command name.
            let rest = stat.rsplit_once(')')?.1;
            rest.split_whitespace().nth(19).map(str::to_owned)
        })
        .unwrap_or_default();
    skip_dir().join(format!("{cargo}-{started}.txt"))
}

fn record(line: &str) {
    let _ = std::fs::create_dir_all(skip_dir());
    // One write of the whole line, so that lines of tests running at once don't mix.
    if let Ok(mut f) = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(skip_file())
    {
        let _ = f.write_all(format!("{line}\n").as_bytes());
    }
}
