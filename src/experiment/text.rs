//! Text for people: the plan (`validate`) and the results table with the check lines (`run`).
//! Pure functions; the binary prints them.

use super::plan;
use super::spec::CheckSide;
use super::summary;
use super::{RunReport, export};

/// `x` with `digits` significant digits, trailing zeros kept (`0.9897`, `1.000`, `0.05000`).
pub fn significant(x: f64, digits: usize) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let magnitude = x.abs().log10().floor() as i64;
    let decimals = (digits as i64 - 1 - magnitude).max(0) as usize;
    format!("{x:.decimals$}")
}

/// A human-readable account of a plan (for `validate`), followed by the resolved JSON.
pub fn describe(plan: &plan::Plan) -> String {
    let cells = plan.integrands.len() * plan.estimators.len() * plan.samples.len();
    let weight_sets: usize = {
        let mut keys: Vec<(usize, crate::sampling::Design)> = plan
            .estimators
            .iter()
            .filter(|e| e.tolerance.is_none())
            .filter_map(|e| e.model.map(|m| (m, e.design)))
            .collect();
        keys.sort_by_key(|k| (k.0, k.1.name()));
        keys.dedup();
        keys.len()
    };
    let max_n = plan.samples.iter().max().copied().unwrap_or(0);
    let mut s = format!(
        "{}: {} integrand(s) × {} estimator(s) × {} sample count(s) × {} trials = {} estimates in {cells} cells\n",
        plan.name,
        plan.integrands.len(),
        plan.estimators.len(),
        plan.samples.len(),
        plan.trials,
        cells * plan.trials
    );
    // The run's own memory estimate (what its guard checks), tolerance estimators' nested
    // factors included: this line said "0.0 MiB per thread" for them (issue 30).
    let (per_thread, what) = plan::thread_memory(plan);
    s += &format!(
        "BMC weight sets: {} per trial and N ({} Cholesky factorisations; largest N = {max_n}); memory: {} per \
         worker thread, for {what}\n",
        weight_sets,
        weight_sets * plan.samples.len() * plan.trials,
        crate::util::memory::human(per_thread),
    );
    let tolerant: Vec<_> = plan.estimators.iter().filter_map(|e| e.tolerance).collect();
    if let Some(largest) = tolerant.iter().map(|t| t.max_n).max() {
        s += &format!(
            "tolerance estimators: {} (each trial doubles N from its sample count or its pilot min_n, whichever is \
             larger, until its half-width meets the tolerance, never on zero evidence; nested sets up to N = {largest})\n",
            tolerant.len()
        );
    }
    s += &serde_json::to_string_pretty(&export::plan_json_with_plot(plan)).expect("plan serializes");
    s.push('\n');
    s
}

/// The summary table (estimators side by side per N) and the check lines.
pub fn format_report(plan: &plan::Plan, report: &RunReport) -> String {
    let mut s = String::new();
    for (fi, f) in plan.integrands.iter().enumerate() {
        s += &format!(
            "\n{} — {} ({}): ∫ f dω = {:.10}; mean |Î − I| over {} trials [95% CI half-width]\n",
            plan.title,
            f.display_name(),
            f.name(),
            f.integral(),
            plan.trials
        );
        s += &format!("{:>7}", "N");
        for e in &plan.estimators {
            s += &format!("  {:>22}", e.label);
        }
        s.push('\n');
        for &n in &plan.samples {
            s += &format!("{n:>7}");
            for ei in 0..plan.estimators.len() {
                let c = report
                    .cells
                    .iter()
                    .find(|c| c.integrand == fi && c.estimator == ei && c.n == n)
                    .expect("every cell is summarised");
                let half = 0.5 * (c.ci95.1 - c.ci95.0);
                let cell = if half.is_nan() {
                    format!("{:.3e}", c.mean_abs_error)
                } else {
                    format!("{:.3e} [{half:.1e}]", c.mean_abs_error)
                };
                s += &format!("  {cell:>22}");
            }
            s.push('\n');
        }
    }
    s.push('\n');
    for o in &report.checks {
        s += &check_line(plan, o);
        s.push('\n');
    }
    for o in &report.calibration {
        s += &calibration_line(plan, o);
        s.push('\n');
    }
    s
}

fn calibration_line(plan: &plan::Plan, o: &summary::CalibrationOutcome) -> String {
    let c = &o.check;
    // Four significant digits: a band edge of 0.9897 shown as 0.990 would seem to admit a
    // coverage of 0.990 that fails.
    let (lo, hi) = (significant(o.band.0, 4), significant(o.band.1, 4));
    let head = match c.side {
        CheckSide::TwoSided => format!(
            "check {} calibrated at {} for N ≥ {} (coverage in the binomial 99% band {lo}–{hi})",
            c.calibrated, c.level, c.from_n
        ),
        CheckSide::Lower => format!(
            "check {} calibrated at {}, lower side, for N ≥ {} (coverage no worse than the level: at least \
             {lo}, the lower edge of the binomial 99% band)",
            c.calibrated, c.level, c.from_n
        ),
    };
    if o.passed() {
        let (lo, hi) = o
            .cells
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| {
                (l.min(x.coverage), h.max(x.coverage))
            });
        format!(
            "PASS {head}: {} cells, coverage {}–{}",
            o.cells.len(),
            significant(lo, 4),
            significant(hi, 4)
        )
    } else {
        let fails: Vec<String> = o
            .cells
            .iter()
            .filter(|x| !x.passed)
            .map(|x| {
                format!(
                    "{} N={}: coverage {}",
                    plan.integrands[x.integrand].name(),
                    x.n,
                    significant(x.coverage, 4)
                )
            })
            .collect();
        format!("FAIL {head}: {}", fails.join("; "))
    }
}

fn check_line(plan: &plan::Plan, o: &summary::CheckOutcome) -> String {
    let c = &o.check;
    let head = format!(
        "check {} < {} for N ≥ {} (paired t-test, α = {})",
        c.better, c.than, c.from_n, c.alpha
    );
    if o.passed() {
        let worst = o.cells.iter().map(|x| x.test.p_value).fold(0.0, f64::max);
        format!("PASS {head}: {} cells, largest p = {worst:.2e}", o.cells.len())
    } else {
        let fails: Vec<String> = o
            .cells
            .iter()
            .filter(|x| !x.passed)
            .map(|x| {
                format!(
                    "{} N={}: {} {:.3e} vs {} {:.3e}, p = {:.3}",
                    plan.integrands[x.integrand].name(),
                    x.n,
                    c.better,
                    x.mean_better,
                    c.than,
                    x.mean_than,
                    x.test.p_value
                )
            })
            .collect();
        format!("FAIL {head}: {}", fails.join("; "))
    }
}
