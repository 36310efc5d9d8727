//! The one place that writes result files: atomically, so a crash never leaves half a file.

use crate::error::{Error, InputError, Result};
use std::io::Write;
use std::path::Path;

/// Writes `bytes` to `path` by way of a temporary file in the same folder and a rename.
///
/// A path that exists but is not a regular file (`/dev/null`, a named pipe, `/dev/stdout`) is
/// written to directly: renaming over it would replace the device. A symbolic link is followed,
/// and its target replaced atomically, so the link survives.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_following(path, bytes, 0)
}

fn write_atomic_following(path: &Path, bytes: &[u8], links: u32) -> Result<()> {
    if std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) {
        if links >= 40 {
            return Err(
                InputError::new(format!("{}: too many levels of symbolic links", path.display())).into(),
            );
        }
        let target = std::fs::read_link(path)
            .map_err(|e| Error::io(format!("reading the link {}", path.display()), e))?;
        let target = match path.parent() {
            Some(dir) if target.is_relative() => dir.join(target),
            _ => target,
        };
        return write_atomic_following(&target, bytes, links + 1);
    }
    if std::fs::metadata(path).is_ok_and(|m| !m.is_file()) {
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .open(path)
            .map_err(|e| Error::io(format!("opening {}", path.display()), e))?;
        return f
            .write_all(bytes)
            .map_err(|e| Error::io(format!("writing {}", path.display()), e));
    }
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    std::fs::create_dir_all(dir).map_err(|e| Error::io(format!("creating folder {}", dir.display()), e))?;
    let mut tmp = tempfile::Builder::new()
        .prefix(".workbench-")
        .tempfile_in(dir)
        .map_err(|e| Error::io(format!("creating a temporary file in {}", dir.display()), e))?;
    tmp.write_all(bytes)
        .map_err(|e| Error::io(format!("writing {}", path.display()), e))?;
    // Temporary files are created 0600; results are ordinary files (0644 before the umask).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        tmp.as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644))
            .map_err(|e| Error::io(format!("setting permissions of {}", path.display()), e))?;
    }
    tmp.as_file()
        .sync_all()
        .map_err(|e| Error::io(format!("syncing {}", path.display()), e))?;
    tmp.persist(path)
        .map_err(|e| Error::io(format!("renaming into {}", path.display()), e.error))?;
    Ok(())
}

/// Creates `dir` if needed and checks that files can be created in it, so that an unwritable
/// output folder fails before the work, not after it.
pub fn check_writable_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(format!("creating {}", dir.display()), e))?;
    tempfile::tempfile_in(dir).map_err(|e| Error::io(format!("{} is not writable", dir.display()), e))?;
    Ok(())
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;
    use std::os::unix::fs::FileTypeExt;

    #[test]
    fn writes_through_links_and_keeps_them() {
        let dir = tempfile::tempdir().unwrap();
        std::os::unix::fs::symlink("target.csv", dir.path().join("link.csv")).unwrap();
        write_atomic(&dir.path().join("link.csv"), b"a,b\n").unwrap();
        assert!(
            std::fs::symlink_metadata(dir.path().join("link.csv"))
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read(dir.path().join("target.csv")).unwrap(), b"a,b\n");
    }

    /// A named pipe (like `/dev/stdout` or `/dev/null`, which a test must not risk replacing) is
    /// written to, not renamed over.
    #[test]
    fn writes_into_a_pipe_instead_of_replacing_it() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("fifo");
        assert!(
            std::process::Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .unwrap()
                .success()
        );
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read(fifo).unwrap())
        };
        write_atomic(&fifo, b"through the pipe\n").unwrap();
        // Checked before joining: had the pipe been renamed over, the reader would wait forever.
        assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
        assert_eq!(reader.join().unwrap(), b"through the pipe\n");
    }
}

/// Where `path` points, for comparing paths that may not exist yet: the canonical form of an
/// existing path, else the canonical parent folder joined with the file name.
fn identity(path: &Path) -> Option<std::path::PathBuf> {
    if let Ok(p) = std::fs::canonicalize(path) {
        return Some(p);
    }
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    Some(std::fs::canonicalize(parent).ok()?.join(path.file_name()?))
}

/// Refuses an output that is one of the inputs or another output (`(flag, path)` pairs), so
/// that a run never destroys what it reads or writes one result over another.
pub fn check_distinct(outputs: &[(&str, &Path)], inputs: &[(&str, &Path)]) -> Result<(), InputError> {
    for (i, (flag, out)) in outputs.iter().enumerate() {
        let Some(id) = identity(out) else { continue };
        let clash = inputs
            .iter()
            .map(|(f, p)| (f, p, "would overwrite"))
            .chain(outputs[..i].iter().map(|(f, p)| (f, p, "is the same file as")))
            .find(|(_, p, _)| identity(p).as_ref() == Some(&id));
        if let Some((other, _, verb)) = clash {
            return Err(InputError::new(format!(
                "{flag} {}: {verb} {other}",
                out.display()
            )));
        }
    }
    Ok(())
}
