//! The layering rule, checked from the `use` lines (and every other `crate::`, `super::`
//! and `self::` path) of `src/**/*.rs`:
//!
//! - a module imports only the stages before it in the pipeline (see [`STAGES`]);
//! - no circle between files (a module's root, `mod.rs` or `x.rs` beside `x/`, may use
//!   what it declares; an item re-exported by a root counts as the file that defines it);
//! - `clap` and `anyhow` only in `src/cli/` and `src/main.rs`.
//!
//! Code after a file's first `#[cfg(test)]` is left out (unit tests may import anything).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The top-level modules in import order: a module may import those of an earlier rank,
/// none of its own rank but itself, none later. `files` and `mem` are the bottom-level
/// utilities every stage may use. `output` (the EXR and PNG writers and their options)
/// comes last in the data flow but is imported by `scene` (the outputs' options) and
/// `render` (which writes): it imports no stage.
const STAGES: &[&[&str]] = &[
    &["files", "mem"],
    &["vdb", "vtk"],
    &["field"],
    &["accel"],
    &["shadow"],
    &["integrate"],
    &["output"],
    &["scene"],
    &["render"],
    &["report"],
    &["cli"],
];

/// A module path (`["field", "mesh", "walk"]`; `[]` is the crate root).
type ModPath = Vec<String>;

/// Source code without comments, the insides of string and char literals, and what
/// follows the first `#[cfg(test)]`.
fn code_of(src: &str) -> String {
    let b = src.as_bytes();
    let mut out = String::with_capacity(src.len());
    let mut i = 0;
    while i < b.len() {
        let rest = &src[i..];
        if rest.starts_with("//") {
            i += rest.find('\n').unwrap_or(rest.len());
        } else if rest.starts_with("/*") {
            i += rest.find("*/").map_or(rest.len(), |e| e + 2);
        } else if rest.starts_with("r#") || rest.starts_with("r\"") {
            let hashes = rest[1..].bytes().take_while(|&c| c == b'#').count();
            if rest.as_bytes().get(1 + hashes) == Some(&b'"') {
                let end = format!("\"{}", "#".repeat(hashes));
                let body = 2 + hashes;
                i += body
                    + rest[body..]
                        .find(&end)
                        .map_or(rest.len() - body, |e| e + end.len());
                out.push_str("\"\"");
            } else {
                out.push('r');
                i += 1;
            }
        } else if b[i] == b'"' {
            let mut j = i + 1;
            while j < b.len() && b[j] != b'"' {
                j += if b[j] == b'\\' { 2 } else { 1 };
            }
            out.push_str("\"\"");
            i = j + 1;
        } else if b[i] == b'\'' {
            // A char literal ('x', '\n', '\u{..}') or a lifetime ('a).
            let close = if rest.as_bytes().get(1) == Some(&b'\\') {
                rest[2..].find('\'').map(|e| e + 3)
            } else {
                rest.char_indices()
                    .nth(2)
                    .filter(|&(_, c)| c == '\'')
                    .map(|(k, _)| k + 1)
            };
            match close {
                Some(n) => {
                    out.push_str("' '");
                    i += n;
                }
                None => {
                    out.push('\'');
                    i += 1;
                }
            }
        } else if rest.starts_with("#[cfg(test)]") {
            break;
        } else {
            let c = rest.chars().next().unwrap_or(' ');
            out.push(c);
            i += c.len_utf8();
        }
    }
    out
}

/// `a::{b, c::{d, e}}` → `a::b`, `a::c::d`, `a::c::e` (whitespace already removed).
fn expand(path: &str) -> Vec<String> {
    let Some(open) = path.find('{') else {
        return vec![path.to_string()];
    };
    let mut depth = 0;
    let mut close = path.len();
    for (k, c) in path.char_indices().skip(open) {
        match c {
            '{' => depth += 1,
            '}' => {
                depth -= 1;
                if depth == 0 {
                    close = k;
                    break;
                }
            }
            _ => {}
        }
    }
    let (pre, inner) = (&path[..open], &path[open + 1..close]);
    let post = path.get(close + 1..).unwrap_or("");
    let mut parts = Vec::new();
    let (mut depth, mut start) = (0, 0);
    for (k, c) in inner.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&inner[start..k]);
                start = k + 1;
            }
            _ => {}
        }
    }
    parts.push(&inner[start..]);
    parts
        .into_iter()
        .filter(|p| !p.is_empty())
        .flat_map(|p| expand(&format!("{pre}{p}{post}")))
        .collect()
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// The paths a file's code names: every `use` (braces expanded, `as` names dropped) and
/// every `crate::…`, `super::…` and `self::…` path elsewhere. `(is_pub_use, path)`.
fn paths_in(code: &str) -> Vec<(bool, String)> {
    let mut out = Vec::new();
    let mut rest_code = String::new();
    let mut i = 0;
    while let Some(k) = code[i..].find("use ").map(|k| k + i) {
        let word_start = k == 0 || !is_ident(code[..k].chars().next_back().unwrap_or(' '));
        if !word_start {
            rest_code.push_str(&code[i..k + 4]);
            i = k + 4;
            continue;
        }
        let Some(end) = code[k..].find(';').map(|e| e + k) else {
            break;
        };
        let before = code[..k].trim_end();
        let is_pub = before.ends_with("pub") || before.ends_with(')') && before.contains("pub(");
        let body: String = code[k + 4..end]
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ");
        let mut cleaned = String::new();
        let mut words = body.split(' ').peekable();
        while let Some(w) = words.next() {
            if w == "as" {
                // `X as Y,` or `X as Y}`: keep what follows the name.
                let renamed = words.next().unwrap_or("");
                cleaned.push_str(renamed.trim_start_matches(is_ident));
            } else {
                cleaned.push_str(w);
            }
        }
        out.extend(expand(&cleaned).into_iter().map(|p| (is_pub, p)));
        rest_code.push_str(&code[i..k]);
        i = end + 1;
    }
    rest_code.push_str(&code[i..]);
    let chars: Vec<char> = rest_code.chars().collect();
    let mut j = 0;
    while j < chars.len() {
        if is_ident(chars[j]) && (j == 0 || !is_ident(chars[j - 1]) && chars[j - 1] != ':') {
            let mut e = j;
            while e < chars.len() && (is_ident(chars[e]) || chars[e] == ':') {
                e += 1;
            }
            let word: String = chars[j..e].iter().collect();
            let word = word.trim_end_matches(':');
            if ["crate::", "super::", "self::"]
                .iter()
                .any(|p| word.starts_with(p))
            {
                out.push((false, word.to_string()));
            }
            j = e;
        } else {
            j += 1;
        }
    }
    out
}

/// The crate's files by module path, as code.
struct Crate {
    files: BTreeMap<ModPath, (String, String)>,
    /// Per module root: re-exported name → the module path it comes from.
    reexports: BTreeMap<ModPath, BTreeMap<String, ModPath>>,
}

impl Crate {
    /// `sources`: (path relative to `src/`, text). `main.rs` is left out (its crate is
    /// the binary; `cli/` is its module and imports the library as `murk::`).
    fn new(sources: &[(String, String)]) -> Crate {
        let mut files = BTreeMap::new();
        for (rel, text) in sources {
            let Some(stem) = rel.strip_suffix(".rs") else {
                continue;
            };
            let mut m: ModPath = stem.split('/').map(str::to_string).collect();
            if m.last().is_some_and(|l| l == "mod") {
                m.pop();
            }
            if m == ["lib"] {
                m.clear();
            }
            if m == ["main"] {
                continue;
            }
            files.insert(m, (rel.clone(), code_of(text)));
        }
        let mut c = Crate {
            files,
            reexports: BTreeMap::new(),
        };
        let mut reexports = BTreeMap::new();
        for (m, (_, code)) in &c.files {
            for (is_pub, p) in paths_in(code) {
                let name = p.rsplit("::").next().unwrap_or("").to_string();
                let relative = ["crate", "super", "self"]
                    .iter()
                    .any(|r| p.starts_with(&format!("{r}::")));
                if is_pub && !relative && !name.is_empty() && name != "*" {
                    let target = c.resolve(m, &format!("self::{p}"));
                    reexports
                        .entry(m.clone())
                        .or_insert_with(BTreeMap::new)
                        .insert(name, target);
                }
            }
        }
        c.reexports = reexports;
        c
    }

    /// The file a path names from module `m`: its longest prefix that is a file, or the
    /// file an item re-exported there comes from.
    fn resolve(&self, m: &ModPath, path: &str) -> ModPath {
        let mut segs: Vec<&str> = path.split("::").collect();
        let mut base: ModPath = m.clone();
        if segs[0] == "crate" {
            base.clear();
            segs.remove(0);
        } else {
            while let Some(&s) = segs.first() {
                match s {
                    "super" => {
                        base.pop();
                    }
                    "self" => {}
                    _ => break,
                }
                segs.remove(0);
            }
        }
        for s in segs {
            let mut next = base.clone();
            next.push(s.to_string());
            if self.files.contains_key(&next) {
                base = next;
            } else {
                if let Some(t) = self.reexports.get(&base).and_then(|r| r.get(s)) {
                    return t.clone();
                }
                break;
            }
        }
        base
    }

    /// Every file → the files it imports (a root's own descendants left out).
    fn edges(&self) -> BTreeMap<ModPath, BTreeSet<ModPath>> {
        let mut edges: BTreeMap<ModPath, BTreeSet<ModPath>> = BTreeMap::new();
        for (m, (_, code)) in &self.files {
            let e = edges.entry(m.clone()).or_default();
            for (_, p) in paths_in(code) {
                let relative = ["crate", "super", "self"]
                    .iter()
                    .any(|r| p.starts_with(&format!("{r}::")));
                if !relative {
                    continue;
                }
                let t = self.resolve(m, &p);
                if t.is_empty() || t.starts_with(m) {
                    continue;
                }
                e.insert(t);
            }
        }
        edges
    }

    fn rel(&self, m: &ModPath) -> &str {
        self.files.get(m).map_or("?", |f| f.0.as_str())
    }
}

fn rank(top: &str) -> Option<usize> {
    STAGES.iter().position(|s| s.contains(&top))
}

/// Imports of a later stage, or of another module of the same rank.
fn layering_violations(c: &Crate) -> Vec<String> {
    let mut bad = Vec::new();
    for (m, targets) in c.edges() {
        let Some(from) = m.first() else { continue };
        for t in targets {
            let to = &t[0];
            if to == from {
                continue;
            }
            match (rank(from), rank(to)) {
                (Some(a), Some(b)) if b < a => {}
                (a, b) => bad.push(format!(
                    "{} imports {} ({to}{} {from})",
                    c.rel(&m),
                    c.rel(&t),
                    match (a, b) {
                        (Some(a), Some(b)) if a == b => " is beside",
                        (Some(_), Some(_)) => " comes after",
                        _ => " is not a known stage, see STAGES; importing from",
                    }
                )),
            }
        }
    }
    bad
}

/// The circles between files: each strongly connected set of two or more files.
fn circles(c: &Crate) -> Vec<Vec<String>> {
    let edges = c.edges();
    let nodes: Vec<&ModPath> = edges.keys().collect();
    let index: BTreeMap<&ModPath, usize> = nodes.iter().enumerate().map(|(i, m)| (*m, i)).collect();
    let adj: Vec<Vec<usize>> = nodes
        .iter()
        .map(|m| {
            edges[*m]
                .iter()
                .filter_map(|t| index.get(t).copied())
                .collect()
        })
        .collect();
    // Tarjan's strongly connected components, iteratively.
    let n = nodes.len();
    let (mut idx, mut low, mut on) = (vec![usize::MAX; n], vec![0; n], vec![false; n]);
    let (mut stack, mut counter, mut out) = (Vec::new(), 0, Vec::new());
    for root in 0..n {
        if idx[root] != usize::MAX {
            continue;
        }
        let mut work = vec![(root, 0usize)];
        while let Some(&mut (v, ref mut next)) = work.last_mut() {
            if *next == 0 {
                idx[v] = counter;
                low[v] = counter;
                counter += 1;
                stack.push(v);
                on[v] = true;
            }
            if let Some(&w) = adj[v].get(*next) {
                *next += 1;
                if idx[w] == usize::MAX {
                    work.push((w, 0));
                } else if on[w] {
                    low[v] = low[v].min(idx[w]);
                }
                continue;
            }
            work.pop();
            if let Some(&(u, _)) = work.last() {
                low[u] = low[u].min(low[v]);
            }
            if low[v] == idx[v] {
                let mut comp = Vec::new();
                while let Some(w) = stack.pop() {
                    on[w] = false;
                    comp.push(c.rel(nodes[w]).to_string());
                    if w == v {
                        break;
                    }
                }
                if comp.len() > 1 {
                    comp.sort();
                    out.push(comp);
                }
            }
        }
    }
    out
}

/// Mentions of clap or anyhow outside `cli/` (and `main.rs`).
fn clap_anyhow_outside_cli(sources: &[(String, String)]) -> Vec<String> {
    let mut bad = Vec::new();
    for (rel, text) in sources {
        if rel.starts_with("cli/") || rel == "main.rs" {
            continue;
        }
        let code = code_of(text);
        for word in ["clap", "anyhow", "bail!"] {
            let mut from = 0;
            while let Some(k) = code[from..].find(word).map(|k| k + from) {
                from = k + word.len();
                let before = code[..k].chars().next_back().unwrap_or(' ');
                let after = code[from..].chars().next().unwrap_or(' ');
                if is_ident(before) || (is_ident(after) && word != "bail!") {
                    continue;
                }
                let line_end = code[k..].find('\n').map_or(code.len(), |e| e + k);
                let mention = code[k..line_end].trim_end_matches(',').trim();
                let line = code[..k].matches('\n').count() + 1;
                bad.push(format!("src/{rel}:{line}: {mention}"));
            }
        }
    }
    bad
}

fn sources() -> Vec<(String, String)> {
    fn walk(dir: &Path, root: &Path, out: &mut Vec<(String, String)>) {
        let mut entries: Vec<_> = std::fs::read_dir(dir)
            .expect("src/ is readable")
            .map(|e| e.expect("a directory entry").path())
            .collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                walk(&p, root, out);
            } else if p.extension().is_some_and(|e| e == "rs") {
                let rel = p.strip_prefix(root).expect("under src/");
                let text = std::fs::read_to_string(&p).expect("a source file is text");
                out.push((rel.to_string_lossy().replace('\\', "/"), text));
            }
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut out = Vec::new();
    walk(&root, &root, &mut out);
    assert!(out.len() > 50, "found only {} source files", out.len());
    out
}

#[test]
fn every_module_imports_only_earlier_stages() {
    let bad = layering_violations(&Crate::new(&sources()));
    assert!(
        bad.is_empty(),
        "imports against the pipeline order:\n{}",
        bad.join("\n")
    );
}

#[test]
fn no_circle_between_files() {
    let found = circles(&Crate::new(&sources()));
    assert!(found.is_empty(), "files that import each other: {found:?}");
}

#[test]
fn clap_and_anyhow_only_in_the_cli() {
    let bad = clap_anyhow_outside_cli(&sources());
    assert!(
        bad.is_empty(),
        "clap or anyhow outside src/cli:\n{}",
        bad.join("\n")
    );
}

fn fake(files: &[(&str, &str)]) -> Vec<(String, String)> {
    files
        .iter()
        .map(|(p, t)| (p.to_string(), t.to_string()))
        .collect()
}

/// The checks find what they are for, and only that: a planted back-arrow, a circle
/// through a re-export, an `anyhow` — and not paths in comments or strings.
#[test]
fn the_checks_find_planted_faults() {
    let src = fake(&[
        (
            "lib.rs",
            "pub mod field;\npub mod render;\npub mod shadow;\n",
        ),
        (
            "field/mod.rs",
            "pub mod grid;\npub mod other;\npub use grid::Grid;\n",
        ),
        // Paths in a comment and a string: not imports.
        (
            "field/grid.rs",
            "// crate::render::x\npub struct Grid;\nfn f() { let _ = \"crate::render::y\"; }\n",
        ),
        // A back-arrow, written inline.
        ("field/other.rs", "pub fn g() { crate::render::run(); }\n"),
        ("shadow/mod.rs", "mod a;\nmod b;\npub use a::A;\n"),
        // a → b directly, b → a through the root's re-export.
        ("shadow/a.rs", "use super::b::{B, C as D};\npub struct A;\n"),
        // b → field through field's re-export of its grid: an earlier stage, allowed.
        (
            "shadow/b.rs",
            "use super::A;\nuse crate::field::Grid;\npub struct B;\n",
        ),
        (
            "render/mod.rs",
            "use anyhow::Result;\nuse crate::shadow::A;\n#[cfg(test)]\nmod tests { use clap::Parser; }\n",
        ),
    ]);
    let c = Crate::new(&src);
    let layering = layering_violations(&c);
    assert_eq!(
        layering,
        vec!["field/other.rs imports render/mod.rs (render comes after field)".to_string()]
    );
    assert_eq!(
        circles(&c),
        vec![vec!["shadow/a.rs".to_string(), "shadow/b.rs".to_string()]]
    );
    assert_eq!(
        clap_anyhow_outside_cli(&src),
        vec!["src/render/mod.rs:1: anyhow::Result;".to_string()]
    );
    // A derive spelled over lines, in the library, is found; the same in cli/ is not.
    let derive = "#[derive(Clone,\n    clap::ValueEnum,\n)]\npub enum E { A }\n";
    let library = fake(&[("integrate/scattering.rs", derive)]);
    assert_eq!(
        clap_anyhow_outside_cli(&library),
        vec!["src/integrate/scattering.rs:2: clap::ValueEnum".to_string()]
    );
    assert!(clap_anyhow_outside_cli(&fake(&[("cli/args.rs", derive)])).is_empty());
}

/// The library's errors are values a caller can match on, each naming the file or the
/// flag at fault (the CLI prints them; it need not parse them).
#[test]
fn library_errors_are_typed() {
    use murk::output::stitch::{StitchError, stitch};
    use murk::render::piece::Piece;
    use murk::render::{RenderError, RenderOptions, RenderPlan, render_image};
    use murk::scene::SceneError;
    use murk::scene::source::SourceError;

    let e = Piece::parse("4/3").unwrap_err();
    assert_eq!(e.value, "4/3");
    assert!(e.to_string().starts_with("--tile 4/3: "), "{e}");

    let dir = std::env::temp_dir();
    let missing = dir.join(format!("murk-architecture-{}-none.vdb", std::process::id()));
    let o = RenderOptions {
        output: Some(dir.join("murk-architecture-unused.exr")),
        ..Default::default()
    };
    let plan = RenderPlan::new(&o, missing.clone()).unwrap();
    match render_image(&plan) {
        Err(RenderError::Scene(SceneError::Source(SourceError::Vdb(e)))) => {
            assert!(e.to_string().contains(&*missing.to_string_lossy()), "{e}")
        }
        Err(e) => panic!("another error: {e:?}"),
        Ok(_) => panic!("rendered a file that does not exist"),
    }
    let out = dir.join("murk-architecture-unused-stitch.exr");
    assert!(matches!(stitch(&[], &out), Err(StitchError::NoPieces)));
}
