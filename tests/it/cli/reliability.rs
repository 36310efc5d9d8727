//! Issue 30 through the binary: the memory guard every command uses (one estimate, a stated
//! budget, exit 2 naming the flag or field, the bytes and the budget), and Sobolev kernels whose
//! `s` is too close to 2 or 3 to keep their scale.

use crate::common::*;
use std::path::Path;
use std::process::{Command, Output};

/// The binary with `WORKBENCH_MEMORY` set.
fn with_budget(dir: &Path, budget: &str, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_workbench"))
        .args(args)
        .current_dir(dir)
        .env("WORKBENCH_MEMORY", budget)
        .output()
        .expect("binary runs")
}

/// Exit 2 with one line holding `what`.
fn refused(o: &Output, what: &str) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.contains(what), "{what:?} not in {err}");
}

#[test]
fn rule_refuses_a_weight_set_over_the_memory_budget_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let o = with_budget(dir.path(), "64MiB", &["rule", "--n", "4096", "--out", "r.csv"]);
    refused(
        &o,
        "--n: a weight set of 4096 points needs 128.0 MiB (134217728 bytes) of memory, more than the \
         budget of 64.0 MiB (WORKBENCH_MEMORY=64MiB)",
    );
    assert!(!dir.path().join("r.csv").exists());
    let o = with_budget(dir.path(), "200MiB", &["rule", "--n", "4096", "--out", "r.csv"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = with_budget(dir.path(), "a lot", &["rule", "--n", "16"]);
    refused(&o, "WORKBENCH_MEMORY: \"a lot\" is not an amount of memory");
}

/// A tolerance estimator with a fitted kernel keeps a nested factor per grid model: `validate`
/// said "0.0 MiB per thread" for it, and the run panicked (exit 101) when memory ran out.
#[test]
fn run_and_validate_count_the_nested_factors_of_a_fitted_tolerance_estimator() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("t.json"),
        r#"{"name": "t", "integrands": ["cos3"], "seed": 1, "trials": 2, "samples": [64],
            "estimators": [{"label": "F", "method": "bmc", "kernel": {"type": "fitted"},
                            "tolerance": {"abs": 1e-3, "max_n": 2048}}]}"#,
    )
    .unwrap();
    let o = workbench(d, &["validate", "t.json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // 8 grid models' factors and the copy of one growing: 9 × 8 · 2048² bytes, and the points.
    assert!(
        stdout(&o).contains(
            "memory: 288.1 MiB per worker thread, for estimators[0] (\"F\"): 8 nested factors up to tolerance.max_n = 2048"
        ),
        "{}",
        stdout(&o)
    );
    let o = with_budget(d, "500MiB", &["run", "t.json", "--threads", "2", "-q"]);
    refused(
        &o,
        "estimators[0] (\"F\"): 8 nested factors up to tolerance.max_n = 2048 per worker thread (288.1 MiB) on 2 \
         threads needs 576.1 MiB",
    );
    assert!(!d.join("results").exists(), "nothing written");
}

#[test]
fn render_refuses_an_image_over_the_memory_budget() {
    let dir = tempfile::tempdir().unwrap();
    let o = with_budget(
        dir.path(),
        "100MiB",
        &[
            "render",
            "--integrator",
            "mc",
            "--spp",
            "1",
            "--width",
            "2048",
            "--height",
            "2048",
            "--out",
            "i.exr",
        ],
    );
    refused(&o, "--width/--height: a 2048×2048 image needs 192.0 MiB");
    assert!(!dir.path().join("i.exr").exists());
}

/// `rule --s 2.0000000000000004 --noise 1e-8` gave Σw = 0.00016 (2π expected) without a word;
/// cos³θ at s = 2.000000000001 had error 1.48 of 1.57 and coverage 0.
#[test]
fn a_sobolev_s_too_close_to_2_or_3_is_refused_with_reason_and_remedy() {
    let dir = tempfile::tempdir().unwrap();
    for (s, limit) in [
        ("2.0000000000000004", "2"),
        ("2.000000000001", "2"),
        ("3.000000000001", "3"),
    ] {
        let o = workbench(dir.path(), &["rule", "--s", s, "--noise", "1e-8"]);
        refused(
            &o,
            &format!("s = {s} is too close to {limit}: the kernel's scale k(x,x) = "),
        );
        assert!(
            stderr(&o).contains(&format!("use s − {limit} ≥ ")),
            "{}",
            stderr(&o)
        );
    }
    // Above the rounding bound but with a scale below the noise: a warning with the remedy.
    let o = workbench(
        dir.path(),
        &["rule", "--s", "2.000001", "--noise", "0.01", "--n", "16"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(
            "the sobolev kernel s = 2.000001 has scale k(x,x) = 1.22e-5, below the noise σ_n² = 0.01"
        ) && stderr(&o).contains("use s − 2 ≥ 8.2e-4 or a noise below 1.2e-5"),
        "{}",
        stderr(&o)
    );
    // Clear of the limit, the weights integrate constants.
    for s in ["2.000001", "3.000001", "1.999999"] {
        let o = workbench(dir.path(), &["rule", "--s", s, "--noise", "1e-8", "--n", "64"]);
        assert!(o.status.success(), "{}", stderr(&o));
        let text = stdout(&o);
        let sum: f64 = text
            .lines()
            .skip(1)
            .map(|l| l.rsplit(',').next().unwrap().parse::<f64>().unwrap())
            .sum();
        assert!((sum - std::f64::consts::TAU).abs() < 0.05, "s = {s}: Σw = {sum}");
    }
}

/// A render's sample sets were unguarded: only the image's size was checked, so a fitted model
/// keeping a factor per set and grid model (8 sets × 8 models × 8·N² at N = 8192: 32 GiB) or a
/// table at a large spp ran until memory ran out. One estimate, one guard: the single image,
/// the adaptive image and every variant of a table, before anything is written.
#[test]
fn render_counts_the_factors_its_sample_sets_keep_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let base = [
        "render",
        "--integrator",
        "bmc",
        "--width",
        "8",
        "--height",
        "8",
        "--out",
        "x.exr",
    ];
    fn with<'a>(base: &[&'a str], extra: &[&'a str]) -> Vec<&'a str> {
        [base, extra].concat()
    }
    // 8 sets × 8 grid models kept, and the one being computed: 65 × 8 · 1024² bytes.
    let o = with_budget(
        d,
        "256MiB",
        &with(&base, &["--spp", "1024", "--gps", "8", "--kernel", "fitted"]),
    );
    refused(
        &o,
        "--spp 1024: 8 sample sets of 1024 points for bmc keeping 64 factors (one per set and grid \
         model) on a 64-pixel image needs 520.0 MiB",
    );
    // A fixed model computes its sets one at a time: one factor, well under the budget.
    let o = with_budget(d, "256MiB", &with(&base, &["--spp", "1024", "--gps", "8"]));
    assert!(o.status.success(), "{}", stderr(&o));
    // Per-pixel sds keep one factor per set.
    let o = with_budget(
        d,
        "40MiB",
        &with(&base, &["--spp", "1024", "--gps", "8", "--sd-out", "sd.exr"]),
    );
    refused(&o, "keeping 8 factors (one per set for the sds)");
    let o = with_budget(
        d,
        "40MiB",
        &with(&base, &["--target-sd", "0.01", "--max-spp", "2048", "--gps", "2"]),
    );
    refused(
        &o,
        "--max-spp 2048: 2 sample sets of 2048 points for bmc keeping 2 factors",
    );
    std::fs::write(
        d.join("t.json"),
        r#"{"name": "t", "width": 8, "height": 8, "spp": [16, 1024], "repetitions": 1,
            "reference": {"spp": 4},
            "variants": [{"label": "MC", "integrator": "mc"},
                         {"label": "F", "integrator": "bmc", "gps": 8, "model": {"kernel": {"type": "fitted"}}}]}"#,
    )
    .unwrap();
    let o = with_budget(d, "256MiB", &["render", "t.json", "--results-dir", "out"]);
    refused(
        &o,
        "t.json: spp 1024 with variants[1]: 8 sample sets of 1024 points for bmc keeping 72 factors",
    );
    assert!(!d.join("out").exists() && !d.join("sd.exr").exists());
}

/// Issue 30 ("one message prints `String("mc")`"): a JSON value in a message is printed as JSON
/// (`"mc"`, `5`, `[1]`), never as a Rust `serde_json::Value` (`String("mc")`, `Number(5)`).
/// Wrong types and unknown values of the fields that take names (method, kernel, design, scale,
/// kernel mean, prior, sweep values, integrands, checks, plot bands; a render table's integrator,
/// repetitions, model) each refused in one line.
#[test]
fn json_values_in_messages_are_printed_as_json() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let experiment = |estimator: &str, extra: &str| {
        format!(
            r#"{{"name": "h", "integrands": ["cos3"], "samples": [16], "trials": 2, "seed": 1,
                "estimators": [{estimator}, {{"label": "M", "method": "mc"}}]{extra}}}"#
        )
    };
    let table = |variant: &str, extra: &str| {
        format!(
            r#"{{"name": "t", "width": 8, "height": 8, "spp": [4], "repetitions": 1,
                "variants": [{variant}]{extra}}}"#
        )
    };
    let cases = [
        (
            experiment(r#"{"label": "A", "method": "mc", "kernel": "mc"}"#, ""),
            r#"string "mc""#,
        ),
        (experiment(r#"{"label": "A", "method": 5}"#, ""), "integer `5`"),
        (experiment(r#"{"label": "A", "method": "zz"}"#, ""), "`zz`"),
        (
            experiment(r#"{"label": "A", "method": "bmc", "design": "mc"}"#, ""),
            r#""mc""#,
        ),
        (
            experiment(r#"{"label": "A", "method": "bmc", "scale": "mc"}"#, ""),
            "`mc`",
        ),
        (
            experiment(r#"{"label": "A", "method": "mc", "scale": "ml"}"#, ""),
            r#""ml" is not used"#,
        ),
        (
            experiment(r#"{"label": "A", "method": "mc", "kernel_mean": "mc"}"#, ""),
            r#""mc" is not used"#,
        ),
        (
            experiment(
                r#"{"label": "A", "method": "mc", "kernel": {"type": "sobolev", "s": 1.5}}"#,
                "",
            ),
            r#"{"type":"sobolev","s":1.5} is not used"#,
        ),
        (
            experiment(r#"{"label": "A", "method": "bmcp", "prior": "mc"}"#, ""),
            r#"string "mc""#,
        ),
        (
            experiment(r#"{"label": "A", "method": "bmc", "kernel": {"type": "mc"}}"#, ""),
            "`mc`",
        ),
        (
            experiment(
                r#"{"label": "A", "method": "bmc", "kernel": {"type": "fitted", "grid": "mc"}}"#,
                "",
            ),
            r#"string "mc""#,
        ),
        (
            experiment(
                r#"{"label": "A {design}", "method": "bmc", "sweep": {"design": ["mc", 5]}}"#,
                "",
            ),
            r#"unknown design "mc""#,
        ),
        (
            experiment(
                r#"{"label": "A", "method": "bmc", "sweep": {"kernel.type": [{"a": 1}]}}"#,
                "",
            ),
            r#"kernel.type={"a":1}"#,
        ),
        (
            experiment(r#"{"label": "A", "method": "bmc"}"#, r#", "plot": {"bands": 5}"#),
            "got 5",
        ),
        (
            experiment(
                r#"{"label": "A", "method": "bmc"}"#,
                r#", "plot": {"bands": ["mc"]}"#,
            ),
            r#""mc""#,
        ),
        (
            experiment(
                r#"{"label": "A", "method": "bmc"}"#,
                r#", "checks": [{"better": "A", "than": "mc"}]"#,
            ),
            r#""mc""#,
        ),
        (table(r#"{"label": "A", "integrator": "mc-x"}"#, ""), r#""mc-x""#),
        (
            table(
                r#"{"label": "A", "integrator": "mc"}"#,
                r#", "model": {"kernel": "mc"}"#,
            ),
            r#"string "mc""#,
        ),
        (
            table(r#"{"label": "A", "integrator": "mc", "scale": "ml"}"#, ""),
            r#""ml" is not used"#,
        ),
    ];
    let debug = [
        "String(", "Number(", "Array(", "Object(", "Bool(", "Null", "Some(",
    ];
    for (spec, want) in cases {
        // The table's file name says what it is (`validate` reads either).
        let name = if spec.contains("\"variants\"") {
            "t.json"
        } else {
            "s.json"
        };
        std::fs::write(d.join(name), &spec).unwrap();
        let o = with_budget(d, "8GiB", &["validate", name]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{spec}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
        assert!(err.contains(want), "{want:?} not in {err}");
        assert!(
            !debug.iter().any(|p| err.contains(p)),
            "a Debug-printed value: {err}"
        );
    }
}
