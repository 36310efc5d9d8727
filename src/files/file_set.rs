//! Outputs named one by one (an image and its PNGs, a rule and its summary), written as a set:
//! each is written completely under a temporary name beside it before any is renamed into
//! place, so a failed write (a full disk) changes none of them. The set holds a [`Lock`] on
//! every output, so two commands writing the same files cannot interleave, and clears what
//! killed commands left behind ([`crate::files::atomic::sweep_stale`]).

use crate::error::{Error, Result};
use crate::files::atomic::{Staged, check_name_length, parent_or_dot, resolve, stage, sweep_stale};
use crate::files::lock::Lock;
use std::path::{Path, PathBuf};

/// Outputs named one by one, written as a set: see the module documentation.
pub struct FileSet {
    _locks: Vec<Lock>,
    staged: Vec<Staged>,
    stale: Vec<PathBuf>,
}

impl FileSet {
    /// Locks every output (`(flag, path)`; devices such as `/dev/null` excepted), so that two
    /// commands writing the same files cannot interleave their sets; `fix` ends the message
    /// when one is busy. Checks every name's length first.
    pub fn lock(outputs: &[(&str, &Path)], fix: &str) -> Result<FileSet> {
        let mut locks = Vec::new();
        let mut seen: Vec<PathBuf> = Vec::new();
        for (flag, path) in outputs {
            check_name_length(flag, path)?;
            let target = resolve(path).map_err(|e| Error::io(format!("resolving {}", path.display()), e))?;
            if std::fs::metadata(&target).is_ok_and(|m| !m.is_file()) || seen.contains(&target) {
                continue;
            }
            locks.push(Lock::acquire(
                &target,
                &format!("{flag} {}", path.display()),
                fix,
            )?);
            sweep_stale(parent_or_dot(&target));
            seen.push(target);
        }
        Ok(FileSet {
            _locks: locks,
            staged: Vec::new(),
            stale: Vec::new(),
        })
    }

    /// Writes one output completely under a temporary name beside it; nothing visible changes
    /// until [`FileSet::commit`].
    pub fn stage(&mut self, path: &Path, bytes: &[u8]) -> Result<()> {
        self.staged.push(stage(path, bytes)?);
        Ok(())
    }

    /// Marks a file this command would write but does not this time (an error image without
    /// `--reference`): a leftover of an earlier command would describe another output.
    pub fn remove_stale(&mut self, path: &Path) {
        self.stale.push(path.to_path_buf());
    }

    /// Renames every staged file into place, in the order staged, then removes the stale ones;
    /// returns those it removed.
    pub fn commit(self) -> Result<Vec<PathBuf>> {
        let FileSet {
            _locks,
            staged,
            stale,
        } = self;
        for s in staged {
            s.persist()?;
        }
        let mut removed = Vec::new();
        for path in stale {
            if std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_file()) {
                std::fs::remove_file(&path)
                    .map_err(|e| Error::io(format!("removing {}", path.display()), e))?;
                removed.push(path);
            }
        }
        Ok(removed)
    }
}
