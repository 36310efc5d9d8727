//! Issue 42 through the binary, by class: negative values of numeric flags, numbers printed
//! short in messages and names, clap's refusals in one line, sub-fields named in spec errors,
//! and irradiance files held to the experiment files' checks.

use crate::common::*;
use std::path::Path;
use std::process::Output;

/// Exit 2 with one line holding every needle, and nothing written into `dir` but `keep`.
fn refused_in_one_line(o: &Output, needles: &[&str], case: &str) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "{case}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{case}: one line: {err}");
    assert!(err.starts_with("Error: "), "{case}: {err}");
    assert!(!err.contains("--help"), "{case}: {err}");
    for n in needles {
        assert!(err.contains(n), "{case}: {n:?} not in {err}");
    }
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

const EXPERIMENT: &str = r#"{"name": "x", "integrands": ["cos3"], "estimators": [{"label": "MC", "method": "mc"}],
    "samples": [4], "trials": 2, "seed": 1}"#;

/// `--spp -4`, `--tolerance -1e-6`, `--shard -1/3` and the rest were clap's four lines of
/// "unexpected argument '-4' found", naming neither the flag nor the value. Every numeric flag of
/// every command, written `--flag -x` and `--flag=-x`, is now refused by the flag's parser or the
/// project's check: one line naming the flag and the value, exit 2, nothing written.
#[test]
fn negative_values_of_numeric_flags_are_refused_in_one_line_naming_flag_and_value() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("x.json"), EXPERIMENT).unwrap();
    let before = files_in(d);
    let render = ["render", "--out", "o.exr"];
    let exact = ["render", "--integrator", "exact", "--out", "o.exr"];
    let se = ["render", "--kernel", "se", "--out", "o.exr"];
    let run = ["run", "x.json", "-q"];
    // (command, flag, value): the message names the flag (a kernel parameter as the kernel's
    // message does: `--kernel sobolev: sobolev kernel: s must be …`) and the value.
    let cases: &[(&[&str], &str, &str)] = &[
        (&render, "--spp", "-4"),
        // `-1e-3`: clap's own test for a negative number knows no negative exponent.
        (&exact, "--tolerance", "-1e-3"),
        (&render, "--gps", "-1"),
        (&render, "--width", "-1"),
        (&render, "--height", "-3"),
        (&render, "--seed", "-1"),
        (
            &["render", "--out", "o.exr", "--reference", "r.exr"],
            "--error-max",
            "-0.5",
        ),
        (
            &["render", "--out", "o.exr", "--max-spp", "256"],
            "--target-sd",
            "-0.01",
        ),
        (
            &["render", "--out", "o.exr", "--target-sd", "0.01"],
            "--max-spp",
            "-64",
        ),
        (&render, "--s", "-1.5"),
        (&se, "--sigma", "-1"),
        (&se, "--length", "-0.5"),
        (&render, "--noise", "-0.01"),
        (
            &["render", "--out", "o.exr", "--kernel-mean", "mc"],
            "--kernel-mean-samples",
            "-5",
        ),
        (&["render", "experiments/t.json"], "--shard", "-1/3"),
        (&run, "--trials", "-2"),
        (&run, "--threads", "-1"),
        (&run, "--shard", "-1/3"),
        (&["rule"], "--n", "-64"),
        (&["rule"], "--seed", "-7"),
        (&["reproduce", "--list"], "--threads", "-2"),
    ];
    for &(command, flag, value) in cases {
        for joined in [false, true] {
            let mut args: Vec<String> = command.iter().map(|s| s.to_string()).collect();
            if joined {
                args.push(format!("{flag}={value}"));
            } else {
                args.extend([flag.to_string(), value.to_string()]);
            }
            let args: Vec<&str> = args.iter().map(String::as_str).collect();
            let o = workbench(d, &args);
            let case = args.join(" ");
            let named = match flag {
                "--s" => "sobolev kernel: s must be",
                "--sigma" => "se kernel: sigma must be",
                "--length" => "se kernel: length must be",
                _ => flag,
            };
            // Numbers as the message prints them (util::shown).
            let value = if value == "-1e-3" { "-0.001" } else { value };
            refused_in_one_line(&o, &[named, value], &case);
            assert_eq!(files_in(d), before, "{case}: nothing written");
        }
    }
}

/// `--tolerance 1e-300` printed the number with 300 digits, and a Phong exponent of 1e-300 gave
/// a 430-character default name that failed after the work: numbers in messages and names are
/// printed by one short form (`1e-300`).
#[test]
fn numbers_in_messages_and_default_names_are_short() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for args in [
        &[
            "render",
            "--integrator",
            "exact",
            "--tolerance",
            "1e-300",
            "--out",
            "o.exr",
        ][..],
        &[
            "render",
            "--integrator",
            "exact",
            "--tolerance=-1e-300",
            "--out",
            "o.exr",
        ],
        &[
            "render",
            "--integrator",
            "exact",
            "--tolerance",
            "-1e-6",
            "--out",
            "o.exr",
        ],
        &[
            "render",
            "--integrator",
            "mc",
            "--tolerance",
            "1e-300",
            "--out",
            "o.exr",
        ],
        &[
            "render",
            "--target-sd",
            "-1e-300",
            "--max-spp",
            "256",
            "--out",
            "o.exr",
        ],
        &[
            "render",
            "--error-max",
            "-1e-300",
            "--reference",
            "r.exr",
            "--out",
            "o.exr",
        ],
    ] {
        let o = workbench(d, args);
        let case = args.join(" ");
        refused_in_one_line(&o, &["e-"], &case);
        assert!(!stderr(&o).contains("0.0000"), "{case}: {}", stderr(&o));
        assert!(stderr(&o).len() < 200, "{case}: {}", stderr(&o));
    }
    // A constant 16×8 map of 1 (RGBE 128,128,128,129 is 1.0).
    let mut hdr = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 16\n".to_vec();
    hdr.extend([128u8, 128, 128, 129].repeat(128));
    std::fs::write(d.join("white.hdr"), hdr).unwrap();
    std::fs::write(
        d.join("p.json"),
        r#"{"name": "p", "integrands": [{"type": "envmap", "env": "white.hdr", "normal": [0, 1, 0],
            "brdf": {"phong": 1e-300, "axis": [0, 0, 1]}}],
            "estimators": [{"label": "MC", "method": "mc"}], "samples": [4], "trials": 1, "seed": 1}"#,
    )
    .unwrap();
    let o = workbench(d, &["run", "p.json", "--out", "p", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let names = files_in(&d.join("p"));
    assert!(names.iter().any(|n| n.contains("phong1e-300")), "{names:?}");
    assert!(names.iter().all(|n| n.len() < 100), "{names:?}");
}

/// clap's refusals ended with a usage block and "For more information, try '--help'." after an
/// otherwise clear first line: they are one line, like every other bad input.
#[test]
fn usage_errors_are_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (args, needles) in [
        (
            &["run", "x.json", "--outt", "d"][..],
            &["unexpected argument '--outt'"][..],
        ),
        (
            &["render", "--integrator", "nope", "--out", "o.exr"],
            &["--integrator", "\"nope\""],
        ),
        (
            &["rule", "--design", "nope"],
            &["--design", "\"nope\"", "uniform"],
        ),
        (&["render", "--spp", "many", "--out", "o.exr"], &["--spp", "many"]),
        (&["render"], &["--out"]),
        (&["frobnicate"], &["frobnicate"]),
    ] {
        let o = workbench(d, args);
        refused_in_one_line(&o, needles, &args.join(" "));
    }
    // --help and --version still print in full, on stdout, exit 0.
    let o = workbench(d, &["run", "--help"]);
    assert!(
        o.status.success() && stdout(&o).contains("Usage:"),
        "{}",
        stderr(&o)
    );
}

/// Errors inside an integrand stopped at `integrands[0]` or `brdf`: the path goes on to the
/// sub-field (`integrands[0].brdf.phong`, `integrands[0].brdf.axis[1]`, `integrands[0].normal[0]`),
/// for serde's type errors and for the checks of values alike.
#[test]
fn spec_errors_name_the_sub_field() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let spec = |integrand: &str| {
        format!(
            r#"{{"name": "s", "integrands": [{integrand}], "estimators": [{{"label": "MC", "method": "mc"}}],
                "samples": [4], "trials": 2, "seed": 1}}"#
        )
    };
    for (integrand, needle) in [
        (
            r#"{"type": "envmap", "env": "c.exr", "normal": [0, 1, 0], "brdf": {"phong": "x", "axis": [0, 0, 1]}}"#,
            "s.json: integrands[0].brdf.phong: invalid type: string \"x\", expected f64",
        ),
        (
            r#"{"type": "envmap", "env": "c.exr", "normal": [0, 1, 0], "brdf": {"phong": 8, "axis": [0, "a", 1]}}"#,
            "s.json: integrands[0].brdf.axis[1]: invalid type: string \"a\", expected f64",
        ),
        (
            r#"{"type": "envmap", "env": "c.exr", "normal": ["x", 1, 0]}"#,
            "s.json: integrands[0].normal[0]: invalid type: string \"x\", expected f64",
        ),
        (
            r#"{"type": "envmap", "env": "c.exr", "normal": [0, 1, 0], "brdf": {"phong": 2e6, "axis": [0, 0, 1]}}"#,
            "s.json: integrands[0].brdf.phong: the exponent must be in (0, 1e6], got 2000000",
        ),
        (
            r#"{"type": "envmap", "env": "c.exr", "normal": [0, 1, 0], "brdf": {"phong": 8, "axis": [0, 0, 0]}}"#,
            "s.json: integrands[0].brdf.axis: must be a non-zero finite vector, got [0, 0, 0]",
        ),
        (
            r#"{"type": "lobe", "axis": [0, 0, 1, 5], "exponent": 3}"#,
            "s.json: integrands[0].axis: invalid length 4",
        ),
        (
            r#"{"type": "cap", "axis": [0, 0, 1], "half_angle": 400}"#,
            "s.json: integrands[0].half_angle: must be in (0, 180] degrees, got 400",
        ),
        (
            r#"{"type": "lobes", "axis": [0, 0, 1]}"#,
            "s.json: integrands[0].type: unknown variant `lobes`",
        ),
    ] {
        std::fs::write(d.join("s.json"), spec(integrand)).unwrap();
        for command in ["validate", "run"] {
            let o = workbench(
                d,
                &[command, "s.json", "-q"][..if command == "run" { 3 } else { 2 }],
            );
            refused_in_one_line(&o, &[needle], &format!("{command} {integrand}"));
        }
    }
}

/// The irradiance protocol's files took `--threads 0` and `257`, read `"kind": "irradiance2"`
/// as an experiment file (naming `env`), and ran `"n": [4, 4]`; they are held to the experiment
/// files' checks, by the same code.
#[test]
fn irradiance_files_are_checked_like_experiment_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let irradiance = |extra: &str, n: &str, kind: &str| {
        format!(
            r#"{{"kind": "{kind}", "name": "irr", "env": "none.hdr", "grid": [8, 4], "n": {n}, "seed": 3,
                "estimators": ["mc"]{extra}}}"#
        )
    };
    std::fs::write(d.join("x.json"), EXPERIMENT).unwrap();
    std::fs::write(d.join("i.json"), irradiance("", "[4, 8]", "irradiance")).unwrap();
    for file in ["x.json", "i.json"] {
        for t in ["0", "257"] {
            let o = workbench(d, &["run", file, "--threads", t, "-q"]);
            refused_in_one_line(&o, &[&format!("--threads: must be in 1..=256, got {t}")], file);
        }
    }
    std::fs::write(
        d.join("t.json"),
        irradiance(r#", "threads": 2"#, "[4, 8]", "irradiance"),
    )
    .unwrap();
    std::fs::write(d.join("k.json"), irradiance("", "[4, 8]", "irradiance2")).unwrap();
    std::fs::write(d.join("n.json"), irradiance("", "[4, 4]", "irradiance")).unwrap();
    std::fs::write(d.join("z.json"), irradiance("", "[4, 0]", "irradiance")).unwrap();
    for (file, needles) in [
        ("t.json", &["t.json: threads: unknown field `threads`"][..]),
        (
            "k.json",
            &["k.json: kind: unknown variant `irradiance2`", "`irradiance`"],
        ),
        ("n.json", &["n.json: n[1]: N = 4 is listed twice"]),
        ("z.json", &["z.json: n[1]: N must be at least 1, got 0"]),
    ] {
        for command in ["validate", "run"] {
            let o = workbench(d, &[command, file]);
            refused_in_one_line(&o, needles, &format!("{command} {file}"));
        }
    }
    // The experiment file says the same of the same list.
    std::fs::write(d.join("e.json"), EXPERIMENT.replace("[4]", "[4, 4]")).unwrap();
    let o = workbench(d, &["validate", "e.json"]);
    refused_in_one_line(&o, &["e.json: samples[1]: N = 4 is listed twice"], "e.json");
    assert!(!d.join("results").exists(), "nothing written");
}
