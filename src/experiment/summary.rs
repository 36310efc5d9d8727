//! Per-cell summaries and the evaluation of checks.

use super::plan::{CalibrationCheck, Check, Plan};
use super::runner::Results;
use crate::stats::{PairedTest, mean, mean_ci95, paired_t_less, quantile_sorted};

/// The levels at which `summary.csv` reports coverage (math.md §7).
pub const COVERAGE_LEVELS: [f64; 3] = [0.5, 0.8, 0.95];

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
    /// Mean of the stated sd (posterior sd, or MC's standard error); None when a trial has
    /// none (MC with N = 1).
    pub mean_posterior_sd: Option<f64>,
    /// Share of trials whose interval at each of [`COVERAGE_LEVELS`] holds the truth.
    pub coverage: Option<[f64; 3]>,
    /// Median over the trials of `|Î − I| / sd` (0/0 counts as 0, e/0 as ∞).
    pub median_error_over_sd: Option<f64>,
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
                let sds: Option<Vec<f64>> = units
                    .iter()
                    .map(|u| u.uncertainty[fi][ei].map(|x| x.sd))
                    .collect();
                let coverage = sds.as_ref().map(|_| {
                    COVERAGE_LEVELS.map(|level| {
                        coverage_at(plan, results, fi, ei, ni, level).expect("every trial has an sd")
                    })
                });
                let median_error_over_sd = sds.as_ref().map(|sds| {
                    let mut ratios: Vec<f64> = errors
                        .iter()
                        .zip(sds)
                        .map(|(&e, &sd)| if e == 0.0 { 0.0 } else { e / sd })
                        .collect();
                    ratios.sort_by(f64::total_cmp);
                    quantile_sorted(&ratios, 0.5)
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
                    coverage,
                    median_error_over_sd,
                    warnings: units.iter().map(|u| u.warnings_for(fi, ei) as u64).sum(),
                });
            }
        }
    }
    out
}

/// The share of the cell's trials whose interval `Î ± q · sd` at `level` holds the truth;
/// None if a trial has no interval. The quantile `q` depends on the interval's law only (the
/// same in every trial of a cell), so it is computed once per law.
pub fn coverage_at(
    plan: &Plan,
    results: &Results,
    integrand: usize,
    estimator: usize,
    n_index: usize,
    level: f64,
) -> Option<f64> {
    let errors = abs_errors(plan, results, integrand, estimator, n_index);
    let mut quantiles: Vec<(Option<usize>, f64)> = Vec::new();
    let mut hits = 0usize;
    for (t, e) in errors.iter().enumerate() {
        let u = results.unit(plan, n_index, t).uncertainty[integrand][estimator]?;
        let q = match quantiles.iter().find(|(d, _)| *d == u.dof) {
            Some(&(_, q)) => q,
            None => {
                let q = u.quantile(level);
                quantiles.push((u.dof, q));
                q
            }
        };
        if *e <= q * u.sd {
            hits += 1;
        }
    }
    Some(hits as f64 / errors.len() as f64)
}

/// The binomial 99% band around `level` for `trials` trials: `level ± z₀.₉₉₅ sqrt(level (1 −
/// level) / trials)` (normal approximation to the binomial count of covering trials), clipped to
/// [0, 1]. A calibrated estimator's coverage falls outside it in about 1% of cells.
pub fn binomial_band(level: f64, trials: usize) -> (f64, f64) {
    let half = crate::stats::interval_quantile(None, 0.99) * (level * (1.0 - level) / trials as f64).sqrt();
    ((level - half).max(0.0), (level + half).min(1.0))
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

/// One (integrand, N) cell of a calibration check.
#[derive(Debug, Clone)]
pub struct CalibrationCell {
    pub integrand: usize,
    pub n: usize,
    pub coverage: f64,
    pub passed: bool,
}

/// The outcome of one calibration check.
#[derive(Debug, Clone)]
pub struct CalibrationOutcome {
    pub check: CalibrationCheck,
    /// The binomial 99% band around the level.
    pub band: (f64, f64),
    pub cells: Vec<CalibrationCell>,
}

impl CalibrationOutcome {
    pub fn passed(&self) -> bool {
        self.cells.iter().all(|c| c.passed)
    }
}

/// Evaluates a calibration check: in every (integrand, N ≥ from_n) cell the estimator's
/// coverage at the level lies within [`binomial_band`] around it.
pub fn evaluate_calibration(plan: &Plan, results: &Results, check: &CalibrationCheck) -> CalibrationOutcome {
    let band = binomial_band(check.level, plan.trials);
    let mut cells = Vec::new();
    for fi in 0..plan.integrands.len() {
        for (ni, &n) in plan.samples.iter().enumerate() {
            if n < check.from_n {
                continue;
            }
            let coverage = coverage_at(plan, results, fi, check.index, ni, check.level)
                .expect("validation ensures an interval at every checked N");
            cells.push(CalibrationCell {
                integrand: fi,
                n,
                coverage,
                passed: band.0 <= coverage && coverage <= band.1,
            });
        }
    }
    CalibrationOutcome {
        check: check.clone(),
        band,
        cells,
    }
}
