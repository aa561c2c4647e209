//! The place an output goes: its folder is made when missing (a sequence into a new
//! `seqA/`), and checked writable before any work, so that a render which cannot be
//! written fails at once rather than after it ran.

use std::fs;
use std::path::Path;

use super::FileError;

/// The folder of `path` (`.` for a bare file name).
fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Makes `path`'s folder (and the folders above it) if missing. Errors name `path` and
/// the folder that could not be made.
pub fn make_folder(path: &Path) -> Result<(), FileError> {
    let dir = folder_of(path);
    if dir.is_dir() {
        return Ok(());
    }
    fs::create_dir_all(dir).map_err(|e| FileError::Invalid {
        path: path.to_owned(),
        reason: format!("cannot create the folder {}: {e}", dir.display()),
    })
}

/// Makes `path`'s folder if missing and checks that a file can be created in it (by
/// creating and removing a hidden probe file named like murk's temporary files), and
/// that `path` is not a folder. What is already at `path` is left as it is.
pub fn prepare(path: &Path) -> Result<(), FileError> {
    make_folder(path)?;
    if path.is_dir() {
        return Err(FileError::Invalid {
            path: path.to_owned(),
            reason: "it is a folder".into(),
        });
    }
    let dir = folder_of(path);
    let probe = dir.join(format!(".murk-probe.tmp-{}-0", std::process::id()));
    match fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
    {
        Ok(_) => {
            let _ = fs::remove_file(&probe);
            Ok(())
        }
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Ok(()),
        Err(e) => Err(FileError::Invalid {
            path: path.to_owned(),
            reason: format!("the folder {} is not writable: {e}", dir.display()),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(tag: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("murk-place-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn missing_folders_are_made_and_nothing_is_left() {
        let dir = scratch("make");
        let out = dir.join("seqA/deeper/fluid_0001.exr");
        prepare(&out).unwrap();
        assert!(dir.join("seqA/deeper").is_dir());
        assert_eq!(fs::read_dir(dir.join("seqA/deeper")).unwrap().count(), 0);
        assert!(!out.exists());
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_place_that_cannot_be_written_is_named() {
        let dir = scratch("bad");
        // A file where a folder should be: no folder can be made under it, even as root.
        fs::write(dir.join("file"), "x").unwrap();
        let under = dir.join("file/sub/out.exr");
        let e = prepare(&under).unwrap_err().to_string();
        assert!(
            e.contains("file/sub/out.exr") && e.contains("cannot create the folder"),
            "{e}"
        );
        fs::create_dir(dir.join("d")).unwrap();
        let e = prepare(&dir.join("d")).unwrap_err().to_string();
        assert!(e.contains("is a folder"), "{e}");
        // /proc/self is not writable by anyone.
        if Path::new("/proc/self/fd").is_dir() {
            let e = prepare(Path::new("/proc/self/out.exr"))
                .unwrap_err()
                .to_string();
            assert!(e.contains("not writable"), "{e}");
        }
        fs::remove_dir_all(&dir).unwrap();
    }
}
