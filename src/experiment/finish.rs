//! The files of a finished run, from its summary and its unit logs: the same code whether the
//! units were run in one go, resumed, or run as shards and merged, so the files are the same
//! bytes (the wall-clock `timings*` files and `*-cost.svg` aside).

use super::log::{for_each_row, rows_per_unit};
use super::plan::Plan;
use super::rows::{timing_part, trials_header, trials_part};
use super::summary::{self, Accumulator, CalibrationOutcome, CellSummary, CheckOutcome};
use super::{adaptive, adaptive_plot, cost_plot, coverage_plot, export, plot};
use crate::error::Error;
use crate::files::result_folder::ResultFolder;
use crate::job::LogSet;

/// What the summary of a finished run found.
pub struct Findings {
    pub cells: Vec<CellSummary>,
    pub checks: Vec<CheckOutcome>,
    pub calibration: Vec<CalibrationOutcome>,
}

/// Writes every file of a finished run into `folder` (not the manifest): `trials.csv` in
/// (integrand, estimator, N, trial) order from the unit-ordered logs, one pass per
/// (integrand, estimator); the summary, fits and plots; and the cost files.
pub fn write_set(
    plan: &Plan,
    folder: &mut ResultFolder,
    summary: &Accumulator,
    logs: &LogSet,
) -> crate::Result<Findings> {
    let cells = summary.summarize(plan);
    let checks: Vec<_> = plan
        .checks
        .iter()
        .map(|c| summary::evaluate_check(plan, summary, c))
        .collect();
    let calibration: Vec<_> = plan
        .calibration_checks
        .iter()
        .map(|c| summary::evaluate_calibration(plan, summary, c))
        .collect();
    let failed = |e: std::io::Error| Error::io("writing trials.csv", e);
    folder.write_stream(
        "trials.csv",
        "one row per (integrand, estimator, n, trial)",
        &mut |w| {
            let with_model = plan.has_fitted_model();
            writeln!(w, "{}", trials_header(with_model)).map_err(failed)?;
            for pair in 0..rows_per_unit(plan) {
                for_each_row(plan, logs, &mut |_, fi, ei, line| {
                    if fi * plan.estimators.len() + ei == pair {
                        writeln!(w, "{}", trials_part(line, with_model)).map_err(failed)?;
                    }
                    Ok(())
                })?;
            }
            Ok(())
        },
    )?;
    folder.write(
        "summary.csv",
        "one row per (integrand, estimator, n)",
        &export::summary_csv(plan, &cells),
    )?;
    folder.write(
        "fits.csv",
        "one row per (integrand, estimator): log-log slope of the mean error over the n fitted (n >= fit_from_n), its 95% interval, and why it is no rate where it is not (plateau, wide interval)",
        &export::fits_csv(plan, &cells),
    )?;
    // With only tolerance estimators every cell sits at its first stage, so error and coverage
    // against N say nothing; `<integrand>-tolerance.svg` replaces them.
    let only_tolerance = plan.estimators.iter().all(|e| e.tolerance.is_some());
    // Beside other estimators, a tolerance estimator is drawn at the N it used: its stopping
    // cells (computed again by `write_stopping`, which writes them).
    let used = if only_tolerance || plan.estimators.iter().all(|e| e.tolerance.is_none()) {
        Vec::new()
    } else {
        adaptive::summarize(plan, &adaptive::read_outcomes(plan, logs)?)
    };
    for (fi, f) in plan.integrands.iter().enumerate() {
        if only_tolerance {
            continue;
        }
        let figure = plot::error_plot_svg(plan, &cells, &used, fi)?;
        crate::plot::write_figure(
            folder,
            &format!("{}.svg", f.name()),
            &format!("absolute error against n for {}, every estimator", f.name()),
            &figure,
        )?;
        if cells.iter().any(|c| c.integrand == fi && c.coverage.is_some()) {
            let figure = coverage_plot::coverage_plot_svg(plan, &cells, &used, fi)?;
            crate::plot::write_figure(
                folder,
                &format!("{}-coverage.svg", f.name()),
                &format!(
                    "95% coverage against n for {}, every estimator with an interval, with the binomial 99% band",
                    f.name()
                ),
                &figure,
            )?;
        }
        let figure = cost_plot::cost_plot_svg(plan, &cells, fi)?;
        crate::plot::write_figure_local(
            folder,
            &format!("{}-cost.svg", f.name()),
            &format!(
                "mean absolute error against median seconds per trial for {} (machine-dependent; not committed)",
                f.name()
            ),
            &figure,
        )?;
    }
    let failed = |e: std::io::Error| Error::io("writing timings-trials.csv", e);
    folder.write_stream_local(
        "timings-trials.csv",
        "integrand evaluations and wall-clock seconds per (integrand, estimator, n, trial), in unit order (machine-dependent; not committed)",
        &mut |w| {
            writeln!(w, "integrand,estimator,n,trial,evaluations,weight_set_seconds,seconds").map_err(failed)?;
            for_each_row(plan, logs, &mut |_, _, _, line| {
                let row = timing_part(line).unwrap_or_default();
                writeln!(w, "{row}").map_err(failed)
            })
        },
    )?;
    folder.write_local(
        "timings-summary.csv",
        "mean evaluations and wall-clock seconds per (integrand, estimator, n) (machine-dependent; not committed)",
        &export::timings_summary_csv(plan, &cells),
    )?;
    Ok(Findings {
        cells,
        checks,
        calibration,
    })
}

/// Writes `stopping_trials.csv`, `stopping_summary.csv` and the `<integrand>-tolerance.svg`
/// figures of a finished run (or merge) into `folder`, from its logs, and returns the cells and
/// the tolerance checks' outcomes (nothing for a plan without tolerance estimators).
pub fn write_stopping(
    plan: &Plan,
    folder: &mut ResultFolder,
    logs: &LogSet,
) -> crate::Result<(Vec<adaptive::Cell>, Vec<adaptive::CheckOutcome>)> {
    if plan.estimators.iter().all(|e| e.tolerance.is_none()) {
        return Ok((Vec::new(), Vec::new()));
    }
    let results = adaptive::read_outcomes(plan, logs)?;
    let stopping = adaptive::summarize(plan, &results);
    let checks: Vec<_> = plan
        .tolerance_checks
        .iter()
        .map(|c| adaptive::evaluate_check(plan, &stopping, c))
        .collect();
    folder.write(
        "stopping_trials.csv",
        "one row per (integrand, tolerance estimator, first n, trial): n used, 95% half-width, stopped by the rule, within the tolerance, the rule's half-width, zero-evidence stages",
        &adaptive::trials_csv(plan, &results),
    )?;
    folder.write(
        "stopping_summary.csv",
        "one row per (integrand, tolerance estimator, first n): mean n used, share stopped by the rule, share within the tolerance, share met, share within among those met, share with a zero-evidence stage",
        &adaptive::summary_csv(plan, &stopping),
    )?;
    for (fi, f) in plan.integrands.iter().enumerate() {
        if let Some(figure) = adaptive_plot::tolerance_plot_svg(plan, &stopping, fi)? {
            crate::plot::write_figure(
                folder,
                &format!("{}-tolerance.svg", f.name()),
                &format!(
                    "mean n used and share within the tolerance against the tolerance for {}, every tolerance estimator",
                    f.name()
                ),
                &figure,
            )?;
        }
    }
    Ok((stopping, checks))
}

/// A finished run's (or merge's) manifest: [`super::export::manifest_json`] with the tolerance
/// checks and their outcomes when the plan has any.
pub fn manifest(plan: &Plan, findings: &Findings, checks: &[adaptive::CheckOutcome]) -> serde_json::Value {
    let mut manifest: serde_json::Value = serde_json::from_slice(&super::export::manifest_json(
        plan,
        &findings.checks,
        &findings.calibration,
    ))
    .expect("the manifest is JSON");
    if !plan.tolerance_checks.is_empty() {
        manifest["plan"]["tolerance_checks"] = serde_json::json!(plan.tolerance_checks);
        manifest["tolerance_checks"] = adaptive::checks_json(plan, checks);
    }
    manifest
}
