//! Issue 42 item 3: every row read back from a unit log or a shard — by `merge` or `--resume`, of
//! an experiment, a render table or the irradiance protocol — is checked as it was written, by the
//! one shared reader (`job::read_rows`, `job::open_log`): finite, in range, the plan's own values
//! recomputed, and then against the row's digest, so that a number edited by hand is refused
//! too. Each case: exit 2, one line naming the file and the line, nothing written.

use crate::common::*;
use image::{ImageFormat, Rgb, Rgb32FImage};
use std::process::Output;

/// Exit 2 with one line naming `what`; returns the line.
fn refused(o: &Output, what: &str) -> String {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.contains(what), "{what:?} not in {err}");
    err
}

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", stderr(o));
}

/// `text` with field `field` (0-based, comma-separated) of line `line` (0-based) replaced by
/// `f(old)`.
fn edit(text: &str, line: usize, field: usize, f: impl Fn(&str) -> String) -> String {
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut cols: Vec<String> = lines[line].split(',').map(String::from).collect();
    cols[field] = f(&cols[field]);
    lines[line] = cols.join(",");
    lines.join("\n") + "\n"
}

fn times(factor: f64) -> impl Fn(&str) -> String {
    move |s: &str| format!("{:e}", s.parse::<f64>().unwrap() * factor)
}

/// An irradiance protocol on a synthetic 16×8 map, 8×4 normals (4 units), two N.
fn irradiance_setup() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    image::DynamicImage::ImageRgb32F(Rgb32FImage::from_fn(16, 8, |x, y| {
        Rgb([1.0 + (x % 3) as f32, 0.5 + y as f32, 2.0])
    }))
    .save_with_format(d.join("v.exr"), ImageFormat::OpenExr)
    .unwrap();
    std::fs::write(
        d.join("irr.json"),
        r#"{"kind": "irradiance", "name": "irr", "env": "v.exr", "grid": [8, 4], "n": [4, 8],
            "seed": 3, "estimators": ["mc", "bmc"]}"#,
    )
    .unwrap();
    for i in 1..=2 {
        ok(&workbench(
            d,
            &[
                "run",
                "irr.json",
                "-q",
                "--shard",
                &format!("{i}/2"),
                "--out",
                &format!("s{i}"),
            ],
        ));
    }
    dir
}

/// The issue's reproduction: a NaN estimate in a shard's `units.csv` merged with exit 0 and NaN
/// RMS in `irradiance.csv`.
#[test]
fn irradiance_merge_refuses_a_nan_in_a_shard() {
    let dir = irradiance_setup();
    let d = dir.path();
    let units = d.join("s2/units.csv");
    let good = std::fs::read_to_string(&units).unwrap();
    // Line 3 (the first row): field 6 is the first estimate's red channel.
    std::fs::write(&units, edit(&good, 2, 5, |_| "NaN".into())).unwrap();
    let line = refused(
        &workbench(d, &["merge", "m", "-q", "s1", "s2"]),
        "s2/units.csv: line 3: the row has mc@4_r \"NaN\" (field 6), not a finite number",
    );
    assert!(line.contains("this shard is damaged"), "{line}");
    assert!(!d.join("m").exists(), "nothing merged");
    std::fs::write(&units, &good).unwrap();
    ok(&workbench(d, &["merge", "m", "-q", "s1", "s2"]));
}

/// A hand-edited exact irradiance (×1.5) in a shard's `units.csv`: finite and positive, so only
/// the row's digest tells it from what was computed.
#[test]
fn irradiance_merge_refuses_an_edited_exact_irradiance() {
    let dir = irradiance_setup();
    let d = dir.path();
    let units = d.join("s1/units.csv");
    let good = std::fs::read_to_string(&units).unwrap();
    std::fs::write(&units, edit(&good, 3, 1, times(1.5))).unwrap();
    refused(
        &workbench(d, &["merge", "m", "-q", "s1", "s2"]),
        "s1/units.csv: line 4: the row was changed after it was written",
    );
    assert!(!d.join("m").exists(), "nothing merged");
    // A negative one is refused for what it is.
    std::fs::write(&units, edit(&good, 3, 1, |s| format!("-{s}"))).unwrap();
    refused(
        &workbench(d, &["merge", "m", "-q", "s1", "s2"]),
        "s1/units.csv: line 4: the row has exact_r",
    );
    assert!(!d.join("m").exists(), "nothing merged");
}

/// The same edit in `irradiance.partial.csv`, the log `--resume` continues: refused, the log
/// left in place; the unedited log resumes.
#[test]
fn irradiance_resume_refuses_an_edited_exact_irradiance() {
    let dir = irradiance_setup();
    let d = dir.path();
    let good = std::fs::read_to_string(d.join("s1/units.csv")).unwrap();
    std::fs::create_dir(d.join("r")).unwrap();
    let log = d.join("r/irradiance.partial.csv");
    std::fs::write(&log, edit(&good, 2, 2, times(1.5))).unwrap();
    let resume = || {
        workbench(
            d,
            &[
                "run", "irr.json", "-q", "--shard", "1/2", "--out", "r", "--resume",
            ],
        )
    };
    refused(
        &resume(),
        "r/irradiance.partial.csv: line 3: the row was changed after it was written",
    );
    assert!(log.is_file(), "the log is kept");
    std::fs::write(&log, &good).unwrap();
    ok(&resume());
    assert_eq!(
        std::fs::read(d.join("r/units.csv")).unwrap(),
        good.as_bytes(),
        "the resumed shard's log is the shard's"
    );
}

const TABLE: &str = r#"{"name": "t", "seed": 3, "width": 16, "height": 12, "spp": [2, 4],
  "repetitions": [2, 3], "reference": {"spp": 8},
  "variants": [{"label": "MC", "integrator": "mc"}, {"label": "BMC 1", "integrator": "bmc", "gps": 1}]}"#;

/// A table that failed after its last round (so `rounds.partial.csv` holds every round), then
/// resumed with one row of a repetition-1 round (line 5: spp 2, repetition 1, MC — a round the
/// resume keeps from the log, not renders again) edited.
fn resume_table_with(field: usize, f: impl Fn(&str) -> String, what: &str) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("t.json"), TABLE).unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_workbench"))
        .args(["render", "t.json", "-q", "--results-dir", "f"])
        .current_dir(d)
        .env("WORKBENCH_TEST_FAIL_WRITE", "table.csv")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let log = d.join("f/t/rounds.partial.csv");
    let good = std::fs::read_to_string(&log).unwrap();
    let row = good.lines().nth(4).unwrap();
    assert!(row.starts_with("MC,mc,,,2,1,"), "{row}");
    std::fs::write(&log, edit(&good, 4, field, f)).unwrap();
    let resume = || workbench(d, &["render", "t.json", "-q", "--results-dir", "f", "--resume"]);
    refused(
        &resume(),
        &format!("f/t/rounds.partial.csv: line 5: the row {what}"),
    );
    assert!(log.is_file(), "the log is kept");
    assert!(!d.join("f/t/table.csv").exists(), "nothing written");
    std::fs::write(&log, &good).unwrap();
    ok(&resume());
}

/// A halved `rmse`: finite and at least 0, so only the digest tells.
#[test]
fn render_table_resume_refuses_a_halved_rmse() {
    resume_table_with(7, times(0.5), "was changed after it was written");
}

/// A `coverage95` of 1.5: a share lies in [0, 1].
#[test]
fn render_table_resume_refuses_a_coverage_above_one() {
    resume_table_with(9, |_| "1.5".into(), "has coverage95 \"1.5\", outside [0, 1]");
}

/// An experiment's row with another estimate and its `abs_error` recomputed to match: every
/// column holds what the plan allows, and only the digest tells.
#[test]
fn experiment_merge_refuses_an_estimate_edited_with_its_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("e.json"),
        r#"{"name": "e", "integrands": ["cos"], "estimators": [{"label": "MC", "method": "mc"}],
            "samples": [4, 8], "trials": 3, "seed": 1}"#,
    )
    .unwrap();
    for i in 1..=2 {
        ok(&workbench(
            d,
            &[
                "run",
                "e.json",
                "-q",
                "--shard",
                &format!("{i}/2"),
                "--out",
                &format!("a{i}"),
            ],
        ));
    }
    let units = d.join("a1/units.csv");
    let good = std::fs::read_to_string(&units).unwrap();
    // Columns: integrand, estimator, method, design, n, trial, estimate (6), truth (7),
    // abs_error (8).
    let row: Vec<&str> = good.lines().nth(2).unwrap().split(',').collect();
    let truth: f64 = row[7].parse().unwrap();
    let estimate = row[6].parse::<f64>().unwrap() + 0.125;
    let edited = edit(&good, 2, 6, |_| format!("{estimate:?}"));
    let edited = edit(&edited, 2, 8, |_| format!("{:?}", (estimate - truth).abs()));
    std::fs::write(&units, edited).unwrap();
    refused(
        &workbench(d, &["merge", "out", "-q", "a1", "a2"]),
        "a1/units.csv: line 3 (N = 4, trial 0): the row was changed after it was written",
    );
    assert!(!d.join("out").exists(), "nothing merged");
    std::fs::write(&units, &good).unwrap();
    ok(&workbench(d, &["merge", "out", "-q", "a1", "a2"]));
}
