//! Tolerance estimators in experiments ([`crate::sequential`]; README, "Stopping at a tolerance").
//!
//! An estimator with `"tolerance": {"abs": A, "max_n": M}` runs once per (N, trial) unit like
//! any other, with the unit's N as its **first stage**: its nested set is the unit's own set for
//! its design extended to `M` points (same stream, so its first N points are exactly what the
//! fixed-N estimators with that design see), and it doubles N until its 95% half-width is at
//! most `A`. `trials.csv` holds the estimate and sd of the stage where it stopped;
//! `stopping_trials.csv` how many points that took, and `stopping_summary.csv` per cell the mean
//! N used and the share of trials whose actual error is within `A`.

use super::plan::{Plan, PlannedEstimator};
use super::runner::Results;
use super::spec::{CheckSpec, EstimatorSpec, KernelMeanName};
use crate::bmc::Scale;
use crate::geometry::Vec3;
use crate::sampling::SetDesign;
use crate::sequential::{self, Outcome, Tolerance};
use serde::Serialize;
use std::fmt::Write;

/// Whether a design's first N points are the same whatever the final N, so that a stage can
/// extend the one before it: i.i.d. points and the Sobol sequence are; the Fibonacci lattice
/// and the jittered grid depend on N.
pub fn is_nested(design: SetDesign) -> bool {
    match design {
        SetDesign::Iid(_) | SetDesign::Sobol => true,
        SetDesign::Fibonacci | SetDesign::Stratified => false,
    }
}

/// The estimator's tolerance, validated against its method, design, model and the sample counts
/// (its first stages); None without one.
pub fn resolve_tolerance(
    e: &EstimatorSpec,
    planned: &PlannedEstimator,
    samples: &[u64],
    at: &dyn Fn(&str) -> String,
) -> Result<Option<Tolerance>, String> {
    let Some(t) = e.tolerance else {
        return Ok(None);
    };
    if !(t.abs.is_finite() && t.abs > 0.0) {
        return Err(format!("{}: must be a positive finite number, got {}", at("tolerance.abs"), t.abs));
    }
    if let Some((i, &n)) = samples.iter().enumerate().max_by_key(|&(_, &n)| n).filter(|&(_, &n)| n > t.max_n) {
        return Err(format!(
            "{}: {} is below the first stage N = {n} (samples[{i}]); a tolerance estimator starts at each \
             sample count and doubles up to max_n, so max_n must be at least the largest sample count",
            at("tolerance.max_n"),
            t.max_n
        ));
    }
    let limit = if planned.method.needs_weights() {
        crate::rule::MAX_POINTS as u64
    } else {
        super::plan::MAX_UNIT_POINTS
    };
    if t.max_n > limit {
        return Err(format!(
            "{}: {} is above the limit of {limit} points for method {}",
            at("tolerance.max_n"),
            t.max_n,
            planned.method
        ));
    }
    if !is_nested(planned.design) {
        return Err(format!(
            "{}: {:?} is not nested (its first N points change with N), so a tolerance cannot extend it; \
             use uniform, cosine or sobol",
            at("design"),
            planned.design.name()
        ));
    }
    if let Some(m) = e.kernel_mean.filter(|&m| m != KernelMeanName::Exact) {
        return Err(format!(
            "{}: {:?} draws each weight set's kernel means afresh, so a tolerance cannot extend the set; \
             use \"exact\"",
            at("kernel_mean"),
            serde_json::to_value(m).expect("names serialize")
        ));
    }
    if let Some((i, &n)) = samples
        .iter()
        .enumerate()
        .find(|&(_, &n)| !planned.method.has_interval(n as usize))
    {
        return Err(format!(
            "{}: method {} has no interval at the first stage N = {n} (samples[{i}]), so it cannot stop on \
             its interval; start from N ≥ 2",
            at("tolerance"),
            planned.method
        ));
    }
    Ok(Some(Tolerance {
        abs: t.abs,
        max_n: t.max_n as usize,
    }))
}

/// A resolved `{"within_tolerance": A, "level": 0.95, "from_n": n0}` check: in every (integrand,
/// first stage ≥ `from_n`) cell, the share of A's trials whose actual error is within A's
/// tolerance is at least the lower end of the binomial 99% band around `level`
/// ([`super::summary::binomial_band`]), i.e. within binomial noise of the level or above.
#[derive(Debug, Clone, Serialize)]
pub struct ToleranceCheck {
    pub within_tolerance: String,
    pub level: f64,
    pub from_n: usize,
    #[serde(skip)]
    pub index: usize,
}

/// Check `i`, which has `within_tolerance`.
pub fn resolve_check(
    spec: &super::spec::ExperimentSpec,
    estimators: &[PlannedEstimator],
    i: usize,
    c: &CheckSpec,
) -> Result<ToleranceCheck, String> {
    let at = |field: &str| format!("checks[{i}].{field}");
    for (field, given) in [
        ("better", c.better.is_some()),
        ("than", c.than.is_some()),
        ("alpha", c.alpha.is_some()),
        ("calibrated", c.calibrated.is_some()),
    ] {
        if given {
            return Err(format!(
                "{}: is not used by a tolerance check (\"within_tolerance\" takes \"level\" and \"from_n\")",
                at(field)
            ));
        }
    }
    let label = c.within_tolerance.as_ref().expect("a tolerance check");
    let Some(index) = estimators.iter().position(|e| &e.label == label) else {
        let known: Vec<_> = estimators.iter().map(|e| e.label.as_str()).collect();
        return Err(format!(
            "{}: no estimator is labelled {label:?} (labels: {})",
            at("within_tolerance"),
            known.join(", ")
        ));
    };
    if estimators[index].tolerance.is_none() {
        return Err(format!(
            "{}: {label:?} has no \"tolerance\", so nothing says what within tolerance means",
            at("within_tolerance")
        ));
    }
    let from_n = c.from_n.unwrap_or(1);
    if !spec.samples.iter().any(|&n| n >= from_n) {
        return Err(format!(
            "{}: {from_n} is above every sample count, so nothing is checked",
            at("from_n")
        ));
    }
    let level = c.level.unwrap_or(0.95);
    if !(level > 0.0 && level < 1.0) {
        return Err(format!("{}: must be in (0, 1), got {level}", at("level")));
    }
    Ok(ToleranceCheck {
        within_tolerance: label.clone(),
        level,
        from_n: from_n as usize,
        index,
    })
}

/// What one tolerance estimator produced in one unit.
#[derive(Debug, Clone)]
pub struct UnitRun {
    /// One outcome per integrand.
    pub outcomes: Vec<Outcome>,
    /// The diagnostics of the largest weight set built (None for MC).
    pub diagnostics: Option<crate::bmc::Diagnostics>,
    /// Whether the amplitude was fitted (`ml`, `loo`).
    pub fitted: bool,
}

/// Runs every tolerance estimator of the plan in the unit with first stage `n`; `draw(design,
/// count)` gives the unit's nested set for a design (the first `n` points are the unit's own).
/// Estimators with the same design, `max_n` and model share one nested set and its weight
/// sets. None for estimators without a tolerance.
pub fn run_unit(
    plan: &Plan,
    n: usize,
    trial: usize,
    draw: &dyn Fn(SetDesign, usize) -> Vec<Vec3>,
) -> crate::Result<Vec<Option<UnitRun>>> {
    let mut out: Vec<Option<UnitRun>> = vec![None; plan.estimators.len()];
    // One set and its values per (design, max_n) in use.
    let mut sets: Vec<((SetDesign, usize), Vec<Vec3>, Vec<Vec<f64>>)> = Vec::new();
    for e in &plan.estimators {
        let Some(t) = e.tolerance else { continue };
        let key = (e.design, t.max_n);
        if !sets.iter().any(|(k, _, _)| *k == key) {
            let points = draw(e.design, t.max_n);
            let values = plan
                .integrands
                .iter()
                .map(|f| points.iter().map(|p| f.value(p)).collect())
                .collect();
            sets.push((key, points, values));
        }
    }
    for (key, points, values) in &sets {
        let stages_of = |e: &PlannedEstimator| e.tolerance.expect("a tolerance estimator").stages(n);
        let of_set = |e: &&PlannedEstimator| e.tolerance.is_some_and(|t| (e.design, t.max_n) == *key);
        // MC on the set.
        for (ei, e) in plan.estimators.iter().enumerate() {
            if !of_set(&e) || e.model.is_some() {
                continue;
            }
            let abs = e.tolerance.expect("a tolerance estimator").abs;
            out[ei] = Some(UnitRun {
                outcomes: values
                    .iter()
                    .map(|v| sequential::mc(e.design.density(), points, v, &stages_of(e), abs))
                    .collect(),
                diagnostics: None,
                fitted: false,
            });
        }
        // One nested weight family per model on the set, shared by its estimators.
        let mut models: Vec<usize> = plan.estimators.iter().filter(of_set).filter_map(|e| e.model).collect();
        models.dedup();
        models.sort_unstable();
        models.dedup();
        for m in models {
            let users: Vec<usize> = (0..plan.estimators.len())
                .filter(|&ei| of_set(&&plan.estimators[ei]) && plan.estimators[ei].model == Some(m))
                .collect();
            let scales: Vec<Scale> = users
                .iter()
                .map(|&ei| plan.estimators[ei].scale.unwrap_or(Scale::Unit))
                .collect();
            let mut nested = sequential::NestedWeights::new(&plan.models[m], points, values, &scales);
            // The estimators walk the stages together, so each stage is factored once.
            let mut runs = sequential::weighted_together(
                &users
                    .iter()
                    .map(|&ei| {
                        let e = &plan.estimators[ei];
                        sequential::Walker {
                            estimator: sequential::WeightedEstimator {
                                method: e.method,
                                scale: e.scale.unwrap_or(Scale::Unit),
                            },
                            priors: plan
                                .integrands
                                .iter()
                                .map(|f| e.prior.map_or(0.0, |p| p.resolve(f.constant_prior())))
                                .collect(),
                            stages: stages_of(e),
                            abs: e.tolerance.expect("a tolerance estimator").abs,
                        }
                    })
                    .collect::<Vec<_>>(),
                &mut nested,
            )
            .map_err(|source| crate::Error::Numerical {
                what: format!(
                    "tolerance estimator {:?}, first stage N = {n}, trial {trial}",
                    plan.estimators[users[0]].label
                ),
                source,
            })?
            .into_iter();
            for (&ei, &scale) in users.iter().zip(&scales) {
                let r = runs.next().expect("one run per walker");
                out[ei] = Some(UnitRun {
                    outcomes: r.outcomes,
                    diagnostics: Some(r.diagnostics),
                    fitted: scale != Scale::Unit,
                });
            }
        }
    }
    Ok(out)
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
                let o: Vec<Outcome> = (0..plan.trials).map(|t| outcome(plan, results, fi, ei, ni, t)).collect();
                let errors: Vec<f64> = o.iter().map(|o| (o.estimate - f.integral()).abs()).collect();
                let share = |k: usize| k as f64 / plan.trials as f64;
                out.push(Cell {
                    integrand: fi,
                    estimator: ei,
                    first_n: n,
                    tolerance,
                    trials: plan.trials,
                    mean_n_used: crate::stats::mean(&o.iter().map(|o| o.n_used as f64).collect::<Vec<_>>()),
                    max_n_used: o.iter().map(|o| o.n_used).max().unwrap_or(0),
                    stopped: share(o.iter().filter(|o| o.met).count()),
                    within: share(errors.iter().filter(|&&e| e <= tolerance.abs).count()),
                    mean_abs_error: crate::stats::mean(&errors),
                });
            }
        }
    }
    out
}

/// `stopping_trials.csv`: one row per (integrand, tolerance estimator, first stage, trial).
pub fn trials_csv(plan: &Plan, results: &Results) -> Vec<u8> {
    let mut s =
        String::from("integrand,estimator,first_n,trial,tolerance,n_used,half_width95,stopped,abs_error,within\n");
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
                            .map_or(String::new(), |u| format!("{:?}", sequential::half_width(&u))),
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
        let worst = c
            .cells
            .iter()
            .map(|x| x.within)
            .fold(f64::INFINITY, f64::min);
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
