//! Every estimator of `Method::ALL` runs in every path that estimates: a fixed-N experiment, a
//! tolerance estimator (the staged walker), and an adaptive render. A new estimator that needs
//! only weights (one file in `bq/estimator/` and its arm in `Method`) is walked here without
//! further edits.

use crate::common::*;
use workbench::bq::estimator::Method;
use workbench::bq::kernel::{Kernel, Sobolev};
use workbench::bq::kernel_mean::KernelMeanMode;
use workbench::bq::model::BmcModel;
use workbench::render::adaptive::{self, AdaptiveSampler, AdaptiveSettings};
use workbench::render::{Environment, IntegratorKind, Renderer};
use workbench::util::report::Silent;

/// Fixed-N and tolerance estimators of every method in one experiment: each states a finite
/// estimate and a posterior sd in `trials.csv`, and each tolerance estimator has a stopping row.
#[test]
fn every_method_runs_fixed_and_to_a_tolerance() {
    let estimators: Vec<String> = Method::ALL
        .iter()
        .flat_map(|m| {
            [
                format!(r#"{{"label": "fixed {m}", "method": "{m}"}}"#),
                format!(
                    r#"{{"label": "tol {m}", "method": "{m}", "tolerance": {{"abs": 0.05, "max_n": 128}}}}"#
                ),
            ]
        })
        .collect();
    let spec = format!(
        r#"{{"name": "conformance", "integrands": ["cos3"], "estimators": [{}], "samples": [16], "trials": 3, "seed": 5}}"#,
        estimators.join(", ")
    );
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("c.json"), spec).unwrap();
    let o = workbench(dir.path(), &["run", "c.json", "-q", "--out", "o"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (header, rows) = read_csv(&dir.path().join("o/trials.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (label, estimate, sd) = (col("estimator"), col("estimate"), col("posterior_sd"));
    for m in Method::ALL {
        for kind in ["fixed", "tol"] {
            let name = format!("{kind} {m}");
            let mine: Vec<&Vec<String>> = rows.iter().filter(|r| r[label] == name).collect();
            assert_eq!(mine.len(), 3, "{name}: one row per trial");
            for r in mine {
                let e: f64 = r[estimate].parse().unwrap();
                let s: f64 = r[sd].parse().unwrap();
                assert!(
                    (e - std::f64::consts::FRAC_PI_2).abs() < 0.5,
                    "{name}: estimate {e}"
                );
                assert!(s.is_finite() && s >= 0.0, "{name}: sd {s}");
            }
        }
    }
    let (header, rows) = read_csv(&dir.path().join("o/stopping_summary.csv"));
    let label = header.iter().position(|h| h == "estimator").unwrap();
    for m in Method::ALL {
        assert!(
            rows.iter().any(|r| r[label] == format!("tol {m}")),
            "tol {m}: no stopping row"
        );
    }
}

/// Every method has an integrator that samples adaptively, and each renders: every hit pixel
/// stops at a stage, finite, and was stopped by the rule exactly when every channel's stated sd
/// meets the target.
#[test]
fn every_method_samples_adaptively() {
    let model = BmcModel::new(
        Kernel::Sobolev(Sobolev::new(1.4).unwrap()),
        0.01,
        KernelMeanMode::Exact,
    );
    let renderer = Renderer::new(12, 8, Environment::Sky);
    let settings = AdaptiveSettings::new(0.05, 8, 64);
    for m in Method::ALL {
        let kinds: Vec<IntegratorKind> = IntegratorKind::all()
            .into_iter()
            .filter(|k| k.method == m && k.adaptive())
            .collect();
        assert!(!kinds.is_empty(), "{m}: no adaptive integrator");
        for kind in kinds {
            let (sampler, _) = AdaptiveSampler::new(kind, &settings, 2, true, Some(&model), 3).unwrap();
            let r = adaptive::render(&renderer, &sampler, &settings, 9, &Silent);
            let mut hit = 0;
            for k in 0..r.spp.len() {
                let Some(met) = r.met[k] else { continue };
                hit += 1;
                assert!(
                    settings.stages.contains(&r.spp[k]),
                    "{kind}: pixel {k} at {} spp",
                    r.spp[k]
                );
                assert!(r.image.data[k].iter().all(|v| v.is_finite()), "{kind}: pixel {k}");
                assert_eq!(
                    met,
                    r.sd[k].iter().all(|&s| s <= 0.05),
                    "{kind}: pixel {k}: {:?}",
                    r.sd[k]
                );
            }
            assert!(hit > 0, "{kind}: no pixel hit the scene");
        }
    }
}
