//! Stopping at a tolerance ([`workbench::bq::stages`]): the stages, nested designs, the stopping rule, the
//! weight sets of extended factors against fresh ones, and experiments with tolerance
//! estimators end to end (outputs, the `within_tolerance` check, bad input).

use crate::common::*;
use workbench::bq::estimator::Method;
use workbench::bq::factor::SpdWorkspace;
use workbench::bq::kernel::{Kernel, Sobolev};
use workbench::bq::kernel_mean::KernelMeanMode;
use workbench::bq::model::BmcModel;
use workbench::bq::stages::{self, NestedWeights, Tolerance, Walker, WeightedEstimator};
use workbench::bq::weights::Scale;
use workbench::bq::weights::Solved;
use workbench::sampling::{Density, Design};
use workbench::util::geometry::Vec3;
use workbench::util::rng::stream;

fn model() -> BmcModel {
    BmcModel::new(
        Kernel::Sobolev(Sobolev::new(1.4).unwrap()),
        0.01,
        KernelMeanMode::Exact,
    )
}

fn cos3(p: &Vec3) -> f64 {
    p.z.powi(3)
}

#[test]
fn stages_double_up_to_max_n() {
    let t = |max_n| Tolerance { abs: 0.1, max_n };
    assert_eq!(t(1024).stages(16), vec![16, 32, 64, 128, 256, 512, 1024]);
    assert_eq!(t(1000).stages(16), vec![16, 32, 64, 128, 256, 512]);
    assert_eq!(t(16).stages(16), vec![16]);
    assert_eq!(t(7).stages(3), vec![3, 6]);
}

/// i.i.d. and Sobol sets are nested (the first N points do not depend on the final N); the
/// Fibonacci lattice and the jittered grid are not, which is why tolerances refuse them.
#[test]
fn nested_designs_keep_their_first_points() {
    for d in Design::ALL {
        let small = d.sample_set(16, &mut stream(3, &[d.stream_id()]));
        let large = d.sample_set(64, &mut stream(3, &[d.stream_id()]));
        let nested = small[..] == large[..16];
        assert_eq!(
            nested,
            d.is_nested(),
            "{}: first 16 points identical = {nested}",
            d.name()
        );
    }
}

/// A constant integrand has zero sample variance (MC) and zero residuals (Bayes–Sard): both
/// state a zero-width interval at the first stage and stop there.
#[test]
fn a_constant_integrand_stops_at_the_first_stage() {
    let pts = Density::Uniform.sample_set(256, &mut stream(1, &[]));
    let ones = vec![1.0; pts.len()];
    let t = Tolerance {
        abs: 1e-9,
        max_n: 256,
    };
    let o = stages::mc(Density::Uniform, &pts, &ones, &t.stages(8), t.abs);
    assert_eq!((o.n_used, o.met), (8, true));
    assert!((o.estimate - std::f64::consts::TAU).abs() < 1e-12);

    let m = model();
    let values = vec![ones];
    let mut nested = NestedWeights::new(&m, &pts, &values, &[Scale::Ml]);
    let walker = Walker {
        estimator: WeightedEstimator {
            method: Method::Bsq,
            scale: Scale::Ml,
        },
        priors: vec![0.0],
        stages: t.stages(8),
        abs: t.abs,
    };
    let run = &stages::weighted_together(&[walker], &mut nested).unwrap()[0];
    assert_eq!((run.outcomes[0].n_used, run.outcomes[0].met), (8, true));
    assert!((run.outcomes[0].estimate - std::f64::consts::TAU).abs() < 1e-9);
    assert_eq!(run.diagnostics.n, 8, "only the first stage was factored");
}

/// An unreachable tolerance runs to the last stage and says it did not meet the rule; a loose
/// one stops early, and what it reports at N is exactly the fixed-N estimate and sd at N.
#[test]
fn the_rule_stops_where_the_interval_is_narrow_enough() {
    let pts = Density::Uniform.sample_set(512, &mut stream(2, &[]));
    let v: Vec<f64> = pts.iter().map(cos3).collect();
    let stages = Tolerance { abs: 1.0, max_n: 512 }.stages(4);
    let tight = stages::mc(Density::Uniform, &pts, &v, &stages, 1e-9);
    assert_eq!((tight.n_used, tight.met), (512, false));
    let loose = stages::mc(Density::Uniform, &pts, &v, &stages, 0.3);
    assert!(loose.met && loose.n_used < 512, "{loose:?}");
    let n = loose.n_used;
    let u = Method::Mc
        .uncertainty(Density::Uniform, &pts[..n], &v[..n], None, Scale::Unit, 1.0)
        .unwrap();
    assert_eq!(
        loose.estimate,
        Method::Mc.estimate(Density::Uniform, &pts[..n], &v[..n], None, 0.0)
    );
    assert_eq!(loose.uncertainty, Some(u));
    assert!(stages::half_width(&u) <= 0.3);
    // The stage before did not meet it (that is why it went on).
    let before = Method::Mc
        .uncertainty(
            Density::Uniform,
            &pts[..n / 2],
            &v[..n / 2],
            None,
            Scale::Unit,
            1.0,
        )
        .unwrap();
    assert!(stages::half_width(&before) > 0.3);
}

/// Sequential BMC, BMCP and Bayes–Sard (ml and loo) stopping at every stage in turn equal the
/// fixed-N estimators on a fresh factorisation of that stage: estimate, sd and dof to 1e-9.
#[test]
fn extended_weight_sets_match_fresh_ones() {
    let m = model();
    let pts = Density::Uniform.sample_set(128, &mut stream(4, &[]));
    let values = vec![pts.iter().map(cos3).collect::<Vec<f64>>()];
    let stages = Tolerance { abs: 1.0, max_n: 128 }.stages(8);
    for method in [Method::Bmc, Method::Bmcp, Method::Bsq] {
        for scale in [Scale::Unit, Scale::Ml, Scale::Loo] {
            let prior = if method.uses_prior() { 0.25 } else { 0.0 };
            // abs = 0 never stops: each stage is reported by forcing max_n to it.
            for (k, &n) in stages.iter().enumerate() {
                let mut nested = NestedWeights::new(&m, &pts, &values, &[scale]);
                let walker = Walker {
                    estimator: WeightedEstimator { method, scale },
                    priors: vec![prior],
                    stages: stages[..=k].to_vec(),
                    abs: 0.0,
                };
                let o = stages::weighted_together(&[walker], &mut nested).unwrap()[0].outcomes[0];
                assert_eq!(o.n_used, n);
                let mut ws = SpdWorkspace::new();
                let w = m.weights(&pts[..n], &mut stream(0, &[]), &mut ws).unwrap();
                let v = &values[0][..n];
                let mut solved = v.to_vec();
                ws.solve_in_place(&mut solved);
                let inv = (scale == Scale::Loo).then(|| ws.inverse_diagonal());
                let amplitude = method
                    .amplitude(scale, v, Solved::Full(&solved), Some(&w), prior, inv.as_deref())
                    .unwrap();
                let u = method
                    .uncertainty(Density::Uniform, &pts[..n], v, Some(&w), scale, amplitude)
                    .unwrap();
                let est = method.estimate(Density::Uniform, &pts[..n], v, Some(&w), prior);
                let got = o.uncertainty.unwrap();
                let what = format!("{method} {} at N = {n}", scale.name());
                assert!(
                    (o.estimate - est).abs() <= 1e-9 * est.abs(),
                    "{what}: {} vs {est}",
                    o.estimate
                );
                assert!(
                    (got.sd - u.sd).abs() <= 1e-9 * u.sd.max(1e-12),
                    "{what}: sd {} vs {}",
                    got.sd,
                    u.sd
                );
                assert_eq!(got.dof, u.dof, "{what}");
            }
        }
    }
}

fn write(dir: &std::path::Path, name: &str, text: &str) {
    std::fs::write(dir.join(name), text).unwrap();
}

fn spec(estimators: &str, samples: &str, checks: &str) -> String {
    format!(
        r#"{{"name": "tol", "integrands": ["cos3"], "estimators": [{estimators}],
            "samples": {samples}, "trials": 60, "seed": 9, "checks": [{checks}]}}"#
    )
}

/// A run with tolerance estimators writes the stopping files; the rows agree with trials.csv;
/// `within_tolerance` passes for an estimator that meets its tolerance and fails (exit 1) for a
/// level it cannot reach.
#[test]
fn experiments_stop_at_a_tolerance_and_check_it() {
    let dir = tempfile::tempdir().unwrap();
    let estimators = r#"{"label": "MC", "method": "mc", "tolerance": {"abs": 0.2, "max_n": 1024}},
        {"label": "BMC", "method": "bmc", "design": "sobol", "tolerance": {"abs": 0.01, "max_n": 256}},
        {"label": "fixed", "method": "bmc"}"#;
    write(
        dir.path(),
        "pass.json",
        &spec(
            estimators,
            "[8, 16]",
            r#"{"within_tolerance": "BMC", "level": 0.95}"#,
        ),
    );
    let o = workbench(dir.path(), &["run", "pass.json", "-q", "--out", "p"]);
    assert_eq!(o.status.code(), Some(0), "{}{}", stdout(&o), stderr(&o));
    assert!(
        stdout(&o).contains("PASS check BMC within tolerance"),
        "{}",
        stdout(&o)
    );
    let p = dir.path().join("p");
    assert!(p.join("cos3-tolerance.svg").is_file() && p.join("cos3.svg").is_file());
    let (h, rows) = read_csv(&p.join("stopping_trials.csv"));
    let col = |name: &str| h.iter().position(|c| c == name).unwrap();
    assert_eq!(
        rows.len(),
        2 * 2 * 60,
        "two tolerance estimators, two first stages"
    );
    let (th, trials) = read_csv(&p.join("trials.csv"));
    let tcol = |name: &str| th.iter().position(|c| c == name).unwrap();
    for r in &rows {
        let n_used: usize = r[col("n_used")].parse().unwrap();
        let first: usize = r[col("first_n")].parse().unwrap();
        assert!(n_used >= first && (n_used / first).is_power_of_two());
        let cap = if r[col("estimator")] == "MC" { 1024 } else { 256 };
        assert!(n_used <= cap);
        let hw: f64 = r[col("half_width95")].parse().unwrap();
        let tol: f64 = r[col("tolerance")].parse().unwrap();
        assert_eq!(r[col("stopped")] == "true", hw <= tol, "{r:?}");
        // The same trial in trials.csv has the same error.
        let t = trials
            .iter()
            .find(|x| {
                x[tcol("estimator")] == r[col("estimator")]
                    && x[tcol("n")] == r[col("first_n")]
                    && x[tcol("trial")] == r[col("trial")]
            })
            .unwrap();
        assert_eq!(t[tcol("abs_error")], r[col("abs_error")]);
    }
    let (sh, summary) = read_csv(&p.join("stopping_summary.csv"));
    assert_eq!(summary.len(), 4);
    let mean_n: f64 = summary[0][sh.iter().position(|c| c == "mean_n_used").unwrap()]
        .parse()
        .unwrap();
    let expect: f64 = rows
        .iter()
        .filter(|r| r[col("estimator")] == "MC" && r[col("first_n")] == "8")
        .map(|r| r[col("n_used")].parse::<f64>().unwrap())
        .sum::<f64>()
        / 60.0;
    assert!((mean_n - expect).abs() < 1e-9, "{mean_n} vs {expect}");

    write(
        dir.path(),
        "fail.json",
        &spec(
            estimators,
            "[8, 16]",
            r#"{"within_tolerance": "MC", "level": 0.999}"#,
        ),
    );
    let o = workbench(dir.path(), &["run", "fail.json", "-q", "--out", "f"]);
    assert_eq!(o.status.code(), Some(1), "{}{}", stdout(&o), stderr(&o));
    assert!(
        stdout(&o).contains("FAIL check MC within tolerance"),
        "{}",
        stdout(&o)
    );
}

/// Bad tolerances are one line naming the file and JSON path, exit 2, nothing written.
#[test]
fn bad_tolerances_are_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let mc = |tol: &str| format!(r#"{{"label": "MC", "method": "mc", "tolerance": {tol}}}"#);
    let cases: Vec<(String, &str)> = vec![
        (
            spec(&mc(r#"{"abs": 0, "max_n": 64}"#), "[8]", ""),
            "estimators[0].tolerance.abs: must be a positive finite number, got 0",
        ),
        (
            spec(&mc(r#"{"abs": -1e-3, "max_n": 64}"#), "[8]", ""),
            "estimators[0].tolerance.abs: must be a positive",
        ),
        (
            spec(&mc(r#"{"abs": 0.1, "max_n": 8}"#), "[8, 16]", ""),
            "estimators[0].tolerance.max_n: 8 is below the first stage N = 16 (samples[1])",
        ),
        (
            spec(&mc(r#"{"abs": 0.1, "max_n": 64}"#), "[1, 8]", ""),
            "estimators[0].tolerance: method mc has no interval at the first stage N = 1 (samples[0])",
        ),
        (
            spec(
                r#"{"label": "S", "method": "mc", "design": "stratified", "tolerance": {"abs": 0.1, "max_n": 64}}"#,
                "[8]",
                "",
            ),
            "estimators[0].design: \"stratified\" is not nested",
        ),
        (
            spec(
                r#"{"label": "B", "method": "bmc", "kernel_mean": "mc", "tolerance": {"abs": 0.1, "max_n": 64}}"#,
                "[8]",
                "",
            ),
            "estimators[0].kernel_mean:",
        ),
        (spec(&mc(r#"{"abs": 0.1}"#), "[8]", ""), "max_n"),
        (
            spec(
                r#"{"label": "MC", "method": "mc"}"#,
                "[8]",
                r#"{"within_tolerance": "MC"}"#,
            ),
            "checks[0].within_tolerance: \"MC\" has no \"tolerance\"",
        ),
        (
            spec(
                &mc(r#"{"abs": 0.1, "max_n": 64}"#),
                "[8]",
                r#"{"within_tolerance": "MC", "alpha": 0.1}"#,
            ),
            "checks[0].alpha: is not used by a tolerance check",
        ),
    ];
    for (i, (text, expected)) in cases.iter().enumerate() {
        let file = format!("bad{i}.json");
        write(dir.path(), &file, text);
        let o = workbench(dir.path(), &["run", &file, "-q", "--out", "o"]);
        assert_eq!(o.status.code(), Some(2), "{file}: {}", stderr(&o));
        let err = stderr(&o);
        assert_eq!(err.trim_end().lines().count(), 1, "{file}: one line: {err}");
        assert!(err.contains(&file) && err.contains(expected), "{file}: {err}");
        assert!(!dir.path().join("o").exists(), "{file}: nothing written");
    }
}
