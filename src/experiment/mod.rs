//! `workbench run` and `workbench validate`: declarative experiments.
//!
//! spec (JSON) → [`plan::Plan`] (validated) → [`runner::run`] (parallel) → [`summary`] →
//! [`export`] / [`plot`] (pure) → one atomic write per file.

pub mod adaptive;
pub mod adaptive_plot;
pub mod adaptive_unit;
pub mod coverage_plot;
pub mod export;
pub mod fit;
pub mod plan;
pub mod plot;
pub mod runner;
pub mod spec;
pub mod summary;
pub mod sweep;
pub mod text;
pub mod tolerance;

pub use text::{describe, format_report};

use crate::error::InputError;
use crate::output_set::ResultFolder;
use crate::report::Reporter;
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
}

/// Reads, applies overrides, validates. Errors are [`InputError`]s naming the file.
pub fn load_plan(path: &Path, overrides: &Overrides) -> Result<plan::Plan, InputError> {
    let file = path.display().to_string();
    let text = crate::json::read_spec(path)?;
    let mut spec = plan::parse(&text).map_err(|m| InputError::new(format!("{file}: {m}")))?;
    if let Some(t) = overrides.trials {
        if t == 0 {
            return Err(InputError::new("--trials: must be at least 1, got 0"));
        }
        if t < 2 && spec.checks.iter().any(|c| c.calibrated.is_none()) {
            return Err(InputError::new(format!(
                "--trials {t}: the file's checks need at least 2 trials for their paired test"
            )));
        }
        spec.trials = t;
    }
    if let Some(t) = overrides.threads {
        crate::threads::check_threads(t)?;
    }
    plan::resolve(&spec).map_err(|m| InputError::new(format!("{file}: {m}")))
}

/// What a run produced, for the caller to report.
pub struct RunReport {
    pub out_dir: PathBuf,
    pub cells: Vec<summary::CellSummary>,
    pub checks: Vec<summary::CheckOutcome>,
    pub calibration: Vec<summary::CalibrationOutcome>,
    /// Tolerance estimators' cells and checks (empty without tolerance estimators).
    pub stopping: Vec<adaptive::Cell>,
    pub tolerance_checks: Vec<adaptive::CheckOutcome>,
    pub wall_seconds: f64,
    pub threads: usize,
    pub warnings: Vec<(String, usize)>,
}

/// Runs a validated plan and writes every output under the output folder.
///
/// The folder holds one run: its files are built in a staging folder beside it and replace the
/// old folder as a whole once all are written ([`ResultFolder`]), so a run that fails (a full
/// disk) or is killed leaves the earlier results as they were, and a run never leaves another
/// run's files beside its own. Everything that can be refused is refused before the trials.
pub fn run_plan(
    plan: &plan::Plan,
    overrides: &Overrides,
    reporter: &dyn Reporter,
) -> crate::Result<RunReport> {
    let out_dir = overrides
        .out
        .clone()
        .unwrap_or_else(|| Path::new("results").join(&plan.name));
    let what = match &overrides.out {
        Some(out) => format!("--out {}", out.display()),
        None => out_dir.display().to_string(),
    };
    let inputs: Vec<(&str, &Path)> = overrides
        .spec
        .iter()
        .map(|p| ("the experiment file", p.as_path()))
        .collect();
    let mut folder = ResultFolder::prepare(&out_dir, &what, "use another --out", &inputs)?;

    let pool = crate::threads::pool(overrides.threads)?;
    let threads = pool.current_num_threads();
    let units = (plan.samples.len() * plan.trials) as u64;
    reporter.start("trials×N", units);
    let start = Instant::now();
    let results = pool.install(|| runner::run(plan, &|| reporter.advance(1)))?;
    reporter.finish();
    let wall_seconds = start.elapsed().as_secs_f64();

    let cells = summary::summarize(plan, &results);
    let checks: Vec<_> = plan
        .checks
        .iter()
        .map(|c| summary::evaluate_check(plan, &results, c))
        .collect();
    let calibration: Vec<_> = plan
        .calibration_checks
        .iter()
        .map(|c| summary::evaluate_calibration(plan, &results, c))
        .collect();
    let stopping = adaptive::summarize(plan, &results);
    let tolerance_checks: Vec<_> = plan
        .tolerance_checks
        .iter()
        .map(|c| adaptive::evaluate_check(plan, &stopping, c))
        .collect();

    folder.write(
        "trials.csv",
        "one row per (integrand, estimator, n, trial)",
        &export::trials_csv(plan, &results),
    )?;
    folder.write(
        "summary.csv",
        "one row per (integrand, estimator, n)",
        &export::summary_csv(plan, &cells),
    )?;
    folder.write(
        "fits.csv",
        "one row per (integrand, estimator): log-log slope of the mean error over n >= fit_from_n, with its 95% interval",
        &export::fits_csv(plan, &cells),
    )?;
    // With only tolerance estimators every cell sits at its first stage, so error and coverage
    // against N say nothing; `<integrand>-tolerance.svg` replaces them.
    let only_tolerance = plan.estimators.iter().all(|e| e.tolerance.is_some());
    for (fi, f) in plan.integrands.iter().enumerate().filter(|_| !only_tolerance) {
        let svg = plot::error_plot_svg(plan, &cells, fi)?;
        folder.write(
            &format!("{}.svg", f.name()),
            &format!("absolute error against n for {}, every estimator", f.name()),
            svg.as_bytes(),
        )?;
        if cells.iter().any(|c| c.integrand == fi && c.coverage.is_some()) {
            let svg = coverage_plot::coverage_plot_svg(plan, &cells, fi)?;
            folder.write(
                &format!("{}-coverage.svg", f.name()),
                &format!(
                    "95% coverage against n for {}, every estimator with an interval, with the binomial 99% band",
                    f.name()
                ),
                svg.as_bytes(),
            )?;
        }
    }
    if !stopping.is_empty() {
        folder.write(
            "stopping_trials.csv",
            "one row per (integrand, tolerance estimator, first n, trial): n used, 95% half-width, stopped by the rule, within the tolerance",
            &adaptive::trials_csv(plan, &results),
        )?;
        folder.write(
            "stopping_summary.csv",
            "one row per (integrand, tolerance estimator, first n): mean n used, share stopped by the rule, share within the tolerance",
            &adaptive::summary_csv(plan, &stopping),
        )?;
        for (fi, f) in plan.integrands.iter().enumerate() {
            if let Some(svg) = adaptive_plot::tolerance_plot_svg(plan, &stopping, fi)? {
                folder.write(
                    &format!("{}-tolerance.svg", f.name()),
                    &format!(
                        "mean n used and share within the tolerance against the tolerance for {}, every tolerance estimator",
                        f.name()
                    ),
                    svg.as_bytes(),
                )?;
            }
        }
    }
    folder.write(
        "timings.json",
        "wall-clock seconds and threads of the run (machine-dependent; not committed)",
        &export::timings_json(threads, wall_seconds),
    )?;
    let mut manifest: serde_json::Value =
        serde_json::from_slice(&export::manifest_json(plan, &checks, &calibration))
            .expect("the manifest is JSON");
    if !plan.tolerance_checks.is_empty() {
        manifest["plan"]["tolerance_checks"] = serde_json::json!(plan.tolerance_checks);
        manifest["tolerance_checks"] = adaptive::checks_json(plan, &tolerance_checks);
    }
    folder.commit(manifest)?;

    let mut warnings: Vec<(String, usize)> = Vec::new();
    for u in &results.units {
        for m in &u.messages {
            // Group by the message's first words (the amounts differ).
            let key = m
                .split(';')
                .next()
                .unwrap_or(m)
                .split(" (")
                .next()
                .unwrap_or(m)
                .to_string();
            match warnings.iter_mut().find(|(k, _)| *k == key) {
                Some((_, c)) => *c += 1,
                None => warnings.push((key, 1)),
            }
        }
    }
    Ok(RunReport {
        out_dir,
        cells,
        checks,
        calibration,
        stopping,
        tolerance_checks,
        wall_seconds,
        threads,
        warnings,
    })
}
