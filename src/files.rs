//! Writing files: atomic file replacement (write a temporary file next to the target, then
//! rename it over the target, so readers never see a half-written file).
//!
//! This module sits below every stage of the pipeline: the EXR writer, the shadow cache,
//! the water-drop table cache and the reports all write through it. It imports no other
//! module of the crate.

pub mod guard;
pub mod place;

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// What can go wrong while writing a file; every variant names the target file.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    /// The path cannot be written (it names no file, ...).
    #[error("cannot write {}: {reason}", path.display())]
    Invalid {
        /// The target file.
        path: PathBuf,
        /// The problem.
        reason: String,
    },

    /// The target is not one murk may replace (see [`check_target`](guard::check_target)).
    #[error("{}: {reason}", path.display())]
    Refused {
        /// The target file.
        path: PathBuf,
        /// Why not.
        reason: String,
    },

    /// The temporary file next to the target could not be created.
    #[error(
        "cannot write {}: cannot create temporary file {}: {source}",
        path.display(),
        temp.display()
    )]
    CreateTemp {
        /// The target file.
        path: PathBuf,
        /// The temporary file.
        temp: PathBuf,
        /// The cause.
        source: std::io::Error,
    },

    /// The finished temporary file could not be renamed over the target.
    #[error(
        "cannot write {}: cannot rename temporary file {} over it: {source}",
        path.display(),
        temp.display()
    )]
    Rename {
        /// The target file.
        path: PathBuf,
        /// The temporary file.
        temp: PathBuf,
        /// The cause.
        source: std::io::Error,
    },

    /// Any other I/O error while writing the file.
    #[error("cannot write {}: {source}", path.display())]
    Io {
        /// The target file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

static COUNTER: AtomicU64 = AtomicU64::new(0);

/// The temporary file used for writing `path`: `.<name>.tmp-<pid>-<n>` in the
/// same directory (so the final rename stays on one file system).
fn temp_path_for(path: &Path) -> Result<PathBuf, FileError> {
    let name = path.file_name().ok_or_else(|| FileError::Invalid {
        path: path.to_owned(),
        reason: "the path does not name a file".to_owned(),
    })?;
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let mut temp_name = std::ffi::OsString::from(".");
    temp_name.push(name);
    temp_name.push(format!(".tmp-{}-{n}", std::process::id()));
    Ok(path.with_file_name(temp_name))
}

/// Removes the temporary files of `path` left by murk processes that no longer run
/// (killed while writing): `.<name>.tmp-<pid>-<n>` whose `<pid>` has no `/proc/<pid>`.
/// Those of a live process (another murk writing the same target) are left alone, and so
/// is anything else. Best effort: an error here only leaves the file.
fn remove_stale_temporaries(path: &Path) {
    let (Some(name), Some(dir)) = (path.file_name(), path.parent()) else {
        return;
    };
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let prefix = format!(".{}.tmp-", name.to_string_lossy());
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let file = e.file_name();
        let Some(rest) = file.to_str().and_then(|f| f.strip_prefix(&prefix)) else {
            continue;
        };
        let Some((pid, n)) = rest.split_once('-') else {
            continue;
        };
        let (Ok(pid), Ok(_)) = (pid.parse::<u32>(), n.parse::<u64>()) else {
            continue;
        };
        let alive = pid == std::process::id() || Path::new(&format!("/proc/{pid}")).exists();
        let regular = e.file_type().is_ok_and(|t| t.is_file());
        if !alive && regular && Path::new("/proc/self").exists() {
            let _ = fs::remove_file(e.path());
        }
    }
}

/// Write `path` atomically.
///
/// Creates an empty temporary file `.<name>.tmp-<pid>-<n>` in the target's
/// directory and calls `write` with its path; `write` fills it (it may
/// truncate or recreate it). On success the temporary file is renamed over
/// `path`, replacing any existing file; on any error (from `write` or from the
/// rename) the temporary file is removed and an existing target is left
/// untouched. The target's folder is made if missing. No fsync is done.
///
/// First the target passes [`check_target`](guard::check_target): a device,
/// FIFO, symbolic link, folder, read-only file or folder, or an input the command
/// protected is refused, and nothing is written.
///
/// Errors produced here are [`FileError`]s naming `path`; `write`'s own
/// error type only needs `From<FileError>` (so `FileError` itself works, and so does
/// `OutputError`).
pub fn write_atomically<T, E, F>(path: &Path, write: F) -> Result<T, E>
where
    F: FnOnce(&Path) -> Result<T, E>,
    E: From<FileError>,
{
    let temp = temp_path_for(path)?;
    guard::check_target(path)?;
    place::make_folder(path)?;
    remove_stale_temporaries(path);
    if let Err(source) = fs::File::create(&temp) {
        return Err(FileError::CreateTemp {
            path: path.to_owned(),
            temp,
            source,
        }
        .into());
    }
    let value = match write(&temp) {
        Ok(value) => value,
        Err(err) => {
            let _ = fs::remove_file(&temp);
            return Err(err);
        }
    };
    if let Err(source) = fs::rename(&temp, path) {
        let _ = fs::remove_file(&temp);
        return Err(FileError::Rename {
            path: path.to_owned(),
            temp,
            source,
        }
        .into());
    }
    Ok(value)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch_dir(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("murk-atomic-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn temp_name_is_hidden_in_same_directory() {
        let t = temp_path_for(Path::new("/a/b/out.exr")).unwrap();
        assert_eq!(t.parent(), Some(Path::new("/a/b")));
        let name = t.file_name().unwrap().to_string_lossy().into_owned();
        assert!(name.starts_with(".out.exr.tmp-"), "{name}");
        assert!(temp_path_for(Path::new("/")).is_err());
    }

    #[test]
    fn stale_temporaries_of_dead_processes_are_removed() {
        let dir = scratch_dir("stale");
        let target = dir.join("out.exr");
        // 4194305 is above Linux's largest pid: no process has it.
        let stale = dir.join(".out.exr.tmp-4194305-0");
        let live = dir.join(format!(".out.exr.tmp-{}-99", std::process::id()));
        let other = dir.join(".other.exr.tmp-4194305-0");
        let odd = dir.join(".out.exr.tmp-notapid-0");
        for f in [&stale, &live, &other, &odd] {
            fs::write(f, "partial").unwrap();
        }
        let r: Result<(), FileError> = write_atomically(&target, |tmp| {
            fs::write(tmp, "new").map_err(|source| FileError::Io {
                path: tmp.into(),
                source,
            })
        });
        r.unwrap();
        assert_eq!(
            entries(&dir),
            vec![
                ".other.exr.tmp-4194305-0".to_string(),
                format!(".out.exr.tmp-{}-99", std::process::id()),
                ".out.exr.tmp-notapid-0".to_string(),
                "out.exr".to_string(),
            ]
        );
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn success_replaces_target() {
        let dir = scratch_dir("ok");
        let target = dir.join("f.txt");
        fs::write(&target, "old").unwrap();
        let r: Result<u32, FileError> = write_atomically(&target, |tmp| {
            fs::write(tmp, "new").map_err(|source| FileError::Io {
                path: tmp.into(),
                source,
            })?;
            Ok(7)
        });
        assert_eq!(r.unwrap(), 7);
        assert_eq!(fs::read_to_string(&target).unwrap(), "new");
        assert_eq!(entries(&dir), vec!["f.txt"]);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn failure_keeps_target_and_removes_temp() {
        let dir = scratch_dir("fail");
        let target = dir.join("f.txt");
        fs::write(&target, "old").unwrap();
        let r: Result<(), FileError> = write_atomically(&target, |tmp| {
            fs::write(tmp, "partial").unwrap();
            Err(FileError::Invalid {
                path: target.clone(),
                reason: "boom".into(),
            })
        });
        assert!(r.unwrap_err().to_string().contains("boom"));
        assert_eq!(fs::read_to_string(&target).unwrap(), "old");
        assert_eq!(entries(&dir), vec!["f.txt"]);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn rename_failure_removes_temp() {
        let dir = scratch_dir("rename");
        let target = dir.join("sub");
        // A folder appears at the target while the file is written: the rename fails.
        let r: Result<(), FileError> = write_atomically(&target, |_| {
            fs::create_dir(&target).unwrap();
            fs::write(target.join("keep"), "x").unwrap();
            Ok(())
        });
        let msg = r.unwrap_err().to_string();
        assert!(msg.contains(&target.display().to_string()), "{msg}");
        assert_eq!(entries(&dir), vec!["sub"]);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn targets_that_are_not_regular_files_or_are_inputs_are_left_alone() {
        use std::os::unix::fs::FileTypeExt;
        let dir = scratch_dir("guard");
        let fifo = dir.join("fifo.exr");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        assert!(made.unwrap().success());
        let link = dir.join("link.exr");
        std::os::unix::fs::symlink(dir.join("elsewhere.exr"), &link).unwrap();
        let input = dir.join("in.vdb");
        fs::write(&input, "keep").unwrap();
        super::guard::protect(&[super::guard::Role::new(&input, "the input")]);
        let write = |target: &Path| -> String {
            let r: Result<(), FileError> = write_atomically(target, |tmp| {
                fs::write(tmp, "new").map_err(|source| FileError::Io {
                    path: tmp.into(),
                    source,
                })
            });
            r.unwrap_err().to_string()
        };
        assert!(write(&fifo).contains("not a regular file"));
        assert!(write(&link).contains("symbolic link"));
        let spelled = dir.join(".").join("in.vdb");
        assert!(write(&spelled).contains("would overwrite the input"));
        assert!(fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
        assert!(
            fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(fs::read_to_string(&input).unwrap(), "keep");
        assert_eq!(entries(&dir), vec!["fifo.exr", "in.vdb", "link.exr"]);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn missing_folders_are_made_and_a_folder_that_cannot_be_names_the_path() {
        let dir = scratch_dir("folders");
        let target = dir.join("seqA/b/out.png");
        let r: Result<(), FileError> = write_atomically(&target, |tmp| {
            fs::write(tmp, "new").map_err(|source| FileError::Io {
                path: tmp.into(),
                source,
            })
        });
        r.unwrap();
        assert_eq!(fs::read_to_string(&target).unwrap(), "new");
        // Under a file no folder can be made, even as root.
        let target = dir.join("seqA/b/out.png/x/out.png");
        let r: Result<(), FileError> = write_atomically(&target, |_| Ok(()));
        let msg = r.unwrap_err().to_string();
        assert!(msg.contains(&target.display().to_string()), "{msg}");
        fs::remove_dir_all(&dir).unwrap();
    }
}
