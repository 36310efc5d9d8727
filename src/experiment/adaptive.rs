//! Tolerance estimators in experiments ([`crate::bq::stages`]; docs/guide/run.md, "Stopping at a tolerance").
//!
//! An estimator with `"tolerance": {"abs": A, "max_n": M}` runs once per (N, trial) unit like
//! any other, with the unit's N as its **first stage** (or its pilot `min_n`, default 64, if
//! larger): its nested set is the unit's own set for its design extended to `M` points (same
//! stream, so its first N points are exactly what the fixed-N estimators with that design see),
//! and it doubles N until `inflate ×` its half-width at `level` is at most `A` — never on a
//! stage with zero evidence. `trials.csv` holds the estimate and sd of the stage where it
//! stopped; `stopping_trials.csv` how many points that took, and `stopping_summary.csv` per cell
//! the mean N used, the share the rule stopped (`met`), the share of those whose actual error is
//! within `A` (`within_given_met`) and the share that met zero evidence on the way.
//!
//! Every unit's outcomes are read back from the unit logs ([`read_outcomes`]; the log rows carry
//! the stopping columns, [`super::rows::COST_HEADER`]), so a run in one go, a resumed run and
//! merged shards write these files from the same rows, byte for byte
//! ([`super::finish::write_stopping`]).

use super::log::for_each_row;
use super::plan::Plan;
pub use super::tolerance::ToleranceCheck;
use crate::bq::stages::{self, Outcome, Tolerance};
use crate::job::LogSet;
use std::fmt::Write;

/// Every tolerance estimator's outcome in every unit: `(unit · integrands + integrand) ·
/// estimators + estimator`, None for the other estimators.
pub struct Outcomes {
    outcomes: Vec<Option<Outcome>>,
}

/// Reads every unit's stopping outcomes from the run's logs (rows checked by whoever read the
/// logs first: the resume or the merge, or written by this very run).
pub fn read_outcomes(plan: &Plan, logs: &LogSet) -> crate::Result<Outcomes> {
    let (ni, ne) = (plan.integrands.len(), plan.estimators.len());
    let mut outcomes = vec![None; plan.samples.len() * plan.trials * ni * ne];
    for_each_row(plan, logs, &mut |u, fi, ei, line| {
        if plan.estimators[ei].tolerance.is_some() {
            let o = super::rows::stopping_outcome(line).ok_or_else(|| {
                crate::error::InputError::new(format!(
                    "unit {u}: the row of {:?} on {} has no stopping outcome",
                    plan.estimators[ei].label,
                    plan.integrands[fi].name()
                ))
            })?;
            outcomes[(u * ni + fi) * ne + ei] = Some(o);
        }
        Ok(())
    })?;
    Ok(Outcomes { outcomes })
}

impl Outcomes {
    /// The outcomes of units computed in memory (`units[n_index · trials + trial]`, as
    /// [`super::runner::Results`] holds them): what the unit logs of the same run hold, for
    /// callers that write no log (the Python bindings' `run(spec, tables=True)`).
    pub fn of_units(plan: &Plan, units: &[super::runner::UnitResult]) -> Outcomes {
        let mut outcomes = Vec::with_capacity(units.len() * plan.integrands.len() * plan.estimators.len());
        for u in units {
            for per_integrand in &u.sequential {
                outcomes.extend(per_integrand.iter().copied());
            }
        }
        Outcomes { outcomes }
    }
}

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
    /// Share of trials the rule stopped (half-width ≤ abs with evidence) before or at `max_n`:
    /// `met` in math.md §9's words.
    pub stopped: f64,
    /// Share of trials whose actual error `|Î − I|` is at most `abs`.
    pub within: f64,
    pub mean_abs_error: f64,
    /// How many trials the rule stopped.
    pub met_trials: usize,
    /// Among the trials the rule stopped, the share whose actual error is at most `abs`; None
    /// when it stopped none.
    pub within_given_met: Option<f64>,
    /// Share of trials that walked at least one stage with zero evidence (each doubled on).
    pub zero_evidence: f64,
}

/// The sequential outcome of a tolerance estimator in one trial.
fn outcome(plan: &Plan, results: &Outcomes, fi: usize, ei: usize, ni: usize, t: usize) -> Outcome {
    let u = ni * plan.trials + t;
    results.outcomes[(u * plan.integrands.len() + fi) * plan.estimators.len() + ei]
        .expect("a tolerance estimator records its outcome")
}

/// Every cell, ordered by integrand, estimator, first stage.
pub fn summarize(plan: &Plan, results: &Outcomes) -> Vec<Cell> {
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
                let met_trials = o.iter().filter(|o| o.met).count();
                let within_and_met = o
                    .iter()
                    .zip(&errors)
                    .filter(|(o, e)| o.met && **e <= tolerance.abs)
                    .count();
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
                    stopped: share(met_trials),
                    within: share(errors.iter().filter(|&&e| e <= tolerance.abs).count()),
                    mean_abs_error: crate::util::stats::mean(&errors),
                    met_trials,
                    within_given_met: (met_trials > 0).then(|| within_and_met as f64 / met_trials as f64),
                    zero_evidence: share(o.iter().filter(|o| o.zero_evidence > 0).count()),
                });
            }
        }
    }
    out
}

/// `stopping_trials.csv`: one row per (integrand, tolerance estimator, first stage, trial).
pub fn trials_csv(plan: &Plan, results: &Outcomes) -> Vec<u8> {
    let mut s = String::from(
        "integrand,estimator,first_n,trial,tolerance,n_used,half_width95,stopped,abs_error,within,half_width,zero_evidence_stages\n",
    );
    for (fi, f) in plan.integrands.iter().enumerate() {
        for (ei, e) in plan.estimators.iter().enumerate() {
            let Some(tol) = e.tolerance else { continue };
            for (ni, &n) in plan.samples.iter().enumerate() {
                for t in 0..plan.trials {
                    let o = outcome(plan, results, fi, ei, ni, t);
                    let error = (o.estimate - f.integral()).abs();
                    let width = |w: fn(&Tolerance, &crate::bq::estimator::Uncertainty) -> f64| {
                        o.uncertainty
                            .map_or(String::new(), |u| format!("{:?}", w(&tol, &u)))
                    };
                    writeln!(
                        s,
                        "{},{},{n},{t},{:?},{},{},{},{error:?},{},{},{}",
                        f.name(),
                        csv_field(&e.label),
                        tol.abs,
                        o.n_used,
                        width(|_, u| stages::half_width(u)),
                        o.met,
                        error <= tol.abs,
                        width(Tolerance::half_width),
                        o.zero_evidence
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
        "integrand,estimator,method,first_n,tolerance,max_n,trials,mean_n_used,max_n_used,stopped,within_tolerance,mean_abs_error,met,within_given_met,zero_evidence\n",
    );
    for c in cells {
        let e = &plan.estimators[c.estimator];
        writeln!(
            s,
            "{},{},{},{},{:?},{},{},{:?},{},{:?},{:?},{:?},{:?},{},{:?}",
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
            c.mean_abs_error,
            c.stopped,
            c.within_given_met.map_or(String::new(), |w| format!("{w:?}")),
            c.zero_evidence
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
    /// The share of trials the rule stopped.
    pub met: f64,
    pub met_trials: usize,
    /// Among those, the share within the tolerance (None when the rule stopped none).
    pub within_given_met: Option<f64>,
    /// The lower end of the binomial 99% band around the level for `met_trials` trials.
    pub within_low: f64,
    /// `met` is at or above the lower end of the band for all trials.
    pub met_passed: bool,
    /// `within_given_met` is at or above `within_low` (vacuously true when nothing was met:
    /// `met_passed` fails then).
    pub within_passed: bool,
}

/// The outcome of a tolerance check.
#[derive(Debug, Clone)]
pub struct CheckOutcome {
    pub check: ToleranceCheck,
    /// The binomial 99% band around the level for all trials; `met` passes at or above its lower
    /// end.
    pub band: (f64, f64),
    pub cells: Vec<CheckCell>,
}

impl CheckOutcome {
    pub fn passed(&self) -> bool {
        self.met_passed() && self.within_passed()
    }

    /// Every cell's share within the tolerance among the met trials is high enough.
    pub fn within_passed(&self) -> bool {
        self.cells.iter().all(|c| c.within_passed)
    }

    /// Every cell's share of met trials is high enough.
    pub fn met_passed(&self) -> bool {
        self.cells.iter().all(|c| c.met_passed)
    }
}

/// Evaluates a tolerance check on the summarised cells.
pub fn evaluate_check(plan: &Plan, cells: &[Cell], check: &ToleranceCheck) -> CheckOutcome {
    let band = super::summary::binomial_band(check.level, plan.trials);
    let cells = cells
        .iter()
        .filter(|c| c.estimator == check.index && c.first_n >= check.from_n)
        .map(|c| {
            let within_low = if c.met_trials > 0 {
                super::summary::binomial_band(check.level, c.met_trials).0
            } else {
                check.level
            };
            CheckCell {
                integrand: c.integrand,
                first_n: c.first_n,
                met: c.stopped,
                met_trials: c.met_trials,
                within_given_met: c.within_given_met,
                within_low,
                met_passed: c.stopped >= band.0,
                within_passed: c.within_given_met.is_none_or(|w| w >= within_low),
            }
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
                "met_passed": c.met_passed(),
                "within_given_met_passed": c.within_passed(),
                "cells": c.cells.iter().map(|x| serde_json::json!({
                    "integrand": plan.integrands[x.integrand].name(),
                    "first_n": x.first_n,
                    "met": x.met,
                    "met_trials": x.met_trials,
                    "within_given_met": x.within_given_met,
                    "within_given_met_band99_low": x.within_low,
                    "met_passed": x.met_passed,
                    "within_given_met_passed": x.within_passed,
                    "passed": x.met_passed && x.within_passed,
                })).collect::<Vec<_>>(),
            }))
            .collect::<Vec<_>>()
    )
}

/// For people: each tolerance estimator's mean N used, shares met, within among met, with zero
/// evidence and within, and the check lines (two per check: within given met, and met).
pub fn format_report(plan: &Plan, cells: &[Cell], checks: &[CheckOutcome]) -> String {
    let mut s = String::new();
    if cells.is_empty() {
        return s;
    }
    s += "\nStopping at a tolerance (half-width ≤ abs, never on zero evidence): mean N used, share of trials the rule \
          stopped (met), share of those within the tolerance, share that met a zero-evidence stage, share within overall\n";
    s += &format!(
        "{:<28} {:>24} {:>7} {:>9} {:>11} {:>8} {:>10} {:>8} {:>8}\n",
        "integrand", "estimator", "N0", "abs", "mean N", "met", "within|met", "zero ev", "within"
    );
    for c in cells {
        s += &format!(
            "{:<28} {:>24} {:>7} {:>9.1e} {:>11.1} {:>8.3} {:>10} {:>8.3} {:>8.3}\n",
            plan.integrands[c.integrand].name(),
            plan.estimators[c.estimator].label,
            c.first_n,
            c.tolerance.abs,
            c.mean_n_used,
            c.stopped,
            c.within_given_met.map_or("—".to_string(), |w| format!("{w:.3}")),
            c.zero_evidence,
            c.within
        );
    }
    for c in checks {
        let lowest = |f: fn(&CheckCell) -> Option<f64>| {
            let shares: Vec<f64> = c.cells.iter().filter_map(f).collect();
            match shares.iter().copied().reduce(f64::min) {
                Some(x) => format!("{x:.3}"),
                None => "— (nothing met)".to_string(),
            }
        };
        let pass = |p: bool| if p { "PASS" } else { "FAIL" };
        s += &format!(
            "\n{} check {} within tolerance given met at level {} (among the trials the rule stopped, share ≥ the \
             lower end of the binomial 99% band for their count, {:.3} for all {} trials): {} cells, lowest share {}\n",
            pass(c.within_passed()),
            c.check.within_tolerance,
            c.check.level,
            c.band.0,
            plan.trials,
            c.cells.len(),
            lowest(|x| x.within_given_met)
        );
        s += &format!(
            "{} check {} met by the rule at level {} (share of trials stopped by the rule ≥ {:.3}, the binomial 99% \
             band's lower end): {} cells, lowest share {}\n",
            pass(c.met_passed()),
            c.check.within_tolerance,
            c.check.level,
            c.band.0,
            c.cells.len(),
            lowest(|x| Some(x.met))
        );
    }
    s
}
