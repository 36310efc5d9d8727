//! An exclusive claim on an output path ([`Lock`]), held by a [`crate::files::result_folder::ResultFolder`]
//! or a [`crate::files::file_set::FileSet`] on what it writes, so that two commands writing the same
//! outputs cannot interleave.

use crate::error::{Error, InputError, Result};
use crate::files::atomic::{LOCK_PREFIX, hidden_name, parent_or_dot, same_inode};
use std::fs::{File, OpenOptions, TryLockError};
use std::io::Write;
use std::path::{Path, PathBuf};

/// An exclusive claim on an output path, held as an advisory lock (`flock`) on
/// `.workbench-lock-<name>` beside it. The kernel drops the lock when its process ends, however
/// it ends, so a lock left by a killed command is simply taken over; the file (which holds the
/// holder's pid, for the message) is removed when the lock is released, or swept later.
pub struct Lock {
    path: PathBuf,
    _file: File,
    /// False where the file system cannot lock files: the command then runs unguarded, and
    /// must not treat other writers' staging folders as abandoned.
    pub(crate) exclusive: bool,
}

impl Lock {
    /// Locks `target` (a resolved path), or says who holds it: `what` names the output in
    /// messages and `fix` says what else the user can do.
    pub fn acquire(target: &Path, what: &str, fix: &str) -> Result<Lock> {
        let dir = parent_or_dot(target);
        std::fs::create_dir_all(dir)
            .map_err(|e| Error::io(format!("creating folder {}", dir.display()), e))?;
        let path = dir.join(hidden_name(LOCK_PREFIX, target.file_name().unwrap_or_default()));
        // A releasing holder unlinks the file before unlocking it, so the file we lock may
        // no longer be the one at `path`; then we try again with the new one.
        for _ in 0..100 {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(|e| Error::io(format!("creating the lock file {}", path.display()), e))?;
            match file.try_lock() {
                Ok(()) if !same_inode(&file, &path) => continue,
                Ok(()) => {
                    // Only for the message a second command prints; the lock is the flock.
                    let _ = file.set_len(0);
                    let _ = write!(file, "{}", std::process::id());
                    return Ok(Lock {
                        path,
                        _file: file,
                        exclusive: true,
                    });
                }
                Err(TryLockError::WouldBlock) => {
                    let holder = std::fs::read_to_string(&path)
                        .ok()
                        .and_then(|s| s.trim().parse::<u32>().ok())
                        .map_or(String::new(), |pid| format!(" (pid {pid})"));
                    return Err(InputError::new(format!(
                        "{what}: another workbench{holder} is writing it; wait for it to finish, or {fix}"
                    ))
                    .into());
                }
                Err(TryLockError::Error(e)) if locks_unsupported(&e) => {
                    return Ok(Lock {
                        path,
                        _file: file,
                        exclusive: false,
                    });
                }
                Err(TryLockError::Error(e)) => {
                    return Err(Error::io(format!("locking {}", path.display()), e));
                }
            }
        }
        Err(Error::io(
            format!("locking {}", path.display()),
            std::io::Error::other("the lock file kept being replaced"),
        ))
    }
}

impl Drop for Lock {
    fn drop(&mut self) {
        // Unlinked while still locked; the file closes (and unlocks) right after.
        let _ = std::fs::remove_file(&self.path);
    }
}

fn locks_unsupported(e: &std::io::Error) -> bool {
    const ENOLCK: i32 = 37;
    e.kind() == std::io::ErrorKind::Unsupported || e.raw_os_error() == Some(ENOLCK)
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    #[test]
    fn results_folder_holds_one_run_lock_is_exclusive_and_released() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("x");
        let lock = Lock::acquire(&target, "x", "use another --out").unwrap();
        let e = Lock::acquire(&target, "x", "use another --out").err().unwrap();
        let pid = std::process::id();
        assert_eq!(
            e.to_string(),
            format!(
                "x: another workbench (pid {pid}) is writing it; wait for it to finish, or use another --out"
            )
        );
        // A sweep leaves a held lock alone.
        crate::files::atomic::sweep_stale(dir.path());
        assert!(dir.path().join(".workbench-lock-x").exists());
        drop(lock);
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert!(left.is_empty());
        drop(Lock::acquire(&target, "x", "").unwrap());
    }
}
