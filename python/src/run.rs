//! `run(spec)`: an experiment's trials in memory, the rows of `trials.csv` as columns; and the
//! points a run's trial draws.

use crate::args::{Text, Whole};
use crate::arrays;
use crate::{library_error, value_error};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use workbench::experiment::plan::Plan;
use workbench::experiment::rows::TrialRow;

/// The plan of a spec dict (its messages: `path: message`) or of an experiment file (the CLI's:
/// `file: path: message`).
fn plan_of(py: Python<'_>, spec: &Bound<'_, PyAny>) -> PyResult<Plan> {
    if spec.cast::<PyDict>().is_ok() {
        let dumps = py.import("json")?.getattr("dumps")?;
        let kwargs = PyDict::new(py);
        kwargs.set_item("allow_nan", false)?;
        let text: String = dumps
            .call((spec,), Some(&kwargs))
            .map_err(|e| value_error(format!("spec: {}", e.value(py))))?
            .extract()?;
        let parsed = workbench::experiment::plan::parse(&text).map_err(value_error)?;
        return py
            .detach(|| workbench::experiment::plan::resolve(&parsed))
            .map_err(value_error);
    }
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
    py.detach(|| workbench::experiment::load_plan(&path, &Default::default()))
        .map_err(|e| value_error(e.0))
}

/// `run(spec, *, threads=None) -> dict`: the trials of an experiment (a dict as its JSON, or an
/// experiment file's path), every row of `trials.csv` in its order, as columns. Writes nothing.
#[pyfunction]
#[pyo3(signature = (spec, *, threads=None))]
pub fn run<'py>(
    py: Python<'py>,
    spec: &Bound<'py, PyAny>,
    threads: Option<Whole>,
) -> PyResult<Bound<'py, PyDict>> {
    let threads = threads.map(|t| t.count("threads")).transpose()?;
    if let Some(t) = threads {
        workbench::util::threads::check_threads(t).map_err(|_| {
            value_error(format!(
                "threads: must be in 1..={}, got {t}",
                workbench::util::threads::MAX_THREADS
            ))
        })?;
    }
    let plan = plan_of(py, spec)?;
    // The run's memory guard, as the CLI's `run` (every worker thread holds its weight sets).
    workbench::experiment::plan::check_memory(&plan, workbench::util::threads::worker_threads(threads))
        .map_err(|e| value_error(e.0))?;
    for w in plan.models.iter().filter_map(|m| m.accuracy_warning()) {
        crate::model::warn(py, &w)?;
    }
    let rows = py
        .detach(|| -> workbench::Result<Vec<TrialRow>> {
            let pool = workbench::util::threads::pool(threads)?;
            let results = pool.install(|| workbench::experiment::runner::run(&plan, &|| {}))?;
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
            Ok(rows)
        })
        .map_err(library_error)?;
    columns(py, &plan, &rows)
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

/// `trial_points(seed, design, n, trial) -> points`: the points `design` draws at `n` in trial
/// `trial` of an experiment with master seed `seed` (every estimator with that design sees them).
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
