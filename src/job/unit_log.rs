//! The unit log: the rows of every finished unit of a job, in unit order, appended as the run
//! goes (`trials.partial.csv`, `rounds.partial.csv` or `irradiance.partial.csv` in a results
//! folder while a run is under way; [`SHARD_UNITS`] in a shard's folder).
//!
//! The first line names what the log was made from ([`Identity`]), the second is the job's
//! column line and `digest`; then `per_unit` rows per unit. A run does its units in increasing
//! order and appends whole units only, so the log always holds a prefix of the run's units (a
//! killed run at most leaves a half-written last unit, which is cut off on resuming).
//!
//! Every row ends in its **digest**, FNV-1a 64 ([`crate::util::hash`]) of the plan hash and the
//! row's text: a row read back ([`open_lines`], [`LogSet`]) is checked by its job as it was
//! written (finite, in range, the plan's own values recomputed) and then against its digest, so
//! that a number changed by hand — a halved RMSE, an exact irradiance ×1.5 — is refused too. It
//! is a check of integrity, not a security measure.

use super::shard::Identity;
use crate::error::{Error, InputError, Result};
use crate::files::read::FileKind;
use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Seek, Write};
use std::path::{Path, PathBuf};

/// A shard's units, in its folder, for `workbench merge`.
pub const SHARD_UNITS: &str = "units.csv";
/// The last column of every log row.
pub const DIGEST_COLUMN: &str = "digest";

/// The log's column line: the job's columns, then [`DIGEST_COLUMN`].
pub fn column_line(columns: &str) -> String {
    format!("{columns},{DIGEST_COLUMN}")
}

/// A row's digest under `key` (the plan hash): 16 hex digits.
pub fn digest(key: &str, row: &str) -> String {
    crate::util::hash::fnv1a_hex(key.bytes().chain([b'\n']).chain(row.bytes()))
}

/// `row` without its digest, and whether the digest is the row's under `key`.
pub fn split_digest<'a>(key: &str, line: &'a str) -> (&'a str, bool) {
    match line.rsplit_once(',') {
        Some((row, d)) => (row, d == digest(key, row)),
        None => (line, false),
    }
}

/// What a row that fails its digest is told.
pub const CHANGED: &str =
    "was changed after it was written (its digest is not the row's: a value edited by hand?)";

/// A log being appended to.
pub struct LogWriter {
    file: File,
    path: PathBuf,
    key: String,
}

impl LogWriter {
    /// Appends whole units' rows (one batch, each row ending in its newline) with their
    /// digests, and hands them to the system, so that a killed process keeps them.
    pub fn append(&mut self, rows: &str) -> Result<()> {
        let mut text = String::with_capacity(rows.len() + rows.len() / 4);
        for row in rows.lines() {
            text.push_str(row);
            text.push(',');
            text.push_str(&digest(&self.key, row));
            text.push('\n');
        }
        self.file
            .write_all(text.as_bytes())
            .map_err(|e| Error::io(format!("appending to {}", self.path.display()), e))
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// A unit log opened for reading through [`crate::files::read`]: a regular file, at most
/// [`FileKind::UnitLog`]'s limit.
pub fn bounded_open(path: &Path) -> Result<crate::files::read::Bounded> {
    crate::files::read::open(path, FileKind::UnitLog).map_err(|e| InputError::new(e.to_string()).into())
}

/// What [`open_lines`] hands each complete unit's rows to: `(unit, rows)`, the rows without
/// their digests; an error names the row (0-based within the unit) and what is wrong with it.
pub type UnitLines<'a> = dyn FnMut(usize, &[&str]) -> std::result::Result<(), (usize, String)> + 'a;

/// Opens the log at `path` of a run of `identity`'s units `units` (in order), `per_unit` rows
/// each, under the job's column line `columns`. Fresh (`resume` false, or no log there): writes
/// the two header lines. Resuming: checks the identity and the column line, hands each complete
/// unit's rows to `each(unit, rows)` — whose error refuses the log — then checks their digests,
/// cuts off a half-written last unit, and returns how many units are done. The errors name the
/// file and the line, and the resume setting by the caller's name for it, `resume_name`.
#[allow(clippy::too_many_arguments)]
pub fn open_lines(
    path: &Path,
    identity: &Identity,
    columns: &str,
    units: &[usize],
    per_unit: usize,
    resume: bool,
    resume_name: &str,
    each: &mut UnitLines<'_>,
) -> Result<(LogWriter, usize)> {
    let io = |what: &str, e| Error::io(format!("{what} {}", path.display()), e);
    let key = identity.plan_hash.clone();
    let columns = column_line(columns);
    if !(resume && path.exists()) {
        let mut file = File::create(path).map_err(|e| io("creating", e))?;
        writeln!(file, "{}\n{columns}", identity.header()).map_err(|e| io("writing", e))?;
        return Ok((
            LogWriter {
                file,
                path: path.to_path_buf(),
                key,
            },
            0,
        ));
    }
    let refuse = |problem: String| -> Error {
        InputError::new(format!(
            "{resume_name}: {}: {problem}; run without {resume_name} to start over",
            path.display()
        ))
        .into()
    };
    let mut reader = BufReader::with_capacity(1 << 16, bounded_open(path)?);
    let mut line = String::new();
    reader.read_line(&mut line).map_err(|e| io("reading", e))?;
    let found = Identity::from_header(&line).ok_or_else(|| refuse("is not a workbench unit log".into()))?;
    if found != *identity {
        return Err(refuse(format!(
            "was written for another run ({}; this run is {})",
            found.describe(),
            identity.describe()
        )));
    }
    let mut kept = line.len() as u64;
    line.clear();
    reader.read_line(&mut line).map_err(|e| io("reading", e))?;
    if line.trim_end() != columns {
        return Err(refuse("its column line is not this version's".into()));
    }
    kept += line.len() as u64;
    let mut done = 0;
    let mut pending: Vec<String> = Vec::with_capacity(per_unit);
    let mut pending_bytes = 0u64;
    loop {
        line.clear();
        let read = reader.read_line(&mut line).map_err(|e| io("reading", e))?;
        if read == 0 || !line.ends_with('\n') {
            break; // the end, or a half-written last row
        }
        let Some(&u) = units.get(done) else {
            return Err(refuse(format!(
                "line {}: more rows than the run has units",
                3 + done * per_unit + pending.len()
            )));
        };
        pending.push(line.trim_end_matches(['\n', '\r']).to_string());
        pending_bytes += read as u64;
        if pending.len() == per_unit {
            let split: Vec<(&str, bool)> = pending.iter().map(|l| split_digest(&key, l)).collect();
            let rows: Vec<&str> = split.iter().map(|(r, _)| *r).collect();
            let line_of = |k: usize| 3 + done * per_unit + k;
            each(u, &rows).map_err(|(k, m)| refuse(format!("line {}: the row {m}", line_of(k))))?;
            if let Some(k) = split.iter().position(|(_, intact)| !intact) {
                return Err(refuse(format!("line {}: the row {CHANGED}", line_of(k))));
            }
            pending.clear();
            kept += pending_bytes;
            pending_bytes = 0;
            done += 1;
        }
    }
    drop(reader);
    let mut file = OpenOptions::new()
        .write(true)
        .open(path)
        .map_err(|e| io("opening", e))?;
    file.set_len(kept).map_err(|e| io("truncating", e))?;
    file.seek(std::io::SeekFrom::End(0))
        .map_err(|e| io("seeking in", e))?;
    Ok((
        LogWriter {
            file,
            path: path.to_path_buf(),
            key,
        },
        done,
    ))
}

/// One row of a log, as [`LogSet::for_each_line`] reads it.
pub struct Line<'a> {
    /// The row without its digest (and newline).
    pub text: &'a str,
    /// The log it is in, and its line number there (1-based; the two header lines first).
    pub path: &'a Path,
    pub number: usize,
    /// The digest the row carries ("" if it has none), and the key it was made under.
    digest: &'a str,
    key: &'a str,
}

impl Line<'_> {
    /// Whether its digest is the row's. Computed when asked, not on every read: a run reads its
    /// own log back once per (integrand, estimator) to write `trials.csv` in cell order, rows it
    /// wrote itself or checked when it resumed, and only a merge's first reading
    /// ([`super::read_rows`]) has rows nobody has checked yet.
    pub fn intact(&self) -> bool {
        !self.digest.is_empty() && self.digest == digest(self.key, self.text)
    }
}

/// The complete logs of every shard of a run (one log for an unsharded run), read in unit
/// order.
pub struct LogSet {
    /// `paths[i]`: the log of shard `i + 1`.
    pub paths: Vec<PathBuf>,
    /// The job's column line (without the digest's), which every log must have.
    pub columns: String,
    /// The digests' key (the plan hash).
    pub key: String,
    /// The caller's name for resuming a run ([`super::SettingNames::resume`]), for messages.
    pub resume: &'static str,
}

impl LogSet {
    /// Calls `f(unit, row, line)` for every row of every unit in unit order (`units` units of
    /// `per_unit` rows, unit `u` in the log of shard `u mod n + 1`). Fails if a log's column
    /// line is not the job's, or it ends early or runs on.
    pub fn for_each_line(
        &self,
        units: usize,
        per_unit: usize,
        f: &mut dyn FnMut(usize, usize, &Line) -> Result<()>,
    ) -> Result<()> {
        let count = self.paths.len();
        let columns = column_line(&self.columns);
        let mut readers = Vec::with_capacity(count);
        for path in &self.paths {
            let mut r = BufReader::with_capacity(1 << 16, bounded_open(path)?);
            let mut head = String::new();
            for _ in 0..2 {
                head.clear();
                r.read_line(&mut head)
                    .map_err(|e| Error::io(format!("reading {}", path.display()), e))?;
            }
            if head.trim_end() != columns {
                return Err(InputError::new(format!(
                    "{}: its column line is not this run's (another version, or not a unit log)",
                    path.display()
                ))
                .into());
            }
            readers.push(r);
        }
        let incomplete = |path: &Path| -> Error {
            InputError::new(format!(
                "{}: ends before its last unit; the run that wrote it did not finish (this shard is \
                 half-written, run it again or resume it with {})",
                path.display(),
                self.resume
            ))
            .into()
        };
        let mut line = String::new();
        for u in 0..units {
            let s = u % count;
            for k in 0..per_unit {
                line.clear();
                let read = readers[s]
                    .read_line(&mut line)
                    .map_err(|e| Error::io(format!("reading {}", self.paths[s].display()), e))?;
                if read == 0 || !line.ends_with('\n') {
                    return Err(incomplete(&self.paths[s]));
                }
                let whole = line.trim_end_matches(['\n', '\r']);
                let (text, digest) = whole.rsplit_once(',').unwrap_or((whole, ""));
                let at = Line {
                    text,
                    path: &self.paths[s],
                    number: 3 + (u / count) * per_unit + k,
                    digest,
                    key: &self.key,
                };
                f(u, k, &at)?;
            }
        }
        for (r, path) in readers.iter_mut().zip(&self.paths) {
            line.clear();
            if r.read_line(&mut line).unwrap_or(0) > 0 {
                return Err(InputError::new(format!(
                    "{}: holds more rows than its share of units",
                    path.display()
                ))
                .into());
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_row_keeps_its_digest_and_an_edit_breaks_it() {
        let row = "cos,MC,mc,uniform,4,0,0.5,0.5,0,,";
        let line = format!("{row},{}", digest("0123456789abcdef", row));
        assert_eq!(split_digest("0123456789abcdef", &line), (row, true));
        // Another plan's key, one changed digit, no digest.
        assert!(!split_digest("0123456789abcdee", &line).1);
        assert!(!split_digest("0123456789abcdef", &line.replacen("0.5", "0.25", 1)).1);
        assert!(!split_digest("0123456789abcdef", row).1);
    }
}
