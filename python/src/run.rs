//! `run(spec)`: an experiment's trials in memory, the rows of `trials.csv` as columns; and the
//! points a run's trial draws.

use crate::args::{Text, Whole};
use crate::arrays;
use crate::{library_error, value_error};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use workbench::experiment::plan::Plan;
use workbench::experiment::rows::TrialRow;
use workbench::experiment::spec::ExternalSpec;
use workbench::integrand::Integrand;
use workbench::integrand::external::ExternalIntegrand;

/// The plan of a spec dict (its messages: `path: message`) or of an experiment file (the CLI's:
/// `file: path: message`), its `"type": "python"` integrands taken from `integrands` (a dict of
/// callables). The spec is checked whole, with the given truths or a stand-in, before any
/// truth is computed by cubature (which calls the callables).
fn plan_of(py: Python<'_>, spec: &Bound<'_, PyAny>, integrands: Option<&Bound<'_, PyAny>>) -> PyResult<Plan> {
    let (text, file) = if spec.cast::<PyDict>().is_ok() {
        let dumps = py.import("json")?.getattr("dumps")?;
        let kwargs = PyDict::new(py);
        kwargs.set_item("allow_nan", false)?;
        let text: String = dumps
            .call((spec,), Some(&kwargs))
            .map_err(|e| value_error(format!("spec: {}", e.value(py))))?
            .extract()?;
        (text, None)
    } else {
        let is_path =
            spec.cast::<PyString>().is_ok() || spec.is_instance(&py.import("os")?.getattr("PathLike")?)?;
        if !is_path {
            return Err(value_error(format!(
                "spec: must be an experiment as a dict (the JSON of an experiment file) or the path of an \
                 experiment file, got a Python {}",
                spec.get_type().name().map_or("?".into(), |n| n.to_string())
            )));
        }
        let path: std::path::PathBuf = spec.extract()?;
        let text = py
            .detach(|| workbench::files::spec_json::read_spec(&path))
            .map_err(|e| value_error(e.0))?;
        (text, Some(path.display().to_string()))
    };
    let at_file = |m: String| match &file {
        Some(f) => value_error(format!("{f}: {m}")),
        None => value_error(m),
    };
    let parsed = workbench::experiment::plan::parse(&text).map_err(at_file)?;
    let callables = crate::external::callables(py, integrands, &parsed)?;
    // First pass: everything but the computed truths (a stand-in of 0), so that a bad estimator
    // is reported before seconds of cubature.
    let mut stand_in = |e: &ExternalSpec| {
        let f = callables
            .get(&e.name)
            .expect("every python integrand has a callable")
            .clone();
        let spec = ExternalSpec {
            truth: Some(e.truth.unwrap_or(0.0)),
            tolerance: None,
            ..e.clone()
        };
        if let Some(t) = e.tolerance {
            check_tolerance(e, t)?;
        }
        ExternalIntegrand::new(&spec, f).map(|f| Integrand::External(Box::new(f)))
    };
    py.detach(|| workbench::experiment::plan::resolve_with(&parsed, &mut stand_in))
        .map_err(at_file)?;
    // Then for real (the callables are called with the GIL taken back).
    let mut real = |e: &ExternalSpec| {
        let f = callables
            .get(&e.name)
            .expect("every python integrand has a callable")
            .clone();
        ExternalIntegrand::new(e, f).map(|f| Integrand::External(Box::new(f)))
    };
    py.detach(|| workbench::experiment::plan::resolve_with(&parsed, &mut real))
        .map_err(at_file)
}

/// Numerical warnings grouped by their first words, with their counts.
type Warnings = Vec<(String, usize)>;

/// `tolerance` of a python integrand: positive, finite, and only without `truth`.
fn check_tolerance(e: &ExternalSpec, t: f64) -> Result<(), String> {
    if e.truth.is_some() {
        return Err("tolerance: is the computed truth's; with \"truth\" given there is none".into());
    }
    if !(t > 0.0 && t.is_finite()) {
        return Err(format!("tolerance: must be a positive number, got {t}"));
    }
    Ok(())
}

/// Runs an experiment (a dict holding an experiment file's JSON, or such a file's path) and
/// returns the rows of its ``trials.csv``, in its order, as columns: ``integrand``,
/// ``estimator``, ``method``, ``design`` and (for plans with a fitted kernel) ``model`` are lists
/// of str; ``n``, ``trial``, ``warnings`` int64 arrays; the rest float64 arrays with NaN where
/// the CSV is empty. ``pandas.DataFrame(run(spec))`` is the CSV as a frame. Every number is the
/// CLI's to the bit, whatever ``threads``. Without ``out`` it writes no files.
///
/// ``integrands`` maps names to your own integrands: callables taking a float64 array of shape
/// ``(n, 3)`` (unit directions, ``z ≥ 0``) and returning ``n`` values (anything
/// ``numpy.asarray(…, dtype=float64)`` turns into shape ``(n,)``), called once per trial's point
/// set, never per point, from the run's worker threads (one at a time, holding the GIL): they
/// must be pure functions of the points. The spec names each as ``{"type": "python", "name":
/// NAME}`` with optional ``"truth"`` (∫ f dω if known), ``"tolerance"`` (the absolute error
/// estimate of the computed truth; default 1e-10 · ∫|f| dω) and ``"display_name"``. Without a
/// truth it is computed by adaptive Gauss–Kronrod cubature over the hemisphere; its error
/// estimate goes into ``manifest.json`` (``truth_error_estimate``). A callable that raises,
/// returns another shape or non-finite values is a ``ValueError`` naming the integrand, the
/// trial and N, and nothing is written.
///
/// With ``out`` (a folder) it writes what ``workbench run FILE --out OUT`` writes — CSVs,
/// figures, summary, checks, manifest — and returns ``{"out": str, "report": str, "passed":
/// bool}``: the folder, the text the CLI prints and whether every check passed.
///
/// Errors are the CLI's messages: for a file ``file: path: message``, for a dict ``path:
/// message``.
#[pyfunction]
#[pyo3(signature = (spec, *, integrands=None, out=None, threads=None))]
pub fn run<'py>(
    py: Python<'py>,
    spec: &Bound<'py, PyAny>,
    integrands: Option<&Bound<'py, PyAny>>,
    out: Option<&Bound<'py, PyAny>>,
    threads: Option<Whole>,
) -> PyResult<Bound<'py, PyDict>> {
    let threads = threads.map(|t| t.count("threads")).transpose()?;
    if let Some(t) = threads {
        workbench::util::threads::check_threads(t, "threads").map_err(|_| {
            value_error(format!(
                "threads: must be in 1..={}, got {t}",
                workbench::util::threads::MAX_THREADS
            ))
        })?;
    }
    let out = out
        .map(|o| {
            let is_path =
                o.cast::<PyString>().is_ok() || o.is_instance(&py.import("os")?.getattr("PathLike")?)?;
            if !is_path {
                return Err(value_error(format!(
                    "out: must be a folder path (str or os.PathLike), got {}",
                    arrays::describe(o)
                )));
            }
            o.extract::<std::path::PathBuf>()
        })
        .transpose()?;
    let plan = plan_of(py, spec, integrands)?;
    // The run's memory guard, as the CLI's `run` (every worker thread holds its weight sets).
    workbench::experiment::plan::check_memory(&plan, workbench::util::threads::worker_threads(threads))
        .map_err(|e| value_error(e.0))?;
    for w in plan.models.iter().filter_map(|m| m.accuracy_warning()) {
        crate::model::warn(py, &w)?;
    }
    if let Some(out) = out {
        return write_folder(py, &plan, spec, out, threads);
    }
    let (rows, warnings) = py
        .detach(|| -> workbench::Result<(Vec<TrialRow>, Warnings)> {
            let pool = workbench::util::threads::pool(threads)?;
            let results = pool.install(|| workbench::experiment::runner::run(&plan, &|| {}))?;
            // The weight sets' numerical warnings, grouped as the CLI prints them.
            let mut warnings = Vec::new();
            for r in &results.units {
                workbench::experiment::drive::group_warnings(&mut warnings, &r.messages);
            }
            // Units come in (N, trial) order, each with its rows in (integrand, estimator) order;
            // trials.csv is in (integrand, estimator, N, trial) order.
            let per_unit: Vec<Vec<TrialRow>> = results
                .units
                .iter()
                .enumerate()
                .map(|(u, r)| {
                    workbench::experiment::rows::unit_row_values(&plan, r, u / plan.trials, u % plan.trials)
                        .into_iter()
                        .map(|(row, _)| row)
                        .collect()
                })
                .collect();
            let (ne, nn) = (plan.estimators.len(), plan.samples.len());
            let mut rows = Vec::with_capacity(per_unit.len() * plan.integrands.len() * ne);
            for fi in 0..plan.integrands.len() {
                for ei in 0..ne {
                    for ni in 0..nn {
                        for t in 0..plan.trials {
                            rows.push(per_unit[ni * plan.trials + t][fi * ne + ei].clone());
                        }
                    }
                }
            }
            Ok((rows, warnings))
        })
        .map_err(library_error)?;
    for (message, count) in &warnings {
        crate::model::warn(py, &format!("{count} weight set(s): {message}"))?;
    }
    // What the `warnings` column counts beyond those: zero evidence (a fitted amplitude of 0)
    // and estimates that are not finite, as one warning for the run.
    let counted: u64 = rows.iter().map(|r| u64::from(r.warnings)).sum();
    if counted > 0 {
        let rows_with = rows.iter().filter(|r| r.warnings > 0).count();
        crate::model::warn(
            py,
            &format!(
                "{rows_with} of {} rows have warnings ({counted} in the warnings column: numerical warnings of \
                 their weight sets, zero evidence — a fitted amplitude of 0 —, estimates that are not finite)",
                rows.len()
            ),
        )?;
    }
    columns(py, &plan, &rows)
}

/// `run(…, out=…)`: the result folder as `workbench run FILE --out OUT` writes it (CSVs, figures,
/// summary, checks, manifest), without the GIL but for the callables; returns `out`, the text the
/// CLI prints (`report`) and whether every check passed (`passed`). The weight sets' numerical
/// warnings become `RuntimeWarning`s. A failing callable leaves nothing written.
fn write_folder<'py>(
    py: Python<'py>,
    plan: &Plan,
    spec: &Bound<'py, PyAny>,
    out: std::path::PathBuf,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    use workbench::experiment as ex;
    let spec_path = if spec.cast::<PyDict>().is_ok() {
        None
    } else {
        Some(spec.extract::<std::path::PathBuf>()?)
    };
    let overrides = ex::Overrides {
        out: Some(out),
        threads,
        spec: spec_path,
        ..Default::default()
    };
    let report = py
        .detach(|| ex::run_plan(plan, &overrides, &workbench::util::report::Silent))
        .map_err(library_error)?;
    for (message, count) in &report.warnings {
        crate::model::warn(py, &format!("{count} weight set(s): {message}"))?;
    }
    let text = format!(
        "{}{}",
        ex::format_report(plan, &report),
        ex::adaptive::format_report(plan, &report.stopping, &report.tolerance_checks)
    )
    .trim_start_matches('\n')
    .to_string();
    let passed = report.checks.iter().all(|c| c.passed())
        && report.calibration.iter().all(|c| c.passed())
        && report.tolerance_checks.iter().all(|c| c.passed());
    let d = PyDict::new(py);
    d.set_item("out", report.out_dir.display().to_string())?;
    d.set_item("report", text)?;
    d.set_item("passed", passed)?;
    Ok(d)
}

/// The rows as `trials.csv`'s columns: strings as lists, numbers as numpy arrays (`n`, `trial`,
/// `warnings` int64; the rest float64, NaN where the CSV is empty — what `pandas.read_csv` gives).
fn columns<'py>(py: Python<'py>, plan: &Plan, rows: &[TrialRow]) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    let text = |f: &dyn Fn(&TrialRow) -> String| rows.iter().map(f).collect::<Vec<String>>();
    let float = |f: &dyn Fn(&TrialRow) -> Option<f64>| {
        arrays::vector(py, rows.iter().map(|r| f(r).unwrap_or(f64::NAN)).collect())
    };
    let int = |f: &dyn Fn(&TrialRow) -> i64| numpy::PyArray1::from_vec(py, rows.iter().map(f).collect());
    out.set_item("integrand", text(&|r| plan.integrands[r.integrand].name()))?;
    out.set_item("estimator", text(&|r| plan.estimators[r.estimator].label.clone()))?;
    out.set_item(
        "method",
        text(&|r| plan.estimators[r.estimator].method.name().to_string()),
    )?;
    out.set_item(
        "design",
        text(&|r| plan.estimators[r.estimator].design.name().to_string()),
    )?;
    out.set_item("n", int(&|r| r.n as i64))?;
    out.set_item("trial", int(&|r| r.trial as i64))?;
    out.set_item("estimate", float(&|r| Some(r.estimate)))?;
    out.set_item("truth", float(&|r| Some(r.truth)))?;
    out.set_item("abs_error", float(&|r| Some(r.abs_error)))?;
    out.set_item("posterior_sd", float(&|r| r.posterior_sd))?;
    out.set_item("warnings", int(&|r| i64::from(r.warnings)))?;
    out.set_item("weight_sum", float(&|r| r.weight_set.map(|w| w.0)))?;
    out.set_item("negative_weights", float(&|r| r.weight_set.map(|w| w.1 as f64)))?;
    out.set_item("jitter", float(&|r| r.weight_set.map(|w| w.2)))?;
    out.set_item("condition_estimate", float(&|r| r.weight_set.map(|w| w.3)))?;
    out.set_item("amplitude", float(&|r| r.amplitude))?;
    out.set_item("dof", float(&|r| r.dof.map(|d| d as f64)))?;
    if plan.has_fitted_model() {
        out.set_item("model", text(&|r| r.model.clone().unwrap_or_default()))?;
    }
    Ok(out)
}

/// The points ``design`` draws at ``n`` in trial ``trial`` of an experiment with master seed
/// ``seed``: what every estimator with that design sees in that row of ``trials.csv``.
#[pyfunction]
pub fn trial_points<'py>(
    py: Python<'py>,
    seed: Whole,
    design: Text,
    n: Whole,
    trial: Whole,
) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
    let seed = seed.get("seed")?;
    let design = design.get("design")?;
    let n = n.count("n")?;
    let trial = trial.count("trial")?;
    let d = workbench::sampling::Design::from_name(design).ok_or_else(|| {
        value_error(format!(
            "design: unknown design {design:?}; expected one of {}",
            workbench::sampling::Design::names()
        ))
    })?;
    if n == 0 {
        return Err(value_error("n: must be at least 1, got 0"));
    }
    d.check_count(n)
        .map_err(|m| value_error(format!("n: {n} with design {design:?}: {m}")))?;
    let max = workbench::experiment::plan::MAX_UNIT_POINTS as usize;
    if n > max {
        return Err(value_error(format!("n: at most {max} points, got {n}")));
    }
    let points = py.detach(|| workbench::experiment::runner::trial_points(seed, d, n, trial));
    Ok(arrays::points_array(py, &points))
}
