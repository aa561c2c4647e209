//! One frame split across machines: `--tile I/N` renders the I-th of N bands of rows into
//! a partial EXR whose header says which piece of which frame it is; `murk stitch`
//! (`output::stitch`) puts the pieces back together.

use std::ops::Range;

/// The header attributes of a piece, which `murk stitch` reads back.
pub use crate::output::attr;

/// A `--tile I/N` that names no piece of the frame.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("--tile {value}: {problem}")]
pub struct PieceError {
    /// The flag's value, as given.
    pub value: String,
    /// What is wrong with it.
    pub problem: String,
}

/// The I-th (from 1) of N bands of rows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Piece {
    pub index: usize,
    pub count: usize,
}

/// The most pieces a frame may be split into.
pub const MAX_PIECES: usize = 65_536;

impl Piece {
    /// Parses `I/N` (1 ≤ I ≤ N).
    pub fn parse(s: &str) -> Result<Piece, PieceError> {
        let bad = |why: &str| PieceError {
            value: s.to_string(),
            problem: why.to_string(),
        };
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| bad("expected I/N, the I-th of N pieces (e.g. 2/4)"))?;
        let num = |t: &str| t.trim().parse::<usize>().ok();
        let (Some(index), Some(count)) = (num(i), num(n)) else {
            return Err(bad("expected I/N with whole numbers (e.g. 2/4)"));
        };
        if count == 0 || count > MAX_PIECES {
            return Err(bad(&format!("N must be 1 to {MAX_PIECES}")));
        }
        if index == 0 || index > count {
            return Err(bad(&format!(
                "I must be 1 to {count} (pieces count from 1)"
            )));
        }
        Ok(Piece { index, count })
    }

    /// Its rows of an image `height` rows high: the bands are as even as can be.
    pub fn rows(&self, height: usize) -> Range<usize> {
        (self.index - 1) * height / self.count..self.index * height / self.count
    }

    /// Refuses more pieces than rows (a piece would be empty).
    pub fn check(&self, height: usize) -> Result<(), PieceError> {
        if self.count > height {
            return Err(PieceError {
                value: self.to_string(),
                problem: format!("more pieces than the image's {height} rows"),
            });
        }
        Ok(())
    }
}

impl std::fmt::Display for Piece {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pieces_cover_every_row_once() {
        for h in [1usize, 7, 90, 101] {
            for n in 1..=h.min(9) {
                let mut next = 0;
                for i in 1..=n {
                    let r = Piece { index: i, count: n }.rows(h);
                    assert_eq!(r.start, next);
                    assert!(!r.is_empty());
                    next = r.end;
                }
                assert_eq!(next, h);
            }
        }
    }

    #[test]
    fn bad_pieces() {
        for bad in ["0/3", "4/3", "1/0", "3", "a/b", "-1/3"] {
            assert!(
                Piece::parse(bad)
                    .unwrap_err()
                    .to_string()
                    .starts_with("--tile"),
                "{bad}"
            );
        }
        assert_eq!(Piece::parse("2/3").unwrap(), Piece { index: 2, count: 3 });
        assert!(Piece { index: 1, count: 5 }.check(4).is_err());
    }
}
