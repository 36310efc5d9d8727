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
        // The lock file appears at `path` with the holder's pid already in it: it is written
        // and locked under a name of our own, then hard-linked into place, which fails if a
        // file is there. So a refused command always finds the pid to name (creating the file
        // at `path` and then writing the pid left a moment in which it was empty).
        // Unique within the process too: two threads asking at the same clock reading got the
        // same name, and one then found "its own" file locked by the other.
        static TAKEN: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let own = dir.join(format!(
            "{}{}-lock-{}-{}.tmp",
            crate::files::atomic::HIDDEN_PREFIX,
            crate::files::atomic::writer(std::process::id()),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos()),
            TAKEN.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
        ));
        let refused = |holder: Option<u32>| -> Error {
            let holder = holder.map_or(String::new(), |pid| format!(" (pid {pid})"));
            InputError::new(format!(
                "{what}: another workbench{holder} is writing it; wait for it to finish, or {fix}"
            ))
            .into()
        };
        let mut last_holder: Option<u32> = None;
        // A releasing holder unlinks the file before unlocking it, so the file we lock may
        // no longer be the one at `path`; then we try again with the new one.
        for _ in 0..1000 {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(true)
                .open(&own)
                .map_err(|e| Error::io(format!("creating the lock file {}", own.display()), e))?;
            let _ = write!(file, "{}", std::process::id());
            let placed = match file.try_lock() {
                Ok(()) => std::fs::hard_link(&own, &path),
                Err(TryLockError::Error(e)) if locks_unsupported(&e) => {
                    let _ = std::fs::remove_file(&own);
                    return Ok(Lock {
                        path: own,
                        _file: file,
                        exclusive: false,
                    });
                }
                Err(TryLockError::Error(e)) => {
                    let _ = std::fs::remove_file(&own);
                    return Err(Error::io(format!("locking {}", own.display()), e));
                }
                Err(TryLockError::WouldBlock) => unreachable!("nobody else knows our own file"),
            };
            let _ = std::fs::remove_file(&own);
            match placed {
                Ok(()) => {
                    return Ok(Lock {
                        path,
                        _file: file,
                        exclusive: true,
                    });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
                Err(e) => return Err(Error::io(format!("creating the lock file {}", path.display()), e)),
            }
            // Someone's lock file is there: held (name the holder), or left by a killed
            // command (remove it and try again).
            drop(file);
            let Ok(theirs) = OpenOptions::new().read(true).open(&path) else {
                continue;
            };
            // From the file we opened, not the path: a releasing holder may have unlinked it
            // meanwhile, but its content is the holder's pid (it was written before the link).
            let mut text = String::new();
            last_holder = std::io::Read::read_to_string(&mut &theirs, &mut text)
                .ok()
                .and_then(|_| text.trim().parse::<u32>().ok())
                .or(last_holder);
            match theirs.try_lock() {
                Ok(()) => {
                    if same_inode(&theirs, &path) {
                        let _ = std::fs::remove_file(&path);
                    }
                }
                Err(TryLockError::WouldBlock) => return Err(refused(last_holder)),
                Err(TryLockError::Error(e)) => {
                    return Err(Error::io(format!("locking {}", path.display()), e));
                }
            }
            std::thread::yield_now();
        }
        // Every try found a lock file that was released and replaced before we could take it:
        // other commands are taking and releasing the folder as fast as we look, so it is as
        // busy as a held lock (a tight loop of commands, or threads of one test).
        Err(refused(last_holder))
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

    /// Issue 21, item 1: a refused writer sometimes found the lock file empty (created, not yet
    /// holding the pid, or unlinked by a holder on its way out) and named no holder. The file now
    /// appears with the pid in it and the pid is read from the file that was opened: a refusal
    /// names the holder, both plainly and with two threads taking and releasing the same lock in
    /// a tight loop.
    #[test]
    fn a_refused_writer_always_names_the_holder() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out");
        let take = || Lock::acquire(&target, "out", "use another --out");
        let names_the_holder = |e: Error| {
            let m = e.to_string();
            assert!(m.contains(&format!("(pid {})", std::process::id())), "{m}");
        };
        let held = take().unwrap();
        names_the_holder(take().err().expect("refused while held"));
        drop(held);
        std::thread::scope(|s| {
            for _ in 0..2 {
                s.spawn(|| {
                    for _ in 0..2000 {
                        match take() {
                            Ok(lock) => drop(lock),
                            Err(e) => names_the_holder(e),
                        }
                    }
                });
            }
        });
        // Nothing is left behind: no lock file, no temporary file.
        let left: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .flatten()
            .map(|e| e.file_name())
            .collect();
        assert!(left.is_empty(), "{left:?}");
    }
}
