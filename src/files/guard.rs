//! The one check every file murk writes passes before it is written: the target must be
//! absent or a writable regular file in a writable folder, and must not be a file the
//! command reads. [`write_atomically`](super::write_atomically) runs it on every target
//! (so no writer can skip it); commands run [`check_outputs`] on all their outputs before
//! any work, so a refusal comes at once rather than after a render.
//!
//! murk replaces a file by renaming a new one over it: over a device or FIFO that would
//! turn it into a regular file (`/dev/null` among them), over a symbolic link it would
//! replace the link rather than what it points to, and over an input it would destroy
//! what the next frame or the next run reads.

use super::FileError;
use std::collections::HashMap;
use std::ffi::CString;
use std::os::unix::ffi::OsStrExt;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// What a path refers to: its device and inode if it exists, else its folder's canonical
/// path joined with its name (two spellings of one absent file compare equal).
#[derive(PartialEq, Eq, Hash, Debug, Clone)]
pub enum Identity {
    Inode(u64, u64),
    Path(PathBuf),
}

impl Identity {
    pub fn of(path: &Path) -> Identity {
        use std::os::unix::fs::MetadataExt;
        if let Ok(m) = std::fs::metadata(path) {
            return Identity::Inode(m.dev(), m.ino());
        }
        let dir = std::fs::canonicalize(folder(path)).unwrap_or_else(|_| folder(path));
        Identity::Path(dir.join(path.file_name().unwrap_or_default()))
    }
}

/// The folder a path's file is in (`.` for a bare name).
fn folder(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// A file a command reads or writes, with what it is to the command, as an error names
/// it ("the input", "frame 12's input", "the output (-o)").
#[derive(Clone, Debug)]
pub struct Role {
    pub path: PathBuf,
    pub what: String,
}

impl Role {
    pub fn new(path: impl Into<PathBuf>, what: impl Into<String>) -> Role {
        Role {
            path: path.into(),
            what: what.into(),
        }
    }
}

/// Inputs of this process that no write may replace (see [`protect`]), by identity.
static PROTECTED: Mutex<Option<HashMap<Identity, Role>>> = Mutex::new(None);

/// Marks `inputs` as files no later write of this process may replace: the last line of
/// defence behind [`check_outputs`], for a writer a command did not list.
pub fn protect(inputs: &[Role]) {
    let mut guard = PROTECTED.lock().unwrap_or_else(|e| e.into_inner());
    let map = guard.get_or_insert_with(HashMap::new);
    for r in inputs {
        let id = Identity::of(&r.path);
        // An entry for this inode whose file is gone (a deleted input's number, reused)
        // is stale: this file takes it.
        let stale = map.get(&id).is_none_or(|old| Identity::of(&old.path) != id);
        if stale {
            map.insert(id, r.clone());
        }
    }
}

fn refused(path: &Path, reason: String) -> FileError {
    FileError::Refused {
        path: path.to_owned(),
        reason,
    }
}

/// Refuses a target that is not absent or a writable regular file, or whose folder is
/// not writable.
pub fn check_replaceable(path: &Path) -> Result<(), FileError> {
    if path.file_name().is_none() {
        return Err(refused(path, "does not name a file".into()));
    }
    if let Ok(meta) = std::fs::symlink_metadata(path) {
        let ft = meta.file_type();
        let problem = if ft.is_symlink() {
            "is a symbolic link: murk replaces only regular files (give the link's target)"
        } else if ft.is_dir() {
            "is a directory"
        } else if !ft.is_file() {
            "is not a regular file (a device, FIFO or socket): murk replaces only regular files"
        } else if meta.permissions().readonly() {
            "is read-only: murk does not replace it"
        } else {
            ""
        };
        if !problem.is_empty() {
            return Err(refused(path, problem.into()));
        }
    }
    let dir = folder(path);
    // A folder that does not exist yet is made by the writer (and one that cannot be,
    // under a file, is said by it).
    let Ok(meta) = std::fs::metadata(&dir) else {
        return Ok(());
    };
    if meta.is_dir() && (meta.permissions().readonly() || !writable(&dir)) {
        return Err(refused(
            path,
            format!(
                "cannot write there: the folder {} is read-only",
                dir.display()
            ),
        ));
    }
    Ok(())
}

/// Whether this process may create files in `dir` (access(2), which also says no on a
/// read-only file system).
fn writable(dir: &Path) -> bool {
    let Ok(c) = CString::new(dir.as_os_str().as_bytes()) else {
        return false;
    };
    // SAFETY: `c` is a valid NUL-terminated string that outlives the call.
    unsafe { libc::access(c.as_ptr(), libc::W_OK | libc::X_OK) == 0 }
}

/// The check [`write_atomically`](super::write_atomically) runs on its target:
/// [`check_replaceable`], and not an input marked by [`protect`].
pub fn check_target(path: &Path) -> Result<(), FileError> {
    check_replaceable(path)?;
    let id = Identity::of(path);
    let guard = PROTECTED.lock().unwrap_or_else(|e| e.into_inner());
    // Still the same file (an inode number freed by a deleted input may be reused).
    let input = guard.as_ref().and_then(|m| m.get(&id));
    if let Some(r) = input.filter(|r| Identity::of(&r.path) == id) {
        return Err(refused(
            path,
            format!("would overwrite {} ({})", r.what, r.path.display()),
        ));
    }
    Ok(())
}

/// Refuses outputs that would replace an input, another output, or anything but a
/// regular file in a writable folder ([`check_replaceable`]); then marks the inputs with
/// [`protect`]. Run it on every output of a command before its work (every frame of a
/// pattern expanded), so that a refusal costs nothing.
pub fn check_outputs(inputs: &[Role], outputs: &[Role]) -> Result<(), FileError> {
    let mut seen: HashMap<Identity, &Role> = HashMap::with_capacity(inputs.len());
    for r in inputs {
        seen.entry(Identity::of(&r.path)).or_insert(r);
    }
    for out in outputs {
        check_replaceable(&out.path)?;
        let id = Identity::of(&out.path);
        if let Some(other) = seen.get(&id) {
            return Err(refused(
                &out.path,
                format!(
                    "{} would overwrite {} ({})",
                    out.what,
                    other.what,
                    other.path.display()
                ),
            ));
        }
        seen.insert(id, out);
    }
    protect(inputs);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    fn scratch(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("murk-guard-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A protected file that is gone leaves its inode's entry stale; a file that comes to
    /// hold that inode (here by a rename; a new file can reuse a freed number) is
    /// protected when marked. Unit tests run side by side in one process, so this once
    /// let a write over a protected input through.
    #[test]
    fn a_file_on_a_stale_entrys_inode_is_protected() {
        let dir = scratch("stale");
        let a = dir.join("a.vdb");
        fs::write(&a, "x").unwrap();
        protect(&[Role::new(&a, "the old input")]);
        let b = dir.join("b.vdb");
        fs::rename(&a, &b).unwrap();
        protect(&[Role::new(&b, "the input")]);
        let e = check_target(&b).unwrap_err().to_string();
        assert!(e.contains("would overwrite the input"), "{e}");
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn two_spellings_of_one_file_are_one_identity() {
        let dir = scratch("id");
        let a = dir.join("a.vdb");
        let dotted = dir.join(".").join("a.vdb");
        assert_eq!(Identity::of(&a), Identity::of(&dotted));
        fs::write(&a, "x").unwrap();
        assert_eq!(Identity::of(&a), Identity::of(&dotted));
        let hard = dir.join("hard.vdb");
        fs::hard_link(&a, &hard).unwrap();
        assert_eq!(Identity::of(&a), Identity::of(&hard));
        assert_ne!(Identity::of(&a), Identity::of(&dir.join("b.vdb")));
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn outputs_equal_to_inputs_or_each_other_are_refused() {
        let dir = scratch("roles");
        let input = dir.join("in_0002.vdb");
        fs::write(&input, "keep").unwrap();
        let inputs = [Role::new(&input, "frame 2's input")];
        let e = check_outputs(&inputs, &[Role::new(dir.join("./in_0002.vdb"), "the job")])
            .unwrap_err()
            .to_string();
        assert!(e.contains("the job would overwrite frame 2's input"), "{e}");
        let twice = [
            Role::new(dir.join("o.csv"), "the table (--csv)"),
            Role::new(dir.join("o.csv"), "the plot (--plot)"),
        ];
        let e = check_outputs(&[], &twice).unwrap_err().to_string();
        assert!(
            e.contains("the plot (--plot) would overwrite the table"),
            "{e}"
        );
        check_outputs(&inputs, &twice[..1]).unwrap();
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn read_only_folders_are_refused() {
        use std::os::unix::fs::PermissionsExt;
        let dir = scratch("rodir");
        let ro = dir.join("ro");
        fs::create_dir(&ro).unwrap();
        fs::set_permissions(&ro, fs::Permissions::from_mode(0o555)).unwrap();
        let e = check_replaceable(&ro.join("out.exr"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("is read-only"), "{e}");
        check_replaceable(&dir.join("out.exr")).unwrap();
        check_replaceable(&dir.join("absent/out.exr")).unwrap();
        fs::set_permissions(&ro, fs::Permissions::from_mode(0o755)).unwrap();
        fs::remove_dir_all(&dir).unwrap();
    }
}
