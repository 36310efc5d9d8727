//! Bounded, typed reads: the one way the tool reads a file it is given (maps, reference images,
//! experiment and render-table JSON, points and values CSVs, unit logs and shard files, the
//! external data files of the catalogue).
//!
//! Every read knows what kind of file it expects ([`FileKind`]) and that kind's size limit, so
//! that a file named by mistake cannot exhaust memory or hang the tool:
//! - the path's type is checked with `metadata` *before* the file is opened: a folder, a named
//!   pipe (FIFO), a device (`/dev/zero`) or a socket is refused, so a FIFO never blocks `open`;
//! - the file is opened non-blocking (Linux) and checked again through the open handle, so a
//!   file swapped for a FIFO between the two steps is refused too;
//! - at most `limit + 1` bytes are read (`take`): a file that grows while read, or whose size
//!   lies, is cut off and refused, never read without end.
//!
//! Errors are [`ReadError`]s, one line naming the file, the kind and (when too large) the limit.

use std::fmt;
use std::fs::{File, Metadata};
use std::io::{self, Read};
use std::path::{Path, PathBuf};

const MIB: u64 = 1 << 20;
const GIB: u64 = 1 << 30;

/// What a file is expected to be: its name in messages and its size limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    /// An experiment or render-table JSON file (real ones are a few kilobytes).
    Spec,
    /// An environment map (`.hdr`/`.exr`): a 16k × 8k Radiance map is about 0.5 GiB.
    Map,
    /// A reference image or a cached reference (`.exr`/`.hdr`).
    Image,
    /// A points CSV (`rule --points`): `MAX_POINTS` rows take about 1.5 MiB.
    Points,
    /// A values CSV (`rule --values`).
    Values,
    /// A unit log or a shard's `units.csv`, read as a stream (long runs write gigabytes).
    UnitLog,
    /// A small record the tool wrote itself (a shard's `shard.json`, timings).
    Record,
    /// A file of the external data catalogue (checked against its size and sha256).
    DataFile,
}

impl FileKind {
    /// The largest file of this kind that is read.
    pub const fn limit(self) -> u64 {
        match self {
            FileKind::Spec | FileKind::Points | FileKind::Values | FileKind::Record => 16 * MIB,
            FileKind::Map | FileKind::Image | FileKind::DataFile => GIB,
            FileKind::UnitLog => 64 * GIB,
        }
    }

    /// The kind in a message, plural: `spec files`, `environment maps`, ….
    pub const fn plural(self) -> &'static str {
        match self {
            FileKind::Spec => "spec files",
            FileKind::Map => "environment maps",
            FileKind::Image => "images",
            FileKind::Points => "points files",
            FileKind::Values => "values files",
            FileKind::UnitLog => "unit logs",
            FileKind::Record => "record files",
            FileKind::DataFile => "data files",
        }
    }
}

/// Why a file was not read. `Display` is one line starting with the path; [`ReadError::reason`]
/// is the same without it, for callers that name the file their own way (`--env FILE: …`).
#[derive(Debug, thiserror::Error)]
#[error("{}: {}", path.display(), self.reason())]
pub struct ReadError {
    pub path: PathBuf,
    pub kind: FileKind,
    pub problem: Problem,
}

/// What was wrong with the file.
#[derive(Debug)]
pub enum Problem {
    /// It does not exist or could not be opened or read.
    Io(io::Error),
    /// It is a folder.
    Folder,
    /// It exists but is not a regular file: `a named pipe (FIFO)`, `a character device`, ….
    NotRegular(&'static str),
    /// It holds more than the kind's limit: its size if known (`None`: found while reading).
    TooLarge(Option<u64>),
    /// A text file holds bytes that are not UTF-8 (the message names line and column).
    NotText(String),
}

impl ReadError {
    /// The message without the path: `cannot read: …`, `is a folder, not a file`,
    /// `is a named pipe (FIFO), not a regular file; environment maps are read from regular
    /// files only`, `the file is 1.0 GiB; spec files are limited to 16.0 MiB`.
    pub fn reason(&self) -> String {
        let kinds = self.kind.plural();
        match &self.problem {
            Problem::Io(e) => format!("cannot read: {e}"),
            Problem::Folder => "is a folder, not a file".into(),
            Problem::NotRegular(what) => {
                format!("is {what}, not a regular file; {kinds} are read from regular files only")
            }
            Problem::TooLarge(size) => {
                let limit = bytes(self.kind.limit());
                let size = match size {
                    None => format!("over {limit}"),
                    // Just over the limit: rounded, both would read the same.
                    Some(n) if bytes(*n) == limit => format!("{n} bytes"),
                    Some(n) => bytes(*n),
                };
                format!("the file is {size}; {kinds} are limited to {limit}")
            }
            Problem::NotText(m) => m.clone(),
        }
    }

    /// True if the file does not exist.
    pub fn is_not_found(&self) -> bool {
        matches!(&self.problem, Problem::Io(e) if e.kind() == io::ErrorKind::NotFound)
    }
}

/// `12.0 MiB`, `1.0 GiB`, `512 bytes`.
pub fn bytes(n: u64) -> String {
    if n >= GIB {
        format!("{:.1} GiB", n as f64 / GIB as f64)
    } else if n >= MIB {
        format!("{:.1} MiB", n as f64 / MIB as f64)
    } else {
        format!("{n} bytes")
    }
}

/// The whole file at `path`, at most `kind.limit()` bytes, if it is a regular file.
pub fn read(path: &Path, kind: FileKind) -> Result<Vec<u8>, ReadError> {
    let (file, meta) = open_checked(path, kind)?;
    let mut data = Vec::with_capacity(meta.len().min(kind.limit()) as usize);
    let err = |problem| ReadError {
        path: path.to_path_buf(),
        kind,
        problem,
    };
    // Capped even for regular files: a file that grows while read has no fixed size.
    file.take(kind.limit() + 1)
        .read_to_end(&mut data)
        .map_err(|e| err(Problem::Io(e)))?;
    if data.len() as u64 > kind.limit() {
        return Err(err(Problem::TooLarge(None)));
    }
    Ok(data)
}

/// [`read`] as UTF-8 text (a byte-order mark is kept; the parsers skip it). Bytes that are not
/// UTF-8 are an error naming their line and column.
pub fn read_text(path: &Path, kind: FileKind) -> Result<String, ReadError> {
    let data = read(path, kind)?;
    utf8(data).map_err(|m| ReadError {
        path: path.to_path_buf(),
        kind,
        problem: Problem::NotText(m),
    })
}

/// `data` as a `String`, or an error naming the line, column and value of the first byte that
/// is not UTF-8.
pub fn utf8(data: Vec<u8>) -> Result<String, String> {
    String::from_utf8(data).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let data = e.as_bytes();
        let line = 1 + data[..at].iter().filter(|&&b| b == b'\n').count();
        let line_start = data[..at].iter().rposition(|&b| b == b'\n').map_or(0, |p| p + 1);
        format!(
            "line {line}, column {}: byte 0x{:02X} is not UTF-8 text; save the file as UTF-8",
            at - line_start + 1,
            data[at]
        )
    })
}

/// The file at `path` opened for a streaming read of at most `kind.limit()` bytes: reading
/// past the limit is an `io::Error` saying so (never a silent end of file).
pub fn open(path: &Path, kind: FileKind) -> Result<Bounded, ReadError> {
    let (file, _) = open_checked(path, kind)?;
    Ok(Bounded {
        inner: file.take(kind.limit() + 1),
        path: path.to_path_buf(),
        kind,
        read: 0,
    })
}

/// A reader that fails once more than its kind's limit has been read ([`open`]).
pub struct Bounded {
    inner: io::Take<File>,
    path: PathBuf,
    kind: FileKind,
    read: u64,
}

impl Read for Bounded {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.read += n as u64;
        if self.read > self.kind.limit() {
            let e = ReadError {
                path: self.path.clone(),
                kind: self.kind,
                problem: Problem::TooLarge(None),
            };
            return Err(io::Error::new(io::ErrorKind::FileTooLarge, e.reason()));
        }
        Ok(n)
    }
}

/// Opens `path` if it is a regular file within the limit, checked before opening and again
/// through the handle.
fn open_checked(path: &Path, kind: FileKind) -> Result<(File, Metadata), ReadError> {
    let err = |problem| ReadError {
        path: path.to_path_buf(),
        kind,
        problem,
    };
    // Before opening: opening a FIFO for reading blocks until a writer comes.
    let before = std::fs::metadata(path).map_err(|e| err(Problem::Io(e)))?;
    check_type(&before, kind).map_err(err)?;
    let file = open_nonblocking(path).map_err(|e| err(Problem::Io(e)))?;
    let meta = file.metadata().map_err(|e| err(Problem::Io(e)))?;
    check_type(&meta, kind).map_err(err)?;
    Ok((file, meta))
}

/// A regular file of at most `kind.limit()` bytes, or the problem.
fn check_type(meta: &Metadata, kind: FileKind) -> Result<(), Problem> {
    if meta.is_dir() {
        return Err(Problem::Folder);
    }
    if !meta.is_file() {
        return Err(Problem::NotRegular(type_name(&meta.file_type())));
    }
    if meta.len() > kind.limit() {
        return Err(Problem::TooLarge(Some(meta.len())));
    }
    Ok(())
}

/// Opened with `O_NONBLOCK` on Linux (no effect on a regular file; a FIFO that replaced the
/// file since `metadata` then opens at once and is refused by type instead of blocking).
fn open_nonblocking(path: &Path) -> io::Result<File> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(rustix::fs::OFlags::NONBLOCK.bits() as i32);
    }
    options.open(path)
}

/// `a named pipe (FIFO)`, `a character device`, … for a path that is not a regular file.
fn type_name(t: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a named pipe (FIFO)";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_symlink() {
        return "a symbolic link";
    }
    "not a file"
}

impl fmt::Display for FileKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.plural())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_regular_files_up_to_the_limit() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.json");
        let file = File::create(&path).unwrap();
        file.set_len(FileKind::Spec.limit()).unwrap();
        assert_eq!(
            read(&path, FileKind::Spec).unwrap().len() as u64,
            FileKind::Spec.limit()
        );
        file.set_len(FileKind::Spec.limit() + 1).unwrap();
        let e = read(&path, FileKind::Spec).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "{}: the file is 16777217 bytes; spec files are limited to 16.0 MiB",
                path.display()
            )
        );
    }

    /// A FIFO is refused by type without opening it: this would block forever otherwise.
    #[cfg(unix)]
    #[test]
    fn a_fifo_or_device_is_refused_before_opening() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe.hdr");
        assert!(
            std::process::Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .unwrap()
                .success()
        );
        let e = read(&fifo, FileKind::Map).unwrap_err();
        assert_eq!(
            e.reason(),
            "is a named pipe (FIFO), not a regular file; environment maps are read from regular files only"
        );
        let e = read(Path::new("/dev/zero"), FileKind::Map).unwrap_err();
        assert!(e.reason().starts_with("is a character device"), "{e}");
        let e = open(dir.path(), FileKind::UnitLog).err().unwrap();
        assert_eq!(e.reason(), "is a folder, not a file");
        assert!(
            read(&dir.path().join("none"), FileKind::Spec)
                .unwrap_err()
                .is_not_found()
        );
    }

    /// The streaming reader fails past its limit instead of ending early.
    #[test]
    fn a_stream_past_the_limit_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("units.csv");
        std::fs::write(&path, b"abc").unwrap();
        let mut r = open(&path, FileKind::UnitLog).unwrap();
        let mut s = String::new();
        r.read_to_string(&mut s).unwrap();
        assert_eq!(s, "abc");
        // The same reader with a tiny limit, as if the file had grown past it.
        let mut r = Bounded {
            inner: File::open(&path).unwrap().take(3),
            path: path.clone(),
            kind: FileKind::UnitLog,
            read: FileKind::UnitLog.limit() - 1,
        };
        let e = r.read_to_end(&mut Vec::new()).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::FileTooLarge);
        assert!(e.to_string().contains("unit logs are limited to 64.0 GiB"), "{e}");
    }
}
