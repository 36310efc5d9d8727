//! Per-cell summaries and the evaluation of checks.

use super::plan::{CalibrationCheck, Check, Plan};
use super::spec::CheckSide;
use crate::util::stats::{PairedTest, mean, mean_ci95, paired_t_less, quantile_sorted};

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
    /// Mean integrand evaluations per trial (deterministic).
    pub mean_evaluations: f64,
    /// Mean and median wall-clock seconds per trial of the estimator alone, and the mean of
    /// its weight set's (machine-dependent: `timings-summary.csv` only). The median shrugs off
    /// the trials a busy machine preempted.
    pub mean_seconds: f64,
    pub median_seconds: f64,
    pub mean_weight_set_seconds: f64,
    /// A fitted model's choices: `model_counts[k]` trials chose the grid's model `k` (empty
    /// for a fixed model).
    pub model_counts: Vec<u64>,
}

/// What the summary needs from one row of `trials.csv` (and its cost columns): the same
/// values whether the row was computed now or read back from a unit log or a shard, since
/// floats are written in shortest round-trip form.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowValues {
    pub abs_error: f64,
    /// The stated sd and the interval's degrees of freedom (None when there is no interval).
    pub sd: Option<(f64, Option<usize>)>,
    pub warnings: u32,
    pub evaluations: u64,
    /// Wall-clock seconds (machine-dependent): the estimator's weight set, and the whole.
    pub weight_set_seconds: f64,
    pub seconds: f64,
    /// A fitted model's choice: the index of the grid's model that won (math.md §9).
    pub model: Option<u16>,
}

/// One cell's running state. Keeps two `f64` per trial (the absolute error and the stated sd,
/// which medians, quantiles and the paired tests need), one `f32` (the seconds, for their
/// median) and counters for the rest.
#[derive(Debug, Clone)]
struct CellState {
    errors: Vec<f64>,
    /// NaN-free while `all_sd`; emptied of meaning (and not pushed) once a trial has no sd.
    sds: Vec<f64>,
    all_sd: bool,
    /// Trials whose interval holds the truth, per level of [`Accumulator::levels`].
    hits: Vec<u64>,
    /// The interval quantiles per level, per law met so far (keyed by the dof).
    quantiles: Vec<(Option<usize>, Vec<f64>)>,
    warnings: u64,
    evaluations: u64,
    seconds: f64,
    /// Each trial's seconds, for the median (single precision is plenty for a clock reading).
    trial_seconds: Vec<f32>,
    weight_set_seconds: f64,
    /// Trials per chosen model of a fitted grid (grown as indices appear).
    model_counts: Vec<u64>,
}

/// Per-cell summaries built row by row, in trial order within each cell, so that memory grows
/// by 20 bytes per row (not by whole rows) and every statistic is the same as from all rows
/// at once.
#[derive(Debug, Clone)]
pub struct Accumulator {
    estimators: usize,
    samples: Vec<usize>,
    /// The coverage levels counted: [`COVERAGE_LEVELS`], then the calibration checks' levels.
    levels: Vec<f64>,
    cells: Vec<CellState>,
}

impl Accumulator {
    /// Empty cells for every (integrand, estimator, N) of the plan, with room for its trials.
    pub fn new(plan: &Plan) -> Accumulator {
        let mut levels = COVERAGE_LEVELS.to_vec();
        for c in &plan.calibration_checks {
            if !levels.contains(&c.level) {
                levels.push(c.level);
            }
        }
        let count = plan.integrands.len() * plan.estimators.len() * plan.samples.len();
        let cell = CellState {
            errors: Vec::new(),
            sds: Vec::new(),
            all_sd: true,
            hits: vec![0; levels.len()],
            quantiles: Vec::new(),
            warnings: 0,
            evaluations: 0,
            seconds: 0.0,
            trial_seconds: Vec::new(),
            weight_set_seconds: 0.0,
            model_counts: Vec::new(),
        };
        let mut cells = vec![cell; count];
        for c in &mut cells {
            c.errors.reserve_exact(plan.trials);
            c.sds.reserve_exact(plan.trials);
            c.trial_seconds.reserve_exact(plan.trials);
        }
        Accumulator {
            estimators: plan.estimators.len(),
            samples: plan.samples.clone(),
            levels,
            cells,
        }
    }

    fn index(&self, integrand: usize, estimator: usize, n_index: usize) -> usize {
        (integrand * self.estimators + estimator) * self.samples.len() + n_index
    }

    /// Adds the next trial of cell (integrand, estimator, N): trials must come in order.
    pub fn push(&mut self, integrand: usize, estimator: usize, n_index: usize, row: &RowValues) {
        let i = self.index(integrand, estimator, n_index);
        let levels = &self.levels;
        let c = &mut self.cells[i];
        c.errors.push(row.abs_error);
        c.warnings += u64::from(row.warnings);
        c.evaluations += row.evaluations;
        c.seconds += row.seconds;
        c.trial_seconds.push(row.seconds as f32);
        c.weight_set_seconds += row.weight_set_seconds;
        if let Some(k) = row.model.map(usize::from) {
            if c.model_counts.len() <= k {
                c.model_counts.resize(k + 1, 0);
            }
            c.model_counts[k] += 1;
        }
        match row.sd {
            Some((sd, dof)) if c.all_sd => {
                c.sds.push(sd);
                let k = match c.quantiles.iter().position(|(d, _)| *d == dof) {
                    Some(k) => k,
                    None => {
                        let q = levels
                            .iter()
                            .map(|&l| crate::util::stats::interval_quantile(dof, l))
                            .collect();
                        c.quantiles.push((dof, q));
                        c.quantiles.len() - 1
                    }
                };
                for (hit, q) in c.hits.iter_mut().zip(&c.quantiles[k].1) {
                    *hit += u64::from(row.abs_error <= q * sd);
                }
            }
            Some(_) => {}
            None => {
                c.all_sd = false;
                c.sds = Vec::new();
            }
        }
    }

    /// Trials added to cell (integrand, estimator, N) so far.
    pub fn trials(&self, integrand: usize, estimator: usize, n_index: usize) -> usize {
        self.cells[self.index(integrand, estimator, n_index)].errors.len()
    }

    /// Absolute errors of one cell, in trial order.
    pub fn abs_errors(&self, integrand: usize, estimator: usize, n_index: usize) -> &[f64] {
        &self.cells[self.index(integrand, estimator, n_index)].errors
    }

    /// The share of the cell's trials whose interval `Î ± q · sd` at `level` holds the truth;
    /// None if a trial has no interval. `level` must be one of [`COVERAGE_LEVELS`] or a
    /// calibration check's.
    pub fn coverage_at(&self, integrand: usize, estimator: usize, n_index: usize, level: f64) -> Option<f64> {
        let c = &self.cells[self.index(integrand, estimator, n_index)];
        let k = self
            .levels
            .iter()
            .position(|&l| l == level)
            .expect("the level is counted");
        c.all_sd.then(|| c.hits[k] as f64 / c.errors.len() as f64)
    }

    /// All cell summaries, ordered by integrand, estimator, N (the plan's orders).
    pub fn summarize(&self, plan: &Plan) -> Vec<CellSummary> {
        let mut out = Vec::with_capacity(self.cells.len());
        for fi in 0..plan.integrands.len() {
            for ei in 0..plan.estimators.len() {
                for (ni, &n) in plan.samples.iter().enumerate() {
                    let c = &self.cells[self.index(fi, ei, ni)];
                    out.push(summarize_cell(c, fi, ei, n, |level| {
                        self.coverage_at(fi, ei, ni, level)
                    }));
                }
            }
        }
        out
    }
}

fn summarize_cell(
    c: &CellState,
    integrand: usize,
    estimator: usize,
    n: usize,
    coverage_at: impl Fn(f64) -> Option<f64>,
) -> CellSummary {
    let errors = &c.errors;
    let mut sorted = errors.clone();
    sorted.sort_by(f64::total_cmp);
    let sds = c.all_sd.then_some(&c.sds);
    let coverage =
        sds.map(|_| COVERAGE_LEVELS.map(|level| coverage_at(level).expect("every trial has an sd")));
    let median_error_over_sd = sds.map(|sds| {
        let mut ratios: Vec<f64> = errors
            .iter()
            .zip(sds)
            .map(|(&e, &sd)| if e == 0.0 { 0.0 } else { e / sd })
            .collect();
        ratios.sort_by(f64::total_cmp);
        quantile_sorted(&ratios, 0.5)
    });
    let trials = errors.len();
    let mut seconds: Vec<f64> = c.trial_seconds.iter().map(|&x| f64::from(x)).collect();
    seconds.sort_by(f64::total_cmp);
    CellSummary {
        integrand,
        estimator,
        n,
        trials,
        mean_abs_error: mean(errors),
        ci95: mean_ci95(errors),
        median_abs_error: quantile_sorted(&sorted, 0.5),
        q10_abs_error: quantile_sorted(&sorted, 0.1),
        q90_abs_error: quantile_sorted(&sorted, 0.9),
        mean_posterior_sd: sds.map(|s| mean(s)),
        coverage,
        median_error_over_sd,
        warnings: c.warnings,
        mean_evaluations: c.evaluations as f64 / trials as f64,
        mean_seconds: c.seconds / trials as f64,
        median_seconds: quantile_sorted(&seconds, 0.5),
        mean_weight_set_seconds: c.weight_set_seconds / trials as f64,
        model_counts: c.model_counts.clone(),
    }
}

/// The binomial 99% band around `level` for `trials` trials: `level ± z₀.₉₉₅ sqrt(level (1 −
/// level) / trials)` (normal approximation to the binomial count of covering trials), clipped to
/// [0, 1]. A calibrated estimator's coverage falls outside it in about 1% of cells.
pub fn binomial_band(level: f64, trials: usize) -> (f64, f64) {
    let half =
        crate::util::stats::interval_quantile(None, 0.99) * (level * (1.0 - level) / trials as f64).sqrt();
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
pub fn evaluate_check(plan: &Plan, summary: &Accumulator, check: &Check) -> CheckOutcome {
    let mut cells = Vec::new();
    for fi in 0..plan.integrands.len() {
        for (ni, &n) in plan.samples.iter().enumerate() {
            if n < check.from_n {
                continue;
            }
            let a = summary.abs_errors(fi, check.better_index, ni);
            let b = summary.abs_errors(fi, check.than_index, ni);
            let test = paired_t_less(a, b);
            let (mean_better, mean_than) = (mean(a), mean(b));
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

/// Whether `coverage` passes a check on `side` of `band`.
pub fn accepts(side: CheckSide, band: (f64, f64), coverage: f64) -> bool {
    match side {
        CheckSide::TwoSided => band.0 <= coverage && coverage <= band.1,
        CheckSide::Lower => band.0 <= coverage,
    }
}

/// Evaluates a calibration check: in every (integrand, N ≥ from_n) cell the estimator's
/// coverage at the level lies within [`binomial_band`] around it, or for
/// [`CheckSide::Lower`] at or above its lower edge.
pub fn evaluate_calibration(
    plan: &Plan,
    summary: &Accumulator,
    check: &CalibrationCheck,
) -> CalibrationOutcome {
    let band = binomial_band(check.level, plan.trials);
    let mut cells = Vec::new();
    for fi in 0..plan.integrands.len() {
        for (ni, &n) in plan.samples.iter().enumerate() {
            if n < check.from_n {
                continue;
            }
            let coverage = summary
                .coverage_at(fi, check.index, ni, check.level)
                .expect("validation ensures an interval at every checked N");
            cells.push(CalibrationCell {
                integrand: fi,
                n,
                coverage,
                passed: accepts(check.side, band, coverage),
            });
        }
    }
    CalibrationOutcome {
        check: check.clone(),
        band,
        cells,
    }
}
