//! `workbench render` through the binary: outputs, and bad input rejected with exit code 2
//! and a message naming the option or file.

use crate::common::*;
use workbench::render::IntegratorKind;

/// Exit 2 with every `needle` in stderr.
fn assert_input_error(args: &[&str], needles: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("bad.hdr"),
        b"#?RADIANCE\nFORMAT=nonsense\n\n-Y 2 +X 2\nxx",
    )
    .unwrap();
    let o = workbench(dir.path(), args);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: `{n}` not in: {err}");
    }
    assert!(
        std::fs::read_dir(dir.path()).unwrap().count() == 1,
        "{args:?} wrote files"
    );
}

const SMALL: [&str; 6] = ["--width", "12", "--height", "10", "--spp", "4"];

#[test]
fn bad_input_is_exit_2_with_a_clear_message() {
    assert_input_error(
        &["render", "--integrator", "bmx", "--out", "a.exr"],
        &["--integrator", "bmx"],
    );
    assert_input_error(
        &["render", "--spp", "0", "--out", "a.exr"],
        &["--spp", "at least 1"],
    );
    assert_input_error(
        &["render", "--integrator", "mc", "--spp", "0", "--out", "a.exr"],
        &["--spp"],
    );
    assert_input_error(&["render", "--spp", "20000", "--out", "a.exr"], &["--spp", "GiB"]);
    assert_input_error(&["render", "--gps", "0", "--out", "a.exr"], &["--gps"]);
    // Issue 42.5: a side the reader refuses is refused by the writer, up front (one limit).
    for (w, h) in [("100000", "1"), ("1", "32769")] {
        assert_input_error(
            &[
                "render",
                "--integrator",
                "mc",
                "--spp",
                "4",
                "--width",
                w,
                "--height",
                h,
                "--out",
                "a.exr",
            ],
            &["--width/--height", "has a side over 32768", "read back"],
        );
    }
    // Ring sets need N = J·M with J near √N.
    assert_input_error(
        &[
            "render",
            "--integrator",
            "bmc-rings",
            "--spp",
            "38",
            "--out",
            "a.exr",
        ],
        &[
            "--spp: got 38 for bmc-rings; the rings design needs N = J·M",
            "36 or 40",
        ],
    );
    // Options that do not apply are errors, not silently ignored.
    let with_weights = IntegratorKind::names_where(|k| k.uses_sets());
    assert!(
        with_weights.starts_with(&["bmc".into(), "bmcp".into()])
            && with_weights.contains(&"bsq-rings".into())
    );
    assert_input_error(
        &["render", "--integrator", "mc", "--gps", "3", "--out", "a.exr"],
        &[&format!(
            "--gps: applies to the integrators with weights ({}), not mc",
            with_weights.join(", ")
        )],
    );
    assert_input_error(
        &["render", "--integrator", "mc-cos", "--s", "1.5", "--out", "a.exr"],
        &["--s: applies to the integrators with weights (bmc,"],
    );
    assert_input_error(
        &["render", "--error-colours", "grey", "--out", "a.exr"],
        &["--reference"],
    );
    assert_input_error(
        &[
            "render",
            "--spp",
            "2000000",
            "--integrator",
            "mc",
            "--out",
            "a.exr",
        ],
        &["at most 1000000"],
    );
    assert_input_error(
        &["render", "--env", "missing.hdr", "--out", "a.exr"],
        &["--env missing.hdr", "cannot read"],
    );
    assert_input_error(
        &["render", "--env", "bad.hdr", "--out", "a.exr"],
        &["--env bad.hdr", "not a valid"],
    );
    // Issue 27: scene and lookup names that do not exist; a lookup for the procedural sky.
    assert_input_error(
        &["render", "--scene", "cornell", "--out", "a.exr"],
        &["--scene", "unknown scene \"cornell\"", "workbench, thesis"],
    );
    assert_input_error(
        &["render", "--env-lookup", "nearest", "--out", "a.exr"],
        &[
            "--env-lookup",
            "unknown map lookup \"nearest\"",
            "mitsuba, thesis",
        ],
    );
    assert_input_error(
        &["render", "--env-lookup", "thesis", "--out", "a.exr"],
        &["--env-lookup", "applies to environment map files, not to `sky`"],
    );
    assert_input_error(
        &[
            "render", "--width", "100000", "--height", "100000", "--out", "a.exr",
        ],
        &["--width/--height", "GiB"],
    );
    assert_input_error(
        &["render", "--width", "0", "--out", "a.exr"],
        &["--width/--height"],
    );
    assert_input_error(&["render", "--out", "a.png"], &["--out a.png", ".exr"]);
    assert_input_error(&["render", "--integrator", "mc"], &["--out"]);
    assert_input_error(
        &["render", "--out", "a.exr", "--reference", "missing.exr"],
        &["--reference missing.exr", "cannot read"],
    );
    assert_input_error(&["render", "--noise=-1", "--out", "a.exr"], &["--noise"]);
    assert_input_error(&["render", "spec.json", "--out", "a.exr"], &["--out"]);
}

#[test]
fn renders_exr_png_and_error_image() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for integrator in ["mc", "mc-cos", "bmc", "bmcp"] {
        let out = format!("{integrator}.exr");
        let mut args = vec!["render", "-q", "--integrator", integrator, "--out", &out];
        args.extend(SMALL);
        let o = workbench(d, &args);
        assert!(o.status.success(), "{integrator}: {}", stderr(&o));
        assert!(d.join(&out).exists() && d.join(format!("{integrator}.png")).exists());
    }
    // A reference of the wrong size is refused before rendering.
    let o = workbench(
        d,
        &["render", "--out", "x.exr", "--reference", "mc.exr", "--spp", "1"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("12×10"), "{}", stderr(&o));
    // The same render against itself: RMSE 0, and the error image is written.
    let mut args = vec![
        "render",
        "-q",
        "--integrator",
        "bmc",
        "--out",
        "again.exr",
        "--reference",
        "bmc.exr",
    ];
    args.extend(SMALL);
    let o = workbench(d, &args);
    assert!(o.status.success(), "{}", stderr(&o));
    // The reference went through f32: only rounding is left.
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    let rmse: f64 = stdout.trim().strip_prefix("rmse = ").unwrap().parse().unwrap();
    assert!(rmse < 1e-6, "{stdout}");
    assert!(d.join("again-error.png").exists());
    assert_eq!(
        std::fs::read(d.join("again.exr")).unwrap(),
        std::fs::read(d.join("bmc.exr")).unwrap()
    );
}

/// An equirectangular `.hdr` of constant radiance 1 lights the scene exactly like `--env white`.
#[test]
fn constant_hdr_map_matches_the_white_environment() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    image::Rgb32FImage::from_pixel(16, 8, image::Rgb([1.0, 1.0, 1.0]))
        .save(d.join("one.hdr"))
        .unwrap();
    let mut white = vec![
        "render",
        "-q",
        "--integrator",
        "bmc",
        "--env",
        "white",
        "--out",
        "white.exr",
    ];
    white.extend(SMALL);
    assert!(workbench(d, &white).status.success());
    let mut map = vec![
        "render",
        "-q",
        "--integrator",
        "bmc",
        "--env",
        "one.hdr",
        "--out",
        "map.exr",
    ];
    map.extend(SMALL);
    map.extend([
        "--reference",
        "white.exr",
        "--error-scale",
        "absolute",
        "--error-colours",
        "grey",
    ]);
    let o = workbench(d, &map);
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    let rmse: f64 = stdout.trim().strip_prefix("rmse = ").unwrap().parse().unwrap();
    assert!(rmse < 1e-6, "{stdout}");
    assert!(d.join("map-error.png").exists());
}

/// Rendering into the reference's own file is refused, and the reference survives.
#[test]
fn out_may_not_overwrite_the_reference() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let base = [
        "render",
        "-q",
        "--integrator",
        "mc",
        "--spp",
        "2",
        "--width",
        "8",
        "--height",
        "8",
    ];
    let o = workbench(d, &[&base[..], &["--out", "ref.exr"]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let before = std::fs::read(d.join("ref.exr")).unwrap();
    let o = workbench(
        d,
        &[
            &base[..],
            &["--seed", "1", "--reference", "ref.exr", "--out", "./ref.exr"],
        ]
        .concat(),
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("--out ./ref.exr: would overwrite --reference"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(d.join("ref.exr")).unwrap(), before);
    // Nor an environment map, and an error-image option must apply.
    let o = workbench(
        d,
        &[&base[..], &["--env", "ref.exr", "--out", "ref.exr"]].concat(),
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("--out ref.exr: would overwrite --env"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(d.join("ref.exr")).unwrap(), before);
    let o = workbench(
        d,
        &[
            &base[..],
            &[
                "--reference",
                "ref.exr",
                "--error-scale",
                "normalised",
                "--error-max",
                "0.5",
                "--out",
                "e.exr",
            ],
        ]
        .concat(),
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("--error-max: applies to --error-scale absolute"),
        "{}",
        stderr(&o)
    );
    let o = workbench(
        d,
        &[&base[..], &["--results-dir", "r", "--out", "e.exr"]].concat(),
    );
    assert_eq!(
        o.status.code(),
        Some(2),
        "--results-dir is for tables: {}",
        stderr(&o)
    );
}

/// `--integrator exact` takes no sampling options and a tolerance in range; the tolerance applies
/// to nothing else. Each is one line, exit 2, before any work.
#[test]
fn exact_rejects_options_that_do_not_apply() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (args, expected) in [
        (
            vec!["--integrator", "exact", "--spp", "4"],
            "Error: --spp: does not apply to --integrator exact (the certified quadrature draws no samples)",
        ),
        (
            vec!["--integrator", "exact", "--seed", "1"],
            "Error: --seed: does not apply to --integrator exact (the certified quadrature draws no samples)",
        ),
        (
            vec!["--integrator", "exact", "--tolerance", "1e-20"],
            "Error: --tolerance: must be in [1e-13, 1e-2] (absolute, per pixel and channel), got 1e-20",
        ),
        (
            vec!["--integrator", "bmc", "--tolerance", "1e-6"],
            "Error: --tolerance 1e-6: applies to --integrator exact, not bmc",
        ),
    ] {
        let mut all = vec!["render", "--out", "x.exr", "--width", "8", "--height", "8"];
        all.extend(args);
        let o = workbench(d, &all);
        assert_eq!(o.status.code(), Some(2));
        assert_eq!(String::from_utf8_lossy(&o.stderr).trim_end(), expected);
        assert!(!d.join("x.exr").exists());
    }
}

/// `--sd-out` and `--scale` that cannot apply are exit 2 with one line naming the flag and
/// value, before any work and without writing anything.
#[test]
fn sd_out_bad_input_is_exit_2() {
    assert_input_error(
        &[
            "render",
            "--integrator",
            "mc",
            "--sd-out",
            "s.exr",
            "--out",
            "a.exr",
        ],
        &[&{
            let names = IntegratorKind::names_where(|k| k.has_posterior());
            let (last, rest) = names.split_last().unwrap();
            assert!(rest.contains(&"bmc".to_string()) && last == "bq-pss-order2-bsq-uniform");
            format!(
                "--sd-out s.exr: needs an integrator with a posterior ({} or {last}), not mc",
                rest.join(", ")
            )
        }],
    );
    assert_input_error(
        &[
            "render",
            "--integrator",
            "exact",
            "--sd-out",
            "s.exr",
            "--out",
            "a.exr",
        ],
        &[
            "--sd-out s.exr: needs an integrator with a posterior",
            "not exact",
        ],
    );
    assert_input_error(
        &["render", "--sd-out", "a.exr", "--out", "a.exr"],
        &["--sd-out a.exr: is the same file as --out a.exr"],
    );
    assert_input_error(
        &["render", "--sd-out", "./a.exr", "--out", "a.exr"],
        &["--sd-out ./a.exr: is the same file as --out a.exr"],
    );
    // Its PNG would be the render's error image.
    assert_input_error(
        &["render", "--sd-out", "a-error.exr", "--out", "a.exr"],
        &["--sd-out (its PNG) a-error.png: is the same file as --out (its error image) a-error.png"],
    );
    assert_input_error(
        &["render", "--sd-out", "bad.hdr", "--out", "a.exr"],
        &["--sd-out bad.hdr: the sd image is OpenEXR"],
    );
    assert_input_error(
        &["render", "--scale", "loo", "--out", "a.exr"],
        &["--scale loo: applies to the posterior sd image; give --sd-out"],
    );
    assert_input_error(
        &["render", "--error-max", "0.1", "--out", "a.exr"],
        &["--error-max: applies to the error image (--reference) or the sd image (--sd-out)"],
    );
}

/// `--sd-out` beside a reference that is an input: refused like `--out` over it.
#[test]
fn sd_out_may_not_overwrite_the_reference() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut args = vec!["render", "-q", "--integrator", "mc", "--out", "ref.exr"];
    args.extend(SMALL);
    assert!(workbench(d, &args).status.success());
    let before = std::fs::read(d.join("ref.exr")).unwrap();
    let mut args = vec![
        "render",
        "-q",
        "--out",
        "b.exr",
        "--reference",
        "ref.exr",
        "--sd-out",
        "ref.exr",
    ];
    args.extend(SMALL);
    let o = workbench(d, &args);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("--sd-out ref.exr: would overwrite --reference ref.exr"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(d.join("ref.exr")).unwrap(), before);
    assert!(!d.join("b.exr").exists());
}

/// With `--sd-out` the render writes the sd EXR, its PNG and, with a reference, the coverage
/// map, and prints the coverage; the image itself is the one rendered without `--sd-out`. A
/// later run without the reference removes the stale coverage map.
#[test]
fn sd_out_writes_the_sd_image_and_the_coverage() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut args = vec![
        "render",
        "-q",
        "--integrator",
        "mc",
        "--spp",
        "400",
        "--out",
        "ref.exr",
    ];
    args.extend(&SMALL[..4]);
    assert!(workbench(d, &args).status.success());
    for integrator in ["bmc", "bmcp-edge", "bsq"] {
        let plain = format!("{integrator}-plain.exr");
        let mut args = vec!["render", "-q", "--integrator", integrator, "--out", &plain];
        args.extend(SMALL);
        assert!(workbench(d, &args).status.success());
        let out = format!("{integrator}.exr");
        let sd = format!("{integrator}-sd.exr");
        let mut args = vec![
            "render",
            "-q",
            "--integrator",
            integrator,
            "--out",
            &out,
            "--reference",
            "ref.exr",
            "--sd-out",
            &sd,
        ];
        args.extend(SMALL);
        let o = workbench(d, &args);
        assert!(o.status.success(), "{}", stderr(&o));
        let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
        let line = stdout.lines().nth(1).unwrap_or_default();
        assert!(
            line.starts_with("coverage50 = ") && line.contains("median |error|/sd = "),
            "{stdout}"
        );
        let c95: f64 = line.split("coverage95 = ").nth(1).unwrap()[..6].parse().unwrap();
        assert!((0.0..=1.0).contains(&c95), "{line}");
        assert!(
            stderr(&o).contains("posterior sd (ml amplitude, Student-t"),
            "{}",
            stderr(&o)
        );
        assert_eq!(
            std::fs::read(d.join(&out)).unwrap(),
            std::fs::read(d.join(&plain)).unwrap()
        );
        for f in [
            sd.clone(),
            format!("{integrator}-sd.png"),
            format!("{integrator}-sd-coverage.png"),
        ] {
            assert!(d.join(&f).exists(), "{f}");
        }
    }
    let mut args = vec![
        "render",
        "-q",
        "--out",
        "bmc.exr",
        "--sd-out",
        "bmc-sd.exr",
        "--scale",
        "unit",
    ];
    args.extend(SMALL);
    let o = workbench(d, &args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!d.join("bmc-sd-coverage.png").exists());
}

/// The largest side `render` accepts is one `--reference` reads back (issue 42.5: the writer and
/// the reader share the decoder's limit, 32768).
#[test]
fn an_image_of_the_largest_side_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "render",
        "--integrator",
        "mc",
        "--spp",
        "1",
        "--width",
        "32768",
        "--height",
        "1",
    ];
    let o = workbench(dir.path(), &[&args[..], &["--out", "a.exr"]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let o = workbench(
        dir.path(),
        &[&args[..], &["--reference", "a.exr", "--out", "b.exr"]].concat(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
}

/// With stderr a file (not a terminal) a long command prints plain progress lines — share,
/// counts, elapsed, an estimate left — at most once an interval (issue 43.1: the exact
/// reference printed nothing for 15 minutes into a log); `-q` silences them. The interval is
/// 10 s; `WORKBENCH_PROGRESS_INTERVAL` (for tests) shortens it so that a small render shows it.
#[test]
fn progress_lines_go_to_a_log_file_unless_quiet() {
    let dir = tempfile::tempdir().unwrap();
    let run = |quiet: bool| -> String {
        let log = dir.path().join("log");
        let mut args = vec![
            "render",
            "--integrator",
            "mc",
            "--spp",
            "4",
            "--width",
            "16",
            "--height",
            "40",
        ];
        args.extend(["--out", "a.exr"]);
        if quiet {
            args.push("-q");
        }
        let status = std::process::Command::new(env!("CARGO_BIN_EXE_workbench"))
            .args(&args)
            .current_dir(dir.path())
            .env("WORKBENCH_PROGRESS_INTERVAL", "0.000001")
            .stderr(std::fs::File::create(&log).unwrap())
            .status()
            .unwrap();
        assert!(status.success());
        std::fs::read_to_string(&log).unwrap()
    };
    let log = run(false);
    let lines: Vec<&str> = log.lines().filter(|l| l.starts_with("rows: ")).collect();
    assert!(lines.len() >= 2, "progress lines missing from: {log}");
    for l in &lines {
        assert!(
            l.contains("% (") && l.contains("/40), ") && l.contains(" elapsed"),
            "{l}"
        );
    }
    assert!(lines.iter().any(|l| l.contains(" left")), "{log}");
    let quiet = run(true);
    assert!(!quiet.contains("rows: "), "-q printed progress: {quiet}");
}
