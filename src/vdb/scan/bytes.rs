//! A bounded reader for the scan: it tracks its position and refuses to read past the
//! end of the file, so no length read from the file turns into an allocation.

use super::*;

/// A position-tracking reader that refuses to read past the end of the file.
pub(super) struct Bytes<R> {
    pub(super) r: R,
    pub(super) pos: u64,
    /// Where the readable data ends: the file's length, or a grid's end offset.
    pub(super) len: u64,
    /// What ends at `len`, for messages.
    pub(super) what: &'static str,
}

/// Skips up to this many bytes by reading them (through the buffer), longer ones by seeking.
const SKIP_BY_READING: u64 = 64 * 1024;

impl<R: Read + Seek> Bytes<R> {
    pub(super) fn left(&self) -> u64 {
        self.len.saturating_sub(self.pos)
    }

    pub(super) fn need(&self, n: u64) -> Result<(), String> {
        if n > self.left() {
            return Err(if self.pos >= self.len || n <= 64 {
                format!(
                    "{} is truncated (unexpected end of data at byte {})",
                    self.what,
                    self.pos.min(self.len)
                )
            } else {
                format!(
                    "a length or size of {n} bytes at byte {} runs past the end of {} ({} bytes left)",
                    self.pos,
                    self.what,
                    self.left()
                )
            });
        }
        Ok(())
    }

    pub(super) fn array<const N: usize>(&mut self) -> Result<[u8; N], String> {
        self.need(N as u64)?;
        let mut b = [0u8; N];
        self.r.read_exact(&mut b).map_err(|e| e.to_string())?;
        self.pos += N as u64;
        Ok(b)
    }

    pub(super) fn u8(&mut self) -> Result<u8, String> {
        Ok(self.array::<1>()?[0])
    }
    pub(super) fn i8(&mut self) -> Result<i8, String> {
        Ok(self.u8()? as i8)
    }
    pub(super) fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.array()?))
    }
    pub(super) fn i32(&mut self) -> Result<i32, String> {
        Ok(i32::from_le_bytes(self.array()?))
    }
    pub(super) fn i64(&mut self) -> Result<i64, String> {
        Ok(i64::from_le_bytes(self.array()?))
    }
    pub(super) fn coord(&mut self) -> Result<[i32; 3], String> {
        Ok([self.i32()?, self.i32()?, self.i32()?])
    }

    pub(super) fn skip(&mut self, n: u64) -> Result<(), String> {
        self.need(n)?;
        if n <= SKIP_BY_READING {
            // A seek would drop the BufReader's buffer and read it again: the scan skips a
            // chunk per leaf, and seeking each time read the file several times over.
            let read = std::io::copy(&mut (&mut self.r).take(n), &mut std::io::sink())
                .map_err(|e| e.to_string())?;
            if read != n {
                return Err(format!(
                    "{} is truncated (unexpected end of data at byte {})",
                    self.what,
                    self.pos + read
                ));
            }
        } else {
            let step = i64::try_from(n)
                .map_err(|_| "a size does not fit into a file offset".to_string())?;
            self.r
                .seek(SeekFrom::Current(step))
                .map_err(|e| e.to_string())?;
        }
        self.pos += n;
        Ok(())
    }

    /// Moves to an absolute position; positions past the end fail on the next read.
    pub(super) fn seek(&mut self, pos: u64) -> Result<(), String> {
        self.r
            .seek(SeekFrom::Start(pos.min(self.len)))
            .map_err(|e| e.to_string())?;
        self.pos = pos;
        Ok(())
    }

    /// An OpenVDB string (u32 length + bytes), decoded as the reader does.
    pub(super) fn string(&mut self) -> Result<String, String> {
        let n = self.u32()? as u64;
        self.need(n)?;
        let mut b = vec![0u8; n as usize];
        self.r.read_exact(&mut b).map_err(|e| e.to_string())?;
        self.pos += n;
        Ok(String::from_utf8_lossy(&b).into_owned())
    }

    pub(super) fn skip_string(&mut self) -> Result<(), String> {
        let n = self.u32()? as u64;
        self.skip(n)
    }

    /// A node mask of `words` 64-bit words.
    pub(super) fn mask(&mut self, words: usize) -> Result<Vec<u64>, String> {
        self.need(words as u64 * 8)?;
        let mut b = vec![0u8; words * 8];
        self.r.read_exact(&mut b).map_err(|e| e.to_string())?;
        self.pos += words as u64 * 8;
        Ok(b.chunks_exact(8)
            .map(|c| u64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]))
            .collect())
    }

    pub(super) fn meta_map(&mut self) -> Result<(), String> {
        let count = self.u32()?;
        for _ in 0..count {
            self.skip_string()?;
            self.skip_string()?;
            let size = self.u32()? as u64;
            self.skip(size)?;
        }
        Ok(())
    }
}

pub(super) fn popcount(words: &[u64]) -> u64 {
    words.iter().map(|w| w.count_ones() as u64).sum()
}
