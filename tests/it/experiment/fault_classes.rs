//! Regression tests for issue 8's fault classes that are not covered elsewhere (the others live
//! in `tests/it/experiment/outputs.rs`, `tests/it/experiment/inputs.rs`, `tests/it/render/image_read.rs` and `tests/it/bq/mc_kernel_means.rs`),
//! each named after its class.

use crate::common::*;
use std::process::Command;

const SPEC: &str = r#"{
  "name": "small", "integrands": ["cos3"],
  "estimators": [ { "label": "MC", "method": "mc" }, { "label": "BMCP", "method": "bmcp", "prior": PRIOR } ],
  "samples": [4, 8], "trials": 4, "seed": 1
}"#;

/// `"prior": 1e308` made every BMCP estimate infinite or NaN: a prior whose `2π·c` overflows is
/// rejected at validation, naming the path and the value; a large but finite one still runs.
#[test]
fn silent_nan_or_infinity_a_prior_that_can_only_overflow_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("x.json"), SPEC.replace("PRIOR", "1e308")).unwrap();
    let o = workbench(dir.path(), &["run", "x.json", "-q"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("x.json: estimators[1].prior:") && err.contains("1e308"),
        "{err}"
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(!dir.path().join("results").exists(), "nothing may be written");

    std::fs::write(dir.path().join("x.json"), SPEC.replace("PRIOR", "1e100")).unwrap();
    let o = workbench(dir.path(), &["run", "x.json", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Issue 21, item 2: a large but finite BMCP prior (|c| ≈ 1e155) overflowed the fitted
/// amplitude — an infinite amplitude and sd with no warning at N = 2, a false "every residual is
/// 0" warning at N = 64. It is now refused with the bound stated; at the bound the amplitude and
/// the posterior sd are finite and nothing warns.
#[test]
fn overflowing_amplitude_a_huge_bmcp_prior_is_refused_with_the_bound() {
    let dir = tempfile::tempdir().unwrap();
    let spec = |prior: &str| SPEC.replace("PRIOR", prior).replace("[4, 8]", "[2, 64]");
    std::fs::write(dir.path().join("x.json"), spec("-1e155")).unwrap();
    let o = workbench(dir.path(), &["run", "x.json", "-q"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("x.json: estimators[1].prior: must be finite with |c| ≤ 1e100")
            && err.contains("-1e155"),
        "{err}"
    );
    assert!(!dir.path().join("results").exists(), "nothing may be written");

    std::fs::write(dir.path().join("x.json"), spec("-1e100")).unwrap();
    let o = workbench(dir.path(), &["run", "x.json", "-q", "--out", "o"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (header, rows) = read_csv(&dir.path().join("o/trials.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    for r in rows.iter().filter(|r| r[col("estimator")] == "BMCP") {
        let amplitude: f64 = r[col("amplitude")].parse().unwrap();
        let sd: f64 = r[col("posterior_sd")].parse().unwrap();
        assert!(amplitude.is_finite() && amplitude > 0.0, "amplitude {amplitude}");
        assert!(sd.is_finite() && sd > 0.0, "sd {sd}");
        assert_eq!(r[col("warnings")], "0", "{r:?}");
    }
}

/// Issue 21, item 2, by another road: the bound on the prior is relative to the kernel's scale.
/// An SE kernel with `σ_f = 1e-100` and no noise (both accepted) made `1ᵀQ⁻¹1` ~1e200 times
/// larger, so `|c| = 1e60` — far below 1e100 — overflowed the amplitude (∞ with no warning at
/// N = 2, a false "every residual is 0" at N = 64). Such a prior is now refused with the bound
/// for that model, `1e100 · √(k(x,x) + σ_n²) = 1`; at the bound nothing overflows or warns.
#[test]
fn overflowing_amplitude_a_prior_large_for_a_tiny_kernel_scale_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let spec = |prior: &str| {
        SPEC.replace(
            r#""prior": PRIOR"#,
            &format!(
                r#""prior": {prior}, "kernel": {{"type": "se", "sigma": 1e-100, "length": 0.5}}, "noise": 0"#
            ),
        )
        .replace("[4, 8]", "[2, 64]")
    };
    std::fs::write(dir.path().join("x.json"), spec("1e60")).unwrap();
    let o = workbench(dir.path(), &["run", "x.json", "-q"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains(
            "x.json: estimators[1].prior: must be finite with |c| ≤ 1e100 · min(1, √(k(x,x) + σ_n²)) = 1e0"
        ) && err.contains("got 1e60"),
        "{err}"
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(!dir.path().join("results").exists(), "nothing may be written");

    std::fs::write(dir.path().join("x.json"), spec("-1")).unwrap();
    let o = workbench(dir.path(), &["run", "x.json", "-q", "--out", "o"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (header, rows) = read_csv(&dir.path().join("o/trials.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let bmcp: Vec<_> = rows.iter().filter(|r| r[col("estimator")] == "BMCP").collect();
    assert_eq!(bmcp.len(), 8);
    for r in bmcp {
        let amplitude: f64 = r[col("amplitude")].parse().unwrap();
        let sd: f64 = r[col("posterior_sd")].parse().unwrap();
        assert!(amplitude.is_finite() && amplitude > 0.0, "amplitude {amplitude}");
        assert!(sd.is_finite() && sd > 0.0, "sd {sd}");
        assert!(!r[col("warnings")].is_empty(), "{r:?}");
    }
    let stderr_text = stderr(&o);
    assert!(!stderr_text.contains("every residual is 0"), "{stderr_text}");
}

/// A cached reference with a NaN pixel was used without a word: it is now damaged, reported and
/// rendered again, and the table's RMSEs are finite.
#[test]
fn silent_nan_or_infinity_a_damaged_reference_cache_is_rendered_again() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let spec = r#"{"name": "t", "width": 8, "height": 6, "spp": [4], "repetitions": 2,
                   "reference": {"spp": 16}, "variants": [{"integrator": "mc"}]}"#;
    std::fs::write(d.join("t.json"), spec).unwrap();
    let o = workbench(d, &["render", "t.json", "--results-dir", "out", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cached: Vec<_> = std::fs::read_dir(d.join("out/cache"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "exr"))
        .collect();
    assert_eq!(cached.len(), 1);
    // Replace the cached image with one of the same size holding a NaN.
    let mut img = image::Rgb32FImage::new(8, 6);
    img.put_pixel(3, 2, image::Rgb([0.5, f32::NAN, 0.5]));
    image::DynamicImage::ImageRgb32F(img)
        .save_with_format(&cached[0], image::ImageFormat::OpenExr)
        .unwrap();

    let o = workbench(d, &["render", "t.json", "--results-dir", "out", "-q"]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("pixel (3, 2) channel g is NaN") && err.contains("rendering it again"),
        "{err}"
    );
    let rmse = std::fs::read_to_string(d.join("out/t/rmse.csv")).unwrap();
    for line in rmse.lines().skip(1) {
        let v: f64 = line.rsplit(',').next().unwrap().parse().unwrap();
        assert!(v.is_finite() && v > 0.0, "{line}");
    }
}

/// `RAYON_NUM_THREADS=100000` bypassed the 256-thread cap: the tool's own cap holds whatever the
/// environment says (the run records how many threads it used).
#[test]
fn the_environment_cannot_override_the_thread_cap() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("x.json"), SPEC.replace("PRIOR", "0.2")).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_workbench"))
        .args(["run", "x.json", "-q"])
        .env("RAYON_NUM_THREADS", "100000")
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let timings: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("results/small/timings.json")).unwrap())
            .unwrap();
    let threads = timings["threads"].as_u64().unwrap();
    assert!((1..=256).contains(&threads), "{threads} threads");
    assert!(stderr(&o).contains(&format!("on {threads} threads")));
}

/// A failed write to a full stdout named nothing useful: it now says "stdout" (exit 2).
#[test]
fn a_full_stdout_is_named() {
    if !std::path::Path::new("/dev/full").exists() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let full = std::fs::OpenOptions::new().write(true).open("/dev/full").unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_workbench"))
        .args(["rule", "--n", "8"])
        .stdout(full)
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(
        err.contains("writing to stdout") && err.contains("No space left"),
        "{err}"
    );
}
