//! Adaptive render tables (`"adaptive": {...}`) through the binary: the outputs, their
//! agreement with single adaptive renders of the same seed, and spec errors rejected before any
//! work.

use crate::common::*;
use std::path::Path;

const SPEC: &str = r#"{
  "name": "tiny-adaptive", "seed": 5, "width": 24, "height": 16,
  "adaptive": {"target_sd": [0.1, 0.04], "first_spp": 8, "max_spp": 64},
  "repetitions": [2, 1],
  "variants": [
    {"label": "MC", "integrator": "mc"},
    {"label": "MC cosine", "integrator": "mc-cos"},
    {"label": "BMC 2 GP", "integrator": "bmc", "gps": 2}
  ]
}"#;

/// `key = value` lines of a single render's stdout.
fn value(stdout: &str, key: &str) -> String {
    stdout
        .lines()
        .find_map(|l| l.strip_prefix(&format!("{key} = ")))
        .unwrap_or_else(|| panic!("no {key} in {stdout}"))
        .to_string()
}

fn number(s: &str) -> f64 {
    s.parse().unwrap_or_else(|_| panic!("not a number: {s:?}"))
}

#[test]
fn adaptive_table_matches_single_adaptive_renders() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("t.json"), SPEC).unwrap();
    let o = workbench(d, &["render", "t.json", "--results-dir", "out", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("| Method | T = 0.1 | T = 0.04 |"),
        "{}",
        stdout(&o)
    );
    let out = d.join("out/tiny-adaptive");

    let (head, rows) = read_csv(&out.join("rmse.csv"));
    assert_eq!(
        head.join(","),
        "variant,integrator,gps,rotate,target_sd,repetition,seed,rmse,mean_spp,share_met,within"
    );
    assert_eq!(rows.len(), 3 * (2 + 1));
    let (thead, cells) = read_csv(&out.join("table.csv"));
    assert_eq!(
        thead.join(","),
        "variant,integrator,gps,rotate,target_sd,repetitions,rmse_mean,rmse_sd,rmse_ci95_low,rmse_ci95_high,mean_spp,share_met,within"
    );
    assert_eq!(cells.len(), 3 * 2);
    // Each cell's mean spp and shares are the means of its renders'.
    for c in &cells {
        let mine: Vec<&Vec<String>> = rows.iter().filter(|r| r[0] == c[0] && r[4] == c[4]).collect();
        assert_eq!(mine.len().to_string(), c[5]);
        for (col, row_col) in [(10, 8), (11, 9), (12, 10)] {
            let mean = mine.iter().map(|r| number(&r[row_col])).sum::<f64>() / mine.len() as f64;
            assert!(
                (number(&c[col]) - mean).abs() <= 1e-12 * mean.abs().max(1.0),
                "{c:?}"
            );
        }
    }
    // Every render's numbers are in range; spp within the stages; a looser target takes fewer
    // samples than a tighter one (same variant, first repetition).
    for r in &rows {
        let spp = number(&r[8]);
        assert!((8.0..=64.0).contains(&spp), "{r:?}");
        for share in [&r[9], &r[10]] {
            assert!((0.0..=1.0).contains(&number(share)), "{r:?}");
        }
    }
    for v in ["MC", "MC cosine", "BMC 2 GP"] {
        let spp = |t: &str| {
            number(
                &rows
                    .iter()
                    .find(|r| r[0] == v && r[4] == t && r[5] == "0")
                    .unwrap()[8],
            )
        };
        assert!(spp("0.1") < spp("0.04"), "{v}");
    }
    // Seconds stay out of the stable files.
    for f in ["rmse.csv", "table.csv", "table.md"] {
        assert!(
            !std::fs::read_to_string(out.join(f)).unwrap().contains("seconds"),
            "{f}"
        );
    }
    assert!(
        std::fs::read_to_string(out.join("timings.csv"))
            .unwrap()
            .starts_with("variant,target_sd,repetition,seconds\n")
    );
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["adaptive"]["stages"], serde_json::json!([8, 16, 32, 64]));
    for f in [
        "bmc-2-gp-sd0.04.png",
        "bmc-2-gp-sd0.04-spp.png",
        "mc-cosine-sd0.1-error.png",
        "rmse_vs_spp.svg",
        "reference.png",
    ] {
        assert!(out.join(f).exists(), "{f}");
        assert!(manifest["files"].get(f).is_some(), "{f} not in the manifest");
    }

    // The same render by `render --target-sd` with the row's seed gives the same numbers.
    let cache = std::fs::read_dir(d.join("out/cache"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "exr"))
        .unwrap();
    for (label, integrator, extra) in [("BMC 2 GP", "bmc", &["--gps", "2"][..]), ("MC", "mc", &[][..])] {
        let row = rows
            .iter()
            .find(|r| r[0] == label && r[4] == "0.04" && r[5] == "0")
            .unwrap();
        let o = single(d, &cache, integrator, extra, "0.04", &row[6]);
        assert!(o.status.success(), "{}", stderr(&o));
        let s = stdout(&o);
        assert_eq!(
            value(&s, "mean spp"),
            format!("{:.2}", number(&row[8])),
            "{label}"
        );
        assert_eq!(
            value(&s, "share of pixels meeting the target"),
            format!("{:.4}", number(&row[9])),
            "{label}"
        );
        assert_eq!(value(&s, "rmse"), format!("{:.6e}", number(&row[7])), "{label}");
        assert_eq!(
            value(&s, "share of pixel channels within 1.96·target"),
            format!("{:.4}", number(&row[10])),
            "{label}"
        );
    }
}

/// `render --target-sd T --max-spp 64 --spp 8 --seed SEED` at the table's size.
fn single(
    d: &Path,
    reference: &Path,
    integrator: &str,
    extra: &[&str],
    target: &str,
    seed: &str,
) -> std::process::Output {
    let reference = reference.to_str().unwrap();
    let args = [
        &[
            "render",
            "--integrator",
            integrator,
            "--target-sd",
            target,
            "--max-spp",
            "64",
            "--spp",
            "8",
            "--seed",
            seed,
            "--width",
            "24",
            "--height",
            "16",
            "--reference",
            reference,
            "--out",
            "single.exr",
            "-q",
        ][..],
        extra,
    ]
    .concat();
    workbench(d, &args)
}

#[test]
fn adaptive_spec_errors_are_exit_2_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases = [
        (
            SPEC.replace("[0.1, 0.04]", "[0.1, 0]"),
            "bad.json: adaptive.target_sd[1]: must be finite and > 0, got 0",
        ),
        (
            SPEC.replace("[0.1, 0.04]", "[0.1, -0.5]"),
            "bad.json: adaptive.target_sd[1]: must be finite and > 0, got -0.5",
        ),
        (
            SPEC.replace("[0.1, 0.04]", "[]"),
            "bad.json: adaptive.target_sd: must list at least one target sd",
        ),
        (
            SPEC.replace("\"max_spp\": 64", "\"max_spp\": 4"),
            "bad.json: adaptive.max_spp: 4 is below the first stage adaptive.first_spp = 8",
        ),
        (
            SPEC.replace("\"first_spp\": 8", "\"first_spp\": 1"),
            "bad.json: adaptive.first_spp: 1 with variants[0] (mc): the first stage of adaptive MC needs at least 2 samples",
        ),
        (
            SPEC.replace("\"integrator\": \"bmc\"", "\"integrator\": \"bmc-rings\""),
            "bad.json: variants[2].integrator: bmc-rings cannot sample adaptively",
        ),
        (
            SPEC.replace("\"gps\": 2", "\"gps\": 2, \"scale\": \"loo\""),
            "bad.json: variants[2].scale: \"loo\": adaptive BMC states the ml amplitude's sd",
        ),
        (
            SPEC.replace("\"seed\": 5", "\"seed\": 5, \"spp\": [20, 40]"),
            "bad.json: spp: [20, 40]: a table with \"adaptive\" takes its samples per pixel from adaptive.first_spp",
        ),
        (
            SPEC.replace("[2, 1]", "[2, 1, 1]"),
            "bad.json: repetitions: has 3 entries; it needs one count per entry of adaptive.target_sd (2), or one number",
        ),
        (
            SPEC.replace("\"max_spp\": 64", "\"max_spp\": 64, \"tolerance\": 1"),
            "bad.json: adaptive.tolerance: unknown field `tolerance`",
        ),
        (
            SPEC.replace("\"max_spp\": 64", "\"max_spp\": 20000"),
            "bad.json: adaptive.max_spp with variants[2] (bmc):",
        ),
    ];
    for (text, want) in cases {
        std::fs::write(d.join("bad.json"), &text).unwrap();
        let o = workbench(d, &["render", "bad.json", "--results-dir", "out"]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{want}: {err}");
        assert!(err.contains(want), "expected `{want}` in: {err}");
        assert_eq!(err.lines().count(), 1, "one line: {err}");
        assert!(!d.join("out").exists(), "{want}: wrote output");
    }
}

/// Defaults of the adaptive fields, and the plan a spec resolves to.
#[test]
fn adaptive_fields_resolve_with_defaults() {
    use workbench::table::adaptive::plan::{AdaptivePlan, DEFAULT_FIRST_SPP};
    let text = r#"{"name": "t", "adaptive": {"target_sd": [0.05, 0.02], "max_spp": 256},
                   "variants": [{"integrator": "mc"}, {"integrator": "bmc"}]}"#;
    let plan = workbench::table::plan::parse(text, Path::new("t.json")).unwrap();
    assert_eq!(
        plan.adaptive,
        Some(AdaptivePlan {
            targets: vec![0.05, 0.02],
            first_spp: DEFAULT_FIRST_SPP,
            max_spp: 256
        })
    );
    assert!(plan.spp.is_empty());
    assert_eq!(plan.repetitions, vec![10, 10]);
    assert_eq!(
        plan.adaptive.as_ref().unwrap().settings(0.05).stages,
        vec![64, 128, 256],
        "the default pilot is an experiment's default min_n"
    );
    assert_eq!(DEFAULT_FIRST_SPP, workbench::bq::stages::DEFAULT_MIN_N);
    // A fixed-spp table has no adaptive plan.
    let fixed = workbench::table::plan::parse(
        r#"{"name": "t", "variants": [{"integrator": "mc"}]}"#,
        Path::new("t.json"),
    )
    .unwrap();
    assert_eq!(fixed.adaptive, None);
    assert_eq!(fixed.spp, vec![20, 40, 60, 80]);
}
