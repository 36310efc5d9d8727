//! Issue 31 item 2: render tables (fixed spp and adaptive) shard into rounds (every variant at
//! one spp or target and repetition) and merge to the bytes of one run; bad sets are refused in
//! one line with nothing written.

use crate::common::*;
use std::path::Path;
use std::process::Output;

const FIXED: &str = r#"{"name": "t", "seed": 3, "width": 16, "height": 12, "spp": [2, 4],
  "repetitions": [2, 3], "reference": {"spp": 8},
  "variants": [{"label": "MC", "integrator": "mc"}, {"label": "BMC 1", "integrator": "bmc", "gps": 1}]}"#;

const ADAPTIVE: &str = r#"{
  "name": "t", "seed": 5, "width": 24, "height": 16,
  "adaptive": {"target_sd": [0.1, 0.04], "first_spp": 8, "max_spp": 64},
  "repetitions": [2, 1],
  "variants": [
    {"label": "MC", "integrator": "mc"},
    {"label": "BMC 2 GP", "integrator": "bmc", "gps": 2}
  ]
}"#;

fn workbench_env(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut c = std::process::Command::new(env!("CARGO_BIN_EXE_workbench"));
    c.args(args).current_dir(dir);
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("binary runs")
}

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", stderr(o));
}

/// Exit 2 with one line naming `what`.
fn refused(o: &Output, what: &str) -> String {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.contains(what), "{what:?} not in {err}");
    err
}

/// Every file of a table but the wall-clock ones (`timings.*`): the PNGs (each cell's first
/// render and its error image, the reference), rmse.csv, table.csv, table.md, the plot and its
/// caption, the manifest.
fn same_files(a: &Path, b: &Path) {
    let names = |d: &Path| {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .filter(|n| !n.starts_with("timings"))
            .collect();
        v.sort();
        v
    };
    let list = names(a);
    assert_eq!(list, names(b), "file lists");
    assert!(list.contains(&"rmse.csv".into()) && list.iter().filter(|n| n.ends_with(".png")).count() > 2);
    for n in list {
        assert!(
            std::fs::read(a.join(&n)).unwrap() == std::fs::read(b.join(&n)).unwrap(),
            "{n} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

/// One run into `one/t`, then 1, 2 and 3 shards (on 1 and 2 threads, given in reverse order)
/// merged into `m<n>/t`: the same bytes. The shards share the reference cache of `m<n>`.
fn shards_merge_to_one_run(spec: &str) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("t.json"), spec).unwrap();
    ok(&workbench(d, &["render", "t.json", "-q", "--results-dir", "one"]));
    for count in 1..=3 {
        let results = format!("m{count}");
        let mut shards = Vec::new();
        for index in 1..=count {
            let out = format!("shards/{count}-{index}");
            let shard = format!("{index}/{count}");
            let threads = (1 + index % 2).to_string();
            let o = workbench_env(
                d,
                &[
                    "render",
                    "t.json",
                    "-q",
                    "--results-dir",
                    &results,
                    "--shard",
                    &shard,
                    "--out",
                    &out,
                ],
                &[("RAYON_NUM_THREADS", threads.as_str())],
            );
            ok(&o);
            assert!(stdout(&o).is_empty(), "a shard has no table to print");
            shards.push(out);
        }
        let merged = format!("{results}/t");
        let mut args = vec!["merge", merged.as_str(), "-q"];
        args.extend(shards.iter().rev().map(String::as_str));
        let o = workbench(d, &args);
        ok(&o);
        assert!(stdout(&o).contains("| MC |"), "{}", stdout(&o));
        // The manifest names the cache under its results folder: compare with one run there.
        let manifest = |p: &Path| std::fs::read_to_string(p.join("manifest.json")).unwrap();
        assert_eq!(
            manifest(&d.join(&merged)).replace(&format!("{results}/cache"), "one/cache"),
            manifest(&d.join("one/t"))
        );
        std::fs::copy(
            d.join("one/t/manifest.json"),
            d.join(&merged).join("manifest.json"),
        )
        .unwrap();
        same_files(&d.join("one/t"), &d.join(&merged));
    }
}

#[test]
fn fixed_render_tables_shard_and_merge_to_the_bytes_of_one_run() {
    shards_merge_to_one_run(FIXED);
}

#[test]
fn adaptive_render_tables_shard_and_merge_to_the_bytes_of_one_run() {
    shards_merge_to_one_run(ADAPTIVE);
}

/// The refusals: another table (seed, map), an experiment's shard among a table's, a missing or
/// repeated shard, a half-written shard (rows cut, an image gone), a damaged row, `--shard 0/4`
/// and `5/4` — each exit 2, one line, nothing merged.
#[test]
fn render_table_merge_refuses_bad_sets_before_writing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("t.json"), FIXED).unwrap();
    std::fs::write(d.join("seed.json"), FIXED.replace("\"seed\": 3", "\"seed\": 4")).unwrap();
    std::fs::write(
        d.join("map.json"),
        FIXED.replace("\"seed\": 3,", "\"seed\": 3, \"env\": \"white\","),
    )
    .unwrap();
    std::fs::write(
        d.join("e.json"),
        r#"{"name": "e", "integrands": ["cos"], "estimators": [{"label": "MC", "method": "mc"}],
            "samples": [4], "trials": 3, "seed": 1}"#,
    )
    .unwrap();
    let shard = |spec: &str, s: &str, out: &str| {
        ok(&workbench(d, &["render", spec, "-q", "--shard", s, "--out", out]));
    };
    shard("t.json", "1/2", "a1");
    shard("t.json", "2/2", "a2");
    shard("seed.json", "2/2", "seed2");
    shard("map.json", "2/2", "map2");
    ok(&workbench(
        d,
        &["run", "e.json", "-q", "--shard", "2/2", "--out", "e2"],
    ));
    let merge = |dirs: &[&str]| {
        let mut args = vec!["merge", "out/t", "-q"];
        args.extend(dirs);
        workbench(d, &args)
    };
    refused(&merge(&["a1", "seed2"]), "different runs (seeds 3 and 4)");
    refused(
        &merge(&["a1", "map2"]),
        "different render tables (maps \"sky\" and \"white\")",
    );
    refused(
        &merge(&["a1", "e2"]),
        "a1 is a shard of a render table and e2 a shard of an experiment",
    );
    refused(
        &merge(&["e2", "a1"]),
        "e2 is a shard of an experiment and a1 a shard of a render table",
    );
    refused(&merge(&["a1"]), "shard 2/2 missing");
    refused(&merge(&["a1", "a2", "a1"]), "are both shard 1/2");
    for bad in ["0/4", "5/4"] {
        let e = refused(
            &workbench(d, &["render", "t.json", "-q", "--shard", bad]),
            "--shard",
        );
        assert!(e.contains(bad), "{e}");
    }
    // Half-written: the log cut short, then an image gone.
    let units = d.join("a2/units.csv");
    let good = std::fs::read_to_string(&units).unwrap();
    std::fs::write(&units, &good[..good.len() - 7]).unwrap();
    refused(&merge(&["a1", "a2"]), "this shard is half-written, run it again");
    // A damaged row: a repetition that is not the unit's.
    let lines: Vec<&str> = good.lines().collect();
    let damaged = lines[2].replacen(",2,1,", ",2,0,", 1);
    assert_ne!(damaged, lines[2], "{}", lines[2]);
    let mut bad: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
    bad[2] = damaged;
    std::fs::write(&units, bad.join("\n") + "\n").unwrap();
    refused(
        &merge(&["a1", "a2"]),
        "a2/units.csv: line 3: the row is spp 2, repetition 0",
    );
    std::fs::write(&units, &good).unwrap();
    let png = d.join("a1/mc-2spp.png");
    let kept = std::fs::read(&png).unwrap();
    std::fs::remove_file(&png).unwrap();
    refused(&merge(&["a1", "a2"]), "this shard is half-written, run it again");
    assert!(!d.join("out").exists(), "nothing merged");
    std::fs::write(&png, kept).unwrap();
    ok(&merge(&["a1", "a2"]));
    assert!(d.join("out/t/table.csv").is_file());
}

/// A shard's rounds' log cut after some rounds and half a row, as a killed shard leaves it:
/// `--resume` keeps those rounds (re-rendering only the repetition-0 ones for their images)
/// and the merge is one run's bytes. A log of another shard is refused and left in place.
fn resume_a_cut_shard(spec: &str) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("t.json"), spec).unwrap();
    ok(&workbench(d, &["render", "t.json", "-q", "--results-dir", "one"]));
    for i in 1..=2 {
        let (s, out) = (format!("{i}/2"), format!("r/s{i}"));
        ok(&workbench(
            d,
            &[
                "render",
                "t.json",
                "-q",
                "--results-dir",
                "r",
                "--shard",
                &s,
                "--out",
                &out,
            ],
        ));
    }
    // Shard 1's log as it was after one round and half a row of the next.
    let units = std::fs::read_to_string(d.join("r/s1/units.csv")).unwrap();
    let lines: Vec<&str> = units.lines().collect();
    let kept = 2 + 2;
    let mut cut: String = lines[..kept].iter().map(|l| format!("{l}\n")).collect();
    cut.push_str(&lines[kept][..5]);
    std::fs::remove_dir_all(d.join("r/s1")).unwrap();
    std::fs::create_dir(d.join("r/s1")).unwrap();
    std::fs::write(d.join("r/s1/rounds.partial.csv"), &cut).unwrap();
    let resume = |shard: &str| {
        workbench(
            d,
            &[
                "render",
                "t.json",
                "-q",
                "--results-dir",
                "r",
                "--shard",
                shard,
                "--out",
                "r/s1",
                "--resume",
            ],
        )
    };
    refused(&resume("1/3"), "rounds.partial.csv: was written for another run");
    assert!(d.join("r/s1/rounds.partial.csv").is_file());
    let o = resume("1/2");
    ok(&o);
    assert!(stderr(&o).contains("resumed: 1 of"), "{}", stderr(&o));
    ok(&workbench(d, &["merge", "r/t", "-q", "r/s1", "r/s2"]));
    let manifest = std::fs::read_to_string(d.join("r/t/manifest.json")).unwrap();
    assert_eq!(
        manifest.replace("r/cache", "one/cache"),
        std::fs::read_to_string(d.join("one/t/manifest.json")).unwrap()
    );
    std::fs::copy(d.join("one/t/manifest.json"), d.join("r/t/manifest.json")).unwrap();
    same_files(&d.join("one/t"), &d.join("r/t"));
}

#[test]
fn fixed_render_table_shards_resume_to_the_bytes_of_one_run() {
    resume_a_cut_shard(FIXED);
}

#[test]
fn adaptive_render_table_shards_resume_to_the_bytes_of_one_run() {
    resume_a_cut_shard(ADAPTIVE);
}

/// A whole table (no `--shard`) resumes: its rounds' log cut after one round and half a row (as
/// a killed table leaves it) and a table that failed after its last round
/// (`WORKBENCH_TEST_FAIL_WRITE`) both end, with `render --resume`, as one uninterrupted run's
/// files, byte for byte; a log of another table (seed) is refused in one line and left in place.
fn resume_a_whole_table(spec: &str) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("t.json"), spec).unwrap();
    ok(&workbench(d, &["render", "t.json", "-q", "--results-dir", "one"]));
    let render = |results: &str, env: &[(&str, &str)]| {
        workbench_env(
            d,
            &["render", "t.json", "-q", "--results-dir", results, "--resume"],
            env,
        )
    };
    let compare = |results: &str| {
        let t = d.join(results).join("t");
        assert!(!t.join("rounds.partial.csv").exists());
        let manifest = std::fs::read_to_string(t.join("manifest.json")).unwrap();
        assert_eq!(
            manifest.replace(&format!("{results}/cache"), "one/cache"),
            std::fs::read_to_string(d.join("one/t/manifest.json")).unwrap()
        );
        std::fs::copy(d.join("one/t/manifest.json"), t.join("manifest.json")).unwrap();
        same_files(&d.join("one/t"), &t);
    };
    // Failed after every round was logged: all are kept.
    let o = workbench_env(
        d,
        &["render", "t.json", "-q", "--results-dir", "f"],
        &[("WORKBENCH_TEST_FAIL_WRITE", "table.csv")],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let log = std::fs::read_to_string(d.join("f/t/rounds.partial.csv")).unwrap();
    let o = render("f", &[]);
    ok(&o);
    let rounds = 5 - if spec == FIXED { 0 } else { 2 };
    assert!(
        stderr(&o).contains(&format!("resumed: {rounds} of {rounds} rounds")),
        "{}",
        stderr(&o)
    );
    compare("f");
    // Cut after one round and half a row.
    let lines: Vec<&str> = log.lines().collect();
    let mut cut: String = lines[..2 + 2].iter().map(|l| format!("{l}\n")).collect();
    cut.push_str(&lines[4][..5]);
    std::fs::create_dir_all(d.join("c/t")).unwrap();
    std::fs::write(d.join("c/t/rounds.partial.csv"), &cut).unwrap();
    std::fs::write(d.join("t.json"), spec.replace("\"seed\": ", "\"seed\": 1")).unwrap();
    refused(
        &render("c", &[]),
        "rounds.partial.csv: was written for another run",
    );
    assert!(d.join("c/t/rounds.partial.csv").is_file());
    std::fs::write(d.join("t.json"), spec).unwrap();
    let o = render("c", &[]);
    ok(&o);
    assert!(stderr(&o).contains("resumed: 1 of"), "{}", stderr(&o));
    compare("c");
}

#[test]
fn fixed_render_tables_resume_without_shards_to_the_bytes_of_one_run() {
    resume_a_whole_table(FIXED);
}

#[test]
fn adaptive_render_tables_resume_without_shards_to_the_bytes_of_one_run() {
    resume_a_whole_table(ADAPTIVE);
}
