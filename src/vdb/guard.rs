//! Checks made on a file's descriptors and transforms before any tree is decoded. The
//! reader recurses through instance chains and trusts offsets; these checks turn the
//! inputs that would crash or exhaust it into errors.

use std::collections::HashMap;

/// Longest chain of instanced grids accepted (real files have chains of length 1).
pub const MAX_INSTANCE_CHAIN: usize = 16;

/// Most instanced grids sharing one tree (each decodes that tree again; real files have
/// a few).
pub const MAX_INSTANCES_PER_TREE: usize = 32;

/// Largest index coordinate magnitude accepted: leaves a margin for node arithmetic in
/// i32 (a root node spans 4096 voxels) and keeps local index space exact in f32 steps.
pub const MAX_INDEX_COORD: i64 = 1 << 30;

/// Instance parents must exist and chains must end: `Err` names the problem. Names are
/// looked up as the reader does (the first grid with that unique name).
pub fn check_instance_chains(unique_names: &[String], parents: &[String]) -> Result<(), String> {
    let mut index: HashMap<&str, usize> = HashMap::with_capacity(unique_names.len());
    for (i, n) in unique_names.iter().enumerate() {
        index.entry(n.as_str()).or_insert(i);
    }
    for (i, start) in parents.iter().enumerate() {
        let mut parent = start.as_str();
        let mut steps = 0;
        while !parent.is_empty() {
            steps += 1;
            if steps > MAX_INSTANCE_CHAIN {
                return Err(format!(
                    "grid \"{}\": instance chain longer than {MAX_INSTANCE_CHAIN} or cyclic",
                    printable(&unique_names[i])
                ));
            }
            let Some(&p) = index.get(parent) else {
                return Err(format!(
                    "grid \"{}\": instance parent \"{}\" is not in the file",
                    printable(&unique_names[i]),
                    printable(parent)
                ));
            };
            if p == i {
                return Err(format!(
                    "grid \"{}\": instance chain is cyclic",
                    printable(&unique_names[i])
                ));
            }
            parent = parents[p].as_str();
        }
    }
    Ok(())
}

/// Grid names as they may be shown on one line (control characters escaped).
/// The largest ratio of a voxel's longest edge to its shortest that murk renders. The
/// shadow bake's lattice and the march's steps follow the shortest edge, so work grows
/// with the ratio (a 32³ grid bakes in ~1 s with cubic voxels, ~8 s at 10:1, ~20 s at
/// 100:1, and ran for minutes at 0.1 × 1e-8 × 1e-8). Real caches stay far below
/// (anisotropic scans reach ~10).
pub const MAX_VOXEL_ASPECT: f64 = 100.0;

/// Why a grid with voxels of these edges is not rendered, if it is not.
pub fn voxel_shape_problem(size: Option<glam::DVec3>) -> Option<String> {
    let v = size?;
    let ratio = v.max_element() / v.min_element();
    (ratio > MAX_VOXEL_ASPECT).then(|| {
        format!(
            "its voxels ({} × {} × {}) are {} times longer than wide; murk renders voxels up to {MAX_VOXEL_ASPECT} times",
            number_text(v.x),
            number_text(v.y),
            number_text(v.z),
            number_text(ratio.round())
        )
    })
}

/// A number as messages and tables print it: plain when that is short, else in
/// scientific notation (`-1e308` is `-1e308`, not 309 digits).
pub fn number_text(f: f64) -> String {
    let a = f.abs();
    if f == 0.0 || !f.is_finite() || (1e-4..1e15).contains(&a) {
        let plain = format!("{f}");
        if plain.len() <= 20 {
            return plain;
        }
        return format!("{f:.6}");
    }
    format!("{f:e}")
}

/// Text from a file as an error names it: [`printable`], and past 40 characters cut
/// with the whole text's length said (a grid name of hundreds of bytes of binary would
/// fill the terminal).
pub fn short_text(s: &str) -> String {
    let p = printable(s);
    if p.chars().count() <= 40 {
        p
    } else {
        let head: String = p.chars().take(40).collect();
        format!("{head}… ({} bytes)", s.len())
    }
}

pub fn printable(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars().take(200) {
        if c == '\x1e' {
            out.push('#');
        } else if c.is_control() {
            out.push_str(&c.escape_default().to_string());
        } else {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(v: &[&str]) -> Vec<String> {
        v.iter().map(|x| x.to_string()).collect()
    }

    #[test]
    fn cycles_and_missing_parents_are_rejected() {
        assert!(check_instance_chains(&s(&["a", "b"]), &s(&["", "a"])).is_ok());
        assert!(
            check_instance_chains(&s(&["a", "b"]), &s(&["b", "a"]))
                .unwrap_err()
                .contains("cyclic")
        );
        assert!(
            check_instance_chains(&s(&["a"]), &s(&["a"]))
                .unwrap_err()
                .contains("cyclic")
        );
        assert!(
            check_instance_chains(&s(&["a"]), &s(&["zz"]))
                .unwrap_err()
                .contains("not in the file")
        );
        let names: Vec<String> = (0..40).map(|i| format!("g{i}")).collect();
        let parents: Vec<String> = (0..40)
            .map(|i| {
                if i == 0 {
                    String::new()
                } else {
                    format!("g{}", i - 1)
                }
            })
            .collect();
        assert!(
            check_instance_chains(&names, &parents)
                .unwrap_err()
                .contains("longer")
        );
    }

    #[test]
    fn printable_escapes_control_characters() {
        assert_eq!(printable("den\nsity\x1e1"), "den\\nsity#1");
    }
}
