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
        (crate::json::to_json(spec, "")?, None)
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

/// `summary.csv`, `stopping_trials.csv` and `stopping_summary.csv` as the CLI writes them.
type Tables = [Vec<u8>; 3];

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
/// ``numpy.asarray(…, dtype=float64)`` turns into shape ``(n,)``; complex values and strings are
/// refused, not converted), called once per trial's point
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
/// With ``tables=True`` it returns every table of the run as columns instead: ``{"trials": …,
/// "summary": …, "stopping_trials": …, "stopping_summary": …}`` — ``trials.csv`` (as above),
/// ``summary.csv`` and, for tolerance estimators, ``stopping_trials.csv`` (per trial the points
/// used, ``n_used``) and ``stopping_summary.csv`` (``{}`` without tolerance estimators), each the
/// CLI's CSV to the bit. With ``out`` too, these keys are added to the folder's dict.
///
/// Errors are the CLI's messages: for a file ``file: path: message``, for a dict ``path:
/// message``.
#[pyfunction]
#[pyo3(signature = (spec, *, integrands=None, out=None, threads=None, tables=false))]
pub fn run<'py>(
    py: Python<'py>,
    spec: &Bound<'py, PyAny>,
    integrands: Option<&Bound<'py, PyAny>>,
    out: Option<&Bound<'py, PyAny>>,
    threads: Option<Whole>,
    tables: bool,
) -> PyResult<Bound<'py, PyDict>> {
    // An int outside the pool's range (negative, 0, too many) is told that range; what is no
    // int at all (2.0, "2") is told it must be a whole number.
    let threads = threads
        .map(|t| match t.int() {
            Some(v) => usize::try_from(v)
                .ok()
                .and_then(|t| workbench::util::threads::check_threads(t, "threads").ok())
                .ok_or_else(|| {
                    value_error(format!(
                        "threads: must be in 1..={}, got {v}",
                        workbench::util::threads::MAX_THREADS
                    ))
                }),
            None => t.count("threads"),
        })
        .transpose()?;
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
        let d = write_folder(py, &plan, spec, out, threads)?;
        if tables {
            let folder = std::path::PathBuf::from(d.get_item("out")?.expect("set").extract::<String>()?);
            for (key, file) in TABLES {
                let bytes = match std::fs::read(folder.join(file)) {
                    Ok(b) => b,
                    Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
                    Err(e) => return Err(value_error(format!("out: reading {file}: {e}"))),
                };
                d.set_item(key, csv_columns(py, &bytes)?)?;
            }
        }
        return Ok(d);
    }
    let (rows, warnings, csvs) = py
        .detach(
            || -> workbench::Result<(Vec<TrialRow>, Warnings, Option<Tables>)> {
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
                        workbench::experiment::rows::unit_row_values(
                            &plan,
                            r,
                            u / plan.trials,
                            u % plan.trials,
                        )
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
                // The other tables, from the same units as the CLI writes them from its logs.
                let csvs = tables.then(|| {
                    use workbench::experiment::{adaptive, export, rows as ex_rows, summary};
                    let mut acc = summary::Accumulator::new(&plan);
                    for (u, r) in results.units.iter().enumerate() {
                        let (ni, t) = (u / plan.trials, u % plan.trials);
                        for (row, values) in ex_rows::unit_row_values(&plan, r, ni, t) {
                            acc.push(row.integrand, row.estimator, ni, &values);
                        }
                    }
                    let summary_csv = export::summary_csv(&plan, &acc.summarize(&plan));
                    let outcomes = adaptive::Outcomes::of_units(&plan, &results.units);
                    let has_tolerance = plan.estimators.iter().any(|e| e.tolerance.is_some());
                    let (stopping_trials, stopping_summary) = if has_tolerance {
                        (
                            adaptive::trials_csv(&plan, &outcomes),
                            adaptive::summary_csv(&plan, &adaptive::summarize(&plan, &outcomes)),
                        )
                    } else {
                        (Vec::new(), Vec::new())
                    };
                    [summary_csv, stopping_trials, stopping_summary]
                });
                Ok((rows, warnings, csvs))
            },
        )
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
    let trials = columns(py, &plan, &rows)?;
    let Some(csvs) = csvs else {
        return Ok(trials);
    };
    let d = PyDict::new(py);
    d.set_item("trials", trials)?;
    for ((key, _), bytes) in TABLES.iter().skip(1).zip(csvs.iter()) {
        d.set_item(key, csv_columns(py, bytes)?)?;
    }
    Ok(d)
}

/// The tables of `run(…, tables=True)`: key and file.
const TABLES: [(&str, &str); 4] = [
    ("trials", "trials.csv"),
    ("summary", "summary.csv"),
    ("stopping_trials", "stopping_trials.csv"),
    ("stopping_summary", "stopping_summary.csv"),
];

/// Columns that hold text whatever their fields look like (labels are free text).
const TEXT_COLUMNS: [&str; 6] = [
    "integrand",
    "estimator",
    "method",
    "design",
    "model",
    "chosen_models",
];

/// A CSV the library wrote (header, then rows; a field quoted when it holds `,`, `"` or a line
/// break) as columns: text columns ([`TEXT_COLUMNS`], or any with a field that is no number) as
/// lists of str, `true`/`false` columns as bool arrays, whole-number columns as int64 arrays,
/// the rest as float64 arrays with NaN where a field is empty (what `pandas.read_csv` gives).
/// Empty bytes: no columns.
fn csv_columns<'py>(py: Python<'py>, bytes: &[u8]) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    let text = std::str::from_utf8(bytes).map_err(|e| value_error(format!("a table is not UTF-8: {e}")))?;
    let mut records = parse_csv(text).into_iter();
    let Some(header) = records.next() else {
        return Ok(out);
    };
    let rows: Vec<Vec<String>> = records.collect();
    for (c, name) in header.iter().enumerate() {
        let fields: Vec<&str> = rows.iter().map(|r| r.get(c).map_or("", String::as_str)).collect();
        let text_column = TEXT_COLUMNS.contains(&name.as_str());
        if !text_column && !fields.is_empty() && fields.iter().all(|f| *f == "true" || *f == "false") {
            let v: Vec<bool> = fields.iter().map(|f| *f == "true").collect();
            out.set_item(name, numpy::PyArray1::from_vec(py, v))?;
        } else if !text_column && !fields.is_empty() && fields.iter().all(|f| f.parse::<i64>().is_ok()) {
            let v: Vec<i64> = fields.iter().map(|f| f.parse().expect("checked")).collect();
            out.set_item(name, numpy::PyArray1::from_vec(py, v))?;
        } else if !text_column && fields.iter().all(|f| f.is_empty() || f.parse::<f64>().is_ok()) {
            let v: Vec<f64> = fields
                .iter()
                .map(|f| {
                    if f.is_empty() {
                        f64::NAN
                    } else {
                        f.parse().expect("checked")
                    }
                })
                .collect();
            out.set_item(name, arrays::vector(py, v))?;
        } else {
            out.set_item(name, fields)?;
        }
    }
    Ok(out)
}

/// The records of a CSV (RFC 4180 quoting).
fn parse_csv(text: &str) -> Vec<Vec<String>> {
    let mut records = Vec::new();
    let (mut record, mut field) = (Vec::new(), String::new());
    let (mut quoted, mut chars) = (false, text.chars().peekable());
    while let Some(c) = chars.next() {
        match (quoted, c) {
            (true, '"') if chars.peek() == Some(&'"') => {
                field.push('"');
                chars.next();
            }
            (true, '"') => quoted = false,
            (true, c) => field.push(c),
            (false, '"') => quoted = true,
            (false, ',') => record.push(std::mem::take(&mut field)),
            (false, '\r') => {}
            (false, '\n') => {
                record.push(std::mem::take(&mut field));
                records.push(std::mem::take(&mut record));
            }
            (false, c) => field.push(c),
        }
    }
    if !field.is_empty() || !record.is_empty() {
        record.push(field);
        records.push(record);
    }
    records
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
