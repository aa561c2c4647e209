//! Frame sequences: the frame patterns of file names (`####`, `%04d`, `$F4`, `$F`), the
//! frame lists of `--frames` (`1-10,20,30-40x2`), and the frames a pattern finds on disk.

use std::path::{Path, PathBuf};

/// A piece of a file name: text as it is, or the frame number padded to `pad` digits.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Piece {
    Text(String),
    Frame { pad: usize },
}

/// A path that may hold frame patterns: `####` (one `#` per digit), `%04d` (or `%d`),
/// Houdini's `$F4` (or `$F`, unpadded). Every pattern in it takes the same frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FramePattern {
    pieces: Vec<Piece>,
    /// The first pattern asking for more than [`MAX_PAD`] digits, as written (its
    /// piece holds [`MAX_PAD`]); [`FramePattern::check`] refuses it.
    too_wide: Option<String>,
}

/// The widest padding accepted (wider is surely a typo).
const MAX_PAD: usize = 12;

impl FramePattern {
    pub fn new(path: &Path) -> FramePattern {
        let (pieces, too_wide) = parse(&path.to_string_lossy());
        FramePattern { pieces, too_wide }
    }

    /// Refuses a pattern wider than [`MAX_PAD`] digits (`what` names the path in the
    /// message): no frame number has that many, so it is surely a typo, and padding it
    /// silently to fewer would write names nobody asked for.
    pub fn check(&self, what: &str) -> Result<(), String> {
        match &self.too_wide {
            Some(p) => Err(format!(
                "{what}: the frame pattern {p} asks for more than {MAX_PAD} digits; use at most {MAX_PAD} (e.g. ####)"
            )),
            None => Ok(()),
        }
    }

    /// Whether the path holds a frame pattern at all.
    pub fn is_pattern(&self) -> bool {
        self.pieces.iter().any(|p| matches!(p, Piece::Frame { .. }))
    }

    /// The path of frame `frame` (the path as it is when it holds no pattern).
    pub fn path(&self, frame: i64) -> PathBuf {
        let mut s = String::new();
        for p in &self.pieces {
            match p {
                Piece::Text(t) => s.push_str(t),
                Piece::Frame { pad } => s.push_str(&format!("{frame:0pad$}")),
            }
        }
        PathBuf::from(s)
    }

    /// The frames whose files exist: the pattern must be in the file name (not in a
    /// folder); files are matched by name in its folder, sorted by frame.
    pub fn existing_frames(&self, shown: &Path) -> Result<Vec<i64>, FramesError> {
        let whole = self.path_text();
        let path = Path::new(&whole);
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        if FramePattern::new(&dir).is_pattern() {
            return Err(FramesError::PatternInFolder {
                pattern: shown.to_owned(),
            });
        }
        let (name, _) = parse(&path.file_name().unwrap_or_default().to_string_lossy());
        let entries = std::fs::read_dir(&dir).map_err(|e| FramesError::Unlisted {
            pattern: shown.to_owned(),
            folder: dir.clone(),
            problem: e.to_string(),
        })?;
        let mut frames: Vec<i64> = entries
            .filter_map(|e| e.ok())
            .filter_map(|e| e.file_name().to_str().and_then(|n| match_name(&name, n)))
            .collect();
        frames.sort_unstable();
        frames.dedup();
        if frames.is_empty() {
            return Err(FramesError::NoMatch {
                pattern: shown.to_owned(),
            });
        }
        Ok(frames)
    }

    /// The pattern as written (patterns in their canonical form).
    fn path_text(&self) -> String {
        self.pieces
            .iter()
            .map(|p| match p {
                Piece::Text(t) => t.clone(),
                Piece::Frame { pad } => "#".repeat(*pad),
            })
            .collect()
    }
}

/// The pieces of `s`, and the first pattern in it wider than [`MAX_PAD`] (as written).
fn parse(s: &str) -> (Vec<Piece>, Option<String>) {
    let b = s.as_bytes();
    let mut pieces = Vec::new();
    let mut text = String::new();
    let mut too_wide = None;
    let mut i = 0;
    let mut push = |pieces: &mut Vec<Piece>, text: &mut String, pad: usize, written: &str| {
        if !text.is_empty() {
            pieces.push(Piece::Text(std::mem::take(text)));
        }
        if pad > MAX_PAD && too_wide.is_none() {
            too_wide = Some(written.to_string());
        }
        pieces.push(Piece::Frame {
            pad: pad.clamp(1, MAX_PAD),
        });
    };
    // A width too long to parse is too wide.
    let width = |digits: &str, none: usize| match digits {
        "" => none,
        d => d.parse::<usize>().unwrap_or(usize::MAX),
    };
    while i < b.len() {
        if b[i] == b'#' {
            let n = b[i..].iter().take_while(|&&c| c == b'#').count();
            push(&mut pieces, &mut text, n, &s[i..i + n]);
            i += n;
            continue;
        }
        if b[i] == b'%' {
            // %d or %0Nd
            let digits: usize = b[i + 1..].iter().take_while(|c| c.is_ascii_digit()).count();
            if b.get(i + 1 + digits) == Some(&b'd') {
                let pad = width(&s[i + 1..i + 1 + digits], 0);
                push(&mut pieces, &mut text, pad, &s[i..i + digits + 2]);
                i += digits + 2;
                continue;
            }
        }
        if b[i] == b'$' && b.get(i + 1) == Some(&b'F') {
            let digits = b[i + 2..].iter().take_while(|c| c.is_ascii_digit()).count();
            let pad = width(&s[i + 2..i + 2 + digits], 1);
            push(&mut pieces, &mut text, pad, &s[i..i + digits + 2]);
            i += digits + 2;
            continue;
        }
        let c = s[i..].chars().next().unwrap_or('?');
        text.push(c);
        i += c.len_utf8();
    }
    if !text.is_empty() {
        pieces.push(Piece::Text(text));
    }
    (pieces, too_wide)
}

/// The frame of file name `name` under the pattern `pieces`, if it fits: every frame
/// piece is all digits, at least its padding wide (exactly, when zero-padded wider than
/// the number), and all pieces take the same frame.
fn match_name(pieces: &[Piece], name: &str) -> Option<i64> {
    let mut rest = name;
    let mut frame: Option<i64> = None;
    for (k, p) in pieces.iter().enumerate() {
        match p {
            Piece::Text(t) => rest = rest.strip_prefix(t.as_str())?,
            Piece::Frame { pad } => {
                let n = rest.bytes().take_while(u8::is_ascii_digit).count();
                // A frame followed directly by another frame piece cannot be split.
                if n == 0 || matches!(pieces.get(k + 1), Some(Piece::Frame { .. })) {
                    return None;
                }
                let digits = &rest[..n];
                if n < *pad || (n > *pad && digits.starts_with('0')) || n > 18 {
                    return None;
                }
                let f: i64 = digits.parse().ok()?;
                if frame.is_some_and(|g| g != f) {
                    return None;
                }
                frame = Some(f);
                rest = &rest[n..];
            }
        }
    }
    if rest.is_empty() { frame } else { None }
}

/// A frame list (`--frames`) that cannot be read, or an input pattern whose frames
/// cannot be found; each names the flag or the pattern.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FramesError {
    /// `--frames SPEC` is not a frame list.
    #[error("--frames {spec}: {problem}")]
    List {
        /// The list as given.
        spec: String,
        /// What is wrong with it.
        problem: String,
    },
    /// The pattern is in a folder's name, where murk does not look for frames.
    #[error("{}: a frame pattern in a folder name needs --frames", pattern.display())]
    PatternInFolder {
        /// The input pattern as given.
        pattern: PathBuf,
    },
    /// The pattern's folder cannot be listed.
    #[error("{}: cannot list {}: {problem}", pattern.display(), folder.display())]
    Unlisted {
        /// The input pattern as given.
        pattern: PathBuf,
        /// Its folder.
        folder: PathBuf,
        /// The system's reason.
        problem: String,
    },
    /// No file in the folder matches the pattern.
    #[error("{}: the pattern matches no file", pattern.display())]
    NoMatch {
        /// The input pattern as given.
        pattern: PathBuf,
    },
}

/// The most frames a list may hold (a typo like `1-1000000000` is refused, not allocated).
pub const MAX_FRAMES: usize = 1_000_000;

/// Parses a frame list: comma-separated `A`, `A-B` or `A-BxSTEP` (frames A, A+STEP, ... up
/// to B). Returns the frames in ascending order. Refuses reversed ranges, a step of 0, and
/// lists naming a frame twice (overlapping ranges).
pub fn parse_frames(spec: &str) -> Result<Vec<i64>, FramesError> {
    let bad = |why: String| FramesError::List {
        spec: spec.to_string(),
        problem: why,
    };
    let mut frames: Vec<i64> = Vec::new();
    for item in spec.split(',').map(str::trim) {
        if item.is_empty() {
            return Err(bad("an empty item".into()));
        }
        if item.contains("..") || item.contains(':') {
            return Err(bad(format!(
                "`{item}`: write a range as A-B, with a step as A-BxSTEP (e.g. 1-10,20,30-40x2)"
            )));
        }
        let num = |t: &str| -> Result<i64, FramesError> {
            t.trim().parse::<i64>().ok().filter(|v| *v >= 0).ok_or_else(|| {
                bad(format!(
                    "`{item}`: `{t}` is not a frame number (0 or more); a list reads 1-10,20,30-40x2"
                ))
            })
        };
        let (range, step) = match item.split_once('x') {
            Some((r, s)) => {
                let step = num(s)?;
                if step == 0 {
                    return Err(bad(format!("`{item}`: the step is 0")));
                }
                (r, step)
            }
            None => (item, 1),
        };
        let (a, b) = match range.split_once('-') {
            Some((a, b)) => (num(a)?, num(b)?),
            None if step != 1 => {
                return Err(bad(format!("`{item}`: a step needs a range A-B")));
            }
            None => {
                let a = num(range)?;
                (a, a)
            }
        };
        if b < a {
            return Err(bad(format!("`{item}` is reversed ({b} < {a})")));
        }
        let count = ((b - a) / step + 1) as usize;
        if frames.len() + count > MAX_FRAMES {
            return Err(bad(format!("more than {MAX_FRAMES} frames")));
        }
        frames.extend((0..count as i64).map(|k| a + k * step));
    }
    frames.sort_unstable();
    if let Some(w) = frames.windows(2).find(|w| w[0] == w[1]) {
        return Err(bad(format!(
            "frame {} is named twice (overlapping ranges)",
            w[0]
        )));
    }
    Ok(frames)
}

/// `frames` (ascending) written as a short list: runs of three or more frames a
/// constant step apart as `A-B` (step 1) or `A-B{step_mark}STEP`, the rest one by one;
/// `x` gives `--frames` syntax, `:` an Open Job Description range expression.
pub fn frame_ranges(frames: &[i64], step_mark: &str) -> String {
    let mut items = Vec::new();
    let mut i = 0;
    while i < frames.len() {
        let mut j = i + 1;
        if let Some(&next) = frames.get(i + 1) {
            let step = next - frames[i];
            while j < frames.len() && frames[j] - frames[j - 1] == step {
                j += 1;
            }
            if j - i >= 3 {
                let (a, b) = (frames[i], frames[j - 1]);
                items.push(if step == 1 {
                    format!("{a}-{b}")
                } else {
                    format!("{a}-{b}{step_mark}{step}")
                });
                i = j;
                continue;
            }
        }
        items.push(frames[i].to_string());
        i += 1;
    }
    items.join(",")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_pattern_style_gives_the_padded_frame() {
        let cases = [
            ("seq/fluid_####.vdb", "seq/fluid_0007.vdb"),
            ("seq/fluid_%04d.vdb", "seq/fluid_0007.vdb"),
            ("seq/fluid_%d.vdb", "seq/fluid_7.vdb"),
            ("pyro.$F4.vdb", "pyro.0007.vdb"),
            ("pyro.$F.vdb", "pyro.7.vdb"),
            ("a_#/b_##.exr", "a_7/b_07.exr"),
            ("plain.vdb", "plain.vdb"),
            ("100%.vdb", "100%.vdb"),
            ("$HOME.vdb", "$HOME.vdb"),
        ];
        for (pattern, want) in cases {
            assert_eq!(
                FramePattern::new(Path::new(pattern)).path(7),
                PathBuf::from(want),
                "{pattern}"
            );
        }
        assert_eq!(
            FramePattern::new(Path::new("f_##.vdb")).path(1234),
            PathBuf::from("f_1234.vdb")
        );
        assert!(!FramePattern::new(Path::new("plain.vdb")).is_pattern());
        assert!(FramePattern::new(Path::new("x.$F.vdb")).is_pattern());
    }

    #[test]
    fn patterns_wider_than_twelve_digits_are_refused() {
        for ok in [
            "f_############.vdb",
            "f_%012d.vdb",
            "f.$F12.vdb",
            "f_%d.vdb",
            "plain.vdb",
        ] {
            assert!(FramePattern::new(Path::new(ok)).check(ok).is_ok(), "{ok}");
        }
        for (bad, shown) in [
            ("f_################.vdb", "################"),
            ("f_%0999d.vdb", "%0999d"),
            ("f.$F99.vdb", "$F99"),
            (
                "f_%099999999999999999999999d.vdb",
                "%099999999999999999999999d",
            ),
            ("ok_####/f_%013d.vdb", "%013d"),
        ] {
            let e = FramePattern::new(Path::new(bad))
                .check(&format!("-o {bad}"))
                .unwrap_err();
            assert!(
                e.starts_with(&format!("-o {bad}: the frame pattern {shown} ")),
                "{e}"
            );
            // Still a pattern (a sequence), whose names are never built wider than 12.
            let p = FramePattern::new(Path::new(bad));
            assert!(p.is_pattern());
            assert!(p.path(7).to_string_lossy().len() <= bad.len() + 12, "{bad}");
        }
    }

    #[test]
    fn names_match_only_with_the_right_padding() {
        let p = parse("fluid_####.vdb").0;
        assert_eq!(match_name(&p, "fluid_0012.vdb"), Some(12));
        assert_eq!(match_name(&p, "fluid_12345.vdb"), Some(12345));
        assert_eq!(match_name(&p, "fluid_012.vdb"), None);
        assert_eq!(match_name(&p, "fluid_00012.vdb"), None);
        assert_eq!(match_name(&p, "fluid_0012.vdb.tmp"), None);
        assert_eq!(match_name(&parse("p.$F.vdb").0, "p.7.vdb"), Some(7));
        assert_eq!(match_name(&parse("p.$F.vdb").0, "p.07.vdb"), None);
    }

    #[test]
    fn frame_lists() {
        assert_eq!(parse_frames("1-3").unwrap(), vec![1, 2, 3]);
        assert_eq!(parse_frames("1-10,20,30-40x2").unwrap().len(), 10 + 1 + 6);
        assert_eq!(parse_frames("30-35x2, 1").unwrap(), vec![1, 30, 32, 34]);
        for bad in [
            "5-1", "1-5,3", "1-5,5-9", "1-5x0", "", "a", "1-", "3x2", "-1", "1,,2",
        ] {
            let e = parse_frames(bad).unwrap_err().to_string();
            assert!(e.starts_with("--frames"), "{bad}: {e}");
        }
        assert!(parse_frames("0-99999999999").is_err());
        for other_syntax in ["1..10", "1:10"] {
            let e = parse_frames(other_syntax).unwrap_err().to_string();
            assert!(e.contains("write a range as A-B"), "{e}");
        }
    }

    #[test]
    fn frame_lists_are_written_back_short() {
        for spec in [
            "1-10,20,30-40x2",
            "1001-2100",
            "1,3",
            "5",
            "1-2,4-9",
            "0-8x4,10-20x5",
        ] {
            let frames = parse_frames(spec).unwrap();
            let short = frame_ranges(&frames, "x");
            assert_eq!(parse_frames(&short).unwrap(), frames, "{spec} -> {short}");
        }
        assert_eq!(
            frame_ranges(&parse_frames("1001-2100").unwrap(), ":"),
            "1001-2100"
        );
        assert_eq!(frame_ranges(&[1, 3, 5, 6], ":"), "1-5:2,6");
        assert_eq!(frame_ranges(&[150, 151, 152, 200], "x"), "150-152,200");
    }
}
