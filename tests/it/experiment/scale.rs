//! Runs past one process: `run --shard i/n` + `merge`, and `run --resume`, must end with the
//! same bytes as one uninterrupted run (the wall-clock `timings*` files and `*-cost.svg` with its caption aside).

use crate::common::*;
use std::path::Path;
use std::process::Output;

const SMALL: &str = r#"{
  "name": "small",
  "title": "small test",
  "integrands": ["cos", "cos3"],
  "estimators": [
    { "label": "MC", "method": "mc" },
    { "label": "BMC", "method": "bmc" },
    { "label": "BMCP", "method": "bmcp", "prior": 0.2 },
    { "label": "BSQ, ml", "method": "bsq", "scale": "ml" }
  ],
  "samples": [4, 16, 32],
  "trials": 13,
  "seed": 5,
  "checks": [
    { "better": "BMC", "than": "MC", "from_n": 16, "alpha": 0.05 },
    { "calibrated": "BSQ, ml", "level": 0.9, "from_n": 16 }
  ]
}"#;

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", stderr(o));
}

/// Exit 2 with one line naming `what`; returns the line.
fn refused(o: &Output, what: &str) -> String {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.contains(what), "{what:?} not in {err}");
    err
}

/// The files of a finished run that must be identical (not the wall-clock ones).
fn deterministic_files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| {
            !n.starts_with("timings") && !n.ends_with("-cost.svg") && !n.ends_with("-cost.caption.txt")
        })
        .collect();
    names.sort();
    names
}

fn assert_same_files(a: &Path, b: &Path) {
    let names = deterministic_files(a);
    assert_eq!(names, deterministic_files(b), "file lists");
    assert!(names.contains(&"trials.csv".to_string()) && names.contains(&"manifest.json".to_string()));
    for n in names {
        let (x, y) = (
            std::fs::read(a.join(&n)).unwrap(),
            std::fs::read(b.join(&n)).unwrap(),
        );
        assert!(x == y, "{n} differs between {} and {}", a.display(), b.display());
    }
}

#[test]
fn shards_merge_to_the_bytes_of_one_run_whatever_the_count_order_and_threads() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("small.json"), SMALL).unwrap();
    ok(&workbench(d, &["run", "small.json", "-q", "--out", "full"]));
    for count in 1..=3 {
        let mut shards = Vec::new();
        for index in (1..=count).rev() {
            let out = format!("s{count}-{index}");
            let threads = (1 + index % 2).to_string();
            let shard = format!("{index}/{count}");
            let args = [
                "run",
                "small.json",
                "-q",
                "--threads",
                &threads,
                "--shard",
                &shard,
                "--out",
                &out,
            ];
            let o = workbench(d, &args);
            ok(&o);
            assert!(stdout(&o).is_empty(), "a shard has no summary to print");
            shards.push(out);
        }
        let merged = format!("m{count}");
        let mut args = vec!["merge", merged.as_str(), "-q"];
        args.extend(shards.iter().map(String::as_str));
        let o = workbench(d, &args);
        ok(&o);
        assert!(stdout(&o).contains("PASS check BMC < MC"), "{}", stdout(&o));
        assert_same_files(&d.join("full"), &d.join(&merged));
        // The cost files exist and list every estimator.
        let costs = std::fs::read_to_string(d.join(&merged).join("timings-summary.csv")).unwrap();
        assert_eq!(costs.lines().count(), 1 + 2 * 4 * 3, "{costs}");
        let trials = std::fs::read_to_string(d.join(&merged).join("timings-trials.csv")).unwrap();
        assert_eq!(trials.lines().count(), 1 + 2 * 4 * 3 * 13);
        check_cost_rows(&d.join(&merged).join("timings-trials.csv"));
    }
}

/// Every row: N evaluations, 0 ≤ weight-set seconds ≤ seconds (0 for MC), and BMC and BMCP,
/// which share one weight set, show the same weight-set seconds in the same trial.
fn check_cost_rows(path: &Path) {
    let (header, rows) = read_csv(path);
    assert_eq!(
        header,
        [
            "integrand",
            "estimator",
            "n",
            "trial",
            "evaluations",
            "weight_set_seconds",
            "seconds"
        ]
    );
    let mut bmc = std::collections::HashMap::new();
    for r in &rows {
        let (set, total): (f64, f64) = (r[5].parse().unwrap(), r[6].parse().unwrap());
        assert_eq!(r[4], r[2], "evaluations = N: {r:?}");
        assert!(0.0 <= set && set <= total && total < 10.0, "{r:?}");
        if r[1] == "MC" {
            assert_eq!(set, 0.0, "{r:?}");
        }
        if r[1] == "BMC" || r[1] == "BMCP" {
            let key = (r[0].clone(), r[2].clone(), r[3].clone());
            if let Some(other) = bmc.insert(key, set) {
                assert_eq!(other, set, "BMC and BMCP share their weight set: {r:?}");
            }
        }
    }
    assert_eq!(bmc.len(), 2 * 3 * 13);
}

#[test]
fn merge_refuses_shards_of_other_runs_and_incomplete_sets_before_writing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("small.json"), SMALL).unwrap();
    std::fs::write(d.join("seed6.json"), SMALL.replace("\"seed\": 5", "\"seed\": 6")).unwrap();
    std::fs::write(d.join("other.json"), SMALL.replace("[4, 16, 32]", "[4, 16, 64]")).unwrap();
    let shard = |file: &str, s: &str, out: &str, extra: &[&str]| {
        let mut args = vec!["run", file, "-q", "--shard", s, "--out", out];
        args.extend(extra);
        ok(&workbench(d, &args));
    };
    shard("small.json", "1/3", "a1", &[]);
    shard("small.json", "2/3", "a2", &[]);
    shard("small.json", "3/3", "a3", &[]);
    shard("seed6.json", "3/3", "seed", &[]);
    shard("small.json", "3/3", "trials", &["--trials", "12"]);
    shard("other.json", "3/3", "other", &[]);
    shard("small.json", "2/2", "two", &[]);
    let merge = |dirs: &[&str]| {
        let mut args = vec!["merge", "out", "-q"];
        args.extend(dirs);
        workbench(d, &args)
    };
    refused(&merge(&["a1", "a2", "seed"]), "seeds 5 and 6");
    refused(&merge(&["a1", "a2", "trials"]), "units 39 and 36");
    refused(&merge(&["a1", "a2", "other"]), "different runs (experiment plans");
    refused(&merge(&["a1", "a2", "two"]), "shard counts 1/3 and 2/2");
    refused(&merge(&["a1", "a3"]), "shard 2/3 missing");
    refused(&merge(&["a1", "a2", "a2", "a3"]), "a2 and a2 are both shard 2/3");
    refused(
        &merge(&["a1", "a2", "small.json"]),
        "small.json is not a shard folder",
    );
    // A shard whose log was cut short (a copied folder, a full disk) is refused, not merged.
    let units = d.join("a2/units.csv");
    let text = std::fs::read_to_string(&units).unwrap();
    let cut: String = text
        .lines()
        .take(text.lines().count() - 3)
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(&units, cut).unwrap();
    refused(
        &merge(&["a1", "a2", "a3"]),
        "a2/units.csv: ends before its last unit",
    );
    assert!(!d.join("out").exists(), "nothing written for refused input");
}

/// Issue 21 item 4: `merge` compared only the package version, so shards built from different
/// commits, or from a clean tree and one with uncommitted changes, were merged as one run. Each
/// shard records its build (version, commit, a fingerprint of the uncommitted changes); here
/// shard 3 is made to look as if another build ran it, and every such set is refused.
#[test]
fn merge_refuses_shards_of_different_builds_a_dirty_tree_included() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("small.json"), SMALL).unwrap();
    for i in 1..=3 {
        let s = format!("{i}/3");
        let out = format!("a{i}");
        ok(&workbench(
            d,
            &["run", "small.json", "-q", "--shard", &s, "--out", &out],
        ));
    }
    let record: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("a1/shard.json")).unwrap()).unwrap();
    assert_eq!(record["workbench_version"], env!("CARGO_PKG_VERSION"));
    let commit = record.get("workbench_commit").and_then(|c| c.as_str());
    let changes = record.get("workbench_changes").and_then(|c| c.as_str());
    assert_eq!(
        record.get("workbench_dirty").and_then(|c| c.as_bool()),
        commit.map(|_| changes.is_some())
    );
    let token = |commit: Option<&str>, changes: Option<&str>| match (commit, changes) {
        (None, _) => "unknown".to_string(),
        (Some(c), None) => c.to_string(),
        (Some(c), Some(f)) => format!("{c}+changes.{f}"),
    };
    let header = std::fs::read_to_string(d.join("a3/units.csv")).unwrap();
    let shard = std::fs::read(d.join("a3/shard.json")).unwrap();
    let here = format!(
        "version={} build={}",
        env!("CARGO_PKG_VERSION"),
        token(commit, changes)
    );
    assert!(
        header.lines().next().unwrap().contains(&here),
        "{here} in {header:.200}"
    );
    // (version, commit, uncommitted changes) of another build.
    let other_commit = "0123456789abcdef0123456789abcdef01234567";
    let mut others: Vec<(&str, Option<&str>, Option<&str>)> = vec![
        ("9.9.9", commit, changes),
        (env!("CARGO_PKG_VERSION"), Some(other_commit), changes),
    ];
    if let Some(c) = commit {
        // The same commit, with other or no uncommitted changes: a dirty tree is another build.
        others.push((env!("CARGO_PKG_VERSION"), Some(c), Some("feedfacefeedface")));
        if changes.is_some() {
            others.push((env!("CARGO_PKG_VERSION"), Some(c), None));
        }
    }
    for (version, commit, changes) in others {
        let mut r = record.clone();
        let o = r.as_object_mut().unwrap();
        o.insert("shard".into(), "3/3".into());
        o.insert("workbench_version".into(), version.into());
        for k in ["workbench_commit", "workbench_dirty", "workbench_changes"] {
            o.remove(k);
        }
        if let Some(c) = commit {
            o.insert("workbench_commit".into(), c.into());
            o.insert("workbench_dirty".into(), changes.is_some().into());
        }
        if let Some(f) = changes {
            o.insert("workbench_changes".into(), f.into());
        }
        std::fs::write(d.join("a3/shard.json"), serde_json::to_vec_pretty(&r).unwrap()).unwrap();
        let there = format!("version={version} build={}", token(commit, changes));
        std::fs::write(d.join("a3/units.csv"), header.replacen(&here, &there, 1)).unwrap();
        let o = workbench(d, &["merge", "out", "-q", "a1", "a2", "a3"]);
        refused(&o, "are shards of different runs (workbench builds");
        assert!(!d.join("out").exists(), "nothing written for refused input");
    }
    // Put back, the set merges.
    std::fs::write(d.join("a3/shard.json"), &shard).unwrap();
    std::fs::write(d.join("a3/units.csv"), &header).unwrap();
    ok(&workbench(d, &["merge", "out", "-q", "a1", "a2", "a3"]));

    // Every shard of another build: they agree with each other, but the merged manifest would
    // name this build for rows it did not compute (the issue-21 audit found exactly that), so
    // this build refuses them and names both.
    let there = format!("version=9.9.9 build={}", token(commit, changes));
    for i in 1..=3 {
        let path = d.join(format!("a{i}/shard.json"));
        let mut r: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
        r["workbench_version"] = "9.9.9".into();
        std::fs::write(&path, serde_json::to_vec_pretty(&r).unwrap()).unwrap();
        let units = d.join(format!("a{i}/units.csv"));
        let text = std::fs::read_to_string(&units).unwrap();
        std::fs::write(&units, text.replacen(&here, &there, 1)).unwrap();
    }
    let e = refused(
        &workbench(d, &["merge", "out2", "-q", "a1", "a2", "a3"]),
        "were written by workbench 9.9.9",
    );
    assert!(
        e.contains(&format!("this is workbench {}", env!("CARGO_PKG_VERSION"))),
        "{e}"
    );
    assert!(!d.join("out2").exists(), "nothing written for refused input");
}

#[test]
fn bad_shard_specs_are_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("small.json"), SMALL).unwrap();
    for bad in ["0/3", "4/3", "1/0", "2", "a/b"] {
        let e = refused(
            &workbench(d, &["run", "small.json", "-q", "--shard", bad]),
            "--shard",
        );
        assert!(e.contains(bad), "{e}");
    }
    assert!(!d.join("results").exists());
}

/// A run's unit log is what `--shard 1/1` leaves as `units.csv`: cut it after a few units and
/// half a row, as a killed run leaves it, and resume.
#[test]
fn resume_continues_a_cut_unit_log_to_the_same_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("small.json"), SMALL).unwrap();
    ok(&workbench(d, &["run", "small.json", "-q", "--out", "full"]));
    ok(&workbench(
        d,
        &["run", "small.json", "-q", "--shard", "1/1", "--out", "whole"],
    ));
    let log = std::fs::read_to_string(d.join("whole/units.csv")).unwrap();
    let lines: Vec<&str> = log.lines().collect();
    let rows_per_unit = 2 * 4;
    let kept_units = 5;
    let mut cut: String = lines[..2 + kept_units * rows_per_unit + 3]
        .iter()
        .map(|l| format!("{l}\n"))
        .collect();
    cut.push_str(&lines[2 + kept_units * rows_per_unit + 3][..10]);
    std::fs::create_dir(d.join("resumed")).unwrap();
    std::fs::write(d.join("resumed/trials.partial.csv"), &cut).unwrap();

    // Another run's log is refused, and left for the right run.
    let o = workbench(
        d,
        &[
            "run",
            "small.json",
            "-q",
            "--trials",
            "12",
            "--resume",
            "--out",
            "resumed",
        ],
    );
    refused(&o, "resumed/trials.partial.csv: was written for another run");
    assert!(d.join("resumed/trials.partial.csv").exists());

    let o = workbench(d, &["run", "small.json", "-q", "--resume", "--out", "resumed"]);
    ok(&o);
    assert!(
        stderr(&o).contains(&format!("resumed: {kept_units} of {} units", 3 * 13)),
        "{}",
        stderr(&o)
    );
    assert_same_files(&d.join("full"), &d.join("resumed"));
    assert!(
        !d.join("resumed/trials.partial.csv").exists(),
        "the log goes with the finished run"
    );
}

/// A spec whose BMC weight sets warn (MC kernel means from 8 directions make `V̂ − zᵀQ⁻¹z`
/// negative in most of them).
const WARNING: &str = r#"{
  "name": "warn",
  "title": "warnings",
  "integrands": ["cos3"],
  "estimators": [
    { "label": "MC", "method": "mc" },
    { "label": "BMC", "method": "bmc", "kernel_mean": "mc", "kernel_mean_samples": 8 }
  ],
  "samples": [8, 32],
  "trials": 6,
  "seed": 3
}"#;

/// The sum of the `warnings` column of a unit log's (or trials.csv's) rows.
fn row_warnings(csv: &str, header_lines: usize) -> u64 {
    let mut lines = csv.lines().skip(header_lines - 1);
    let columns: Vec<&str> = lines.next().unwrap().split(',').collect();
    let at = columns
        .iter()
        .position(|c| *c == "warnings")
        .expect("a warnings column");
    lines
        .map(|l| l.split(',').nth(at).unwrap().parse::<u64>().unwrap())
        .sum()
}

/// The warnings of units done before an interruption are not lost on `--resume`, nor those of
/// shards on `merge`: the messages were printed when those units ran, and the resumed or
/// merged run says how many warnings their trial rows hold.
#[test]
fn resume_and_merge_report_the_warnings_of_units_run_before() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("warn.json"), WARNING).unwrap();
    ok(&workbench(
        d,
        &["run", "warn.json", "-q", "--shard", "1/1", "--out", "whole"],
    ));
    let log = std::fs::read_to_string(d.join("whole/units.csv")).unwrap();
    let lines: Vec<&str> = log.lines().collect();
    // Two header lines, then two rows (MC, BMC) per unit: keep 8 of the 12 units.
    let cut: String = lines[..2 + 8 * 2].iter().map(|l| format!("{l}\n")).collect();
    let before = row_warnings(&cut, 2);
    assert!(
        before > 0,
        "the kept units must warn for this test to mean anything"
    );
    std::fs::create_dir(d.join("resumed")).unwrap();
    std::fs::write(d.join("resumed/trials.partial.csv"), &cut).unwrap();
    let o = workbench(d, &["run", "warn.json", "-q", "--resume", "--out", "resumed"]);
    ok(&o);
    let err = stderr(&o);
    assert!(
        err.contains(&format!("the resumed units' trial rows hold {before} warning(s)")),
        "{err}"
    );

    for i in 1..=2 {
        let shard = format!("{i}/2");
        ok(&workbench(
            d,
            &[
                "run",
                "warn.json",
                "-q",
                "--shard",
                &shard,
                "--out",
                &format!("s{i}"),
            ],
        ));
    }
    let o = workbench(d, &["merge", "merged", "s1", "s2", "-q"]);
    ok(&o);
    let total = row_warnings(&std::fs::read_to_string(d.join("merged/trials.csv")).unwrap(), 1);
    assert!(total > before, "{total} vs {before}");
    let err = stderr(&o);
    assert!(
        err.contains(&format!("the shards' trial rows hold {total} warning(s)")),
        "{err}"
    );
}

/// A real interruption: the run is killed while its log grows, then resumed.
#[test]
fn a_killed_run_resumes_without_redoing_its_finished_units() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 1200 units of about a millisecond: a run long enough that a test thread descheduled on a
    // loaded machine still kills it before its log is complete; without the checks, whose
    // verdicts at 400 trials are not this test's subject.
    let mut spec: serde_json::Value = serde_json::from_str(SMALL).unwrap();
    spec["samples"] = serde_json::json!([64, 128, 192]);
    spec["trials"] = serde_json::json!(400);
    spec.as_object_mut().unwrap().remove("checks");
    let spec = spec.to_string();
    std::fs::write(d.join("slow.json"), spec).unwrap();
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_workbench"))
        .args(["run", "slow.json", "-q", "--threads", "1", "--out", "killed"])
        .current_dir(d)
        .stderr(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let log = d.join("killed/trials.partial.csv");
    let started = std::time::Instant::now();
    // Two header lines and more than one unit (8 rows).
    while std::fs::read_to_string(&log).map_or(0, |t| t.lines().count()) < 2 + 9 {
        assert!(started.elapsed().as_secs() < 60, "the log never grew");
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before it was killed"
        );
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    let running = child.try_wait().unwrap().is_none();
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        running,
        "the run finished before it could be killed; make it slower"
    );
    assert!(!d.join("killed/manifest.json").exists());

    let o = workbench(d, &["run", "slow.json", "-q", "--resume", "--out", "killed"]);
    ok(&o);
    let err = stderr(&o);
    let resumed: usize = err
        .split("resumed: ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no resumed count in {err}"));
    assert!((1..3 * 400).contains(&resumed), "{err}");
    ok(&workbench(d, &["run", "slow.json", "-q", "--out", "full"]));
    assert_same_files(&d.join("full"), &d.join("killed"));
}

/// Tolerance estimators (issue 31): MC and BMC stopping at a tolerance beside a fixed-N MC, with
/// a `within_tolerance` check; `stopping_trials.csv`, `stopping_summary.csv`, the tolerance
/// figure and the manifest's tolerance checks come from the unit log.
const TOLERANCE: &str = r#"{
  "name": "tol",
  "title": "tolerance test",
  "integrands": ["cos", "cos3"],
  "estimators": [
    { "label": "MC", "method": "mc" },
    { "label": "MC tol", "method": "mc", "tolerance": { "abs": 0.6, "max_n": 64, "min_n": 4 } },
    { "label": "BMC tol", "method": "bmc", "design": "sobol", "tolerance": { "abs": 0.3, "max_n": 64, "min_n": 4 } }
  ],
  "samples": [4, 16],
  "trials": 11,
  "seed": 7,
  "checks": [{ "within_tolerance": "BMC tol", "level": 0.9 }]
}"#;

/// Issue 31 item 1: files with tolerance estimators were refused by `--shard` and `--resume`
/// (their stopping outcomes were kept in memory, not in the unit log). Now shards of 1, 2 and 3
/// on 1 and 2 threads merge to the bytes of one run, the stopping files included.
#[test]
fn tolerance_experiments_shard_and_merge_to_the_bytes_of_one_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("tol.json"), TOLERANCE).unwrap();
    ok(&workbench(d, &["run", "tol.json", "-q", "--out", "full"]));
    let names = deterministic_files(&d.join("full"));
    for n in [
        "stopping_trials.csv",
        "stopping_summary.csv",
        "cos3-tolerance.svg",
    ] {
        assert!(names.contains(&n.to_string()), "{n} in {names:?}");
    }
    let manifest = std::fs::read_to_string(d.join("full/manifest.json")).unwrap();
    assert!(manifest.contains("\"tolerance_checks\""), "{manifest}");
    for count in 1..=3 {
        let mut shards = Vec::new();
        for index in 1..=count {
            let out = format!("s{count}-{index}");
            let threads = (1 + index % 2).to_string();
            let shard = format!("{index}/{count}");
            ok(&workbench(
                d,
                &[
                    "run",
                    "tol.json",
                    "-q",
                    "--threads",
                    &threads,
                    "--shard",
                    &shard,
                    "--out",
                    &out,
                ],
            ));
            shards.push(out);
        }
        let merged = format!("m{count}");
        let mut args = vec!["merge", merged.as_str(), "-q"];
        args.extend(shards.iter().rev().map(String::as_str));
        let o = workbench(d, &args);
        ok(&o);
        assert!(
            stdout(&o).contains("check BMC tol within tolerance given met"),
            "the merge reports the tolerance check: {}",
            stdout(&o)
        );
        assert_same_files(&d.join("full"), &d.join(&merged));
    }
}

/// Issue 31 item 1: a tolerance run's log cut after five units and half a row, and a killed
/// tolerance run, both resume to the bytes of one run.
#[test]
fn tolerance_experiments_resume_to_the_bytes_of_one_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("tol.json"), TOLERANCE).unwrap();
    ok(&workbench(d, &["run", "tol.json", "-q", "--out", "full"]));
    ok(&workbench(
        d,
        &["run", "tol.json", "-q", "--shard", "1/1", "--out", "whole"],
    ));
    let log = std::fs::read_to_string(d.join("whole/units.csv")).unwrap();
    let lines: Vec<&str> = log.lines().collect();
    let rows_per_unit = 2 * 3;
    let kept_units = 5;
    let mut cut: String = lines[..2 + kept_units * rows_per_unit + 4]
        .iter()
        .map(|l| format!("{l}\n"))
        .collect();
    cut.push_str(&lines[2 + kept_units * rows_per_unit + 4][..10]);
    std::fs::create_dir(d.join("resumed")).unwrap();
    std::fs::write(d.join("resumed/trials.partial.csv"), &cut).unwrap();
    let o = workbench(
        d,
        &[
            "run",
            "tol.json",
            "-q",
            "--threads",
            "2",
            "--resume",
            "--out",
            "resumed",
        ],
    );
    ok(&o);
    assert!(
        stderr(&o).contains(&format!("resumed: {kept_units} of {} units", 2 * 11)),
        "{}",
        stderr(&o)
    );
    assert_same_files(&d.join("full"), &d.join("resumed"));

    // A real interruption: a slower tolerance run (BMC doubling to 512 points) killed while its
    // log grows.
    let slow = TOLERANCE
        .replace("\"trials\": 11", "\"trials\": 200")
        .replace("\"max_n\": 64", "\"max_n\": 512")
        .replace("\"abs\": 0.3", "\"abs\": 0.0001")
        .replace(r#"[{ "within_tolerance": "BMC tol", "level": 0.9 }]"#, "[]");
    assert!(slow.contains("\"checks\": []"));
    std::fs::write(d.join("slow.json"), slow).unwrap();
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_workbench"))
        .args(["run", "slow.json", "-q", "--threads", "1", "--out", "killed"])
        .current_dir(d)
        .stderr(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let log = d.join("killed/trials.partial.csv");
    let started = std::time::Instant::now();
    while std::fs::read_to_string(&log).map_or(0, |t| t.lines().count()) < 2 + rows_per_unit + 1 {
        assert!(started.elapsed().as_secs() < 60, "the log never grew");
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before it was killed"
        );
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    let running = child.try_wait().unwrap().is_none();
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        running,
        "the run finished before it could be killed; make it slower"
    );
    let o = workbench(d, &["run", "slow.json", "-q", "--resume", "--out", "killed"]);
    ok(&o);
    assert!(stderr(&o).contains("resumed: "), "{}", stderr(&o));
    ok(&workbench(d, &["run", "slow.json", "-q", "--out", "slow"]));
    assert_same_files(&d.join("slow"), &d.join("killed"));
}

/// The stopping columns of a shard's rows are checked like every other column: a tolerance
/// estimator's `stopped` must be true or false, its points used within max_n, and a fixed-N
/// estimator's stopping columns empty.
#[test]
fn merge_refuses_damaged_stopping_columns() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("tol.json"), TOLERANCE).unwrap();
    for i in 1..=2 {
        let (s, out) = (format!("{i}/2"), format!("a{i}"));
        ok(&workbench(
            d,
            &["run", "tol.json", "-q", "--shard", &s, "--out", &out],
        ));
    }
    let units = d.join("a1/units.csv");
    let good = std::fs::read_to_string(&units).unwrap();
    let lines: Vec<&str> = good.lines().collect();
    // Line 3: MC (fixed N), line 4: MC tol, both on cos.
    assert!(lines[2].starts_with("cos,MC,mc,") && lines[3].starts_with("cos,MC tol,mc,"));
    let with = |row: &str, from_end: usize, value: &str| -> String {
        let mut cols: Vec<String> = row.split(',').map(String::from).collect();
        // The last column is the row's digest.
        let at = cols.len() - 2 - from_end;
        cols[at] = value.to_string();
        cols.join(",")
    };
    let cases = [
        (
            3,
            with(lines[3], 4, "maybe"),
            "has stopped \"maybe\", not true or false",
        ),
        (3, with(lines[3], 3, "-1"), "zero_evidence_stages \"-1\""),
        (
            3,
            with(lines[3], 2, "128"),
            "has evaluations 128 where a tolerance estimator uses 1 to max_n = 64",
        ),
        (
            2,
            with(lines[2], 4, "true"),
            "where estimator \"MC\" has no tolerance",
        ),
    ];
    for (target, row, what) in &cases {
        let mut bad: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
        bad[*target] = row.clone();
        std::fs::write(&units, bad.join("\n") + "\n").unwrap();
        let line = refused(&workbench(d, &["merge", "out", "-q", "a1", "a2"]), what);
        assert!(
            line.contains(&format!("a1/units.csv: line {}", target + 1)),
            "{line}"
        );
        assert!(!d.join("out").exists(), "nothing written for a bad shard");
    }
    std::fs::write(&units, &good).unwrap();
    ok(&workbench(d, &["merge", "out", "-q", "a1", "a2"]));
}

/// Issue 30 item 5: `merge` copied a shard's rows into the merged CSVs unchecked — NUL bytes in
/// an estimate, a NaN `abs_error`, a wrong label or a wrong truth merged with exit 0. Every
/// column of every row is now checked against the plan, and a bad row is refused by file and
/// line, exit 2, before anything is written; `--resume` reads its log with the same check.
#[test]
fn merge_refuses_a_shard_row_that_does_not_hold_what_the_plan_computes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("small.json"), SMALL).unwrap();
    for i in 1..=2 {
        let (s, out) = (format!("{i}/2"), format!("a{i}"));
        ok(&workbench(
            d,
            &["run", "small.json", "-q", "--shard", &s, "--out", &out],
        ));
    }
    let units = d.join("a2/units.csv");
    let good = std::fs::read_to_string(&units).unwrap();
    let lines: Vec<&str> = good.lines().collect();
    // Line 4 of the log (header, columns, then rows): the second row of its first unit, MC is
    // line 3 and BMC line 4, both on integrand cos.
    let bmc = lines[3];
    assert!(bmc.starts_with("cos,BMC,bmc,"), "{bmc}");
    let field = |row: &str, i: usize| row.split(',').nth(i).unwrap().to_string();
    let with = |i: usize, value: &str| -> String {
        let mut cols: Vec<String> = bmc.split(',').map(String::from).collect();
        cols[i] = value.to_string();
        cols.join(",")
    };
    let estimate = field(bmc, 6);
    let cases: Vec<(String, &str)> = vec![
        (with(6, &format!("{estimate}\0\0")), "estimate"),
        (with(8, "NaN"), "abs_error \"NaN\", not a finite number"),
        (with(8, "0.5"), "abs_error 0.5 where |estimate − truth|"),
        (
            bmc.replacen("cos,BMC,", "cos,BMCX,", 1),
            "where the plan has integrand and estimator \"cos,BMC\"",
        ),
        (with(7, "3.0"), "has truth 3.0 where cos has"),
        (with(9, "-1.0"), "posterior_sd -1.0, below 0"),
        (
            with(3, "sobol"),
            "design \"sobol\" where the plan has \"uniform\"",
        ),
        (
            lines[2].replacen(",,,,,", ",1.0,0,0.0,1.0,", 1),
            "where method \"mc\" has no weight set",
        ),
    ];
    let mc_line = lines[2];
    assert!(mc_line.starts_with("cos,MC,mc,"), "{mc_line}");
    for (k, (row, what)) in cases.iter().enumerate() {
        let target = if k == cases.len() - 1 { 2 } else { 3 };
        let mut bad: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
        bad[target] = row.clone();
        std::fs::write(&units, bad.join("\n") + "\n").unwrap();
        let o = workbench(d, &["merge", "out", "-q", "a1", "a2"]);
        let line = refused(&o, what);
        assert!(
            line.contains(&format!("a2/units.csv: line {}", target + 1)),
            "names the file and line: {line}"
        );
        assert!(!d.join("out").exists(), "nothing written for a bad shard");
    }
    std::fs::write(&units, &good).unwrap();
    ok(&workbench(d, &["merge", "out", "-q", "a1", "a2"]));
}
