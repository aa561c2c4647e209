//! Helpers shared by the integration tests: tools nobody here wrote (exrheader,
//! oiiotool) run as a reader would, failing the test when a tool is missing.
#![allow(dead_code)]

pub mod march;

use std::path::Path;
use std::process::Command;

/// Runs an external tool; a missing tool or a failure fails the test.
pub fn tool(tool: &str, args: &[&str], package: &str) -> String {
    let out = Command::new(tool).args(args).output().unwrap_or_else(|e| {
        panic!("cannot run `{tool}` ({e}): it is required; install the Debian package `{package}`")
    });
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "`{tool} {}` failed: {}\n{text}\n{}",
        args.join(" "),
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

pub fn exrheader(path: &Path) -> String {
    tool("exrheader", &[path.to_str().unwrap()], "openexr")
}

pub fn oiio_info(path: &Path) -> String {
    tool(
        "oiiotool",
        &["--info", "-v", path.to_str().unwrap()],
        "openimageio-tools",
    )
}

/// The channel list printed by exrheader: (name, type), in file order.
pub fn exrheader_channels(header: &str) -> Vec<(String, String)> {
    header
        .lines()
        .skip_while(|l| !l.starts_with("channels (type chlist):"))
        .skip(1)
        .take_while(|l| l.starts_with("    "))
        .map(|l| {
            let mut parts = l.trim().split(", ");
            (
                parts.next().unwrap().to_owned(),
                parts.next().unwrap().to_owned(),
            )
        })
        .collect()
}
