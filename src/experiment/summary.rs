//! Per-cell summaries and the evaluation of checks.

use super::plan::{Check, Plan};
use super::runner::Results;
use crate::stats::{PairedTest, mean, mean_ci95, paired_t_less, quantile_sorted};

/// The 95% credible interval is `Î ± 1.96 σ_post`.
pub const Z95: f64 = 1.959_963_984_540_054;

/// Summary of one (integrand, estimator, N) cell.
#[derive(Debug, Clone)]
pub struct CellSummary {
    pub integrand: usize,
    pub estimator: usize,
    pub n: usize,
    pub trials: usize,
    pub mean_abs_error: f64,
    pub ci95: (f64, f64),
    pub median_abs_error: f64,
    pub q10_abs_error: f64,
    pub q90_abs_error: f64,
    /// None for estimators without a posterior (MC).
    pub mean_posterior_sd: Option<f64>,
    /// Share of trials whose 95% credible interval holds the truth.
    pub coverage95: Option<f64>,
    pub warnings: u64,
}

/// Absolute errors of one cell, in trial order.
pub fn abs_errors(
    plan: &Plan,
    results: &Results,
    integrand: usize,
    estimator: usize,
    n_index: usize,
) -> Vec<f64> {
    let truth = plan.integrands[integrand].integral();
    (0..plan.trials)
        .map(|t| (results.unit(plan, n_index, t).estimates[integrand][estimator] - truth).abs())
        .collect()
}

/// All cell summaries, ordered by integrand, estimator, N (the plan's orders).
pub fn summarize(plan: &Plan, results: &Results) -> Vec<CellSummary> {
    let mut out = Vec::new();
    for fi in 0..plan.integrands.len() {
        for ei in 0..plan.estimators.len() {
            for (ni, &n) in plan.samples.iter().enumerate() {
                let errors = abs_errors(plan, results, fi, ei, ni);
                let mut sorted = errors.clone();
                sorted.sort_by(f64::total_cmp);
                let units: Vec<_> = (0..plan.trials).map(|t| results.unit(plan, ni, t)).collect();
                let sds: Option<Vec<f64>> = units.iter().map(|u| u.posterior_sd[ei]).collect();
                let coverage95 = sds.as_ref().map(|sds| {
                    let hits = errors.iter().zip(sds).filter(|(e, sd)| **e <= Z95 * **sd).count();
                    hits as f64 / plan.trials as f64
                });
                out.push(CellSummary {
                    integrand: fi,
                    estimator: ei,
                    n,
                    trials: plan.trials,
                    mean_abs_error: mean(&errors),
                    ci95: mean_ci95(&errors),
                    median_abs_error: quantile_sorted(&sorted, 0.5),
                    q10_abs_error: quantile_sorted(&sorted, 0.1),
                    q90_abs_error: quantile_sorted(&sorted, 0.9),
                    mean_posterior_sd: sds.as_ref().map(|s| mean(s)),
                    coverage95,
                    warnings: units.iter().map(|u| u.warnings_for(fi, ei) as u64).sum(),
                });
            }
        }
    }
    out
}

/// One (integrand, N) cell of a check.
#[derive(Debug, Clone)]
pub struct CheckCell {
    pub integrand: usize,
    pub n: usize,
    pub mean_better: f64,
    pub mean_than: f64,
    pub test: PairedTest,
    pub passed: bool,
}

/// The outcome of one check.
#[derive(Debug, Clone)]
pub struct CheckOutcome {
    pub check: Check,
    pub cells: Vec<CheckCell>,
}

impl CheckOutcome {
    pub fn passed(&self) -> bool {
        self.cells.iter().all(|c| c.passed)
    }
}

/// Evaluates a check: for every integrand and N ≥ from_n, A's mean absolute error is below B's
/// and the one-sided paired t-test on per-trial differences rejects "A is no better" at α.
pub fn evaluate_check(plan: &Plan, results: &Results, check: &Check) -> CheckOutcome {
    let mut cells = Vec::new();
    for fi in 0..plan.integrands.len() {
        for (ni, &n) in plan.samples.iter().enumerate() {
            if n < check.from_n {
                continue;
            }
            let a = abs_errors(plan, results, fi, check.better_index, ni);
            let b = abs_errors(plan, results, fi, check.than_index, ni);
            let test = paired_t_less(&a, &b);
            let (mean_better, mean_than) = (mean(&a), mean(&b));
            cells.push(CheckCell {
                integrand: fi,
                n,
                mean_better,
                mean_than,
                test,
                passed: mean_better < mean_than && test.p_value < check.alpha,
            });
        }
    }
    CheckOutcome {
        check: check.clone(),
        cells,
    }
}
