//! `workbench run` and `workbench validate`: declarative experiments.
//!
//! spec (JSON) → [`plan::Plan`] (validated) → [`runner::run`] (parallel) → [`summary`] →
//! [`export`] / [`plot`] (pure) → one atomic write per file.

pub mod export;
pub mod plan;
pub mod plot;
pub mod runner;
pub mod spec;
pub mod summary;

use crate::io::{InputError, write_atomic};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Most worker threads `--threads` accepts (each holds its own `Q` and factor).
pub const MAX_THREADS: usize = 256;

/// Command-line overrides of the experiment file.
#[derive(Debug, Clone, Default)]
pub struct Overrides {
    pub out: Option<PathBuf>,
    pub trials: Option<u64>,
    pub threads: Option<usize>,
    pub quiet: bool,
}

/// Reads, applies overrides, validates. Errors are [`InputError`]s naming the file.
pub fn load_plan(path: &Path, overrides: &Overrides) -> Result<plan::Plan, InputError> {
    let file = path.display().to_string();
    let text =
        std::fs::read_to_string(path).map_err(|e| InputError::new(format!("{file}: cannot read: {e}")))?;
    let mut spec = plan::parse(&text).map_err(|m| InputError::new(format!("{file}: {m}")))?;
    if let Some(t) = overrides.trials {
        if t == 0 {
            return Err(InputError::new("--trials: must be at least 1, got 0"));
        }
        if t < 2 && !spec.checks.is_empty() {
            return Err(InputError::new(format!(
                "--trials {t}: the file's checks need at least 2 trials for their paired test"
            )));
        }
        spec.trials = t;
    }
    if let Some(t) = overrides.threads.filter(|&t| t == 0 || t > MAX_THREADS) {
        return Err(InputError::new(format!(
            "--threads: must be in 1..={MAX_THREADS}, got {t}"
        )));
    }
    let plan = plan::resolve(&spec).map_err(|m| InputError::new(format!("{file}: {m}")))?;
    for w in plan.models.iter().filter_map(|m| m.accuracy_warning()) {
        crate::status!("warning: {w}");
    }
    Ok(plan)
}

/// A human-readable account of a plan (for `validate`), followed by the resolved JSON.
pub fn describe(plan: &plan::Plan) -> String {
    let cells = plan.integrands.len() * plan.estimators.len() * plan.samples.len();
    let weight_sets: usize = {
        let mut keys: Vec<(usize, crate::sampling::SetDesign)> = plan
            .estimators
            .iter()
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
    s += &format!(
        "BMC weight sets: {} per trial and N ({} Cholesky factorisations; largest N = {max_n}, {:.1} MiB per thread)\n",
        weight_sets,
        weight_sets * plan.samples.len() * plan.trials,
        if weight_sets > 0 {
            16.0 * (max_n as f64).powi(2) / (1u64 << 20) as f64
        } else {
            0.0
        }
    );
    s += &serde_json::to_string_pretty(&export::plan_json(plan)).expect("plan serializes");
    s.push('\n');
    s
}

/// What a run produced, for the caller to report.
pub struct RunReport {
    pub out_dir: PathBuf,
    pub cells: Vec<summary::CellSummary>,
    pub checks: Vec<summary::CheckOutcome>,
    pub wall_seconds: f64,
    pub threads: usize,
    pub warnings: Vec<(String, usize)>,
}

/// Runs a validated plan and writes every output under the output folder.
pub fn run_plan(plan: &plan::Plan, overrides: &Overrides) -> anyhow::Result<RunReport> {
    let out_dir = overrides
        .out
        .clone()
        .unwrap_or_else(|| Path::new("results").join(&plan.name));
    // Fail on an unwritable folder now, not after the run.
    std::fs::create_dir_all(&out_dir).map_err(|e| anyhow::anyhow!("creating {}: {e}", out_dir.display()))?;
    tempfile::tempfile_in(&out_dir)
        .map_err(|e| anyhow::anyhow!("{} is not writable: {e}", out_dir.display()))?;

    let pool = {
        let mut b = rayon::ThreadPoolBuilder::new();
        if let Some(t) = overrides.threads {
            b = b.num_threads(t);
        }
        b.build()?
    };
    let threads = pool.current_num_threads();
    let units = (plan.samples.len() * plan.trials) as u64;
    let bar = progress_bar(units, overrides.quiet);
    let start = Instant::now();
    let results = pool.install(|| runner::run(plan, &|| bar.inc(1)))?;
    bar.finish_and_clear();
    let wall_seconds = start.elapsed().as_secs_f64();

    let cells = summary::summarize(plan, &results);
    let checks: Vec<_> = plan
        .checks
        .iter()
        .map(|c| summary::evaluate_check(plan, &results, c))
        .collect();

    write_atomic(&out_dir.join("trials.csv"), &export::trials_csv(plan, &results))?;
    write_atomic(&out_dir.join("summary.csv"), &export::summary_csv(plan, &cells))?;
    for (fi, f) in plan.integrands.iter().enumerate() {
        let svg = plot::error_plot_svg(plan, &cells, fi)?;
        write_atomic(&out_dir.join(format!("{}.svg", f.name())), svg.as_bytes())?;
    }
    write_atomic(
        &out_dir.join("manifest.json"),
        &export::manifest_json(plan, threads, wall_seconds, &checks),
    )?;

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
        wall_seconds,
        threads,
        warnings,
    })
}

fn progress_bar(len: u64, quiet: bool) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if quiet || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} trials×N  {elapsed} (ETA {eta})")
            .expect("valid template"),
    );
    bar
}

/// The summary table (estimators side by side per N) and the check lines.
pub fn format_report(plan: &plan::Plan, report: &RunReport) -> String {
    let mut s = String::new();
    for (fi, f) in plan.integrands.iter().enumerate() {
        s += &format!(
            "\n{} — ∫ {} dω = {:.10}; mean |Î − I| over {} trials [95% CI half-width]\n",
            plan.title,
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
    s
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
