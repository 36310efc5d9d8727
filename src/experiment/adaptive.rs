//! Tolerance estimators in experiments ([`crate::bq::stages`]; README, "Stopping at a tolerance").
//!
//! An estimator with `"tolerance": {"abs": A, "max_n": M}` runs once per (N, trial) unit like
//! any other, with the unit's N as its **first stage**: its nested set is the unit's own set for
//! its design extended to `M` points (same stream, so its first N points are exactly what the
//! fixed-N estimators with that design see), and it doubles N until its 95% half-width is at
//! most `A`. `trials.csv` holds the estimate and sd of the stage where it stopped;
//! `stopping_trials.csv` how many points that took, and `stopping_summary.csv` per cell the mean
//! N used and the share of trials whose actual error is within `A`.

use super::plan::Plan;
use super::runner::Results;
pub use super::tolerance::ToleranceCheck;
use crate::bq::stages::{self, Outcome, Tolerance};
use std::fmt::Write;

/// One (integrand, tolerance estimator, first stage) cell of `stopping_summary.csv`.
#[derive(Debug, Clone)]
pub struct Cell {
    pub integrand: usize,
    pub estimator: usize,
    pub first_n: usize,
    pub tolerance: Tolerance,
    pub trials: usize,
    pub mean_n_used: f64,
    pub max_n_used: usize,
    /// Share of trials the rule stopped (half-width ≤ abs) before or at `max_n`.
    pub stopped: f64,
    /// Share of trials whose actual error `|Î − I|` is at most `abs`.
    pub within: f64,
    pub mean_abs_error: f64,
}

/// The sequential outcome of a tolerance estimator in one trial.
fn outcome(plan: &Plan, results: &Results, fi: usize, ei: usize, ni: usize, t: usize) -> Outcome {
    results.unit(plan, ni, t).sequential[fi][ei].expect("a tolerance estimator records its outcome")
}

/// Every cell, ordered by integrand, estimator, first stage.
pub fn summarize(plan: &Plan, results: &Results) -> Vec<Cell> {
    let mut out = Vec::new();
    for (fi, f) in plan.integrands.iter().enumerate() {
        for (ei, e) in plan.estimators.iter().enumerate() {
            let Some(tolerance) = e.tolerance else { continue };
            for (ni, &n) in plan.samples.iter().enumerate() {
                let o: Vec<Outcome> = (0..plan.trials)
                    .map(|t| outcome(plan, results, fi, ei, ni, t))
                    .collect();
                let errors: Vec<f64> = o.iter().map(|o| (o.estimate - f.integral()).abs()).collect();
                let share = |k: usize| k as f64 / plan.trials as f64;
                out.push(Cell {
                    integrand: fi,
                    estimator: ei,
                    first_n: n,
                    tolerance,
                    trials: plan.trials,
                    mean_n_used: crate::util::stats::mean(
                        &o.iter().map(|o| o.n_used as f64).collect::<Vec<_>>(),
                    ),
                    max_n_used: o.iter().map(|o| o.n_used).max().unwrap_or(0),
                    stopped: share(o.iter().filter(|o| o.met).count()),
                    within: share(errors.iter().filter(|&&e| e <= tolerance.abs).count()),
                    mean_abs_error: crate::util::stats::mean(&errors),
                });
            }
        }
    }
    out
}

/// `stopping_trials.csv`: one row per (integrand, tolerance estimator, first stage, trial).
pub fn trials_csv(plan: &Plan, results: &Results) -> Vec<u8> {
    let mut s = String::from(
        "integrand,estimator,first_n,trial,tolerance,n_used,half_width95,stopped,abs_error,within\n",
    );
    for (fi, f) in plan.integrands.iter().enumerate() {
        for (ei, e) in plan.estimators.iter().enumerate() {
            let Some(tol) = e.tolerance else { continue };
            for (ni, &n) in plan.samples.iter().enumerate() {
                for t in 0..plan.trials {
                    let o = outcome(plan, results, fi, ei, ni, t);
                    let error = (o.estimate - f.integral()).abs();
                    writeln!(
                        s,
                        "{},{},{n},{t},{:?},{},{},{},{error:?},{}",
                        f.name(),
                        csv_field(&e.label),
                        tol.abs,
                        o.n_used,
                        o.uncertainty
                            .map_or(String::new(), |u| format!("{:?}", stages::half_width(&u))),
                        o.met,
                        error <= tol.abs
                    )
                    .expect("writing to a String");
                }
            }
        }
    }
    s.into_bytes()
}

/// `stopping_summary.csv`: one row per (integrand, tolerance estimator, first stage).
pub fn summary_csv(plan: &Plan, cells: &[Cell]) -> Vec<u8> {
    let mut s = String::from(
        "integrand,estimator,method,first_n,tolerance,max_n,trials,mean_n_used,max_n_used,stopped,within_tolerance,mean_abs_error\n",
    );
    for c in cells {
        let e = &plan.estimators[c.estimator];
        writeln!(
            s,
            "{},{},{},{},{:?},{},{},{:?},{},{:?},{:?},{:?}",
            plan.integrands[c.integrand].name(),
            csv_field(&e.label),
            e.method.name(),
            c.first_n,
            c.tolerance.abs,
            c.tolerance.max_n,
            c.trials,
            c.mean_n_used,
            c.max_n_used,
            c.stopped,
            c.within,
            c.mean_abs_error
        )
        .expect("writing to a String");
    }
    s.into_bytes()
}

/// Quotes a field if CSV needs it (labels are free text).
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// One cell of a tolerance check.
#[derive(Debug, Clone)]
pub struct CheckCell {
    pub integrand: usize,
    pub first_n: usize,
    pub within: f64,
    pub passed: bool,
}

/// The outcome of a tolerance check.
#[derive(Debug, Clone)]
pub struct CheckOutcome {
    pub check: ToleranceCheck,
    /// The binomial 99% band around the level; a cell passes at or above its lower end.
    pub band: (f64, f64),
    pub cells: Vec<CheckCell>,
}

impl CheckOutcome {
    pub fn passed(&self) -> bool {
        self.cells.iter().all(|c| c.passed)
    }
}

/// Evaluates a tolerance check on the summarised cells.
pub fn evaluate_check(plan: &Plan, cells: &[Cell], check: &ToleranceCheck) -> CheckOutcome {
    let band = super::summary::binomial_band(check.level, plan.trials);
    let cells = cells
        .iter()
        .filter(|c| c.estimator == check.index && c.first_n >= check.from_n)
        .map(|c| CheckCell {
            integrand: c.integrand,
            first_n: c.first_n,
            within: c.within,
            passed: c.within >= band.0,
        })
        .collect();
    CheckOutcome {
        check: check.clone(),
        band,
        cells,
    }
}

/// The checks' outcomes for the manifest.
pub fn checks_json(plan: &Plan, outcomes: &[CheckOutcome]) -> serde_json::Value {
    serde_json::json!(
        outcomes
            .iter()
            .map(|c| serde_json::json!({
                "within_tolerance": c.check.within_tolerance,
                "level": c.check.level,
                "from_n": c.check.from_n,
                "band99": [c.band.0, c.band.1],
                "passed": c.passed(),
                "cells": c.cells.iter().map(|x| serde_json::json!({
                    "integrand": plan.integrands[x.integrand].name(),
                    "first_n": x.first_n,
                    "within_tolerance": x.within,
                    "passed": x.passed,
                })).collect::<Vec<_>>(),
            }))
            .collect::<Vec<_>>()
    )
}

/// For people: each tolerance estimator's mean N used and share within tolerance, and the check
/// lines.
pub fn format_report(plan: &Plan, cells: &[Cell], checks: &[CheckOutcome]) -> String {
    let mut s = String::new();
    if cells.is_empty() {
        return s;
    }
    s += "\nStopping at a tolerance (95% half-width ≤ abs): mean N used, share of trials stopped by the rule, share within the tolerance\n";
    s += &format!(
        "{:<28} {:>24} {:>7} {:>9} {:>11} {:>8} {:>8}\n",
        "integrand", "estimator", "N0", "abs", "mean N", "stopped", "within"
    );
    for c in cells {
        s += &format!(
            "{:<28} {:>24} {:>7} {:>9.1e} {:>11.1} {:>8.3} {:>8.3}\n",
            plan.integrands[c.integrand].name(),
            plan.estimators[c.estimator].label,
            c.first_n,
            c.tolerance.abs,
            c.mean_n_used,
            c.stopped,
            c.within
        );
    }
    for c in checks {
        let worst = c.cells.iter().map(|x| x.within).fold(f64::INFINITY, f64::min);
        s += &format!(
            "\n{} check {} within tolerance at level {} (share ≥ {:.3}, the binomial 99% band's lower end): {} cells, lowest share {worst:.3}\n",
            if c.passed() { "PASS" } else { "FAIL" },
            c.check.within_tolerance,
            c.check.level,
            c.band.0,
            c.cells.len()
        );
    }
    s
}
