//! The `envmap` integrand family through `workbench run` (issue 28 item 1): every estimator kind
//! (MC, cosine MC, BMC on Sobol points, fitted kernel, `loo` calibration, Bayes–Sard, tolerance
//! stopping) runs on a map; bad input is one line, exit 2, nothing written. Synthetic maps only
//! (the data topic `envmap` checks Pisa).

use crate::common::*;
use image::{ImageFormat, Rgb, Rgb32FImage};
use std::path::Path;

/// A `w × h` OpenEXR map with radiance `rgb` everywhere.
fn constant_map(path: &Path, w: u32, h: u32, rgb: [f32; 3]) {
    image::DynamicImage::ImageRgb32F(Rgb32FImage::from_pixel(w, h, Rgb(rgb)))
        .save_with_format(path, ImageFormat::OpenExr)
        .unwrap();
}

fn experiment(integrands: &str) -> String {
    format!(
        r#"{{
  "name": "envmap-small",
  "integrands": [{integrands}],
  "estimators": [
    {{ "label": "MC", "method": "mc" }},
    {{ "label": "MC cosine", "method": "mc", "design": "cosine" }},
    {{ "label": "BMC Sobol", "method": "bmc", "design": "sobol" }},
    {{ "label": "BMC fitted", "method": "bmc", "kernel": {{ "type": "fitted" }} }},
    {{ "label": "BMC loo", "method": "bmc", "scale": "loo" }},
    {{ "label": "BSQ", "method": "bsq", "scale": "ml" }},
    {{ "label": "BMC tol", "method": "bmc", "tolerance": {{ "abs": 0.01, "max_n": 64, "min_n": 8 }} }}
  ],
  "samples": [8, 16],
  "trials": 4,
  "seed": 5
}}"#
    )
}

/// Under a constant map `L = (0.5, 1, 2)` the Lambert truth is the channel's `L` whatever the
/// normal (f_r = 1/π, albedo 1): luminance `0.2126·0.5 + 0.7152 + 0.0722·2`; cosine MC, whose
/// density is the integrand's shape, is exact; the manifest records the definition and the
/// quadrature's error estimate.
#[test]
fn envmap_integrands_run_with_every_estimator_kind() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    constant_map(&d.join("c.exr"), 16, 8, [0.5, 1.0, 2.0]);
    let spec = experiment(
        r#"{ "name": "lum", "type": "envmap", "env": "c.exr", "normal": [0.3, -0.5, 0.8] },
           { "name": "blue-phong", "type": "envmap", "env": "c.exr", "normal": [0, 1, 0], "channel": "b",
             "brdf": { "phong": 8, "axis": [0, 0, 1] }, "lookup": "thesis" }"#,
    );
    std::fs::write(d.join("e.json"), spec).unwrap();
    let o = workbench(d, &["run", "e.json", "-q", "--out", "out"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let (header, rows) = read_csv(&d.join("out/trials.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let lum = 0.2126 * 0.5 + 0.7152 + 0.0722 * 2.0;
    let phong = 2.0 * 9.0 / 10.0;
    let mut seen = std::collections::BTreeSet::new();
    for r in &rows {
        let truth: f64 = r[col("truth")].parse().unwrap();
        let want = if r[col("integrand")] == "lum" { lum } else { phong };
        assert!((truth - want).abs() < 1e-9, "{r:?}");
        seen.insert(r[col("estimator")].clone());
        if r[col("estimator")] == "MC cosine" && r[col("integrand")] == "lum" {
            let est: f64 = r[col("estimate")].parse().unwrap();
            assert!((est - lum).abs() < 1e-12, "cosine MC on a constant map: {est}");
        }
    }
    assert_eq!(seen.len(), 7, "{seen:?}");
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("out/manifest.json")).unwrap()).unwrap();
    let integrands = manifest["plan"]["integrands"].as_array().unwrap();
    assert_eq!(integrands[0]["type"], "envmap");
    assert_eq!(integrands[0]["brdf"], "lambert");
    assert_eq!(integrands[0]["channel"], "luminance");
    assert_eq!(integrands[1]["brdf"]["phong"], 8.0);
    assert_eq!(integrands[1]["lookup"], "thesis");
    assert!(integrands[0]["truth_error_estimate"].as_f64().unwrap() < 1e-8);
}

/// A zero normal, an unknown BRDF, a Phong exponent ≤ 0, a missing map and a catalogue map in a
/// data folder whose copy is altered: exit 2, one line naming the field, nothing written.
#[test]
fn bad_envmap_integrands_are_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    constant_map(&d.join("c.exr"), 16, 8, [1.0; 3]);
    let entry = workbench::data::catalog::find("pisa-256").unwrap();
    let copy = d.join("data").join(&entry.path);
    std::fs::create_dir_all(copy.parent().unwrap()).unwrap();
    std::fs::write(&copy, b"#?RADIANCE\nnot the catalogue's bytes\n").unwrap();
    for (integrand, needle) in [
        (
            r#"{ "type": "envmap", "env": "c.exr", "normal": [0, 0, 0] }"#,
            "normal: must be a non-zero finite vector, got [0, 0, 0]",
        ),
        (
            r#"{ "type": "envmap", "env": "c.exr", "normal": [0, 1, 0], "brdf": "glass" }"#,
            "integrands[0].brdf: unknown BRDF \"glass\"",
        ),
        (
            r#"{ "type": "envmap", "env": "c.exr", "normal": [0, 1, 0], "brdf": { "phong": 0, "axis": [0, 0, 1] } }"#,
            "integrands[0].brdf.phong: the exponent must be in (0, 1e6], got 0",
        ),
        (
            r#"{ "type": "envmap", "env": "c.exr", "normal": [0, 1, 0], "brdf": { "phong": 2e6, "axis": [0, 0, 1] } }"#,
            "integrands[0].brdf.phong: the exponent must be in (0, 1e6], got 2000000",
        ),
        (
            r#"{ "type": "envmap", "env": "c.exr", "normal": [0, 1, 0], "brdf": { "phong": 2 } }"#,
            "missing field `axis`",
        ),
        (
            r#"{ "type": "envmap", "env": "none.exr", "normal": [0, 1, 0] }"#,
            "env: none.exr: cannot read",
        ),
        (
            r#"{ "type": "envmap", "env": "sky", "normal": [0, 1, 0] }"#,
            "env: the envmap family needs a map",
        ),
        (
            r#"{ "type": "envmap", "env": "pisa-256", "normal": [0, 1, 0] }"#,
            "pisa_256x128.hdr: altered",
        ),
        (
            r#"{ "type": "envmap", "env": "c.exr", "normal": [0, 1, 0], "channel": "alpha" }"#,
            "channel: must be",
        ),
    ] {
        std::fs::write(d.join("e.json"), experiment(integrand)).unwrap();
        let before = std::fs::read_dir(d).unwrap().count();
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_workbench"))
            .args(["run", "e.json", "-q", "--out", "out"])
            .env("WORKBENCH_DATA", "data")
            .current_dir(d)
            .output()
            .unwrap();
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{integrand}: {err}");
        assert_eq!(
            err.trim_end().lines().count(),
            1,
            "{integrand}: not one line: {err}"
        );
        assert!(err.contains(needle), "{integrand}: `{needle}` not in: {err}");
        assert!(
            err.contains("integrands[0]"),
            "{integrand}: the field is not named: {err}"
        );
        assert_eq!(
            std::fs::read_dir(d).unwrap().count(),
            before,
            "{integrand}: wrote files"
        );
    }
}
