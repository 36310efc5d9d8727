//! `workbench run` and `workbench validate`: declarative experiments.
//!
//! spec (JSON) → [`plan::Plan`] (validated) → [`drive`] (batches of units in parallel,
//! [`runner`]) → the unit log ([`crate::job::unit_log`]) and the [`summary`] → [`finish`]
//! ([`export`] / [`plot`], pure) → one atomic swap of the results folder. A run may be a shard
//! of the units ([`crate::job::Shard`]), whose logs `merge` turns into the same files ([`job`]:
//! the experiment as a [`crate::job::Job`]).

pub mod adaptive;
pub mod adaptive_plot;
pub mod adaptive_unit;
pub mod cost_plot;
pub mod coverage_plot;
pub mod drive;
pub mod export;
pub mod finish;
pub mod fit;
pub mod job;
pub mod log;
pub mod plan;
pub mod plot;
pub mod rows;
pub mod runner;
pub mod spec;
pub mod summary;
pub mod sweep;
pub mod text;
pub mod tolerance;

pub use text::{describe, format_report};

use crate::error::InputError;
use crate::files::result_folder::ResultFolder;
use crate::job::{Job, Shard};
use crate::util::report::Reporter;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Command-line overrides of the experiment file.
#[derive(Debug, Clone, Default)]
pub struct Overrides {
    pub out: Option<PathBuf>,
    pub trials: Option<u64>,
    pub threads: Option<usize>,
    /// The experiment file itself, so that the outputs can never replace it (`run
    /// D/manifest.json --out D`).
    pub spec: Option<PathBuf>,
    /// Run only this share of the units, into a shard folder for `merge` (`--shard i/n`).
    pub shard: Option<Shard>,
    /// Continue the run the folder's unit log holds, without redoing its units (`--resume`).
    pub resume: bool,
    /// How messages name these settings (the CLI: its flags; by default the field names).
    pub names: crate::job::SettingNames,
}

/// Reads, applies overrides, validates. Errors are [`InputError`]s naming the file.
pub fn load_plan(path: &Path, overrides: &Overrides) -> Result<plan::Plan, InputError> {
    load(path, overrides).map(|(_, plan)| plan)
}

/// [`load_plan`], also returning the spec with the overrides applied (what a shard records).
pub fn load(path: &Path, overrides: &Overrides) -> Result<(spec::ExperimentSpec, plan::Plan), InputError> {
    let file = path.display().to_string();
    let text = crate::files::spec_json::read_spec(path)?;
    let mut spec = plan::parse(&text).map_err(|m| InputError::new(format!("{file}: {m}")))?;
    if let Some(t) = overrides.trials {
        if t == 0 {
            return Err(InputError::new(format!(
                "{}: must be at least 1, got 0",
                overrides.names.trials
            )));
        }
        if t < 2 && spec.checks.iter().any(|c| c.calibrated.is_none()) {
            return Err(InputError::new(format!(
                "{} {t}: the file's checks need at least 2 trials for their paired test",
                overrides.names.trials
            )));
        }
        spec.trials = t;
    }
    if let Some(t) = overrides.threads {
        crate::util::threads::check_threads(t, "threads")?;
    }
    let plan = plan::resolve(&spec).map_err(|m| InputError::new(format!("{file}: {m}")))?;
    Ok((spec, plan))
}

/// What a run produced, for the caller to report.
pub struct RunReport {
    pub out_dir: PathBuf,
    /// Empty for a shard (its summary comes with the merge).
    pub cells: Vec<summary::CellSummary>,
    pub checks: Vec<summary::CheckOutcome>,
    pub calibration: Vec<summary::CalibrationOutcome>,
    /// Tolerance estimators' cells and checks (empty without tolerance estimators).
    pub stopping: Vec<adaptive::Cell>,
    pub tolerance_checks: Vec<adaptive::CheckOutcome>,
    pub wall_seconds: f64,
    pub threads: usize,
    /// Weight sets' numerical warnings of the units run now (not of resumed ones).
    pub warnings: Vec<(String, usize)>,
    pub shard: Shard,
    /// Units found done in the unit log (`--resume`), and units in the run (or shard).
    pub resumed: usize,
    /// Warnings in the trial rows of the resumed units (the `warnings` column; their messages
    /// were printed by the interrupted run and are not kept).
    pub resumed_row_warnings: u64,
    pub units: usize,
}

/// Runs a validated plan and writes every output under the output folder.
///
/// The folder holds one run: its files are built in a staging folder beside it and replace the
/// old folder as a whole once all are written ([`ResultFolder`]), so a run that fails (a full
/// disk) or is killed leaves the earlier results as they were, and a run never leaves another
/// run's files beside its own — apart from the unit log, `trials.partial.csv`, which keeps the
/// finished units of an interrupted run for `--resume`. Everything that can be refused is
/// refused before the trials.
pub fn run_plan(
    plan: &plan::Plan,
    overrides: &Overrides,
    reporter: &dyn Reporter,
) -> crate::Result<RunReport> {
    let shard = overrides.shard.unwrap_or(Shard::WHOLE);
    let out_dir = overrides.out.clone().unwrap_or_else(|| {
        let name = if overrides.shard.is_some() {
            format!("{}-shard-{}-of-{}", plan.name, shard.index, shard.count)
        } else {
            plan.name.clone()
        };
        Path::new("results").join(name)
    });
    let what = match &overrides.out {
        Some(out) => format!("{} {}", overrides.names.out, out.display()),
        None => out_dir.display().to_string(),
    };
    // A shard records the experiment as run, for the merge to rebuild the plan from.
    let shard_spec = match (&overrides.shard, &overrides.spec) {
        (Some(_), Some(path)) => Some(load(path, overrides)?.0),
        (Some(_), None) => {
            return Err(
                InputError::new(format!("{}: needs the experiment file", overrides.names.shard)).into(),
            );
        }
        _ => None,
    };
    // Every worker thread holds its weight sets at once: refused before anything is written.
    plan::check_memory(plan, crate::util::threads::worker_threads(overrides.threads))?;
    let inputs: Vec<(&str, &Path)> = overrides
        .spec
        .iter()
        .map(|p| ("the experiment file", p.as_path()))
        .collect();
    let mut folder = ResultFolder::prepare(
        &out_dir,
        &what,
        &format!("use another {}", overrides.names.out),
        &inputs,
        export::legacy_manifest_files,
    )?;

    let pool = crate::util::threads::pool(overrides.threads)?;
    let threads = pool.current_num_threads();
    let identity = plan.identity(shard);
    let mut summary = overrides.shard.is_none().then(|| summary::Accumulator::new(plan));
    let log_path = folder.partial_path(job::PARTIAL_LOG)?;
    let mut resumed_row_warnings = 0u64;
    let ne = plan.estimators.len();
    let (mut log, resumed) = crate::job::open_log(
        plan,
        &log_path,
        shard,
        overrides.resume,
        &overrides.names,
        &mut |u, k, v| {
            resumed_row_warnings += u64::from(v.warnings);
            if let Some(s) = summary.as_mut() {
                s.push(k / ne, k % ne, u / plan.trials, &v);
            }
        },
    )?;
    let units = shard.len(plan.samples.len() * plan.trials);
    reporter.start("trials×N", units as u64);
    reporter.advance(resumed as u64);
    let start = Instant::now();
    let outcome = drive::run_units(plan, &pool, shard, resumed, &mut log, summary.as_mut(), &|| {
        reporter.advance(1)
    });
    let warnings = match outcome {
        // A failing integrand (a Python callable) fails the same way on a resume: nothing of the
        // run is kept, the unit log included.
        Err(e @ crate::Error::Integrand(_)) => {
            drop(log);
            folder.discard_partial(job::PARTIAL_LOG);
            return Err(e);
        }
        other => other?,
    };
    reporter.finish();
    drop(log);
    let wall_seconds = start.elapsed().as_secs_f64();

    let (findings, stopping, tolerance_checks, manifest) = match (summary, shard_spec) {
        (Some(summary), _) => {
            let logs = crate::job::log_set(plan, vec![log_path], &overrides.names);
            let findings = finish::write_set(plan, &mut folder, &summary, &logs)?;
            // Tolerance estimators' stopping outputs, from the same log.
            let (stopping, checks) = finish::write_stopping(plan, &mut folder, &logs)?;
            let manifest = finish::manifest(plan, &findings, &checks);
            (Some(findings), stopping, checks, manifest)
        }
        (None, Some(spec)) => {
            job::write_shard(&spec, &identity, &mut folder, &log_path)?;
            let manifest = job::shard_manifest(plan, &identity);
            let manifest = serde_json::from_slice(&manifest).expect("the manifest is JSON");
            (None, Vec::new(), Vec::new(), manifest)
        }
        (None, None) => unreachable!("a shard has its spec"),
    };
    // The whole plan's time only: a shard's or a resumed remainder's would understate it.
    let whole = (overrides.shard.is_none() && !overrides.resume).then(|| job::plan_hash(plan));
    folder.commit(manifest, export::timings_json(threads, wall_seconds, whole))?;
    let findings = findings.unwrap_or(finish::Findings {
        cells: Vec::new(),
        checks: Vec::new(),
        calibration: Vec::new(),
    });
    Ok(RunReport {
        out_dir,
        cells: findings.cells,
        checks: findings.checks,
        calibration: findings.calibration,
        stopping,
        tolerance_checks,
        wall_seconds,
        threads,
        warnings,
        shard,
        resumed,
        resumed_row_warnings,
        units,
    })
}
