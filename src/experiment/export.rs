//! Pure exporters: each turns results into bytes; only the caller touches the disk.
//!
//! Floats are written in Rust's shortest round-trip form (`{:?}`), so the CSVs hold the exact
//! `f64` values and are byte-identical for identical results.

use super::plan::Plan;
use super::rows::csv_field;
use super::summary::{CalibrationOutcome, CellSummary, CheckOutcome};
use std::fmt::Write;

/// `timings-summary.csv`: per (integrand, estimator, N), the mean absolute error against the
/// mean integrand evaluations and wall-clock seconds per trial (its weight set's mean, which
/// estimators with the same model and design share, and the estimator alone: mean and
/// median). Machine-dependent.
pub fn timings_summary_csv(plan: &Plan, cells: &[CellSummary]) -> Vec<u8> {
    let mut s = String::from(
        "integrand,estimator,n,trials,mean_abs_error,mean_evaluations,mean_weight_set_seconds,mean_seconds,\
         median_seconds\n",
    );
    for c in cells {
        writeln!(
            s,
            "{},{},{},{},{:?},{:?},{:?},{:?},{:?}",
            plan.integrands[c.integrand].name(),
            csv_field(&plan.estimators[c.estimator].label),
            c.n,
            c.trials,
            c.mean_abs_error,
            c.mean_evaluations,
            c.mean_weight_set_seconds,
            c.mean_seconds,
            c.median_seconds as f32
        )
        .expect("writing to a String");
    }
    s.into_bytes()
}

fn opt(v: Option<f64>) -> String {
    v.map_or(String::new(), |x| format!("{x:?}"))
}

/// Empty for NaN (an undefined statistic, e.g. a CI from one trial).
fn num(v: f64) -> String {
    if v.is_nan() {
        String::new()
    } else {
        format!("{v:?}")
    }
}

/// `summary.csv`: one row per (integrand, estimator, N).
pub fn summary_csv(plan: &Plan, cells: &[CellSummary]) -> Vec<u8> {
    let mut s = String::from(
        "integrand,estimator,n,trials,mean_abs_error,ci95_low,ci95_high,median_abs_error,\
         q10_abs_error,q90_abs_error,mean_posterior_sd,coverage50,coverage80,coverage95,\
         median_abs_error_over_sd,warnings",
    );
    // Only a plan with a fitted model has the column of its choices.
    let fitted = plan.has_fitted_model();
    s.push_str(if fitted { ",chosen_models\n" } else { "\n" });
    for c in cells {
        writeln!(
            s,
            "{},{},{},{},{:?},{},{},{:?},{:?},{:?},{},{},{},{},{},{}",
            plan.integrands[c.integrand].name(),
            csv_field(&plan.estimators[c.estimator].label),
            c.n,
            c.trials,
            c.mean_abs_error,
            num(c.ci95.0),
            num(c.ci95.1),
            c.median_abs_error,
            c.q10_abs_error,
            c.q90_abs_error,
            opt(c.mean_posterior_sd),
            opt(c.coverage.map(|c| c[0])),
            opt(c.coverage.map(|c| c[1])),
            opt(c.coverage.map(|c| c[2])),
            opt(c.median_error_over_sd),
            c.warnings
        )
        .expect("writing to a String");
        if fitted {
            s.pop();
            writeln!(s, ",{}", model_shares(plan, c)).expect("writing to a String");
        }
    }
    s.into_bytes()
}

/// A fitted model's choices in a cell, most chosen first (ties in grid order):
/// `s=3.75 noise=1e-8: 0.82; s=2.75 noise=1e-8: 0.18` (empty for a fixed model).
fn model_shares(plan: &Plan, c: &CellSummary) -> String {
    let Some(m) = plan.estimators[c.estimator].model else {
        return String::new();
    };
    let mut counts: Vec<(usize, u64)> = c
        .model_counts
        .iter()
        .copied()
        .enumerate()
        .filter(|&(_, k)| k > 0)
        .collect();
    counts.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    counts
        .iter()
        .map(|&(k, count)| {
            format!(
                "{}: {}",
                plan.models[m].candidates()[k].label(),
                count as f64 / c.trials as f64
            )
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// The resolved plan as JSON (what `validate` prints and the manifest records).
pub fn plan_json(plan: &Plan) -> serde_json::Value {
    serde_json::json!({
        "name": plan.name,
        "title": plan.title,
        "integrands": plan.integrands.iter().map(integrand_json).collect::<Vec<_>>(),
        "estimators": plan.estimators.iter().map(|e| {
            let mut v = serde_json::to_value(&e.settings).expect("settings serialize");
            v["label"] = serde_json::json!(e.label);
            v
        }).collect::<Vec<_>>(),
        "samples": plan.samples,
        "fit_from_n": plan.fit_from_n,
        "trials": plan.trials,
        "seed": plan.seed,
        "checks": plan.checks,
        "calibration_checks": plan.calibration_checks,
    })
}

/// [`plan_json`] with how the figures are drawn, `"plot": {"bands": [labels]}` or, by default,
/// `{"bands": "auto"}` (bands where they overlap no other; what `validate`
/// prints and the manifest records). Kept out of [`plan_json`], which identifies the trials
/// across shards and resumed runs: how a figure is drawn changes no trial.
pub fn plan_json_with_plot(plan: &Plan) -> serde_json::Value {
    let mut v = plan_json(plan);
    let banded: Vec<&str> = plan
        .estimators
        .iter()
        .zip(&plan.bands)
        .filter(|(_, on)| **on)
        .map(|(e, _)| e.label.as_str())
        .collect();
    v["plot"] = if plan.auto_bands {
        serde_json::json!({ "bands": "auto" })
    } else {
        serde_json::json!({ "bands": banded })
    };
    v
}

/// An integrand's name, truth and oracle prior, and for a family its definition.
fn integrand_json(f: &crate::integrand::Integrand) -> serde_json::Value {
    let mut v = serde_json::json!({
        "name": f.name(), "truth": f.integral(), "analytic_prior": f.constant_prior()
    });
    if let crate::integrand::Integrand::Axis { f: a, .. } = f {
        let (key, param) = a.profile.parameter();
        v["type"] = a.profile.family().into();
        v["axis"] = serde_json::json!([a.axis.x, a.axis.y, a.axis.z]);
        v[key] = param.into();
        v["cosine"] = a.cosine.into();
    }
    if let crate::integrand::Integrand::External(e) = f {
        v["type"] = "python".into();
        match e.truth_source {
            crate::integrand::external::Truth::Given => v["truth_source"] = "given".into(),
            crate::integrand::external::Truth::Cubature(c) => {
                v["truth_source"] = "cubature".into();
                v["truth_error_estimate"] = c.error.into();
                v["truth_evaluations"] = c.evaluations.into();
            }
        }
    }
    if let crate::integrand::Integrand::Pixel { f: p, .. } = f {
        v["type"] = "pixel".into();
        v["pixel"] = serde_json::json!(p.pixel);
        v["width"] = p.width.into();
        v["height"] = p.height.into();
        v["env"] = p.env_name.clone().into();
        v["channel"] = ["r", "g", "b"][p.channel].into();
        v["truth_error_estimate"] = p.integral_error().into();
    }
    if let crate::integrand::Integrand::Envmap { f: e, .. } = f {
        v["type"] = "envmap".into();
        v["env"] = e.env_name.clone().into();
        v["normal"] = serde_json::json!([e.normal.x, e.normal.y, e.normal.z]);
        v["brdf"] = match e.brdf {
            crate::integrand::envmap::Brdf::Lambert => "lambert".into(),
            crate::integrand::envmap::Brdf::Phong { exponent, axis } => {
                serde_json::json!({ "phong": exponent, "axis": [axis.x, axis.y, axis.z] })
            }
        };
        v["lookup"] = e.lookup.name().into();
        v["channel"] = e.channel.clone().into();
        v["truth_error_estimate"] = e.integral_error().into();
    }
    v
}

/// `manifest.json`: the plan and how the run went (the folder adds the files and the build:
/// [`crate::files::result_folder::ResultFolder::commit`]).
pub fn manifest_json(plan: &Plan, checks: &[CheckOutcome], calibration: &[CalibrationOutcome]) -> Vec<u8> {
    let v = serde_json::json!({
        "plan": plan_json_with_plot(plan),
        "seed": plan.seed,
        "checks": checks.iter().map(|c| serde_json::json!({
            "better": c.check.better,
            "than": c.check.than,
            "from_n": c.check.from_n,
            "alpha": c.check.alpha,
            "passed": c.passed(),
            "cells": c.cells.iter().map(|x| serde_json::json!({
                "integrand": plan.integrands[x.integrand].name(),
                "n": x.n,
                "mean_abs_error_better": x.mean_better,
                "mean_abs_error_than": x.mean_than,
                "t": x.test.t,
                "p_value": x.test.p_value,
                "passed": x.passed,
            })).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "calibration_checks": calibration.iter().map(|c| serde_json::json!({
            "calibrated": c.check.calibrated,
            "level": c.check.level,
            "from_n": c.check.from_n,
            "side": c.check.side,
            "band99": [c.band.0, c.band.1],
            "passed": c.passed(),
            "cells": c.cells.iter().map(|x| serde_json::json!({
                "integrand": plan.integrands[x.integrand].name(),
                "n": x.n,
                "coverage": x.coverage,
                "passed": x.passed,
            })).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
    });
    let mut bytes = serde_json::to_vec_pretty(&v).expect("manifest serializes");
    bytes.push(b'\n');
    bytes
}

/// The names an experiment's `manifest.json` accounts for beyond its `files`, or `None` if it is
/// not one (see [`crate::files::result_folder::LegacyManifest`]): the machine-dependent files
/// (`timings*`, one `<integrand>-cost.svg` each), and for a manifest written before manifests
/// listed their files every file of its run (one `<integrand>.svg` each); the cost plot's
/// caption, `<integrand>-cost.caption.txt`, is machine-dependent with it. Passed to
/// [`crate::files::result_folder::ResultFolder::prepare`].
pub fn legacy_manifest_files(manifest: &serde_json::Value) -> Option<Vec<String>> {
    use crate::files::result_folder::{MANIFEST, TIMINGS};
    manifest.get("workbench_version")?;
    let integrands = manifest.pointer("/plan/integrands")?.as_array()?;
    let lists = manifest.pointer(&format!("/files/{MANIFEST}")).is_some();
    let mut names: Vec<String> = vec![
        TIMINGS.into(),
        "timings-trials.csv".into(),
        "timings-summary.csv".into(),
    ];
    if !lists {
        names.extend(["trials.csv", "summary.csv", MANIFEST].map(String::from));
    }
    for f in integrands {
        let name = f.get("name")?.as_str()?;
        names.push(format!("{name}-cost.svg"));
        names.push(format!("{name}-cost.caption.txt"));
        if !lists {
            names.push(format!("{name}.svg"));
        }
    }
    Some(names)
}

/// `timings.json`: how long the run took on how many threads (the folder adds the list of
/// machine-dependent files and the build). Machine-dependent, so it stays out of the manifest and
/// out of the committed results. `plan_hash` ([`super::job::plan_hash`]) is given only when
/// `wall_seconds` is the time of the whole plan (not a shard, a resumed remainder or a merge):
/// `reproduce` estimates a file's time from an earlier run only with it, and only for the same
/// plan.
pub fn timings_json(threads: usize, wall_seconds: f64, plan_hash: Option<String>) -> serde_json::Value {
    let mut v = serde_json::json!({ "threads": threads, "wall_seconds": wall_seconds });
    if let Some(h) = plan_hash {
        v["plan_hash"] = h.into();
    }
    v
}

/// `fits.csv`: per (integrand, estimator), the least-squares slope of ln(mean |Î − I|) against
/// ln N over N ≥ `fit_from_n` (the rate the plot legends state), its 95% interval (Student t,
/// empty with two points), the N range actually fitted (`from_n`, `to_n`: the smallest and
/// largest N that entered; empty with no fit) and number of points used, `exact` for a series
/// whose error is zero up to rounding (no slope then), and `slope_flag` — `plateau` or
/// `wide_interval` ([`super::fit::SlopeFlag`]) — for a slope that is no rate to state (the
/// legends say `slope n/a`). Slopes in shortest round-trip form.
pub fn fits_csv(plan: &Plan, cells: &[CellSummary]) -> Vec<u8> {
    use super::fit::{SeriesFit, fit_series};
    let mut out = String::from(
        "integrand,estimator,from_n,to_n,points,slope,slope_ci95_low,slope_ci95_high,exact,slope_flag\n",
    );
    for (fi, f) in plan.integrands.iter().enumerate() {
        for (ei, e) in plan.estimators.iter().enumerate() {
            let mut points: Vec<(usize, f64)> = cells
                .iter()
                .filter(|c| c.integrand == fi && c.estimator == ei)
                .map(|c| (c.n, c.mean_abs_error))
                .collect();
            points.sort_by_key(|p| p.0);
            let head = format!("{},{}", csv_field(&f.name()), csv_field(&e.label));
            let row = match fit_series(&points, f.integral(), plan.fit_from_n) {
                SeriesFit::Exact => format!("{head},,,0,,,,true,"),
                SeriesFit::TooFew { .. } => format!("{head},,,0,,,,false,"),
                SeriesFit::Slope { fit, .. } => {
                    let (lo, hi) = fit.ci95.map_or((String::new(), String::new()), |(lo, hi)| {
                        (format!("{lo:?}"), format!("{hi:?}"))
                    });
                    format!(
                        "{head},{},{},{},{:?},{lo},{hi},false,{}",
                        fit.from_n,
                        fit.to_n,
                        fit.points,
                        fit.slope,
                        fit.flag.map_or("", |f| f.name())
                    )
                }
            };
            out.push_str(&row);
            out.push('\n');
        }
    }
    out.into_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_folder_holds_one_run_legacy_manifests_are_read_by_content() {
        let experiment = serde_json::json!({
            "workbench_version": "0.1.0",
            "plan": {"integrands": [{"name": "cos3"}]},
            "files": {"trials.csv": "…"},
        });
        let mut names = legacy_manifest_files(&experiment).unwrap();
        names.sort();
        assert_eq!(
            names,
            [
                "cos3-cost.caption.txt",
                "cos3-cost.svg",
                "cos3.svg",
                "manifest.json",
                "summary.csv",
                "timings-summary.csv",
                "timings-trials.csv",
                "timings.json",
                "trials.csv"
            ]
        );
        assert!(legacy_manifest_files(&serde_json::json!({"files": {"a": "b"}})).is_none());
    }

    /// A manifest that lists its files accounts beyond them for its run's machine-dependent
    /// files only (a folder whose manifest a checkout replaced keeps its timing files).
    #[test]
    fn committed_manifests_list_only_files_a_checkout_has_timing_files_stay_ours() {
        let experiment = serde_json::json!({
            "workbench_version": "0.1.0",
            "plan": {"integrands": [{"name": "cos3"}]},
            "files": {"trials.csv": "…", "manifest.json": "…"},
        });
        let mut names = legacy_manifest_files(&experiment).unwrap();
        names.sort();
        assert_eq!(
            names,
            [
                "cos3-cost.caption.txt",
                "cos3-cost.svg",
                "timings-summary.csv",
                "timings-trials.csv",
                "timings.json"
            ]
        );
    }
}
