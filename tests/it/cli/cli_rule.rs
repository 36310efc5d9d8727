//! `workbench rule` through the binary.

use crate::common::*;

#[test]
fn points_file_of_a_generated_set_reproduces_its_weights() {
    let dir = tempfile::tempdir().unwrap();
    for extra in [
        &[][..],
        &[
            "--kernel", "se", "--sigma", "1.5", "--length", "0.4", "--design", "cosine",
        ][..],
        &["--design", "fibonacci"][..],
    ] {
        let mut args = vec![
            "rule",
            "--n",
            "48",
            "--seed",
            "7",
            "--out",
            "a.csv",
            "--summary",
            "a.json",
        ];
        args.extend_from_slice(extra);
        let o = workbench(dir.path(), &args);
        assert!(o.status.success(), "{}", stderr(&o));
        let (header, rows) = read_csv(&dir.path().join("a.csv"));
        assert_eq!(header, ["x", "y", "z", "weight"]);
        assert_eq!(rows.len(), 48);
        let points: String = std::iter::once("x,y,z\n".to_string())
            .chain(rows.iter().map(|r| r[..3].join(",") + "\n"))
            .collect();
        std::fs::write(dir.path().join("points.csv"), points).unwrap();

        // From the points alone, and from the rule's own CSV (its weight column is ignored).
        for points in ["points.csv", "a.csv"] {
            let mut args = vec!["rule", "--points", points, "--seed", "7", "--out", "b.csv"];
            args.extend(
                extra
                    .iter()
                    .filter(|a| !["--design", "cosine", "fibonacci"].contains(a)),
            );
            let o = workbench(dir.path(), &args);
            assert!(o.status.success(), "{}", stderr(&o));
            let a = std::fs::read(dir.path().join("a.csv")).unwrap();
            let b = std::fs::read(dir.path().join("b.csv")).unwrap();
            assert_eq!(a, b, "weights differ after the round trip from {points}");
        }

        let summary: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join("a.json")).unwrap()).unwrap();
        for key in [
            "n",
            "kernel",
            "noise",
            "weight_sum",
            "prior_variance",
            "posterior_variance",
            "negative_weights",
            "jitter",
        ] {
            assert!(summary.get(key).is_some(), "summary lacks {key}");
        }
        let sum: f64 = rows.iter().map(|r| r[3].parse::<f64>().unwrap()).sum();
        assert!((sum - summary["weight_sum"].as_f64().unwrap()).abs() < 1e-12);
    }
}

#[test]
fn rule_to_stdout_has_the_header_and_n_rows() {
    let dir = tempfile::tempdir().unwrap();
    let o = workbench(dir.path(), &["rule", "--n", "5", "--seed", "1"]);
    assert!(o.status.success());
    let out = stdout(&o);
    assert!(out.starts_with("x,y,z,weight\n"));
    assert_eq!(out.lines().count(), 6);
}

#[test]
fn bad_rule_input_is_exit_2_with_a_clear_message() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.csv"), "x,y,z\n0,0,1\n0.5,0.5,0.5\n").unwrap();
    std::fs::write(dir.path().join("below.csv"), "x,y,z\n0,0,-1\n").unwrap();
    let cases: &[(&[&str], &str)] = &[
        (&["rule", "--points", "bad.csv"], "line 3"),
        (&["rule", "--points", "below.csv"], "below the horizon"),
        (&["rule", "--points", "missing.csv"], "missing.csv"),
        (&["rule", "--n", "0"], "--n"),
        (&["rule", "--n", "100000"], "GiB"),
        (
            &["rule", "--s", "2"],
            "s must be in (1, 2), (2, 3) or (3, 4), got 2",
        ),
        (
            &["rule", "--s", "4.5"],
            "s must be in (1, 2), (2, 3) or (3, 4), got 4.5",
        ),
        (&["rule", "--kernel", "se", "--length", "0"], "length"),
        (&["rule", "--noise", "-1"], "--noise"),
        (
            &["rule", "--kernel-mean", "mc", "--kernel-mean-samples", "0"],
            "--kernel-mean-samples",
        ),
        (&["rule", "--kernel", "matern"], "matern"),
        (
            &["rule", "--out", "r.csv", "--summary", "r.csv"],
            "--summary r.csv: is the same file as --out",
        ),
        (
            &["rule", "--points", "bad.csv", "--out", "./bad.csv"],
            "--out ./bad.csv: would overwrite --points",
        ),
        (
            &["rule", "--kernel", "se", "--length", "1e-300"],
            "length must be in [0.001, 10000]",
        ),
        (
            &["rule", "--kernel", "se", "--sigma", "1e200"],
            "sigma must be in [1e-100, 1e100]",
        ),
        (
            &["rule", "--kernel", "se", "--s", "1.3"],
            "--s: applies to --kernel sobolev, not se",
        ),
        (
            &["rule", "--length", "0.3"],
            "--length: applies to --kernel se, not sobolev",
        ),
        (
            &["rule", "--kernel-mean-samples", "10"],
            "--kernel-mean-samples: applies to --kernel-mean mc",
        ),
        (
            &[
                "rule",
                "--kernel-mean",
                "mc",
                "--kernel-mean-samples",
                "100000000000",
            ],
            "must be in 1..=10000000",
        ),
    ];
    for (args, needle) in cases {
        let o = workbench(dir.path(), args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
    }
}

/// `workbench rule … | head -1`: a reader that goes away ends the command quietly (exit 0, no
/// panic), as for any Unix filter.
#[test]
fn a_closed_stdout_is_a_quiet_exit() {
    use std::process::{Command, Stdio};
    // ~250 KB of CSV: more than a pipe holds, so the writer meets the closed pipe.
    let mut child = Command::new(env!("CARGO_BIN_EXE_workbench"))
        .args(["rule", "--n", "3000"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(!err.contains("panicked") && !err.contains("Error"), "{err}");
}

/// `workbench rule --n N --seed 3 --method M --scale S` into `dir`: the rule's rows and the
/// text of its `--summary`.
fn rule_with_summary(
    dir: &std::path::Path,
    n: &str,
    method: &str,
    scale: &str,
) -> (Vec<Vec<String>>, String) {
    let o = workbench(
        dir,
        &[
            "rule",
            "--n",
            n,
            "--seed",
            "3",
            "--method",
            method,
            "--scale",
            scale,
            "--out",
            "r.csv",
            "--summary",
            "r.json",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let (_, rows) = read_csv(&dir.join("r.csv"));
    (rows, std::fs::read_to_string(dir.join("r.json")).unwrap())
}

/// `--method bsq` writes the Bayes–Sard rule on the same points: weights summing to 2π to
/// rounding, and §8's Var₁ = BMC's + (2π − Σw_BMC)² / 1ᵀQ⁻¹1, so never below BMC's. It needs
/// two points; `--scale` is recorded with its interval law.
#[test]
fn bayes_sard_rule_sums_to_two_pi() {
    let dir = tempfile::tempdir().unwrap();
    let run = |method: &str, scale: &str| {
        let (rows, text) = rule_with_summary(dir.path(), "40", method, scale);
        let s: serde_json::Value = serde_json::from_str(&text).unwrap();
        let sum: f64 = rows.iter().map(|r| r[3].parse::<f64>().unwrap()).sum();
        (sum, s)
    };
    let (sum_bmc, bmc) = run("bmc", "unit");
    let (sum_bsq, bsq) = run("bsq", "ml");
    let tau = std::f64::consts::TAU;
    assert!((sum_bsq - tau).abs() < 1e-12, "{sum_bsq}");
    assert!(
        (sum_bmc - tau).abs() > 1e-6,
        "BMC's weights do not sum to 2π at N = 40"
    );
    let v = |s: &serde_json::Value| s["posterior_variance"].as_f64().unwrap();
    assert!(v(&bsq) > v(&bmc), "{} vs {}", v(&bsq), v(&bmc));
    assert_eq!(bsq["method"], "bsq");
    assert_eq!(bsq["scale"]["scale"], "ml");
    assert_eq!(bsq["scale"]["student_t_dof"], 39);
    assert_eq!(bsq["scale"]["interval"], "student_t");
    // Regression (issue 21, item 3): no `"student_t_dof": null` where no Student-t interval
    // applies; the interval kind says what does.
    assert!(bmc["scale"].get("student_t_dof").is_none(), "{}", bmc["scale"]);
    assert_eq!(bmc["scale"]["interval"], "normal");

    let o = workbench(dir.path(), &["rule", "--n", "1", "--method", "bsq"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--method bsq"), "{}", stderr(&o));
}

/// Issue 21, item 3: `rule --summary` wrote `"student_t_dof": null` under `--scale unit` and
/// `loo` — the JSON a NaN would give. Where no Student-t interval applies the key is left out
/// and `interval` says `normal`; under `ml` it is the Student-t's N dof (BMC) or N − 1 (BSQ).
#[test]
fn null_student_t_dof_rule_summary_leaves_it_out_under_unit_and_loo() {
    let dir = tempfile::tempdir().unwrap();
    for method in ["bmc", "bsq"] {
        for scale in ["unit", "loo", "ml"] {
            let (_, text) = rule_with_summary(dir.path(), "16", method, scale);
            assert!(!text.contains("null"), "{method} {scale}: {text}");
            let s: serde_json::Value = serde_json::from_str(&text).unwrap();
            let sc = &s["scale"];
            assert_eq!(sc["scale"], scale, "{sc}");
            if scale == "ml" {
                assert_eq!(sc["interval"], "student_t", "{sc}");
                let dof = if method == "bmc" { 16 } else { 15 };
                assert_eq!(sc["student_t_dof"], dof, "{method}: {sc}");
            } else {
                assert_eq!(sc["interval"], "normal", "{method} {scale}: {sc}");
                assert!(sc.get("student_t_dof").is_none(), "{method} {scale}: {sc}");
            }
        }
    }
}

/// `rule --kernel fitted --values FILE`: on cos³θ at 64 points the chosen model is a smooth one
/// (s > 2), its weights are byte for byte those of `rule` with that fixed kernel and noise, the
/// summary lists every grid model's ℓ with the chosen one largest, and the rule integrates the
/// values closer to the truth than the default s = 1.4 rule.
#[test]
fn rule_with_a_fitted_kernel_chooses_by_the_values() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = workbench(d, &["rule", "--n", "64", "--seed", "3", "--out", "fixed.csv"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let points = std::fs::read_to_string(d.join("fixed.csv")).unwrap();
    let rows: Vec<Vec<f64>> = points
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let values: Vec<f64> = rows.iter().map(|r| r[2].powi(3)).collect();
    let text: String = std::iter::once("value".to_string())
        .chain(values.iter().map(|v| format!("{v:?}")))
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(d.join("v.csv"), text + "\n").unwrap();
    let o = workbench(
        d,
        &[
            "rule",
            "--n",
            "64",
            "--seed",
            "3",
            "--kernel",
            "fitted",
            "--values",
            "v.csv",
            "--out",
            "fitted.csv",
            "--summary",
            "fitted.json",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("fitted.json")).unwrap()).unwrap();
    let s = summary["kernel"]["s"].as_f64().unwrap();
    let noise = summary["noise"].as_f64().unwrap();
    assert!(s > 2.0, "cos³ chose s = {s}");
    let grid = summary["fitted"]["grid"].as_array().unwrap();
    assert_eq!(grid.len(), 8);
    let chosen = summary["fitted"]["chosen"].as_u64().unwrap() as usize;
    let ell = |g: &serde_json::Value| g["log_marginal_likelihood"].as_f64().unwrap();
    assert!(grid.iter().all(|g| ell(g) <= ell(&grid[chosen])));
    assert_eq!(grid[chosen]["s"].as_f64(), Some(s));
    let o = workbench(
        d,
        &[
            "rule",
            "--n",
            "64",
            "--seed",
            "3",
            "--s",
            &s.to_string(),
            "--noise",
            &noise.to_string(),
            "--out",
            "same.csv",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let fitted = std::fs::read(d.join("fitted.csv")).unwrap();
    assert!(
        fitted == std::fs::read(d.join("same.csv")).unwrap(),
        "the chosen model's weights differ"
    );
    let integrate = |file: &str| -> f64 {
        std::fs::read_to_string(d.join(file))
            .unwrap()
            .lines()
            .skip(1)
            .zip(&values)
            .map(|(l, v)| l.rsplit(',').next().unwrap().parse::<f64>().unwrap() * v)
            .sum()
    };
    let truth = std::f64::consts::FRAC_PI_2;
    let (e_fitted, e_fixed) = (
        (integrate("fitted.csv") - truth).abs(),
        (integrate("fixed.csv") - truth).abs(),
    );
    assert!(
        e_fitted < e_fixed,
        "fitted error {e_fitted} vs s = 1.4's {e_fixed}"
    );
}

/// A fitted rule's bad input: each a one-line error naming the flag or file and the value,
/// exit 2, nothing written.
#[test]
fn rule_with_a_fitted_kernel_refuses_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("v.csv"), "value\n".to_string() + &"0.5\n".repeat(16)).unwrap();
    std::fs::write(d.join("bad.csv"), "value\n0.5\nnan\n").unwrap();
    let cases: [(&[&str], &str); 8] = [
        (&["--n", "16", "--kernel", "fitted"], "needs --values"),
        (
            &["--n", "16", "--values", "v.csv"],
            "only used with --kernel fitted",
        ),
        (
            &["--kernel", "fitted", "--values", "v.csv", "--n", "15"],
            "16 values for 15 points",
        ),
        (
            &["--kernel", "fitted", "--values", "bad.csv", "--n", "2"],
            "line 3: value = `nan`",
        ),
        (
            &[
                "--n", "16", "--kernel", "fitted", "--values", "v.csv", "--grid-s", "3",
            ],
            "--grid-s: sobolev kernel: s must be in",
        ),
        (
            &[
                "--n",
                "16",
                "--kernel",
                "fitted",
                "--values",
                "v.csv",
                "--grid-noise=-1",
            ],
            "--grid-noise must be finite and >= 0, got -1",
        ),
        (
            &[
                "--n", "16", "--kernel", "fitted", "--values", "v.csv", "--noise", "0.1",
            ],
            "--noise: not used with --kernel fitted",
        ),
        (
            &["--n", "16", "--grid-s", "1.5"],
            "--grid-s: applies to --kernel fitted only",
        ),
    ];
    for (extra, message) in cases {
        let mut args = vec!["rule", "--out", "never.csv"];
        args.extend_from_slice(extra);
        let o = workbench(d, &args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {err}");
        assert!(err.contains(message), "{extra:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(!d.join("never.csv").exists());
    }
}
