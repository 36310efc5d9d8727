//! The rows of `trials.csv`, one per (integrand, estimator, N, trial), and the cost columns a
//! unit log adds to them ([`super::job`]).
//!
//! A row is written once, as text, when its unit finishes; everything downstream (the summary,
//! `trials.csv`, a resumed run, a merge of shards) reads these values back. Floats are written
//! in Rust's shortest round-trip form (`{:?}`), so reading a row gives back the exact `f64`s
//! and the outputs are the same bytes whichever way the rows arrived.

use super::plan::Plan;
use super::runner::UnitResult;
use super::summary::RowValues;
use std::fmt::Write;

/// The columns of `trials.csv`.
pub const TRIALS_HEADER: &str = "integrand,estimator,method,design,n,trial,estimate,truth,abs_error,posterior_sd,\
                                 warnings,weight_sum,negative_weights,jitter,condition_estimate,amplitude,dof";

/// The column `trials.csv` adds after [`TRIALS_HEADER`] when an estimator's model is fitted
/// (math.md §9): the grid's model that won, e.g. `s=2.75 noise=1e-8` (empty for the others).
pub const MODEL_HEADER: &str = "model";

/// The columns a unit log adds after [`TRIALS_HEADER`]: the chosen model ([`MODEL_HEADER`],
/// kept in every log so that one row format serves every plan), a tolerance estimator's
/// stopping outcome (`stopped`: whether the rule stopped it, `zero_evidence_stages`; empty for
/// the other estimators — with the row's estimate, sd, amplitude, dof and evaluations they are
/// its whole [`crate::bq::stages::Outcome`], so `stopping_*.csv` come from the log like every
/// other output), integrand evaluations (deterministic) and wall-clock seconds (not).
pub const COST_HEADER: &str = "model,stopped,zero_evidence_stages,evaluations,weight_set_seconds,seconds";

/// Number of columns of [`COST_HEADER`] after `model`: the two stopping columns and the three
/// cost columns.
const COST_COLUMNS: usize = 2 + 3;
/// Columns of a log row after the estimator label: `method` … `dof`, `model`, then the stopping
/// and cost columns.
const TAIL_COLUMNS: usize = 15 + 1 + COST_COLUMNS;

/// The header of `trials.csv`: [`TRIALS_HEADER`], and [`MODEL_HEADER`] when `with_model`.
pub fn trials_header(with_model: bool) -> String {
    if with_model {
        format!("{TRIALS_HEADER},{MODEL_HEADER}")
    } else {
        TRIALS_HEADER.to_string()
    }
}

fn opt(v: Option<f64>) -> String {
    v.map_or(String::new(), |x| format!("{x:?}"))
}

/// Quotes a field if CSV needs it (labels are free text).
pub fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// One row of `trials.csv` as values: what [`unit_rows`] writes as text, for callers that want
/// the numbers themselves (the Python bindings' `run`). Every float is the exact `f64` the CSV
/// holds in shortest round-trip form.
#[derive(Clone, Debug, PartialEq)]
pub struct TrialRow {
    /// Index into [`Plan::integrands`].
    pub integrand: usize,
    /// Index into [`Plan::estimators`].
    pub estimator: usize,
    pub n: usize,
    pub trial: usize,
    pub estimate: f64,
    pub truth: f64,
    pub abs_error: f64,
    /// The stated sd (None where the estimator states none, e.g. MC at N = 1).
    pub posterior_sd: Option<f64>,
    pub warnings: u32,
    /// The weight set's `weight_sum, negative_weights, jitter, condition_estimate` (None for MC).
    pub weight_set: Option<(f64, usize, f64, f64)>,
    /// The amplitude λ used (None for MC).
    pub amplitude: Option<f64>,
    /// Student-t degrees of freedom of the interval (None for a normal interval or none).
    pub dof: Option<usize>,
    /// A fitted model's winner, as its label (`s=2.75 noise=1e-8`); None for the others.
    pub model: Option<String>,
}

/// The rows of unit (`n_index`, `trial`): every (integrand, estimator) in the plan's order, as
/// values, each with what the summary and the unit log's cost columns need.
pub fn unit_row_values(
    plan: &Plan,
    unit: &UnitResult,
    n_index: usize,
    trial: usize,
) -> Vec<(TrialRow, RowValues)> {
    let n = plan.samples[n_index];
    let mut rows = Vec::with_capacity(plan.integrands.len() * plan.estimators.len());
    for (fi, f) in plan.integrands.iter().enumerate() {
        let truth = f.integral();
        for (ei, e) in plan.estimators.iter().enumerate() {
            let est = unit.estimates[fi][ei];
            let uncertainty = unit.uncertainty[fi][ei];
            let values = RowValues {
                abs_error: (est - truth).abs(),
                sd: uncertainty.map(|u| (u.sd, u.dof)),
                warnings: unit.warnings_for(fi, ei),
                evaluations: unit.cost.evaluations[fi][ei],
                weight_set_seconds: unit.cost.weight_set[ei],
                seconds: unit.cost.seconds[fi][ei],
                model: unit.chosen[fi][ei].map(|c| c as u16),
            };
            let model = values.model.map(|c| {
                let m = e.model.expect("a chosen model has a model");
                plan.models[m].candidates()[usize::from(c)].label()
            });
            let row = TrialRow {
                integrand: fi,
                estimator: ei,
                n,
                trial,
                estimate: est,
                truth,
                abs_error: values.abs_error,
                posterior_sd: uncertainty.map(|x| x.sd),
                warnings: values.warnings,
                weight_set: unit.diagnostics[fi][ei]
                    .as_ref()
                    .map(|d| (d.weight_sum, d.negative_weights, d.jitter, d.condition_estimate)),
                amplitude: uncertainty.and_then(|x| x.amplitude),
                dof: uncertainty.and_then(|x| x.dof),
                model,
            };
            rows.push((row, values));
        }
    }
    rows
}

/// Appends the log rows of unit (`n_index`, `trial`) to `out` — every (integrand, estimator)
/// in the plan's order, each a `trials.csv` row followed by the cost columns — and returns
/// their values for the summary, in the same order.
pub fn unit_rows(
    plan: &Plan,
    unit: &UnitResult,
    n_index: usize,
    trial: usize,
    out: &mut String,
) -> Vec<RowValues> {
    let rows = unit_row_values(plan, unit, n_index, trial);
    let mut values = Vec::with_capacity(rows.len());
    for (r, v) in rows {
        // A tolerance estimator's stopping outcome (the rest of it is in the row already).
        let stopping = unit.sequential[r.integrand][r.estimator]
            .map_or(",".to_string(), |o| format!("{},{}", o.met, o.zero_evidence));
        // The weight set's diagnostics (empty for MC).
        let weight_set = r
            .weight_set
            .map_or(",,,".to_string(), |(sum, negative, jitter, condition)| {
                format!("{sum:?},{negative},{jitter:?},{condition:?}")
            });
        writeln!(
            out,
            "{},{},{},{},{},{},{:?},{:?},{:?},{},{},{weight_set},{},{},{},{stopping},{},{:?},{:?}",
            plan.integrands[r.integrand].name(),
            csv_field(&plan.estimators[r.estimator].label),
            plan.estimators[r.estimator].method.name(),
            plan.estimators[r.estimator].design.name(),
            r.n,
            r.trial,
            r.estimate,
            r.truth,
            r.abs_error,
            opt(r.posterior_sd),
            r.warnings,
            opt(r.amplitude),
            r.dof.map_or(String::new(), |d| d.to_string()),
            r.model.as_deref().unwrap_or(""),
            v.evaluations,
            v.weight_set_seconds,
            v.seconds,
        )
        .expect("writing to a String");
        values.push(v);
    }
    values
}

/// The `trials.csv` part of a log row: without its cost columns, and without the `model`
/// column unless `with_model`.
pub fn trials_part(line: &str, with_model: bool) -> &str {
    let drop = COST_COLUMNS + usize::from(!with_model);
    line.rsplitn(drop + 1, ',').last().unwrap_or(line)
}

/// `integrand,estimator,n,trial` and the cost columns of a log row (a `timings-trials.csv`
/// row).
pub fn timing_part(line: &str) -> Option<String> {
    let mut tail: Vec<&str> = line.rsplitn(TAIL_COLUMNS + 1, ',').collect();
    if tail.len() != TAIL_COLUMNS + 1 {
        return None;
    }
    tail.reverse();
    // tail: [integrand,estimator], method, design, n, trial, …, evaluations, weight set, seconds
    Some(format!(
        "{},{},{},{},{},{}",
        tail[0],
        tail[3],
        tail[4],
        tail[TAIL_COLUMNS - 2],
        tail[TAIL_COLUMNS - 1],
        tail[TAIL_COLUMNS]
    ))
}

/// Reads a log row back: its N, trial, values and the chosen model's label (fitted models;
/// [`model_index`] turns it into [`RowValues::model`]); `Err` says what is wrong with it.
pub fn parse_row(line: &str) -> Result<(usize, usize, RowValues, Option<&str>), String> {
    let mut tail: Vec<&str> = line.rsplitn(TAIL_COLUMNS + 1, ',').collect();
    if tail.len() != TAIL_COLUMNS + 1 {
        return Err(format!("has {} columns, not {}", tail.len(), TAIL_COLUMNS + 2));
    }
    tail.reverse();
    // After the prefix: 1 method, 2 design, 3 n, 4 trial, 5 estimate, 6 truth, 7 abs_error,
    // 8 posterior_sd, 9 warnings, 10–13 diagnostics, 14 amplitude, 15 dof, 16 model (the chosen
    // model's label; its index is resolved by the caller), 17–18 stopping, 19–21 cost.
    fn num<T: std::str::FromStr>(s: &str, what: &str) -> Result<T, String> {
        s.parse().map_err(|_| format!("has {what} {s:?}"))
    }
    let sd = match (tail[8], tail[15]) {
        ("", _) => None,
        (sd, "") => Some((num(sd, "posterior_sd")?, None)),
        (sd, dof) => Some((num(sd, "posterior_sd")?, Some(num(dof, "dof")?))),
    };
    Ok((
        num(tail[3], "n")?,
        num(tail[4], "trial")?,
        RowValues {
            abs_error: num(tail[7], "abs_error")?,
            sd,
            warnings: num(tail[9], "warnings")?,
            evaluations: num(tail[19], "evaluations")?,
            weight_set_seconds: num(tail[20], "weight_set_seconds")?,
            seconds: num(tail[21], "seconds")?,
            model: None,
        },
        (!tail[16].is_empty()).then_some(tail[16]),
    ))
}

/// [`parse_row`] for the row of integrand `fi` and estimator `ei` of `plan`, with every column
/// checked against the plan (issue 30: a merge wrote NUL bytes, a NaN `abs_error`, a wrong label
/// or truth from a shard into the merged CSVs), since a merge and a resume copy a row's text into
/// `trials.csv`: the integrand, label, method and design are the plan's; `estimate` is a finite
/// number, `truth` the integrand's integral bit for bit, and `abs_error` is `|estimate − truth|`
/// recomputed bit for bit; the sd, amplitude and weight-set columns are finite numbers (≥ 0 where
/// they must be; the condition estimate may be `inf`), present together or absent as for the
/// method (MC has no weight set or amplitude); counts are whole numbers; the chosen model is one
/// of the estimator's grid ([`model_index`]), and the cost columns are finite and ≥ 0. The model's
/// index is filled in. `Err` says what is wrong, naming the column.
pub fn check_row(plan: &Plan, fi: usize, ei: usize, line: &str) -> Result<(usize, usize, RowValues), String> {
    let (n, trial, mut values, model) = parse_row(line)?;
    let (f, e) = (&plan.integrands[fi], &plan.estimators[ei]);
    let mut tail: Vec<&str> = line.rsplitn(TAIL_COLUMNS + 1, ',').collect();
    tail.reverse();
    let prefix = format!("{},{}", f.name(), csv_field(&e.label));
    if tail[0] != prefix {
        return Err(format!(
            "starts with {:?} where the plan has integrand and estimator {prefix:?}",
            tail[0]
        ));
    }
    for (i, column, want) in [(1, "method", e.method.name()), (2, "design", e.design.name())] {
        if tail[i] != want {
            return Err(format!("has {column} {:?} where the plan has {want:?}", tail[i]));
        }
    }
    let number = |i: usize, column: &str| -> Result<f64, String> {
        let s = tail[i];
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(format!("has {column} {s:?}, not a finite number")),
        }
    };
    let non_negative = |i: usize, column: &str| -> Result<f64, String> {
        let v = number(i, column)?;
        if v < 0.0 {
            return Err(format!("has {column} {v:?}, below 0"));
        }
        Ok(v)
    };
    let estimate = number(5, "estimate")?;
    let truth = number(6, "truth")?;
    if truth.to_bits() != f.integral().to_bits() {
        return Err(format!(
            "has truth {truth:?} where {} has {:?}",
            f.name(),
            f.integral()
        ));
    }
    let abs_error = number(7, "abs_error")?;
    if abs_error.to_bits() != (estimate - truth).abs().to_bits() {
        return Err(format!(
            "has abs_error {abs_error:?} where |estimate − truth| = {:?}",
            (estimate - truth).abs()
        ));
    }
    if !tail[8].is_empty() {
        non_negative(8, "posterior_sd")?;
    }
    let weighted = e.method.needs_weights();
    let diagnostics = [10, 11, 12, 13, 14];
    if !weighted {
        if let Some(&i) = diagnostics.iter().find(|&&i| !tail[i].is_empty()) {
            return Err(format!(
                "has {:?} in column {} where method {:?} has no weight set",
                tail[i],
                i + 2,
                e.method.name()
            ));
        }
    } else if !tail[10].is_empty() || !tail[14].is_empty() {
        number(10, "weight_sum")?;
        tail[11]
            .parse::<usize>()
            .map_err(|_| format!("has negative_weights {:?}, not a whole number", tail[11]))?;
        non_negative(12, "jitter")?;
        match tail[13].parse::<f64>() {
            Ok(c) if c >= 0.0 => {}
            _ => return Err(format!("has condition_estimate {:?}, not a number ≥ 0", tail[13])),
        }
        if !tail[14].is_empty() {
            non_negative(14, "amplitude")?;
        }
    }
    for (i, column) in [(20, "weight_set_seconds"), (21, "seconds")] {
        non_negative(i, column)?;
    }
    // The stopping columns: a tolerance estimator's outcome, nothing for the others.
    match e.tolerance {
        None => {
            if let Some(i) = [17, 18].into_iter().find(|&i| !tail[i].is_empty()) {
                return Err(format!(
                    "has {:?} in column {} where estimator {:?} has no tolerance",
                    tail[i],
                    i + 2,
                    e.label
                ));
            }
        }
        Some(t) => {
            if !matches!(tail[17], "true" | "false") {
                return Err(format!("has stopped {:?}, not true or false", tail[17]));
            }
            tail[18]
                .parse::<usize>()
                .map_err(|_| format!("has zero_evidence_stages {:?}, not a whole number", tail[18]))?;
            if values.evaluations == 0 || values.evaluations > t.max_n as u64 {
                return Err(format!(
                    "has evaluations {} where a tolerance estimator uses 1 to max_n = {} points",
                    values.evaluations, t.max_n
                ));
            }
        }
    }
    if let Some(label) = model {
        values.model = Some(model_index(plan, ei, label)?);
    }
    Ok((n, trial, values))
}

/// The stopping outcome of a tolerance estimator's row checked by [`check_row`] (None for the
/// other estimators): its estimate, stated uncertainty (sd, dof, amplitude), points used
/// (`evaluations`), whether the rule stopped it and its zero-evidence stages — the exact values
/// the run had, since floats are written in shortest round-trip form.
pub fn stopping_outcome(line: &str) -> Option<crate::bq::stages::Outcome> {
    let mut tail: Vec<&str> = line.rsplitn(TAIL_COLUMNS + 1, ',').collect();
    if tail.len() != TAIL_COLUMNS + 1 {
        return None;
    }
    tail.reverse();
    if tail[17].is_empty() {
        return None;
    }
    let uncertainty = match tail[8] {
        "" => None,
        sd => Some(crate::bq::estimator::Uncertainty {
            sd: sd.parse().ok()?,
            dof: (!tail[15].is_empty())
                .then(|| tail[15].parse())
                .transpose()
                .ok()?,
            amplitude: (!tail[14].is_empty())
                .then(|| tail[14].parse())
                .transpose()
                .ok()?,
        }),
    };
    Some(crate::bq::stages::Outcome {
        estimate: tail[5].parse().ok()?,
        uncertainty,
        n_used: tail[19].parse().ok()?,
        met: tail[17].parse().ok()?,
        zero_evidence: tail[18].parse().ok()?,
    })
}

/// The index of the chosen model `label` among estimator `ei`'s fitted grid; `Err` when the
/// estimator's model is not fitted or has no such model.
pub fn model_index(plan: &Plan, ei: usize, label: &str) -> Result<u16, String> {
    plan.estimators[ei]
        .model
        .map(|m| plan.models[m].candidates())
        .and_then(|c| c.iter().position(|m| m.label() == label))
        .map(|i| i as u16)
        .ok_or_else(|| format!("has model {label:?}, not one of its estimator's grid"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_log_row_reads_back_exactly_and_splits_into_its_parts() {
        let line = "cos3,\"BMC, ml\",bmc,uniform,16,7,0.1234567890123,0.125,0.0015432109877,\
                    1e-300,2,1.0,0,0.0,12.5,0.3,,s=2.75 noise=1e-8,,,16,0.001,0.0025";
        let (n, t, v, model) = parse_row(line).unwrap();
        assert_eq!(model, Some("s=2.75 noise=1e-8"));
        assert_eq!((n, t), (16, 7));
        assert_eq!(v.abs_error, 0.0015432109877);
        assert_eq!(v.sd, Some((1e-300, None)));
        assert_eq!((v.warnings, v.evaluations), (2, 16));
        assert_eq!((v.weight_set_seconds, v.seconds), (0.001, 0.0025));
        assert_eq!(
            trials_part(line, false),
            "cos3,\"BMC, ml\",bmc,uniform,16,7,0.1234567890123,0.125,0.0015432109877,1e-300,2,1.0,0,0.0,12.5,0.3,"
        );
        assert_eq!(
            trials_part(line, true),
            "cos3,\"BMC, ml\",bmc,uniform,16,7,0.1234567890123,0.125,0.0015432109877,1e-300,2,1.0,0,0.0,12.5,0.3,,\
             s=2.75 noise=1e-8"
        );
        assert_eq!(
            timing_part(line).unwrap(),
            "cos3,\"BMC, ml\",16,7,16,0.001,0.0025"
        );
        let mc = "f,MC,mc,uniform,1,0,0.5,0.25,0.25,,0,,,,,,,,,,1,0.0,1e-6";
        assert_eq!(parse_row(mc).unwrap().2.sd, None);
        assert_eq!(parse_row(mc).unwrap().3, None);
        let t = "f,BSQ,bsq,uniform,8,0,0.5,0.25,0.25,0.1,0,1.0,0,0.0,3.0,0.2,7,,,,8,0.0,1e-6";
        assert_eq!(parse_row(t).unwrap().2.sd, Some((0.1, Some(7))));
        assert_eq!(stopping_outcome(t), None);
        // A tolerance estimator's row gives back its whole stopping outcome.
        let tol = "f,BMC tol,bmc,sobol,8,0,0.5,0.25,0.25,0.1,0,1.0,0,0.0,3.0,0.2,7,,true,2,32,0.0,1e-6";
        let o = stopping_outcome(tol).unwrap();
        assert_eq!((o.estimate, o.n_used, o.met, o.zero_evidence), (0.5, 32, true, 2));
        let u = o.uncertainty.unwrap();
        assert_eq!((u.sd, u.dof, u.amplitude), (0.1, Some(7), Some(0.2)));
        assert_eq!(parse_row(tol).unwrap().2.evaluations, 32);
        assert!(parse_row("f,MC,mc,uniform,1,0").is_err());
        assert!(parse_row(&mc.replace("0.25,0.25", "0.25,zz")).is_err());
    }
}
