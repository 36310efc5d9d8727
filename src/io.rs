//! The one place that writes result files: atomically, so a crash never leaves half a file.

use anyhow::Context;
use std::io::Write;
use std::path::Path;

/// Writes `bytes` to `path` by way of a temporary file in the same folder and a rename.
///
/// A path that exists but is not a regular file (`/dev/null`, a named pipe, `/dev/stdout`) is
/// written to directly: renaming over it would replace the device. A symbolic link is followed,
/// and its target replaced atomically, so the link survives.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    write_atomic_following(path, bytes, 0)
}

fn write_atomic_following(path: &Path, bytes: &[u8], links: u32) -> anyhow::Result<()> {
    if std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) {
        anyhow::ensure!(
            links < 40,
            "{}: too many levels of symbolic links",
            path.display()
        );
        let target =
            std::fs::read_link(path).with_context(|| format!("reading the link {}", path.display()))?;
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
            .with_context(|| format!("opening {}", path.display()))?;
        return f
            .write_all(bytes)
            .with_context(|| format!("writing {}", path.display()));
    }
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    std::fs::create_dir_all(dir).with_context(|| format!("creating folder {}", dir.display()))?;
    let mut tmp = tempfile::Builder::new()
        .prefix(".workbench-")
        .tempfile_in(dir)
        .with_context(|| format!("creating a temporary file in {}", dir.display()))?;
    tmp.write_all(bytes)
        .with_context(|| format!("writing {}", path.display()))?;
    // Temporary files are created 0600; results are ordinary files (0644 before the umask).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        tmp.as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644))
            .with_context(|| format!("setting permissions of {}", path.display()))?;
    }
    tmp.as_file()
        .sync_all()
        .with_context(|| format!("syncing {}", path.display()))?;
    tmp.persist(path)
        .map_err(|e| e.error)
        .with_context(|| format!("renaming into {}", path.display()))?;
    Ok(())
}

/// Bad input from the user: the binary exits with code 2.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct InputError(pub String);

impl InputError {
    pub fn new(message: impl Into<String>) -> Self {
        InputError(message.into())
    }
}

/// Writes `s` to standard output. A reader that has gone away (`| head`) gives an
/// `io::ErrorKind::BrokenPipe` error, which the binary turns into a quiet exit.
pub fn stdout(s: &str) -> std::io::Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_all(s.as_bytes())?;
    out.flush()
}

/// Whether an error was caused by writing to a closed pipe.
pub fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// A status line on standard error (progress notes, warnings). Unlike `eprintln!` it never
/// panics: if standard error is closed there is nowhere left to report to.
#[macro_export]
macro_rules! status {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
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
