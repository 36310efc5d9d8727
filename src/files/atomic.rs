//! The one place that writes result files: atomically, so a crash never leaves half a file, with
//! the permissions the user's umask asks for, and never over one of the command's inputs.
//!
//! Sets of files that belong together (a run's folder, an image and its PNGs) are in
//! [`crate::files::result_folder`] and [`crate::files::file_set`]; this module holds the pieces:
//! staging one file, resolving where a path really points, and cleaning what killed writers left
//! behind.

use crate::error::{Error, InputError, Result};
use std::ffi::{OsStr, OsString};
use std::io::Write;
use std::path::{Component, Path, PathBuf};

/// Every hidden file or folder this crate creates starts with this. Temporary files and staging
/// folders go on with their writer, `<pid>.<host>` and `-` (`.workbench-1234.9f3a07c2e1d4-…`,
/// [`writer`]), so a later run on the same host can tell a dead writer's leftovers from a live
/// writer's work, and leaves other hosts' alone ([`sweep_stale`]); lock files go on with `lock-`
/// ([`LOCK_PREFIX`]).
pub const HIDDEN_PREFIX: &str = ".workbench-";

/// Lock files are `.workbench-lock-<name of what they guard>`, beside it.
pub const LOCK_PREFIX: &str = ".workbench-lock-";

/// The longest output name (file or folder) accepted, in bytes: file systems allow 255, and the
/// hidden names made from it (lock file, staging folder) add up to 45.
pub const MAX_NAME_BYTES: usize = 200;

/// Writes `bytes` to `path` by way of a temporary file in the same folder and a rename.
///
/// A path that exists but is not a regular file (`/dev/null`, a named pipe, `/dev/stdout`) is
/// written to directly: renaming over it would replace the device. A symbolic link is followed,
/// and its target replaced atomically, so the link survives. The new file gets the permissions
/// the umask gives any new file (0644 under the usual 022).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    stage(path, bytes)?.persist()
}

/// A file written completely and synced to disk under a temporary name beside its target,
/// waiting for [`Staged::persist`] to rename it into place. Dropped unpersisted, the temporary
/// file is removed: a failed command leaves the target as it was.
pub struct Staged {
    kind: StagedKind,
}

enum StagedKind {
    Temp {
        tmp: tempfile::NamedTempFile,
        target: PathBuf,
    },
    /// A device or pipe: written at [`Staged::persist`], not before, so that nothing of a set
    /// is touched until all of it is ready.
    Direct { target: PathBuf, bytes: Vec<u8> },
}

/// Writes `bytes` under a temporary name beside `path` (following symbolic links, as
/// [`write_atomic`] does), creating the folder if needed. Nothing at `path` changes yet.
pub fn stage(path: &Path, bytes: &[u8]) -> Result<Staged> {
    let target = follow_links(path)?;
    if std::fs::metadata(&target).is_ok_and(|m| !m.is_file()) {
        return Ok(Staged {
            kind: StagedKind::Direct {
                target,
                bytes: bytes.to_vec(),
            },
        });
    }
    let dir = parent_or_dot(&target);
    std::fs::create_dir_all(dir).map_err(|e| Error::io(format!("creating folder {}", dir.display()), e))?;
    sweep_stale(dir);
    let prefix = format!("{HIDDEN_PREFIX}{}-", writer(std::process::id()));
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    // Temporary files are created 0600; results are ordinary new files: 0666 requested, cut by
    // the umask when the file is created, as for any tool's output.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut tmp = builder
        .tempfile_in(dir)
        .map_err(|e| Error::io(format!("creating a temporary file in {}", dir.display()), e))?;
    write_all_checked(tmp.as_file_mut(), &target, bytes)
        .map_err(|e| Error::io(format!("writing {}", path.display()), e))?;
    tmp.as_file()
        .sync_all()
        .map_err(|e| Error::io(format!("syncing {}", path.display()), e))?;
    Ok(Staged {
        kind: StagedKind::Temp { tmp, target },
    })
}

impl Staged {
    /// Renames the staged file into place (one atomic step), or writes a device.
    pub fn persist(self) -> Result<()> {
        match self.kind {
            StagedKind::Temp { tmp, target } => {
                tmp.persist(&target)
                    .map_err(|e| Error::io(format!("renaming into {}", target.display()), e.error))?;
                Ok(())
            }
            StagedKind::Direct { target, bytes } => {
                let mut f = std::fs::OpenOptions::new()
                    .write(true)
                    .open(&target)
                    .map_err(|e| Error::io(format!("opening {}", target.display()), e))?;
                f.write_all(&bytes)
                    .map_err(|e| Error::io(format!("writing {}", target.display()), e))
            }
        }
    }

    /// Where the file will be.
    pub fn target(&self) -> &Path {
        match &self.kind {
            StagedKind::Temp { target, .. } | StagedKind::Direct { target, .. } => target,
        }
    }
}

/// `path` with every symbolic link in its last component followed (a link to a link too).
fn follow_links(path: &Path) -> Result<PathBuf> {
    let mut path = path.to_path_buf();
    for _ in 0..40 {
        if !std::fs::symlink_metadata(&path).is_ok_and(|m| m.file_type().is_symlink()) {
            return Ok(path);
        }
        let target = std::fs::read_link(&path)
            .map_err(|e| Error::io(format!("reading the link {}", path.display()), e))?;
        path = match path.parent() {
            Some(dir) if target.is_relative() => dir.join(target),
            _ => target,
        };
    }
    Err(InputError::new(format!("{}: too many levels of symbolic links", path.display())).into())
}

/// The folder holding `path`: its parent, or `.` for a bare name.
pub(crate) fn parent_or_dot(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Writes `bytes` to `file`, meant for `target`, honouring [`injected_failure`] halfway.
pub(crate) fn write_all_checked(
    file: &mut std::fs::File,
    target: &Path,
    bytes: &[u8],
) -> std::io::Result<()> {
    let half = bytes.len() / 2;
    file.write_all(&bytes[..half])?;
    injected_failure(target)?;
    file.write_all(&bytes[half..])
}

/// Test support: when the environment variable `WORKBENCH_TEST_FAIL_WRITE` names the file being
/// written (its last component, e.g. `summary.csv`), the write fails halfway as on a full disk.
/// It lets the tests drive every "a write failed partway through a command" path through the
/// real binary; nobody sets it otherwise.
pub(crate) fn injected_failure(target: &Path) -> std::io::Result<()> {
    match std::env::var_os("WORKBENCH_TEST_FAIL_WRITE") {
        Some(name) if target.file_name() == Some(name.as_os_str()) => Err(std::io::Error::new(
            std::io::ErrorKind::StorageFull,
            "No space left on device (injected by WORKBENCH_TEST_FAIL_WRITE)",
        )),
        _ => Ok(()),
    }
}

/// Creates `dir` if needed and checks that files can be created in it, so that an unwritable
/// output folder fails before the work, not after it.
pub fn check_writable_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(format!("creating {}", dir.display()), e))?;
    tempfile::tempfile_in(dir).map_err(|e| Error::io(format!("{} is not writable", dir.display()), e))?;
    Ok(())
}

/// Refuses an output name longer than [`MAX_NAME_BYTES`] before any work, instead of failing
/// when the file is finally written.
pub fn check_name_length(flag: &str, path: &Path) -> Result<(), InputError> {
    let len = path.file_name().map_or(0, |n| n.len());
    if len > MAX_NAME_BYTES {
        return Err(InputError::new(format!(
            "{flag} {}: the name is {len} bytes long; at most {MAX_NAME_BYTES} are supported, use a shorter one",
            path.display()
        )));
    }
    Ok(())
}

/// Where `path` really points, whether or not it exists yet: made absolute, then resolved one
/// component at a time — symbolic links followed (dangling ones too, to the path they name),
/// `.` dropped and `..` taken as the parent of what is resolved so far. Past the longest
/// existing prefix this is lexical, which is what writing the path will do: the writer creates
/// the missing folders, after which `absent/..` is the folder `absent` sits in.
///
/// Two paths that resolve alike name one file, so comparing resolved paths catches an output
/// that would replace an input however it is spelled.
pub fn resolve(path: &Path) -> std::io::Result<PathBuf> {
    let absolute = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir()?.join(path)
    };
    let mut resolved = PathBuf::new();
    // Components still to resolve, the next one last.
    let mut pending: Vec<OsString> = Vec::new();
    for c in absolute.components() {
        match c {
            Component::Prefix(_) | Component::RootDir => resolved.push(c.as_os_str()),
            _ => pending.push(c.as_os_str().to_os_string()),
        }
    }
    pending.reverse();
    let mut links = 0;
    while let Some(name) = pending.pop() {
        if name == "." {
            continue;
        }
        if name == ".." {
            resolved.pop();
            continue;
        }
        let candidate = resolved.join(&name);
        match std::fs::symlink_metadata(&candidate) {
            Ok(m) if m.file_type().is_symlink() => {
                links += 1;
                if links > 40 {
                    return Err(std::io::Error::other(format!(
                        "{}: too many levels of symbolic links",
                        path.display()
                    )));
                }
                let target = std::fs::read_link(&candidate)?;
                if target.is_absolute() {
                    resolved = PathBuf::new();
                }
                let mut parts: Vec<OsString> = Vec::new();
                for c in target.components() {
                    match c {
                        Component::Prefix(_) | Component::RootDir => resolved.push(c.as_os_str()),
                        _ => parts.push(c.as_os_str().to_os_string()),
                    }
                }
                pending.extend(parts.into_iter().rev());
            }
            _ => resolved = candidate,
        }
    }
    Ok(resolved)
}

/// Whether `a` and `b` name one file: the same resolved path, or (hard links) the same file on
/// disk.
fn same_file(a: &Path, b: &Path) -> bool {
    if let (Ok(ra), Ok(rb)) = (resolve(a), resolve(b))
        && ra == rb
    {
        return true;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return ma.dev() == mb.dev() && ma.ino() == mb.ino();
        }
    }
    false
}

/// Refuses an output that is one of the inputs or another output (`(flag, path)` pairs), so
/// that a run never destroys what it reads or writes one result over another. Paths are
/// compared where they really point ([`resolve`]), so `absent/../p.csv`, `./p.csv`, a link to
/// `p.csv` (dangling or not) and a hard link all count as `p.csv`.
pub fn check_distinct(outputs: &[(&str, &Path)], inputs: &[(&str, &Path)]) -> Result<(), InputError> {
    for (i, (flag, out)) in outputs.iter().enumerate() {
        if let Some((other, path)) = inputs.iter().find(|(_, p)| same_file(out, p)) {
            return Err(InputError::new(format!(
                "{flag} {}: would overwrite {other} {}; choose another {}",
                out.display(),
                path.display(),
                flag.split(' ').next().unwrap_or(flag)
            )));
        }
        if let Some((other, path)) = outputs[..i].iter().find(|(_, p)| same_file(out, p)) {
            return Err(InputError::new(format!(
                "{flag} {}: is the same file as {other} {}; give each output its own name",
                out.display(),
                path.display()
            )));
        }
    }
    Ok(())
}

/// Whether process `pid` may still be running. Only Linux can say no (`/proc/<pid>` is
/// absent); elsewhere, or without `/proc`, every process is taken as alive, so nothing of a
/// live writer is ever removed.
pub fn pid_alive(pid: u32) -> bool {
    if pid == std::process::id() {
        return true;
    }
    #[cfg(target_os = "linux")]
    {
        if Path::new("/proc/self").exists() {
            return Path::new("/proc").join(pid.to_string()).exists();
        }
    }
    true
}

/// `prefix` followed by `name`, byte for byte (names need not be UTF-8).
pub(crate) fn hidden_name(prefix: &str, name: &OsStr) -> OsString {
    let mut s = OsString::from(prefix);
    s.push(name);
    s
}

/// Who wrote a hidden name: `<pid>.<host>`, with [`host_tag`] of this host.
pub fn writer(pid: u32) -> String {
    format!("{pid}.{}", host_tag())
}

/// This host and pid namespace, as 12 hex digits: a hash of the kernel's boot id and of the pid
/// namespace. Folders shared between hosts (a cluster's result folders and caches) hold other
/// hosts' hidden files, whose pids mean nothing here; a pid is only judged on the host (and in
/// the pid namespace) that wrote it. `000000000000` where neither can be read (not Linux).
pub fn host_tag() -> &'static str {
    static TAG: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    TAG.get_or_init(|| {
        let boot = std::fs::read_to_string("/proc/sys/kernel/random/boot_id").unwrap_or_default();
        let namespace = std::fs::read_link("/proc/self/ns/pid").unwrap_or_default();
        if boot.is_empty() && namespace.as_os_str().is_empty() {
            return "0".repeat(12);
        }
        // Stable across builds and platforms (std's hasher is not).
        let hash = crate::util::hash::fnv1a(
            boot.trim()
                .bytes()
                .chain([0])
                .chain(namespace.as_os_str().as_encoded_bytes().iter().copied()),
        );
        format!("{:012x}", hash >> 16)
    })
}

/// The writer of one of our hidden names, `.workbench-<pid>.<host>-…`: its pid and host tag, as
/// text (`<pid>.<host>`) and parsed. Names of earlier versions (`.workbench-<pid>-…`) give the
/// pid with no host.
pub fn hidden_name_writer(name: &OsStr) -> Option<(&str, u32, Option<&str>)> {
    let rest = name.to_str()?.strip_prefix(HIDDEN_PREFIX)?;
    let (writer, _) = rest.split_once('-')?;
    let (pid, host) = match writer.split_once('.') {
        Some((pid, host)) if host.len() == 12 && host.bytes().all(|b| b.is_ascii_hexdigit()) => {
            (pid, Some(host))
        }
        Some(_) => return None,
        None => (writer, None),
    };
    if pid.is_empty() || !pid.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some((writer, pid.parse().ok()?, host))
}

/// The pid in one of our hidden names (see [`hidden_name_writer`]).
pub fn hidden_name_pid(name: &OsStr) -> Option<u32> {
    hidden_name_writer(name).map(|(_, pid, _)| pid)
}

/// Removes from `dir` what killed writers left: our temporary files and staging folders written
/// on this host whose process is gone, and lock files nobody holds. Best effort and silent: a leftover that cannot
/// be removed now is tried again next time, and never blocks the command.
pub fn sweep_stale(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let path = entry.path();
        if let Some((_, pid, host)) = hidden_name_writer(&name) {
            // Only this host's, and only a dead writer's: another host's pid means nothing here,
            // and a name without a host (an earlier version's) may be anyone's.
            if host == Some(host_tag()) && !pid_alive(pid) {
                remove_any(&path);
            }
        } else if name.to_str().is_some_and(|n| n.starts_with(LOCK_PREFIX)) {
            remove_if_unlocked(&path);
        }
    }
}

/// Removes a file or a whole folder (never following a link out of it).
pub(crate) fn remove_any(path: &Path) {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.is_dir() => {
            let _ = std::fs::remove_dir_all(path);
        }
        Ok(_) => {
            let _ = std::fs::remove_file(path);
        }
        Err(_) => {}
    }
}

/// Removes a lock file nobody holds (left by a killed command). A command that opened it
/// just before finds, once it has locked it, that it is no longer at its path, and starts over.
pub(crate) fn remove_if_unlocked(path: &Path) {
    let Ok(file) = std::fs::OpenOptions::new().read(true).open(path) else {
        return;
    };
    if file.try_lock().is_ok() && same_inode(&file, path) {
        let _ = std::fs::remove_file(path);
    }
}

/// Whether `path` still names the open `file`.
pub(crate) fn same_inode(file: &std::fs::File, path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (file.metadata(), std::fs::metadata(path)) {
            (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        let _ = (file, path);
        true
    }
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

    /// The cases `check_distinct` used to miss: a missing folder followed by `..`, and links
    /// that dangle.
    #[test]
    fn output_overwrites_input_resolution_sees_through_absent_folders_and_dangling_links() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path().canonicalize().unwrap();
        std::fs::write(d.join("p.csv"), "x").unwrap();
        assert_eq!(resolve(&d.join("absent/../p.csv")).unwrap(), d.join("p.csv"));
        assert_eq!(resolve(&d.join("absent/x/../../p.csv")).unwrap(), d.join("p.csv"));
        assert_eq!(resolve(&d.join("./absent/./y")).unwrap(), d.join("absent/y"));
        // A dangling link resolves to the path it names; a link inside the path is followed
        // before the `..` after it is applied.
        std::os::unix::fs::symlink("sub/s.json", d.join("dangling")).unwrap();
        assert_eq!(resolve(&d.join("dangling")).unwrap(), d.join("sub/s.json"));
        std::fs::create_dir_all(d.join("a/b")).unwrap();
        std::os::unix::fs::symlink(d.join("a/b"), d.join("ab")).unwrap();
        assert_eq!(resolve(&d.join("ab/../p.csv")).unwrap(), d.join("a/p.csv"));
        // A loop is an error, not a hang.
        std::os::unix::fs::symlink("loop2", d.join("loop1")).unwrap();
        std::os::unix::fs::symlink("loop1", d.join("loop2")).unwrap();
        assert!(resolve(&d.join("loop1")).is_err());

        let p = d.join("p.csv");
        let sneaky = d.join("absent/../p.csv");
        let e = check_distinct(&[("--out", &sneaky)], &[("--points", &p)]).unwrap_err();
        assert!(e.0.contains("would overwrite --points"), "{e}");
        let link = d.join("dangling");
        let summary = d.join("sub/s.json");
        let e = check_distinct(&[("--summary", &summary), ("--out", &link)], &[]).unwrap_err();
        assert!(
            e.0.contains("--out") && e.0.contains("is the same file as --summary"),
            "{e}"
        );
        std::fs::hard_link(&p, d.join("hard.csv")).unwrap();
        assert!(check_distinct(&[("--out", &d.join("hard.csv"))], &[("--points", &p)]).is_err());
        assert!(check_distinct(&[("--out", &d.join("q.csv"))], &[("--points", &p)]).is_ok());
    }

    #[test]
    fn hidden_names_carry_the_writer_pid() {
        assert_eq!(hidden_name_pid(OsStr::new(".workbench-123-abc.tmp")), Some(123));
        assert_eq!(hidden_name_pid(OsStr::new(".workbench-123-staging-x")), Some(123));
        assert_eq!(hidden_name_pid(OsStr::new(".workbench-lock-x")), None);
        assert_eq!(hidden_name_pid(OsStr::new(".workbench-Ab3x9q")), None);
        assert_eq!(hidden_name_pid(OsStr::new("workbench-1-x")), None);
        // With the host: `<pid>.<12 hex digits>`; anything else after the dot is not ours.
        let name = format!(".workbench-{}-staging-x", writer(77));
        assert_eq!(
            hidden_name_writer(OsStr::new(&name)),
            Some((writer(77).as_str(), 77, Some(host_tag())))
        );
        assert_eq!(
            hidden_name_writer(OsStr::new(".workbench-5-a.tmp")),
            Some(("5", 5, None))
        );
        assert_eq!(hidden_name_writer(OsStr::new(".workbench-5.xyz-a.tmp")), None);
        assert_eq!(host_tag().len(), 12);
    }
}
