//! An experiment as a [`Job`]: its units are the (N, trial) pairs, `u = n_index · trials +
//! trial`; a unit's rows are every (integrand, estimator) of the plan in the plan's order, each
//! a `trials.csv` row followed by the cost columns ([`super::rows`]).
//!
//! `run FILE --shard i/n` writes a shard folder: `units.csv` (its unit log), `shard.json` (the
//! experiment as run, and the [`Identity`] the merge checks), `timings.json` and a manifest.
//! `merge` ([`crate::job::merge`]) checks the set, reads every row back checked against the plan
//! ([`super::rows::check_row`]) and writes the run's files with the code a single run uses
//! ([`super::finish`]) — the same bytes as one run of the whole file, the wall-clock
//! `timings*` files and `*-cost.svg` aside.

use super::finish::{self, Findings};
use super::log::rows_per_unit;
use super::plan::{self, Plan};
use super::spec::ExperimentSpec;
use super::summary::{Accumulator, RowValues};
use super::{export, rows};
use crate::error::InputError;
use crate::files::result_folder::ResultFolder;
use crate::job::shard_set::{self, EXPERIMENT, ShardFolder};
use crate::job::{Identity, Job, LogSet, Shard};
use crate::provenance::Build;
use crate::util::report::Reporter;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The log of a run under way, in its results folder; gone once the run's set replaces it.
pub const PARTIAL_LOG: &str = "trials.partial.csv";

/// FNV-1a (64 bits) of the resolved plan's JSON, in hex: what identifies an experiment across
/// shards and resumed runs (not a security measure).
pub fn plan_hash(plan: &Plan) -> String {
    let bytes = serde_json::to_vec(&export::plan_json(plan)).expect("the plan serializes");
    crate::util::hash::fnv1a_hex(bytes)
}

/// What a merge produced.
pub struct MergeReport {
    pub out_dir: PathBuf,
    pub findings: Findings,
    /// Tolerance estimators' cells and checks (empty without tolerance estimators).
    pub stopping: Vec<super::adaptive::Cell>,
    pub tolerance_checks: Vec<super::adaptive::CheckOutcome>,
    pub shards: usize,
    pub wall_seconds: f64,
}

impl Job for Plan {
    const KIND: &'static str = EXPERIMENT;
    const UNIT_NAME: &'static str = "trials×N";
    type Row = RowValues;
    type Gathered = (Accumulator, Instant);
    type Merged = (Plan, MergeReport);

    fn identity(&self, shard: Shard) -> Identity {
        Identity {
            plan_hash: plan_hash(self),
            seed: self.seed,
            units: self.units(),
            build: Build::current(),
            shard,
        }
    }

    fn units(&self) -> usize {
        self.samples.len() * self.trials
    }

    fn rows_per_unit(&self) -> usize {
        rows_per_unit(self)
    }

    fn columns(&self) -> String {
        format!("{},{}", rows::TRIALS_HEADER, rows::COST_HEADER)
    }

    fn parse_row(&self, unit: usize, k: usize, line: &str) -> Result<RowValues, String> {
        let ne = self.estimators.len();
        let (ni, t) = (unit / self.trials, unit % self.trials);
        let (n, trial, values) = rows::check_row(self, k / ne, k % ne, line)?;
        if (n, trial) != (self.samples[ni], t) {
            return Err(format!(
                "is N = {n}, trial {trial}, where N = {}, trial {t} was expected",
                self.samples[ni]
            ));
        }
        Ok(values)
    }

    fn unit_label(&self, unit: usize) -> String {
        format!(
            " (N = {}, trial {})",
            self.samples[unit / self.trials],
            unit % self.trials
        )
    }

    fn from_record(first: &ShardFolder) -> Result<Plan, InputError> {
        let path = first.record();
        let bad = |m: String| InputError::new(format!("merge: {}: \"experiment\": {m}", path.display()));
        let spec: ExperimentSpec =
            serde_json::from_value(first.spec.clone()).map_err(|e| bad(e.to_string()))?;
        let plan = plan::resolve(&spec).map_err(bad)?;
        if plan_hash(&plan) != first.identity.plan_hash {
            return Err(bad("does not resolve to the plan its shards were run from".into()));
        }
        Ok(plan)
    }

    fn gather(&self) -> Self::Gathered {
        (Accumulator::new(self), Instant::now())
    }

    fn push(&self, gathered: &mut Self::Gathered, unit: usize, k: usize, row: RowValues) {
        let ne = self.estimators.len();
        gathered.0.push(k / ne, k % ne, unit / self.trials, &row);
    }

    fn write_merged(
        self,
        out: &Path,
        set: &[ShardFolder],
        logs: &LogSet,
        (summary, start): Self::Gathered,
        _reporter: &dyn Reporter,
    ) -> crate::Result<(Plan, MergeReport)> {
        let plan = self;
        let mut folder = ResultFolder::prepare_merge(
            out,
            set.iter().map(|s| s.dir.as_path()),
            export::legacy_manifest_files,
        )?;
        let findings = finish::write_set(&plan, &mut folder, &summary, logs)?;
        let (stopping, tolerance_checks) = finish::write_stopping(&plan, &mut folder, logs)?;
        let wall_seconds = start.elapsed().as_secs_f64();
        let manifest = finish::manifest(&plan, &findings, &tolerance_checks);
        // The merge's own seconds, not the run's: no plan hash, so `reproduce` does not take
        // them for the run's time.
        folder.commit(manifest, export::timings_json(1, wall_seconds, None))?;
        Ok((
            plan,
            MergeReport {
                out_dir: out.to_path_buf(),
                findings,
                stopping,
                tolerance_checks,
                shards: set.len(),
                wall_seconds,
            },
        ))
    }
}

/// Writes a shard's own files into its folder: its unit log as `units.csv`, and `shard.json`
/// with the experiment as run.
pub fn write_shard(
    spec: &ExperimentSpec,
    identity: &Identity,
    folder: &mut ResultFolder,
    log: &Path,
) -> crate::Result<()> {
    shard_set::write_shard(
        folder,
        identity,
        log,
        "this shard's rows in unit order: the trials.csv columns, then integrand evaluations and wall-clock seconds, and each row's digest",
        serde_json::json!({ "experiment": spec }),
        "which shard this is, of which run, and the experiment as run (for workbench merge)",
    )
}

/// A shard folder's manifest: the plan and the shard (the build is added on commit, as to
/// every manifest).
pub fn shard_manifest(plan: &Plan, identity: &Identity) -> Vec<u8> {
    let v = serde_json::json!({
        "plan": export::plan_json(plan),
        "seed": plan.seed,
        "shard": identity.shard.to_string(),
    });
    serde_json::to_vec_pretty(&v).expect("the manifest serializes")
}

/// Merges experiment shard folders into `out` ([`crate::job::merge`]).
pub fn merge(
    out: &Path,
    dirs: &[PathBuf],
    names: &crate::job::SettingNames,
    reporter: &dyn Reporter,
) -> crate::Result<(Plan, MergeReport)> {
    crate::job::merge::<Plan>(out, dirs, names, reporter)
}
