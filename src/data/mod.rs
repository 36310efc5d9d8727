//! External data: files made by other people (light probes, the thesis author's renders,
//! Mitsuba's test scenes), never copied into the repository, read from a data folder the user
//! names (`--data DIR`, else the environment variable `WORKBENCH_DATA`) and checked against the
//! [`catalog`] (size and sha256) before use.
//!
//! [`resolve`] turns what a user wrote where a file is expected (`"env": "pisa"`,
//! `--env maps/x.hdr`) into a [`Source`]: a catalogue entry or a path; [`Source::read`] reads it
//! bounded (through [`crate::files::read`]) and, for an entry, verified. [`check`] verifies one
//! entry in a folder without keeping its bytes (`workbench data`). Every failure is one
//! [`DataError`], a one-line message naming the file, its expected sha256 and where to obtain it.

pub mod catalog;

pub use catalog::{Entry, Kind};

use crate::files::read::{FileKind, ReadError};
use sha2::{Digest, Sha256};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The environment variable naming the data folder when the caller names none.
pub const ENV_VAR: &str = "WORKBENCH_DATA";

/// Where the data folder was named, for messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Origin {
    /// By the caller's own setting, named as the caller names it (the CLI: `--data`).
    Setting(&'static str),
    /// `WORKBENCH_DATA`.
    Env,
}

/// The data folder and where it was named.
#[derive(Clone, Debug)]
pub struct Folder {
    pub path: PathBuf,
    pub origin: Origin,
}

impl Folder {
    /// `SETTING DIR` (the CLI's `--data DIR`) or `WORKBENCH_DATA=DIR`, for messages.
    pub fn shown(&self) -> String {
        match self.origin {
            Origin::Setting(name) => format!("{name} {}", self.path.display()),
            Origin::Env => format!("{ENV_VAR}={}", self.path.display()),
        }
    }

    /// Where `entry` is in this folder.
    pub fn file(&self, entry: &Entry) -> PathBuf {
        self.path.join(&entry.path)
    }
}

static FLAG_FOLDER: OnceLock<PathBuf> = OnceLock::new();
static FOLDER_SETTING: OnceLock<&'static str> = OnceLock::new();

/// Names the caller's own data-folder setting in messages (the CLI: `--data`), whether or not it
/// is given; without one (a library or Python caller), messages name only `WORKBENCH_DATA`.
/// Called once before any work; later calls are ignored.
pub fn name_setting(name: &'static str) {
    let _ = FOLDER_SETTING.set(name);
}

/// Sets the folder given by the caller's setting ([`name_setting`]), which takes precedence
/// over `WORKBENCH_DATA`. Called once before any work; later calls are ignored.
pub fn set_folder(path: PathBuf) {
    let _ = FLAG_FOLDER.set(path);
}

/// How to name a data folder: `pass SETTING DIR or set WORKBENCH_DATA=DIR`, or only the latter
/// for a caller without a setting of its own.
fn how_to_set() -> String {
    match FOLDER_SETTING.get() {
        Some(name) => format!("pass {name} DIR or set {ENV_VAR}=DIR"),
        None => format!("set {ENV_VAR}=DIR"),
    }
}

/// The data folder: `--data DIR` if given, else `WORKBENCH_DATA` if set and not empty, else
/// `None`. A folder that is named but is not a folder is an error.
pub fn folder() -> Result<Option<Folder>, DataError> {
    let named = match FLAG_FOLDER.get() {
        Some(p) => Folder {
            path: p.clone(),
            origin: Origin::Setting(FOLDER_SETTING.get().copied().unwrap_or("the data folder")),
        },
        None => match std::env::var_os(ENV_VAR) {
            Some(p) if !p.is_empty() => Folder {
                path: PathBuf::from(p),
                origin: Origin::Env,
            },
            _ => return Ok(None),
        },
    };
    match std::fs::metadata(&named.path) {
        Ok(m) if m.is_dir() => Ok(Some(named)),
        Ok(_) => Err(DataError::BadFolder {
            folder: named,
            problem: "is not a folder".into(),
        }),
        Err(e) => Err(DataError::BadFolder {
            folder: named,
            problem: format!("cannot be read ({e})"),
        }),
    }
}

/// What a user wrote where a file is expected, resolved.
#[derive(Clone, Debug)]
pub enum Source {
    /// A path, read as given.
    Path(PathBuf),
    /// A catalogue entry, read from the data folder and verified.
    Entry(&'static Entry),
}

/// Resolves `arg` where a file of `kind` is expected: a path if it contains a `/` or names an
/// existing file (or symbolic link), else the catalogue entry of that name, which must be of
/// `kind`. Anything else is [`DataError::Unknown`], listing the catalogue's names of `kind`.
pub fn resolve(arg: &str, kind: Kind) -> Result<Source, DataError> {
    let path = Path::new(arg);
    if arg.contains('/') || path.symlink_metadata().is_ok() {
        return Ok(Source::Path(path.to_path_buf()));
    }
    match catalog::find(arg) {
        Some(entry) if entry.kind == kind => Ok(Source::Entry(entry)),
        Some(entry) => Err(DataError::WrongKind { entry, kind }),
        None => Err(DataError::Unknown { kind }),
    }
}

impl Source {
    /// The file's bytes, at most `file_kind`'s limit: a path as it is, a catalogue entry from
    /// the data folder, checked against its size and sha256.
    pub fn read(&self, file_kind: FileKind) -> Result<Vec<u8>, DataError> {
        match self {
            Source::Path(p) => crate::files::read::read(p, file_kind).map_err(DataError::Read),
            Source::Entry(entry) => read(entry),
        }
    }
}

/// The catalogue file `entry`, read from the data folder and verified (size, then sha256).
pub fn read(entry: &'static Entry) -> Result<Vec<u8>, DataError> {
    let folder = folder()?.ok_or(DataError::NoFolder { entry })?;
    let path = folder.file(entry);
    let bytes =
        crate::files::read::read(&path, FileKind::DataFile).map_err(|e| unreadable(entry, &path, e))?;
    let found = Found {
        bytes: bytes.len() as u64,
        sha256: hex(&Sha256::digest(&bytes)),
    };
    verify(entry, &path, found)?;
    Ok(bytes)
}

/// Checks the catalogue file `entry` in `folder` (streamed through sha256, nothing kept) and
/// returns its path.
pub fn check(folder: &Folder, entry: &'static Entry) -> Result<PathBuf, DataError> {
    let path = folder.file(entry);
    let mut file =
        crate::files::read::open(&path, FileKind::DataFile).map_err(|e| unreadable(entry, &path, e))?;
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    let mut bytes = 0u64;
    loop {
        let n = file.read(&mut buf).map_err(|e| DataError::File {
            entry,
            path: path.clone(),
            problem: FileProblem::Unreadable(e.to_string()),
        })?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
        bytes += n as u64;
    }
    let found = Found {
        bytes,
        sha256: hex(&hasher.finalize()),
    };
    verify(entry, &path, found)?;
    Ok(path)
}

/// What a file holds: its size and sha256.
struct Found {
    bytes: u64,
    sha256: String,
}

fn verify(entry: &'static Entry, path: &Path, found: Found) -> Result<(), DataError> {
    if found.bytes == entry.bytes && found.sha256 == entry.sha256 {
        return Ok(());
    }
    Err(DataError::File {
        entry,
        path: path.to_path_buf(),
        problem: FileProblem::Altered {
            bytes: found.bytes,
            sha256: found.sha256,
        },
    })
}

fn unreadable(entry: &'static Entry, path: &Path, e: ReadError) -> DataError {
    let problem = if e.is_not_found() {
        FileProblem::Missing
    } else {
        FileProblem::Unreadable(e.reason())
    };
    DataError::File {
        entry,
        path: path.to_path_buf(),
        problem,
    }
}

/// Lower-case hex.
fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Why an external file could not be used. One line each; those about a catalogue file name
/// the file, its expected size and sha256, and where to obtain it.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// A catalogue file was named but no data folder is set.
    #[error(
        "`{}` is the catalogue's {} {} and no data folder is set: {}, the folder that holds it (`workbench data` lists the catalogue; docs/guide/data.md)",
        entry.name, entry.kind.name(), entry.path, how_to_set()
    )]
    NoFolder { entry: &'static Entry },
    /// The folder named by `--data` or `WORKBENCH_DATA` is not a readable folder.
    #[error("{}: {problem}; it must be the data folder (`workbench data` checks it)", folder.shown())]
    BadFolder { folder: Folder, problem: String },
    /// A catalogue file in the data folder is missing, altered or unreadable.
    #[error(
        "{}: {problem}; the catalogue's `{}` is {} bytes with sha256 {}; obtain it from {}",
        path.display(), entry.name, entry.bytes, entry.sha256, entry.source
    )]
    File {
        entry: &'static Entry,
        path: PathBuf,
        problem: FileProblem,
    },
    /// A name that is neither a file nor in the catalogue.
    #[error(
        "cannot read: no such file, and not the name of a catalogue {} ({}); `workbench data` lists the catalogue",
        kind.name(), catalog::names(*kind).join(", ")
    )]
    Unknown { kind: Kind },
    /// A catalogue name of another kind (an image where a map is expected).
    #[error(
        "`{}` is the catalogue's {}, not a {} (the catalogue's {}s: {})",
        entry.name, entry.kind.name(), kind.name(), kind.name(), catalog::names(*kind).join(", ")
    )]
    WrongKind { entry: &'static Entry, kind: Kind },
    /// A path could not be read.
    #[error(transparent)]
    Read(ReadError),
}

impl DataError {
    /// The message without the path for a path that could not be read (the caller names it
    /// its own way, e.g. `--env FILE: …`); otherwise the message.
    pub fn reason(&self) -> String {
        match self {
            DataError::Read(e) => e.reason(),
            other => other.to_string(),
        }
    }
}

/// What is wrong with a catalogue file in the data folder.
#[derive(Debug)]
pub enum FileProblem {
    /// Not there.
    Missing,
    /// Its bytes are not the catalogue's.
    Altered { bytes: u64, sha256: String },
    /// Not a regular file, too large, or unreadable (the reason).
    Unreadable(String),
}

impl std::fmt::Display for FileProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FileProblem::Missing => f.write_str("missing"),
            FileProblem::Altered { bytes, sha256 } => {
                write!(f, "altered (it is {bytes} bytes with sha256 {sha256})")
            }
            FileProblem::Unreadable(reason) => f.write_str(reason),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sha256 of the empty string and of "abc" (FIPS 180-2, appendix B.1).
    #[test]
    fn sha256_hex_matches_the_standard_vectors() {
        assert_eq!(
            hex(&Sha256::digest(b"")),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"
        );
        assert_eq!(
            hex(&Sha256::digest(b"abc")),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn names_paths_and_unknown_words_resolve_as_documented() {
        assert!(matches!(resolve("pisa", Kind::Map), Ok(Source::Entry(e)) if e.name == "pisa"));
        assert!(matches!(resolve("maps/pisa", Kind::Map), Ok(Source::Path(_))));
        assert!(matches!(
            resolve("/nonexistent.hdr", Kind::Map),
            Ok(Source::Path(_))
        ));
        let e = resolve("thesis-mc3000", Kind::Map).unwrap_err().to_string();
        assert!(
            e.starts_with(
                "`thesis-mc3000` is the catalogue's image, not a map (the catalogue's maps: pisa, "
            ),
            "{e}"
        );
        let e = resolve("pisaa", Kind::Map).unwrap_err().to_string();
        assert!(
            e.starts_with("cannot read: no such file, and not the name of a catalogue map (pisa, pisa-256, "),
            "{e}"
        );
    }

    /// A catalogue file is checked by size and sha256 (streamed for [`check`]); each failure
    /// names the file, the expected checksum and the source.
    #[test]
    fn check_reports_missing_altered_and_not_regular_files() {
        let entry = catalog::find("black-and-white").unwrap();
        let dir = tempfile::tempdir().unwrap();
        let folder = Folder {
            path: dir.path().to_path_buf(),
            origin: Origin::Setting("--data"),
        };
        let e = check(&folder, entry).unwrap_err().to_string();
        let tail = format!(
            "; the catalogue's `black-and-white` is {} bytes with sha256 {}; obtain it from {}",
            entry.bytes, entry.sha256, entry.source
        );
        assert_eq!(e, format!("{}: missing{tail}", folder.file(entry).display()));
        std::fs::create_dir_all(folder.file(entry).parent().unwrap()).unwrap();
        std::fs::write(folder.file(entry), b"abc").unwrap();
        let e = check(&folder, entry).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "{}: altered (it is 3 bytes with sha256 ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad){tail}",
                folder.file(entry).display()
            )
        );
        std::fs::remove_file(folder.file(entry)).unwrap();
        std::fs::create_dir(folder.file(entry)).unwrap();
        let e = check(&folder, entry).unwrap_err().to_string();
        assert!(e.contains(": is a folder, not a file; the catalogue's"), "{e}");
    }
}
