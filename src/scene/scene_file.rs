//! A scene file's parse errors in one line: the line of the file as written (not TOML's
//! multi-line drawing squashed), the nearest key for a misspelt one, and the syntax for
//! what is written in a way murk does not take.

/// Kept from a scene file's line in an error.
const SNIPPET_CHARS: usize = 80;

/// The one-line problem of a scene file that TOML (or the keys murk takes) refused.
pub fn describe(e: &toml::de::Error, text: &str) -> String {
    let message = e.message().trim().replace('\n', " ");
    let line = e.span().map(|s| {
        let start = s.start.min(text.len());
        let number = text.as_bytes()[..start]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1;
        (number, text.lines().nth(number - 1).unwrap_or("").trim())
    });
    let at = match line {
        Some((n, l)) => format!("line {n}, `{}`: ", snippet(l)),
        None => String::new(),
    };
    if let Some(rest) = message.strip_prefix("unknown field `")
        && let Some((key, rest)) = rest.split_once('`')
    {
        let known: Vec<&str> = rest.split('`').skip(1).step_by(2).collect();
        let hint = match nearest(key, &known) {
            Some(k) => format!("; did you mean `{k}`?"),
            None => " (the keys are murk render's long flags with _ for -)".to_string(),
        };
        return format!("{at}unknown key `{key}`{hint}");
    }
    let table = line.is_some_and(|(_, l)| {
        let l = l.trim_start_matches('[').trim_start();
        l.starts_with("light]") || l.starts_with("light ]")
    });
    if table && message.contains("expected a string") {
        return format!(
            "{at}`light` is a list of strings: light = [\"sun:0.6,1,0.5\", \"point:2,3,1:1,1,1:40\"]; a named light is a table [[lights]] with name = \"key\" and spec = \"sun:...\""
        );
    }
    format!("{at}{message}")
}

/// `line` cut to [`SNIPPET_CHARS`] characters.
fn snippet(line: &str) -> String {
    match line.char_indices().nth(SNIPPET_CHARS) {
        Some((at, _)) => format!("{}...", &line[..at]),
        None => line.to_string(),
    }
}

/// The known key nearest to `key`: by edit distance to the key or to its first word
/// (`colour` → `color_grid`), if near enough to be a slip.
fn nearest<'a>(key: &str, known: &[&'a str]) -> Option<&'a str> {
    let score = |k: &str| {
        let first = k.split('_').next().unwrap_or(k);
        edit_distance(key, k).min(edit_distance(key, first) + 1)
    };
    let limit = (key.chars().count() / 3).max(2);
    known
        .iter()
        .map(|k| (score(k), *k))
        .filter(|(s, _)| *s <= limit)
        .min_by_key(|(s, _)| *s)
        .map(|(_, k)| k)
}

/// Levenshtein distance, by characters.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let next = (row[j + 1] + 1)
                .min(row[j] + 1)
                .min(diagonal + usize::from(ca != *cb));
            diagonal = row[j + 1];
            row[j + 1] = next;
        }
    }
    row[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::RenderOptions;

    fn problem(text: &str) -> String {
        describe(&toml::from_str::<RenderOptions>(text).unwrap_err(), text)
    }

    #[test]
    fn a_misspelt_key_names_its_line_and_the_key_meant() {
        let p = problem("res = \"48x36\"\ncolour = \"Cd\"\n");
        assert_eq!(
            p,
            "line 2, `colour = \"Cd\"`: unknown key `colour`; did you mean `color_grid`?"
        );
        assert!(problem("sigma_ss = \"1,1,1\"").contains("did you mean `sigma_s`?"));
        assert!(problem("[[lights]]\nnmae = \"a\"\nspec = \"sun:1,1,1\"").contains("`name`"));
        let far = problem("zzzzzzzz = 1");
        assert!(
            !far.contains("did you mean") && !far.contains('\n'),
            "{far}"
        );
    }

    #[test]
    fn a_light_table_gets_the_syntax() {
        let p = problem("[[light]]\nspec = \"sun:1,1,1\"\n");
        assert!(
            p.starts_with("line 1, `[[light]]`: `light` is a list of strings"),
            "{p}"
        );
        assert!(p.contains("[[lights]]"), "{p}");
        let p = problem("res = 48\n");
        assert!(p.starts_with("line 1, `res = 48`: invalid type"), "{p}");
    }

    #[test]
    fn edit_distances() {
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(edit_distance("same", "same"), 0);
    }
}
