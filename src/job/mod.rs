//! What the three jobs — experiments (`experiment/`), render tables (`table/`) and the
//! irradiance protocol (`irradiance/`) — share: a run is a
//! list of **units** done in order, each a fixed number of rows appended to a unit log
//! ([`unit_log`]) as it finishes; a run may be a [`Shard`] of the units, and `merge` turns the
//! shards' logs into the files one run writes ([`shard_set`], [`merge`]).
//!
//! A job says what its units and rows are ([`Job`]); `--resume` ([`open_log`]), the merge's
//! reading of every row ([`read_rows`]) and the merge itself are written here once. Every row
//! read back is checked by the job as it was written ([`Job::parse_row`]: finite, in range,
//! the values that are functions of the plan recomputed) and then against its digest. This
//! room imports no job.

pub mod shard;
pub mod shard_set;
pub mod unit_log;

pub use shard::{Identity, Shard};
pub use shard_set::ShardFolder;
pub use unit_log::{LogSet, LogWriter};

use crate::error::{Error, InputError};
use crate::util::report::Reporter;
use std::path::{Path, PathBuf};

/// How messages name a job's settings: the caller's names for them — the CLI's flags
/// (`--out`, `--resume`), a library caller's field names ([`SettingNames::FIELDS`], which the
/// Python bindings' arguments share). The library itself names no flag.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SettingNames {
    /// The output folder.
    pub out: &'static str,
    /// The trials override of an experiment.
    pub trials: &'static str,
    /// The share of the units run (`i/n`).
    pub shard: &'static str,
    /// Continuing an interrupted run from its unit log.
    pub resume: &'static str,
    /// The folder of a render table's outputs and reference cache.
    pub results_dir: &'static str,
}

impl SettingNames {
    /// The settings' field names.
    pub const FIELDS: SettingNames = SettingNames {
        out: "out",
        trials: "trials",
        shard: "shard",
        resume: "resume",
        results_dir: "results_dir",
    };
}

impl Default for SettingNames {
    fn default() -> Self {
        SettingNames::FIELDS
    }
}

/// A kind of job, as the shared machinery sees it: its resolved plan.
pub trait Job: Sized {
    /// `shard.json`'s `"kind"`.
    const KIND: &'static str;
    /// What the progress bar counts while a merge reads the units.
    const UNIT_NAME: &'static str;
    /// One row of the log, parsed.
    type Row;
    /// What a merge gathers the rows into, in unit order.
    type Gathered;
    /// What a merge returns.
    type Merged;

    /// What this plan's logs and shard records say they are, for `shard`.
    fn identity(&self, shard: Shard) -> Identity;
    /// The run's units (of every shard).
    fn units(&self) -> usize;
    /// Rows per unit.
    fn rows_per_unit(&self) -> usize;
    /// The log's column line (the digest's column is added to it).
    fn columns(&self) -> String;
    /// Reads row `k` of unit `unit` as it was written, checking every value: finite, in range,
    /// and those that are functions of the plan (truths, seeds, exact values) recomputed or
    /// compared bit for bit. The error says what is wrong (after "the row ").
    fn parse_row(&self, unit: usize, k: usize, line: &str) -> Result<Self::Row, String>;
    /// How messages name unit `unit` after its line number (e.g. ` (N = 4, trial 2)`).
    fn unit_label(&self, _unit: usize) -> String {
        String::new()
    }

    /// Refuses shards that differ in what the plan hash would only call "another plan", before
    /// their set is checked (a render table names its maps and scenes).
    fn check_records(_set: &[ShardFolder]) -> Result<(), InputError> {
        Ok(())
    }
    /// The plan the shards ran, rebuilt from the first shard's record and checked against its
    /// plan hash.
    fn from_record(first: &ShardFolder) -> Result<Self, InputError>;
    /// An empty gathering.
    fn gather(&self) -> Self::Gathered;
    /// Adds row `k` of unit `unit` (called in unit order).
    fn push(&self, gathered: &mut Self::Gathered, unit: usize, k: usize, row: Self::Row);
    /// Writes the merged run into `out` (every row of `logs` read and checked already): the
    /// files one run writes, with the code one run uses.
    fn write_merged(
        self,
        out: &Path,
        set: &[ShardFolder],
        logs: &LogSet,
        gathered: Self::Gathered,
        reporter: &dyn Reporter,
    ) -> crate::Result<Self::Merged>;
}

/// The logs of `paths` (of shards 1…n in order) of `job`.
pub fn log_set<J: Job>(job: &J, paths: Vec<PathBuf>, names: &SettingNames) -> LogSet {
    LogSet {
        paths,
        columns: job.columns(),
        key: job.identity(Shard::WHOLE).plan_hash,
        resume: names.resume,
    }
}

/// Opens the unit log at `path` of `shard` of `job` ([`unit_log::open_lines`]): fresh, or with
/// `resume` (and a log there) checked to be this run's, every row of its complete units read
/// ([`Job::parse_row`], then its digest) and handed to `each(unit, k, row)`, a half-written last
/// unit cut off. Returns the writer and how many units are done.
pub fn open_log<J: Job>(
    job: &J,
    path: &Path,
    shard: Shard,
    resume: bool,
    names: &SettingNames,
    each: &mut dyn FnMut(usize, usize, J::Row),
) -> crate::Result<(LogWriter, usize)> {
    let units: Vec<usize> = shard.units(job.units()).collect();
    let mut rows = Vec::with_capacity(job.rows_per_unit());
    unit_log::open_lines(
        path,
        &job.identity(shard),
        &job.columns(),
        &units,
        job.rows_per_unit(),
        resume,
        names.resume,
        &mut |u, lines| {
            rows.clear();
            for (k, line) in lines.iter().enumerate() {
                rows.push(job.parse_row(u, k, line).map_err(|m| (k, m))?);
            }
            for (k, row) in rows.drain(..).enumerate() {
                each(u, k, row);
            }
            Ok(())
        },
    )
}

/// Reads every row of `logs` in unit order for a merge, each checked as it was written
/// ([`Job::parse_row`], then its digest), and hands it to `each(unit, k, row)`. A bad row is
/// refused by file and line.
pub fn read_rows<J: Job>(
    job: &J,
    logs: &LogSet,
    each: &mut dyn FnMut(usize, usize, J::Row) -> crate::Result<()>,
) -> crate::Result<()> {
    logs.for_each_line(job.units(), job.rows_per_unit(), &mut |u, k, line| {
        let wrong = |m: &str| -> Error {
            InputError::new(format!(
                "merge: {}: line {}{}: the row {m}; this shard is damaged, run it again",
                line.path.display(),
                line.number,
                job.unit_label(u)
            ))
            .into()
        };
        let row = job.parse_row(u, k, line.text).map_err(|m| wrong(&m))?;
        if !line.intact() {
            return Err(wrong(unit_log::CHANGED));
        }
        each(u, k, row)
    })
}

/// `workbench merge OUT DIR…` for shards of `J`: the set read and checked ([`shard_set`]), the
/// plan rebuilt ([`Job::from_record`]), every row read and checked ([`read_rows`]) before the
/// job writes anything ([`Job::write_merged`]).
pub fn merge<J: Job>(
    out: &Path,
    dirs: &[PathBuf],
    names: &SettingNames,
    reporter: &dyn Reporter,
) -> crate::Result<J::Merged> {
    let set = shard_set::read_shards(dirs, names)?;
    J::check_records(&set)?;
    let set = shard_set::check_set(set)?;
    // The merged manifest records one build, the one writing it: that must be the build whose
    // rows it holds (its summaries and plots are computed again here).
    shard_set::check_build(&set)?;
    let job = J::from_record(&set[0])?;
    let logs = log_set(&job, set.iter().map(ShardFolder::units).collect(), names);
    let mut gathered = job.gather();
    let per_unit = job.rows_per_unit();
    reporter.start(J::UNIT_NAME, job.units() as u64);
    read_rows(&job, &logs, &mut |u, k, row| {
        job.push(&mut gathered, u, k, row);
        if k + 1 == per_unit {
            reporter.advance(1);
        }
        Ok(())
    })?;
    reporter.finish();
    job.write_merged(out, &set, &logs, gathered, reporter)
}
