//! Helpers shared by the integration tests: tools nobody here wrote (exrheader,
//! oiiotool) run as a reader would. A test that runs one starts with `need!` (see
//! `tools`), which skips it where the tool is missing.
#![allow(dead_code)]

pub mod camera;
pub mod deep;
pub mod frames;
pub mod march;
pub mod motion;
pub mod tools;
pub mod volumes;

use std::path::Path;

/// Runs an external tool, which the test asked for with `need!` (`tools`); a failure
/// fails the test.
pub fn tool(tool: &str, args: &[&str], package: &str) -> String {
    let out = tools::command_named(tool)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run `{tool}` (Debian package `{package}`): {e}"));
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

/// Each `--compression` name murk writes and how exrheader names it.
pub const COMPRESSIONS: [(&str, &str); 6] = [
    ("none", "none"),
    ("rle", "run-length encoding"),
    ("zips", "zip, individual scanlines"),
    ("zip", "zip, multi-scanline blocks"),
    ("piz", "piz"),
    ("dwaa", "dwa, small scanline blocks"),
];

/// Asserts that exrheader and oiiotool both read the file's compression as `name`
/// (one of [`COMPRESSIONS`]).
pub fn assert_compression_named(path: &Path, name: &str) {
    let exrheader_name = COMPRESSIONS
        .iter()
        .find(|(n, _)| *n == name)
        .unwrap_or_else(|| panic!("no compression named {name}"))
        .1;
    let h = exrheader(path);
    let line = format!("compression (type compression): {exrheader_name}");
    assert!(
        h.lines().any(|l| l == line),
        "{name}: exrheader lacks `{line}`:\n{h}"
    );
    let info = oiio_info(path);
    assert!(
        info.contains(&format!("compression: \"{name}\"")),
        "{name}: oiiotool says otherwise:\n{info}"
    );
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

/// The command lines under `Examples:` in a help text, without the leading `murk`.
pub fn examples(help: &str) -> Vec<Vec<String>> {
    let mut lines = help.lines().skip_while(|l| l.trim() != "Examples:");
    assert!(lines.next().is_some(), "no `Examples:` section in:\n{help}");
    let found: Vec<Vec<String>> = lines
        .take_while(|l| !l.trim().is_empty())
        .filter_map(|l| l.trim().strip_prefix("murk "))
        .map(split_words)
        .collect();
    assert!(
        !found.is_empty(),
        "`Examples:` lists no `murk ...` command:\n{help}"
    );
    found
}

/// Splits a command line into words, honouring '...' and "..." quotes.
pub fn split_words(line: &str) -> Vec<String> {
    let (mut words, mut word, mut quote, mut in_word) = (Vec::new(), String::new(), None, false);
    for c in line.chars() {
        match (quote, c) {
            (Some(q), c) if c == q => quote = None,
            (Some(_), c) => word.push(c),
            (None, '\'' | '"') => {
                quote = Some(c);
                in_word = true;
            }
            (None, c) if c.is_whitespace() => {
                if in_word {
                    words.push(std::mem::take(&mut word));
                    in_word = false;
                }
            }
            (None, c) => {
                word.push(c);
                in_word = true;
            }
        }
    }
    assert!(quote.is_none(), "unbalanced quote in `{line}`");
    if in_word {
        words.push(word);
    }
    words
}
