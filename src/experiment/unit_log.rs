//! The unit log: the rows of every finished (N, trial) unit, in unit order, appended as the
//! run goes (`trials.partial.csv` in the results folder while a run is under way, `units.csv`
//! in a shard's folder).
//!
//! A unit's rows are every (integrand, estimator) of the plan in the plan's order, each a
//! `trials.csv` row followed by the cost columns ([`super::rows`]). Units are numbered
//! `u = n_index · trials + trial`; a run does units in increasing order, in batches, and appends a
//! batch only once all of it is done, so the log always holds a prefix of the run's units (a
//! killed run at most leaves a half-written last unit, which is cut off on resuming). The first
//! line names what the log was made from ([`Identity`]), so that a log is only ever continued,
//! or merged, with its own kind.

use super::plan::Plan;
use super::rows::{COST_HEADER, TRIALS_HEADER};
use super::summary::RowValues;
use crate::error::{Error, InputError, Result};
use crate::files::read::FileKind;
use crate::provenance::Build;
use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Seek, Write};
use std::path::{Path, PathBuf};

/// The log of a run under way, in its results folder; gone once the run's set replaces it.
pub const PARTIAL_LOG: &str = "trials.partial.csv";
/// A shard's units, in its folder, for `workbench merge`.
pub const SHARD_UNITS: &str = "units.csv";

/// A deterministic share of a run's units, `index` of `count`, 1-based like cargo-nextest's
/// `--partition count:i/n`: unit `u` belongs to shard `(u mod count) + 1`. Consecutive units
/// go to different shards, so every shard gets its share of every N (and of the costly ones).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    /// All units.
    pub const WHOLE: Shard = Shard { index: 1, count: 1 };

    /// Reads `i/n` with `1 ≤ i ≤ n`; the error says what is wrong.
    pub fn parse(text: &str) -> std::result::Result<Shard, String> {
        let wrong = || format!("expected i/n with 1 <= i <= n (e.g. 1/4), got {text:?}");
        let (i, n) = text.split_once('/').ok_or_else(wrong)?;
        let (index, count): (usize, usize) = (
            i.trim().parse().map_err(|_| wrong())?,
            n.trim().parse().map_err(|_| wrong())?,
        );
        if count == 0 {
            return Err(format!("{text:?}: the number of shards must be at least 1"));
        }
        if index == 0 || index > count {
            return Err(format!("{text:?}: shards are numbered 1 to {count}"));
        }
        Ok(Shard { index, count })
    }

    /// The units of this shard among `total`, in increasing order.
    pub fn units(self, total: usize) -> impl Iterator<Item = usize> {
        (self.index - 1..total).step_by(self.count)
    }

    /// How many of `total` units this shard holds.
    pub fn len(self, total: usize) -> usize {
        total.saturating_sub(self.index - 1).div_ceil(self.count)
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// What a log was made from: the resolved plan (as a hash of its JSON, which holds the seed and
/// the number of trials), the tool's build (version, commit and uncommitted changes: rows of
/// two builds are never combined), and the share of units.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Identity {
    pub plan_hash: String,
    pub seed: u64,
    pub trials: usize,
    pub build: Build,
    pub shard: Shard,
}

impl Identity {
    pub fn new(plan: &Plan, shard: Shard) -> Identity {
        Identity {
            plan_hash: plan_hash(plan),
            seed: plan.seed,
            trials: plan.trials,
            build: Build::current(),
            shard,
        }
    }

    /// The log's first line.
    pub fn header(&self) -> String {
        format!(
            "# workbench unit log: plan={} seed={} trials={} version={} build={} shard={}",
            self.plan_hash,
            self.seed,
            self.trials,
            self.build.version,
            self.build.token(),
            self.shard
        )
    }

    /// Reads a first line written by [`Identity::header`].
    pub fn from_header(line: &str) -> Option<Identity> {
        let rest = line.trim_end().strip_prefix("# workbench unit log: ")?;
        let mut fields = rest.split(' ').map(|f| f.split_once('='));
        let mut next = |key: &str| match fields.next() {
            Some(Some((k, v))) if k == key => Some(v.to_string()),
            _ => None,
        };
        let plan_hash = next("plan")?;
        let seed = next("seed")?.parse().ok()?;
        let trials = next("trials")?.parse().ok()?;
        let version = next("version")?;
        let build = Build::from_token(&version, &next("build")?)?;
        Some(Identity {
            plan_hash,
            seed,
            trials,
            build,
            shard: Shard::parse(&next("shard")?).ok()?,
        })
    }
}

/// FNV-1a (64 bits) of the resolved plan's JSON, in hex: what identifies an experiment across
/// shards and resumed runs (not a security measure).
pub fn plan_hash(plan: &Plan) -> String {
    let bytes = serde_json::to_vec(&super::export::plan_json(plan)).expect("the plan serializes");
    crate::util::hash::fnv1a_hex(bytes)
}

/// The column line after the identity.
fn columns() -> String {
    format!("{TRIALS_HEADER},{COST_HEADER}")
}

/// Rows per unit: one per (integrand, estimator).
pub fn rows_per_unit(plan: &Plan) -> usize {
    plan.integrands.len() * plan.estimators.len()
}

/// A log being appended to.
pub struct LogWriter {
    file: File,
    path: PathBuf,
}

impl LogWriter {
    /// Appends whole units' rows (one batch) and hands them to the system, so that a killed
    /// process keeps them.
    pub fn append(&mut self, rows: &str) -> Result<()> {
        self.file
            .write_all(rows.as_bytes())
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

/// Opens the log at `path` for a run of `identity`'s units. Fresh (`resume` false, or no log
/// there): writes its two header lines. Resuming: checks that the log was made from the same
/// plan, seed, trials, build and shard, hands every row of its complete units to `each`
/// (`unit, integrand, estimator, n_index, values`), cuts off a half-written last unit, and
/// returns how many units are done.
pub fn open(
    path: &Path,
    plan: &Plan,
    identity: &Identity,
    resume: bool,
    each: &mut dyn FnMut(usize, usize, usize, usize, &RowValues),
) -> Result<(LogWriter, usize)> {
    let units: Vec<usize> = identity.shard.units(plan.samples.len() * plan.trials).collect();
    let ne = plan.estimators.len();
    let mut rows: Vec<(usize, usize, RowValues)> = Vec::with_capacity(rows_per_unit(plan));
    open_lines(
        path,
        identity,
        &columns(),
        &units,
        rows_per_unit(plan),
        resume,
        &mut |u, lines| {
            let (ni, t) = (u / plan.trials, u % plan.trials);
            rows.clear();
            for (k, line) in lines.iter().enumerate() {
                let (n, trial, values) = super::rows::check_row(plan, k / ne, k % ne, line)
                    .map_err(|m| format!("row {} {m}", k + 1))?;
                if (n, trial) != (plan.samples[ni], t) {
                    return Err(format!(
                        "row {} is N = {n}, trial {trial}, where N = {}, trial {t} was expected",
                        k + 1,
                        plan.samples[ni]
                    ));
                }
                rows.push((k / ne, k % ne, values));
            }
            for (fi, ei, v) in &rows {
                each(u, *fi, *ei, ni, v);
            }
            Ok(())
        },
    )
}

/// What [`open_lines`] hands each complete unit's lines to: `(unit, lines)`, an error naming
/// what is wrong with a row.
pub type UnitLines<'a> = dyn FnMut(usize, &[&str]) -> std::result::Result<(), String> + 'a;

/// [`open`] for any kind of job whose log rows are lines checked by the job: the log at `path`
/// of a run of `identity`'s units `units` (in order), `per_unit` lines each, under the column
/// line `columns`. Fresh (`resume` false, or no log there): writes the two header lines.
/// Resuming: checks the identity and the column line, hands each complete unit's lines (without
/// their newlines) to `each(unit, lines)` — whose error, naming what is wrong with a row, refuses
/// the log —, cuts off a half-written last unit, and returns how many units are done.
pub fn open_lines(
    path: &Path,
    identity: &Identity,
    columns: &str,
    units: &[usize],
    per_unit: usize,
    resume: bool,
    each: &mut UnitLines<'_>,
) -> Result<(LogWriter, usize)> {
    let io = |what: &str, e| Error::io(format!("{what} {}", path.display()), e);
    if !(resume && path.exists()) {
        let mut file = File::create(path).map_err(|e| io("creating", e))?;
        writeln!(file, "{}\n{columns}", identity.header()).map_err(|e| io("writing", e))?;
        return Ok((
            LogWriter {
                file,
                path: path.to_path_buf(),
            },
            0,
        ));
    }
    let refuse = |problem: String| -> Error {
        InputError::new(format!(
            "--resume: {}: {problem}; run without --resume to start over",
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
            describe(&found),
            describe(identity)
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
            let lines: Vec<&str> = pending.iter().map(String::as_str).collect();
            each(u, &lines).map_err(|m| {
                refuse(format!(
                    "unit {u} (lines {} to {}): {m}",
                    3 + done * per_unit,
                    2 + (done + 1) * per_unit
                ))
            })?;
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
        },
        done,
    ))
}

fn describe(id: &Identity) -> String {
    format!(
        "plan {}, seed {}, {} trials, workbench {}, shard {}",
        id.plan_hash,
        id.seed,
        id.trials,
        id.build.describe(),
        id.shard
    )
}

/// The complete logs of every shard of a run (one log for an unsharded run), read in unit
/// order.
pub struct LogSet {
    /// `paths[i]`: the log of shard `i + 1`.
    pub paths: Vec<PathBuf>,
}

impl LogSet {
    /// Calls `f(unit, integrand, estimator, line)` for every row of every unit in unit order,
    /// the line without its newline. Fails if a log ends early or runs on.
    pub fn for_each_row(
        &self,
        plan: &Plan,
        f: &mut dyn FnMut(usize, usize, usize, &str) -> Result<()>,
    ) -> Result<()> {
        let ne = plan.estimators.len();
        self.for_each_line(
            plan.samples.len() * plan.trials,
            rows_per_unit(plan),
            &mut |u, k, line| f(u, k / ne, k % ne, line),
        )
    }

    /// Calls `f(unit, row, line)` for every row of every unit in unit order (`units` units of
    /// `per_unit` rows, unit `u` in the log of shard `u mod n + 1`), the line without its
    /// newline. Fails if a log ends early or runs on.
    pub fn for_each_line(
        &self,
        units: usize,
        per_unit: usize,
        f: &mut dyn FnMut(usize, usize, &str) -> Result<()>,
    ) -> Result<()> {
        let count = self.paths.len();
        let mut readers = Vec::with_capacity(count);
        for path in &self.paths {
            let mut r = BufReader::with_capacity(1 << 16, bounded_open(path)?);
            let mut skip = String::new();
            for _ in 0..2 {
                r.read_line(&mut skip)
                    .map_err(|e| Error::io(format!("reading {}", path.display()), e))?;
            }
            readers.push(r);
        }
        let incomplete = |path: &Path, problem: &str| -> Error {
            InputError::new(format!(
                "{}: {problem}; the run that wrote it did not finish (resume it with --resume)",
                path.display()
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
                    return Err(incomplete(&self.paths[s], "ends before its last unit"));
                }
                f(u, k, line.trim_end_matches(['\n', '\r']))?;
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
    fn shards_parse_and_partition_the_units() {
        assert_eq!(Shard::parse("2/3"), Ok(Shard { index: 2, count: 3 }));
        for bad in ["0/3", "4/3", "1/0", "3", "a/b", "-1/3", ""] {
            assert!(Shard::parse(bad).is_err(), "{bad}");
        }
        for count in 1..5 {
            let mut seen = vec![0; 10];
            for index in 1..=count {
                let s = Shard { index, count };
                let units: Vec<usize> = s.units(10).collect();
                assert_eq!(units.len(), s.len(10));
                for u in units {
                    seen[u] += 1;
                }
            }
            assert!(seen.iter().all(|&c| c == 1), "{count}: {seen:?}");
        }
        assert_eq!(Shard { index: 3, count: 4 }.len(2), 0);
    }

    #[test]
    fn identity_reads_back_from_its_header() {
        let id = Identity {
            plan_hash: "0123456789abcdef".into(),
            seed: 42,
            trials: 300,
            build: Build {
                version: "0.1.0".into(),
                commit: Some("d9ea8fe".into()),
                changes: Some("0123456789abcdef".into()),
            },
            shard: Shard { index: 2, count: 5 },
        };
        assert_eq!(Identity::from_header(&id.header()), Some(id.clone()));
        assert_eq!(
            Identity::from_header(&format!("{}\n", id.header())),
            Some(id.clone())
        );
        assert_eq!(Identity::from_header("integrand,estimator"), None);
        // Outside git, and clean.
        for (commit, changes) in [(None, None), (Some("d9ea8fe".to_string()), None)] {
            let other = Identity {
                build: Build {
                    commit,
                    changes,
                    ..id.build.clone()
                },
                ..id.clone()
            };
            assert_eq!(Identity::from_header(&other.header()), Some(other));
        }
    }
}
