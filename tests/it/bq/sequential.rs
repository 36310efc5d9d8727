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
    assert_eq!(stages::doubling(16, 1024), vec![16, 32, 64, 128, 256, 512, 1024]);
    assert_eq!(stages::doubling(16, 1000), vec![16, 32, 64, 128, 256, 512]);
    assert_eq!(stages::doubling(16, 16), vec![16]);
    assert_eq!(stages::doubling(3, 7), vec![3, 6]);
}

/// No stage has fewer points than the pilot `min_n` (default 64): a smaller first stage starts
/// at `min_n`, a larger one at itself.
#[test]
fn stages_start_at_the_pilot_min_n() {
    let t = Tolerance::new(0.1, 1024);
    assert_eq!((t.min_n, t.level, t.inflate), (64, 0.95, 1.0), "the defaults");
    assert_eq!(t.stages(16), vec![64, 128, 256, 512, 1024]);
    assert_eq!(t.stages(128), vec![128, 256, 512, 1024]);
    let small = Tolerance { min_n: 8, ..t };
    assert_eq!(small.stages(16), vec![16, 32, 64, 128, 256, 512, 1024]);
    assert_eq!(small.stages(2), vec![8, 16, 32, 64, 128, 256, 512, 1024]);
    let pts = Density::Uniform.sample_set(1024, &mut stream(7, &[]));
    let v: Vec<f64> = pts.iter().map(cos3).collect();
    let o = stages::mc(
        Density::Uniform,
        &pts,
        &v,
        &t.stages(16),
        Tolerance::new(1e3, 1024).target(),
    );
    assert_eq!(
        (o.n_used, o.met),
        (64, true),
        "a loose tolerance stops at the pilot"
    );
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

/// The guard (math.md §9): an integrand that is 0 on every sample (a light none of them saw)
/// gives MC a sample sd of 0 and BMC, BMCP and Bayes–Sard a fitted amplitude of 0 — a
/// zero-width interval that meets any tolerance. No stage with zero evidence stops the walk:
/// it runs to the last stage, is not met, and counts every stage.
#[test]
fn zero_evidence_never_stops_the_rule() {
    let pts = Density::Uniform.sample_set(256, &mut stream(1, &[]));
    let zeros = vec![0.0; pts.len()];
    let t = Tolerance {
        min_n: 8,
        ..Tolerance::new(1.0, 256)
    };
    let stages = t.stages(8);
    assert_eq!(stages.len(), 6);
    let o = stages::mc(Density::Uniform, &pts, &zeros, &stages, t.target());
    assert_eq!((o.n_used, o.met, o.zero_evidence), (256, false, 6), "MC");
    assert_eq!(o.uncertainty.unwrap().sd, 0.0);

    let m = model();
    let values = vec![zeros];
    for method in [Method::Bmc, Method::Bmcp, Method::Bsq] {
        for scale in [Scale::Ml, Scale::Loo] {
            let mut nested = NestedWeights::new(&m, &pts, &values, &[scale]);
            let walker = Walker {
                estimator: WeightedEstimator { method, scale },
                priors: vec![0.0],
                stages: stages.clone(),
                target: t.target(),
            };
            let o = stages::weighted_together(&[walker], &mut nested).unwrap()[0].outcomes[0];
            let what = format!("{method} {}", scale.name());
            assert_eq!(o.uncertainty.unwrap().amplitude, Some(0.0), "{what}");
            assert_eq!((o.n_used, o.met, o.zero_evidence), (256, false, 6), "{what}");
        }
        // The unit amplitude states its prior's sd whatever the values: evidence enough for the
        // rule (it is not a fitted interval), so it stops at the first stage.
        let mut nested = NestedWeights::new(&m, &pts, &values, &[Scale::Unit]);
        let walker = Walker {
            estimator: WeightedEstimator {
                method,
                scale: Scale::Unit,
            },
            priors: vec![0.0],
            stages: stages.clone(),
            target: Tolerance::new(10.0, 256).target(),
        };
        let o = stages::weighted_together(&[walker], &mut nested).unwrap()[0].outcomes[0];
        assert_eq!((o.n_used, o.met, o.zero_evidence), (8, true, 0), "{method} unit");
    }
}

/// The guard with a prior constant: BMCP's residuals `Y − c` are `−c`, not 0, when every
/// sample is 0, so its fitted amplitude is positive — but the samples saw nothing, and a
/// trial whose pilot missed a light must not stop there on the constant alone (found on a 5°
/// cap: BMCP met a 0.01 tolerance at N = 64 with the whole integral missing). Values that are
/// all equal are zero evidence for every fitted amplitude; a unit amplitude still stops.
#[test]
fn bmcp_on_samples_that_are_all_zero_never_stops() {
    let pts = Density::Uniform.sample_set(256, &mut stream(1, &[]));
    let values = vec![vec![0.0; pts.len()], vec![0.25; pts.len()]];
    let t = Tolerance {
        min_n: 8,
        ..Tolerance::new(1.0, 256)
    };
    let stages = t.stages(8);
    let m = model();
    for method in [Method::Bmc, Method::Bmcp, Method::Bsq] {
        for scale in [Scale::Ml, Scale::Loo] {
            let mut nested = NestedWeights::new(&m, &pts, &values, &[scale]);
            let walker = Walker {
                estimator: WeightedEstimator { method, scale },
                priors: vec![0.5, 0.5],
                stages: stages.clone(),
                target: t.target(),
            };
            for (fi, o) in stages::weighted_together(&[walker], &mut nested).unwrap()[0]
                .outcomes
                .iter()
                .enumerate()
            {
                let what = format!("{method} {} integrand {fi}", scale.name());
                assert_eq!((o.n_used, o.met, o.zero_evidence), (256, false, 6), "{what}");
            }
        }
    }
    // The same samples and prior with values that vary meet the loose tolerance at once.
    let varied = vec![pts.iter().map(cos3).collect::<Vec<_>>()];
    let mut nested = NestedWeights::new(&m, &pts, &varied, &[Scale::Ml]);
    let walker = Walker {
        estimator: WeightedEstimator {
            method: Method::Bmcp,
            scale: Scale::Ml,
        },
        priors: vec![0.5],
        stages: stages.clone(),
        target: Tolerance::new(10.0, 256).target(),
    };
    let o = stages::weighted_together(&[walker], &mut nested).unwrap()[0].outcomes[0];
    assert_eq!((o.n_used, o.met, o.zero_evidence), (8, true, 0));
}

/// A fitted model's walk chooses at each stage what a fixed-N fit on that stage's points
/// chooses ([`workbench::bq::fitted::choose_on_points`], its own dense factorisations), and its
/// estimate is that choice's weights applied to the values, to rounding: the nested factors
/// change no decision.
#[test]
fn a_fitted_walk_chooses_at_each_stage_as_a_fixed_n_fit() {
    use workbench::bq::fitted::choose_on_points;
    let fitted = BmcModel::fitted(
        [1.2, 1.6, 2.75, 3.75]
            .iter()
            .flat_map(|&s| {
                [1e-2, 1e-8].map(|noise| {
                    BmcModel::new(
                        Kernel::Sobolev(Sobolev::new(s).unwrap()),
                        noise,
                        KernelMeanMode::Exact,
                    )
                })
            })
            .collect(),
    );
    let pts = Density::Uniform.sample_set(256, &mut stream(5, &[]));
    let cap = |p: &Vec3| if p.x > 0.6 { p.z } else { 0.0 };
    let values = vec![
        pts.iter().map(cos3).collect::<Vec<f64>>(),
        pts.iter().map(cap).collect(),
    ];
    let scales = [Scale::Ml];
    let mut candidates: Vec<NestedWeights> = fitted
        .candidates()
        .iter()
        .map(|m| NestedWeights::new(m, &pts, &values, &scales))
        .collect();
    // Targets that stop at different stages: none (the last), and a loose one.
    for abs in [1e-12, 0.05] {
        let t = Tolerance {
            min_n: 16,
            ..Tolerance::new(abs, 256)
        };
        let walker = Walker {
            estimator: WeightedEstimator {
                method: Method::Bmc,
                scale: Scale::Ml,
            },
            priors: vec![0.0, 0.0],
            stages: t.stages(16),
            target: t.target(),
        };
        let run = &stages::fitted_together(&[walker], &mut candidates).unwrap()[0];
        for (fi, o) in run.run.outcomes.iter().enumerate() {
            let n = o.n_used;
            let y = &values[fi][..n];
            let choice = choose_on_points(
                &fitted,
                &pts[..n],
                Design::Iid(Density::Uniform),
                Method::Bmc,
                y,
                0.0,
                &mut stream(0, &[]),
            )
            .unwrap();
            assert_eq!(
                run.chosen[fi], choice.chosen,
                "abs {abs}, integrand {fi}, N = {n}"
            );
            let direct: f64 = choice.weights.weights.iter().zip(y).map(|(w, v)| w * v).sum();
            assert!(
                (o.estimate - direct).abs() <= 1e-9 * direct.abs().max(1.0),
                "abs {abs}, integrand {fi}: {} vs {direct}",
                o.estimate
            );
        }
    }
}

/// A feature the first stages miss: MC doubles on through the zero-evidence stages (counting
/// them) and stops at the first stage whose interval, now with evidence, meets the tolerance.
#[test]
fn zero_evidence_stages_are_counted_and_doubled_on() {
    let pts = Density::Uniform.sample_set(512, &mut stream(2, &[]));
    // 0 on the first 32 points, cos³θ from there on.
    let v: Vec<f64> = pts
        .iter()
        .enumerate()
        .map(|(i, p)| if i < 32 { 0.0 } else { cos3(p) })
        .collect();
    let t = Tolerance {
        min_n: 8,
        ..Tolerance::new(2.0, 512)
    };
    let o = stages::mc(Density::Uniform, &pts, &v, &t.stages(8), t.target());
    assert_eq!(o.zero_evidence, 3, "stages 8, 16 and 32 saw only zeros: {o:?}");
    assert!(o.met && o.n_used == 64, "{o:?}");
    assert!(o.uncertainty.unwrap().sd > 0.0);
}

/// An unreachable tolerance runs to the last stage and says it did not meet the rule; a loose
/// one stops early, and what it reports at N is exactly the fixed-N estimate and sd at N.
#[test]
fn the_rule_stops_where_the_interval_is_narrow_enough() {
    let pts = Density::Uniform.sample_set(512, &mut stream(2, &[]));
    let v: Vec<f64> = pts.iter().map(cos3).collect();
    let stages = stages::doubling(4, 512);
    let tol = |abs| Tolerance {
        min_n: 4,
        ..Tolerance::new(abs, 512)
    };
    let tight = stages::mc(Density::Uniform, &pts, &v, &stages, tol(1e-9).target());
    assert_eq!((tight.n_used, tight.met), (512, false));
    let loose = stages::mc(Density::Uniform, &pts, &v, &stages, tol(0.3).target());
    assert!(loose.met && loose.n_used < 512, "{loose:?}");
    assert_eq!(loose.zero_evidence, 0);
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

/// `level` and `inflate` widen the half-width the rule compares (QMCPy's `inflate · q · sd`):
/// each stops at the first stage where its own half-width meets the tolerance, no earlier than
/// the default rule.
#[test]
fn level_and_inflate_widen_the_half_width() {
    let pts = Density::Uniform.sample_set(4096, &mut stream(5, &[]));
    let v: Vec<f64> = pts.iter().map(cos3).collect();
    let base = Tolerance::new(0.16, 4096);
    let stages = base.stages(64);
    let at = |t: Tolerance| stages::mc(Density::Uniform, &pts, &v, &stages, t.target());
    let plain = at(base);
    for t in [
        Tolerance { inflate: 2.0, ..base },
        Tolerance { level: 0.99, ..base },
    ] {
        let o = at(t);
        assert!(o.met && o.n_used > plain.n_used, "{t:?}: {o:?} vs {plain:?}");
        let u = o.uncertainty.unwrap();
        let expect = t.inflate * u.quantile(t.level) * u.sd;
        assert_eq!(t.half_width(&u), expect);
        assert!(expect <= 0.16);
        let m = o.n_used / 2;
        let before = Method::Mc
            .uncertainty(Density::Uniform, &pts[..m], &v[..m], None, Scale::Unit, 1.0)
            .unwrap();
        assert!(t.half_width(&before) > 0.16, "{t:?} went on at {m}");
    }
}

/// Sequential BMC, BMCP and Bayes–Sard (ml and loo) stopping at every stage in turn equal the
/// fixed-N estimators on a fresh factorisation of that stage: estimate, sd and dof to 1e-9.
#[test]
fn extended_weight_sets_match_fresh_ones() {
    let m = model();
    let pts = Density::Uniform.sample_set(128, &mut stream(4, &[]));
    let values = vec![pts.iter().map(cos3).collect::<Vec<f64>>()];
    let stages = stages::doubling(8, 128);
    for method in [Method::Bmc, Method::Bmcp, Method::Bsq] {
        for scale in [Scale::Unit, Scale::Ml, Scale::Loo] {
            let prior = if method.uses_prior() { 0.25 } else { 0.0 };
            // abs = 0 never stops: each stage is reported by ending the stages at it.
            for (k, &n) in stages.iter().enumerate() {
                let mut nested = NestedWeights::new(&m, &pts, &values, &[scale]);
                let walker = Walker {
                    estimator: WeightedEstimator { method, scale },
                    priors: vec![prior],
                    stages: stages[..=k].to_vec(),
                    target: Tolerance::new(0.0, n).target(),
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

/// A run with tolerance estimators writes the stopping files; the rows agree with trials.csv and
/// the summary's columns (`met`, `within_given_met`, `zero_evidence` among them) with the rows;
/// `within_tolerance` passes for an estimator that meets its tolerance.
#[test]
fn experiments_stop_at_a_tolerance_and_check_it() {
    let dir = tempfile::tempdir().unwrap();
    let estimators = r#"{"label": "MC", "method": "mc", "tolerance": {"abs": 0.2, "max_n": 1024}},
        {"label": "BMC", "method": "bmc", "design": "sobol", "tolerance": {"abs": 0.03, "max_n": 256}},
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
    for line in [
        "PASS check BMC within tolerance given met",
        "PASS check BMC met by the rule",
    ] {
        assert!(stdout(&o).contains(line), "{line}: {}", stdout(&o));
    }
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
        // The default pilot: no trial uses fewer than 64 points.
        assert!(n_used >= 64 && (n_used / 64).is_power_of_two(), "{r:?}");
        let cap = if r[col("estimator")] == "MC" { 1024 } else { 256 };
        assert!(n_used <= cap && first <= n_used);
        let hw: f64 = r[col("half_width")].parse().unwrap();
        let hw95: f64 = r[col("half_width95")].parse().unwrap();
        assert_eq!(hw, hw95, "level 0.95 and inflate 1 by default");
        let tol: f64 = r[col("tolerance")].parse().unwrap();
        assert_eq!(r[col("zero_evidence_stages")], "0", "cos3 is never 0 everywhere");
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
    let scol = |name: &str| sh.iter().position(|c| c == name).unwrap();
    assert_eq!(summary.len(), 4);
    for s in &summary {
        let mine: Vec<&Vec<String>> = rows
            .iter()
            .filter(|r| {
                r[col("estimator")] == s[scol("estimator")] && r[col("first_n")] == s[scol("first_n")]
            })
            .collect();
        assert_eq!(mine.len(), 60);
        let mean_n = mine
            .iter()
            .map(|r| r[col("n_used")].parse::<f64>().unwrap())
            .sum::<f64>()
            / 60.0;
        let got: f64 = s[scol("mean_n_used")].parse().unwrap();
        assert!((got - mean_n).abs() < 1e-9, "{got} vs {mean_n}");
        let met: Vec<&&Vec<String>> = mine.iter().filter(|r| r[col("stopped")] == "true").collect();
        let within_met = met.iter().filter(|r| r[col("within")] == "true").count();
        assert_eq!(s[scol("met")], s[scol("stopped")]);
        let share: f64 = s[scol("met")].parse().unwrap();
        assert!((share - met.len() as f64 / 60.0).abs() < 1e-12);
        assert!(!met.is_empty(), "{s:?}");
        let wgm: f64 = s[scol("within_given_met")].parse().unwrap();
        assert!(
            (wgm - within_met as f64 / met.len() as f64).abs() < 1e-12,
            "{s:?}"
        );
        assert_eq!(s[scol("zero_evidence")], "0.0");
    }
}

/// The check's two ways to fail, each on its own line and each exit 1: the share within the
/// tolerance among the trials the rule stopped (a level MC cannot reach), and the share the rule
/// stopped at all (a tolerance BMC does not meet within max_n, however accurate it is).
#[test]
fn the_tolerance_check_fails_on_within_given_met_and_on_met_separately() {
    let dir = tempfile::tempdir().unwrap();
    let estimators = r#"{"label": "MC", "method": "mc", "tolerance": {"abs": 0.2, "max_n": 1024}},
        {"label": "BMC", "method": "bmc", "design": "sobol", "tolerance": {"abs": 0.01, "max_n": 256}}"#;
    let cases = [
        (
            r#"{"within_tolerance": "MC", "level": 0.999}"#,
            "FAIL check MC within tolerance given met",
            "PASS check MC met by the rule",
        ),
        (
            r#"{"within_tolerance": "BMC", "level": 0.95}"#,
            "PASS check BMC within tolerance given met",
            "FAIL check BMC met by the rule",
        ),
    ];
    for (i, (check, within, met)) in cases.iter().enumerate() {
        let file = format!("f{i}.json");
        write(dir.path(), &file, &spec(estimators, "[8, 16]", check));
        let out = format!("f{i}");
        let o = workbench(dir.path(), &["run", &file, "-q", "--out", &out]);
        assert_eq!(o.status.code(), Some(1), "{}{}", stdout(&o), stderr(&o));
        for line in [within, met] {
            assert!(stdout(&o).contains(line), "{line}: {}", stdout(&o));
        }
        let manifest: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.path().join(&out).join("manifest.json")).unwrap(),
        )
        .unwrap();
        let c = &manifest["tolerance_checks"][0];
        assert_eq!(c["passed"], false);
        assert_eq!(
            (c["within_given_met_passed"].as_bool(), c["met_passed"].as_bool()),
            (Some(within.starts_with("PASS")), Some(met.starts_with("PASS")))
        );
    }
    // BMC's trials are all within 0.01 (its error is far smaller), yet the rule stopped none.
    let (h, rows) = read_csv(&dir.path().join("f1/stopping_summary.csv"));
    let col = |name: &str| h.iter().position(|c| c == name).unwrap();
    let bmc: Vec<_> = rows.iter().filter(|r| r[col("estimator")] == "BMC").collect();
    assert!(
        bmc.iter()
            .all(|r| r[col("met")] == "0.0" && r[col("within_given_met")].is_empty())
    );
    assert!(bmc.iter().all(|r| r[col("within_tolerance")] == "1.0"));
}

/// The issue's failure (issue 20 item 3): a 25° cap light 45° off the zenith, × cos θ, with
/// BMC at A = 0.01 from N₀ = 16 (pilot min_n 16). About a fifth of the trials see no light in
/// their first 16 points, so every residual is 0, λ̂ = 0 and the interval has width 0; before
/// the guard those trials stopped at N = 16 with the whole integral missing. Now no trial stops
/// on a zero-width interval, the zero-evidence trials are counted, and they double on.
#[test]
fn issue_20_no_trial_stops_on_zero_evidence() {
    let dir = tempfile::tempdir().unwrap();
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let text = format!(
        r#"{{"name": "cap", "integrands": [{{"type": "cap", "axis": [{s}, 0, {s}], "half_angle": 25, "cosine": true}}],
            "estimators": [
              {{"label": "BMC", "method": "bmc", "tolerance": {{"abs": 0.01, "max_n": 128, "min_n": 16}}}},
              {{"label": "MC", "method": "mc", "tolerance": {{"abs": 0.01, "max_n": 128, "min_n": 16}}}}],
            "samples": [16], "trials": 80, "seed": 20}}"#
    );
    write(dir.path(), "cap.json", &text);
    let o = workbench(dir.path(), &["run", "cap.json", "-q", "--out", "o"]);
    assert_eq!(o.status.code(), Some(0), "{}{}", stdout(&o), stderr(&o));
    let (h, rows) = read_csv(&dir.path().join("o/stopping_trials.csv"));
    let col = |name: &str| h.iter().position(|c| c == name).unwrap();
    for label in ["BMC", "MC"] {
        let mine: Vec<_> = rows.iter().filter(|r| r[col("estimator")] == label).collect();
        for r in &mine {
            let hw: f64 = r[col("half_width")].parse().unwrap();
            assert!(
                !(r[col("stopped")] == "true" && hw == 0.0),
                "{label}: stopped on a zero-width interval: {r:?}"
            );
        }
        let zero: Vec<_> = mine
            .iter()
            .filter(|r| r[col("zero_evidence_stages")] != "0")
            .collect();
        assert!(
            zero.len() >= 5,
            "{label}: the scenario needs trials that miss the light at N = 16 ({} did)",
            zero.len()
        );
        for r in &zero {
            assert_ne!(
                r[col("n_used")],
                "16",
                "{label}: stopped at the first stage: {r:?}"
            );
        }
        let (sh, summary) = read_csv(&dir.path().join("o/stopping_summary.csv"));
        let s = summary.iter().find(|r| r[1] == label).unwrap();
        let share: f64 = s[sh.iter().position(|c| c == "zero_evidence").unwrap()]
            .parse()
            .unwrap();
        assert!(
            (share - zero.len() as f64 / 80.0).abs() < 1e-12,
            "{label}: {share}"
        );
    }
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
            spec(&mc(r#"{"abs": 0.1, "max_n": 64, "min_n": 1}"#), "[1, 8]", ""),
            "estimators[0].tolerance: method mc has no interval at the first stage N = 1 (samples[0], min_n 1)",
        ),
        (
            spec(&mc(r#"{"abs": 0.1, "max_n": 64, "min_n": 128}"#), "[8]", ""),
            "estimators[0].tolerance.min_n: 128 is above max_n = 64",
        ),
        (
            spec(&mc(r#"{"abs": 0.1, "max_n": 32}"#), "[8]", ""),
            "estimators[0].tolerance.min_n: 64 (the default pilot) is above max_n = 32",
        ),
        (
            spec(&mc(r#"{"abs": 0.1, "max_n": 64, "min_n": 0}"#), "[8]", ""),
            "estimators[0].tolerance.min_n: must be at least 1, got 0",
        ),
        (
            spec(&mc(r#"{"abs": 0.1, "max_n": 64, "inflate": 0.5}"#), "[8]", ""),
            "estimators[0].tolerance.inflate: must be a finite number ≥ 1 (it widens the half-width), got 0.5",
        ),
        (
            spec(&mc(r#"{"abs": 0.1, "max_n": 64, "level": 1}"#), "[8]", ""),
            "estimators[0].tolerance.level: must be in (0, 1), got 1",
        ),
        (
            spec(&mc(r#"{"abs": 0.1, "max_n": 64, "level": 0}"#), "[8]", ""),
            "estimators[0].tolerance.level: must be in (0, 1), got 0",
        ),
        (
            spec(&mc(r#"{"abs": 0.1, "max_n": 64, "pilot": 16}"#), "[8]", ""),
            "unknown field `pilot`",
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
