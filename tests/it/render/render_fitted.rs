//! The renderer with a fitted model (math.md §9): one factor per grid model per sample set and a
//! choice per pixel and channel, in single renders and as a render-table row.

use crate::common::{stderr, workbench};
use std::path::Path;

fn render(dir: &Path, out: &str, model: &[&str]) {
    let mut args = vec![
        "render",
        "--integrator",
        "bmc",
        "--spp",
        "24",
        "--width",
        "24",
        "--height",
        "24",
        "--seed",
        "5",
        "--out",
        out,
    ];
    args.extend_from_slice(model);
    let o = workbench(dir, &args);
    assert!(o.status.success(), "{}", stderr(&o));
}

fn pixels(path: &Path) -> Vec<f32> {
    image::open(path).unwrap().to_rgb32f().into_raw()
}

/// A one-model grid renders the same image as that fixed model; a two-model grid renders, in
/// every pixel and channel, the value of one of the two fixed models' renders (the same sets,
/// set choices and rotations), and both models are chosen somewhere.
#[test]
fn fitted_render_chooses_one_of_its_models_per_pixel_and_channel() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    render(d, "smooth.exr", &["--s", "2.75", "--noise", "1e-8"]);
    render(d, "rough.exr", &["--s", "1.2", "--noise", "0.01"]);
    render(
        d,
        "one.exr",
        &["--kernel", "fitted", "--grid-s", "2.75", "--grid-noise", "1e-8"],
    );
    assert!(
        pixels(&d.join("one.exr")) == pixels(&d.join("smooth.exr")),
        "a one-model grid differs from its fixed model"
    );
    // Two noises × two smoothnesses; the two fixed renders are the diagonal of the grid.
    render(
        d,
        "two.exr",
        &[
            "--kernel",
            "fitted",
            "--grid-s",
            "1.2,2.75",
            "--grid-noise",
            "0.01,1e-8",
        ],
    );
    let (smooth, rough, two) = (
        pixels(&d.join("smooth.exr")),
        pixels(&d.join("rough.exr")),
        pixels(&d.join("two.exr")),
    );
    let (mut from_smooth, mut from_rough, mut other) = (0, 0, 0);
    for ((a, b), c) in smooth.iter().zip(&rough).zip(&two) {
        if c == a {
            from_smooth += 1;
        } else if c == b {
            from_rough += 1;
        } else {
            other += 1;
        }
    }
    // The off-diagonal models (s = 1.2 with 1e-8, s = 2.75 with 0.01) may win too; the two
    // fixed ones must each win somewhere, and every value is some model's.
    assert!(
        from_smooth > 0 && from_rough > 0,
        "smooth {from_smooth}, rough {from_rough}, other {other}"
    );
    render(d, "rough-tight.exr", &["--s", "1.2", "--noise", "1e-8"]);
    render(d, "smooth-loose.exr", &["--s", "2.75", "--noise", "0.01"]);
    let (c, e) = (
        pixels(&d.join("rough-tight.exr")),
        pixels(&d.join("smooth-loose.exr")),
    );
    for (i, v) in two.iter().enumerate() {
        assert!(
            [smooth[i], rough[i], c[i], e[i]].contains(v),
            "value {i} = {v} is none of the grid's renders"
        );
    }
}

/// A render table takes a row's own `model` (here fitted) beside the table's; its manifest
/// records it; a fitted model in an adaptive table, and a row model on MC, are refused.
#[test]
fn render_table_row_with_its_own_fitted_model() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let table = |variants: &str, adaptive: &str| {
        let spp = if adaptive.is_empty() { r#""spp":[16],"# } else { "" };
        format!(
            r#"{{"name":"t","seed":3,"width":16,"height":16,{spp}"repetitions":[2],{adaptive}
                "variants":[{{"label":"MC","integrator":"mc"}},{variants}]}}"#
        )
    };
    let fitted_row =
        r#"{"label":"BMC fitted","integrator":"bmc","gps":2,"model":{"kernel":{"type":"fitted"}}}"#;
    std::fs::write(d.join("t.json"), table(fitted_row, "")).unwrap();
    let o = workbench(d, &["render", "t.json", "-q", "--results-dir", "r"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("r/t/manifest.json")).unwrap()).unwrap();
    let row = &manifest["variants"][1];
    assert_eq!(row["label"], "BMC fitted");
    assert_eq!(row["model"]["kernel"]["type"], "fitted");
    assert_eq!(
        row["model"]["kernel"]["grid"]["s"],
        serde_json::json!([1.2, 1.6, 2.75, 3.75])
    );
    let rmse = std::fs::read_to_string(d.join("r/t/rmse.csv")).unwrap();
    assert!(rmse.lines().any(|l| l.contains("BMC fitted")), "{rmse}");

    let bad = [
        (
            table(
                r#"{"label":"B","integrator":"bmc","model":{"kernel":{"type":"fitted"}}}"#,
                r#""adaptive":{"target_sd":[0.05],"max_spp":64},"#,
            ),
            "variants[1].model.kernel: a fitted kernel cannot be used with \"adaptive\" yet",
        ),
        (
            table(
                r#"{"label":"M2","integrator":"mc-cos","model":{"noise":0.1}}"#,
                "",
            ),
            "variants[1].model.noise: 0.1 is not used by integrator mc-cos",
        ),
    ];
    for (spec, message) in bad {
        std::fs::write(d.join("bad.json"), spec).unwrap();
        let o = workbench(d, &["render", "bad.json", "-q", "--results-dir", "never"]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(message), "{err}");
        assert!(!d.join("never").exists());
    }
}

/// An adaptive single render refuses a fitted kernel before any work.
#[test]
fn adaptive_render_refuses_a_fitted_kernel() {
    let dir = tempfile::tempdir().unwrap();
    let o = workbench(
        dir.path(),
        &[
            "render",
            "--integrator",
            "bmc",
            "--kernel",
            "fitted",
            "--target-sd",
            "0.05",
            "--width",
            "8",
            "--height",
            "8",
            "--out",
            "x.exr",
        ],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("--kernel fitted: cannot be used with --target-sd"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.path().join("x.exr").exists());
}
