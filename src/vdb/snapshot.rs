//! One immutable copy of the input, read once: the structural scan ([`super::scan`]) and
//! the reader crate both read it, so what was checked is what is decoded even when a
//! simulation rewrites or replaces the cache while murk reads it.
//!
//! On Linux the bytes go into an anonymous sealed memory file (`memfd_create`, then
//! `F_SEAL_WRITE | F_SEAL_GROW | F_SEAL_SHRINK`): nothing can change it, and the scan and
//! the reader open it as `/proc/self/fd/<n>` (the reader crate opens paths, and reopens
//! them for every grid). Elsewhere the path itself is read, as before.

use super::VdbError;
use std::fs::File;
use std::path::{Path, PathBuf};

/// The input as murk reads it; the copy lives as long as this does.
pub(super) struct Snapshot {
    /// The memory file (kept open: its `/proc/self/fd` path is valid while it is).
    _file: Option<File>,
    /// Where the scan and the reader open it.
    path: PathBuf,
}

impl Snapshot {
    /// The path the scan and the reader should open.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Copies the regular file at `path` (its length when opened: bytes a writer appends
    /// later are not read) into a sealed memory file.
    pub fn take(path: &Path, file: File, len: u64) -> Result<Snapshot, VdbError> {
        #[cfg(target_os = "linux")]
        if let Some(memory) = memory_file() {
            use std::io::{Read, Seek, Write};
            let mut memory = memory;
            let mut writer = std::io::BufWriter::with_capacity(1 << 20, &mut memory);
            std::io::copy(&mut (&file).take(len), &mut writer)
                .and_then(|_| writer.flush())
                .map_err(|e| VdbError::file(path, super::io_problem(&e)))?;
            drop(writer);
            memory
                .rewind()
                .map_err(|e| VdbError::file(path, super::io_problem(&e)))?;
            seal(&memory);
            let fd = std::os::fd::AsRawFd::as_raw_fd(&memory);
            let proc_path = PathBuf::from(format!("/proc/self/fd/{fd}"));
            if proc_path.exists() {
                return Ok(Snapshot {
                    _file: Some(memory),
                    path: proc_path,
                });
            }
        }
        let _ = (file, len);
        Ok(Snapshot {
            _file: None,
            path: path.to_path_buf(),
        })
    }
}

/// A new anonymous memory file that can be sealed, or `None` where there is none.
#[cfg(target_os = "linux")]
fn memory_file() -> Option<File> {
    use std::os::fd::FromRawFd;
    let name = c"murk-input";
    // SAFETY: `name` is a valid NUL-terminated string; the flags are defined by Linux.
    let fd =
        unsafe { libc::memfd_create(name.as_ptr(), libc::MFD_CLOEXEC | libc::MFD_ALLOW_SEALING) };
    if fd < 0 {
        return None;
    }
    // SAFETY: `fd` was just returned by memfd_create and is owned by nothing else.
    Some(unsafe { File::from_raw_fd(fd) })
}

/// Seals the memory file against any change (best effort: an unsealed private memory
/// file is still one nobody else knows about).
#[cfg(target_os = "linux")]
fn seal(file: &File) {
    let fd = std::os::fd::AsRawFd::as_raw_fd(file);
    // SAFETY: `fd` is an open memfd; F_ADD_SEALS takes an int of seal flags.
    unsafe {
        libc::fcntl(
            fd,
            libc::F_ADD_SEALS,
            libc::F_SEAL_WRITE | libc::F_SEAL_GROW | libc::F_SEAL_SHRINK | libc::F_SEAL_SEAL,
        );
    }
}
