use super::RenderPlan;
use crate::scene::options::{DefaultValue, FLAGS, Kind, RenderOptions};
use std::path::PathBuf;

/// Options that make every option matter to the plan: an output and a preview (whose
/// exposure and background are otherwise not read).
fn base() -> RenderOptions {
    RenderOptions {
        output: Some("out.exr".into()),
        preview: Some("out.png".into()),
        ..RenderOptions::default()
    }
}

fn plan_text(o: &RenderOptions) -> String {
    match RenderPlan::new(o, PathBuf::from("in.vdb")) {
        Ok(p) => format!("{p:?}"),
        Err(e) => format!("error: {e}"),
    }
}

#[test]
fn every_documented_default_is_the_default() {
    let unset = plan_text(&base());
    assert!(!unset.starts_with("error"), "{unset}");
    let mut checked = 0;
    for f in FLAGS {
        let DefaultValue::Value(v) = f.default else {
            continue;
        };
        let mut o = base();
        o.set_flag(f.key, v)
            .unwrap_or_else(|e| panic!("--{}'s documented default {v:?}: {e}", f.long()));
        assert_eq!(
            plan_text(&o),
            unset,
            "--{} {v} (its documented default) changes the plan",
            f.long()
        );
        checked += 1;
    }
    assert!(checked >= 20, "only {checked} flags state a default value");
}

#[test]
fn a_wrong_documented_default_is_caught() {
    // The check above must be able to fail: a default off by a little changes the plan.
    for (key, wrong) in [("fov", "41"), ("dsm_tolerance", "2e-3"), ("antialias", "3")] {
        let mut o = base();
        o.set_flag(key, wrong).unwrap();
        assert_ne!(plan_text(&o), plan_text(&base()), "{key} {wrong}");
    }
}

#[test]
fn every_option_is_a_scene_key_and_a_flag() {
    for f in FLAGS {
        // The scene file takes the key (a switch as `key = true`, a repeated flag as a
        // list of strings), and the flag's value as text.
        let toml_value = match f.kind {
            Kind::Switch => "true".to_string(),
            Kind::Repeated => "[]".to_string(),
            Kind::Value => continue,
        };
        let parsed: Result<RenderOptions, _> = toml::from_str(&format!("{} = {toml_value}", f.key));
        assert!(parsed.is_ok(), "scene key {}: {:?}", f.key, parsed.err());
    }
    let mut o = RenderOptions::default();
    o.set_flag("sigma_a", "0.2").unwrap();
    let scene: RenderOptions = toml::from_str("sigma_a = \"0.2\"").unwrap();
    assert_eq!(o, scene);
}

/// docs/scene-file.md's key table is made from the same table as `--help`; with
/// `MURK_BLESS=1` this test writes it.
#[test]
fn scene_file_docs_are_current() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/scene-file.md");
    let text = std::fs::read_to_string(&path).unwrap_or_default();
    let (begin, end) = ("<!-- keys: begin -->\n", "<!-- keys: end -->");
    let table = crate::scene::options::scene_keys_markdown();
    let (Some(a), Some(b)) = (text.find(begin), text.find(end)) else {
        panic!("{} lacks the markers {begin:?} … {end:?}", path.display());
    };
    let current = &text[a + begin.len()..b];
    if current != table {
        if std::env::var_os("MURK_BLESS").is_some() {
            let new = format!("{}{begin}{table}{}", &text[..a], &text[b..]);
            std::fs::write(&path, new).unwrap();
        } else {
            panic!(
                "docs/scene-file.md's key table is out of date: run `MURK_BLESS=1 cargo test --release --lib scene_file_docs_are_current`"
            );
        }
    }
}
