//! How commands treat what they write, through the binary: a results folder holds one run,
//! a failed or killed command leaves no half-replaced set, no output replaces an input,
//! files follow the umask, and names keep their bytes.

use crate::common::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

const BIN: &str = env!("CARGO_BIN_EXE_workbench");

/// A pid no process can have (Linux's largest pid_max is 2^22).
const DEAD_PID: u32 = 4_194_305;

const COS3: &str = r#"{"name": "a", "integrands": ["cos3"],
  "estimators": [{"label": "MC", "method": "mc"}, {"label": "BMC", "method": "bmc"}],
  "samples": [4, 8], "trials": 40, "seed": 1}"#;

fn cos2() -> String {
    COS3.replace("\"cos3\"", "\"cos2\", \"cos\"")
}

const TABLE: &str = r#"{"name": "t", "seed": 3, "width": 16, "height": 12, "spp": [2, 4],
  "repetitions": [2, 1], "reference": {"spp": 8},
  "variants": [{"label": "MC", "integrator": "mc"}, {"label": "BMC 1", "integrator": "bmc", "gps": 1}]}"#;

const RENDER: [&str; 9] = [
    "render",
    "-q",
    "--integrator",
    "mc",
    "--spp",
    "2",
    "--width",
    "8",
    "--height",
];

fn render_args<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    let mut v: Vec<&str> = RENDER.to_vec();
    v.push("6");
    v.extend_from_slice(extra);
    v
}

/// Runs the binary in `dir` with extra environment variables.
fn workbench_env(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut c = Command::new(BIN);
    c.args(args).current_dir(dir);
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("binary runs")
}

/// Runs the binary through `sh -c "<prelude>; exec workbench …"`.
fn workbench_sh(dir: &Path, prelude: &str, args: &[&str]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!("{prelude}; exec \"$0\" \"$@\""))
        .arg(BIN)
        .args(args)
        .current_dir(dir)
        .output()
        .expect("sh runs")
}

fn ok(o: &Output) {
    assert!(o.status.success(), "{}\n{}", stdout(o), stderr(o));
}

/// Exit code 2 with exactly one line on stderr, which contains `needle`.
fn refused(o: &Output, needle: &str) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    assert!(err.contains(needle), "expected `{needle}` in: {err}");
}

/// Every file in `dir` (names, sorted), hidden ones included.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Every regular file under `dir` with its contents, to compare before and after.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut m = BTreeMap::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            m.extend(snapshot(&p));
        } else {
            m.insert(p.clone(), std::fs::read(&p).unwrap());
        }
    }
    m
}

fn hidden(dir: &Path) -> Vec<String> {
    listing(dir)
        .into_iter()
        .filter(|n| n.starts_with(".workbench-"))
        .collect()
}

/// The files `record` (a JSON file in `dir`) lists, sorted.
fn files_of(dir: &Path, record: &str) -> Vec<String> {
    let m: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join(record)).unwrap()).unwrap();
    let mut v: Vec<String> = m["files"].as_object().unwrap().keys().cloned().collect();
    v.sort();
    v
}

/// Every file the folder's records list: its manifest (the files a checkout of committed results
/// has) and its `timings.json` (the machine-dependent ones), sorted.
fn manifest_files(dir: &Path) -> Vec<String> {
    let mut v = files_of(dir, "manifest.json");
    if dir.join("timings.json").exists() {
        v.extend(files_of(dir, "timings.json"));
    }
    v.sort();
    v
}

/// Whether `name` is one of the wall-clock files `.gitignore` keeps out of `results/`.
fn git_ignored(name: &str) -> bool {
    name.starts_with("timings") || name.ends_with("-cost.svg") || name.ends_with("-cost.caption.txt")
}

#[test]
fn results_folder_holds_one_run_after_another_experiment() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("a.json"), COS3).unwrap();
    std::fs::write(d.join("b.json"), cos2()).unwrap();
    ok(&workbench(d, &["run", "a.json", "-q", "--out", "o"]));
    assert!(d.join("o/cos3.svg").exists());
    assert_eq!(listing(&d.join("o")), manifest_files(&d.join("o")));
    ok(&workbench(d, &["run", "b.json", "-q", "--out", "o"]));
    // The first run's plot went with it; the folder holds what its manifest lists, no more.
    assert_eq!(
        listing(&d.join("o")),
        [
            "cos-cost.caption.txt",
            "cos-cost.svg",
            "cos-coverage.caption.txt",
            "cos-coverage.svg",
            "cos.caption.txt",
            "cos.svg",
            "cos2-cost.caption.txt",
            "cos2-cost.svg",
            "cos2-coverage.caption.txt",
            "cos2-coverage.svg",
            "cos2.caption.txt",
            "cos2.svg",
            "fits.csv",
            "manifest.json",
            "summary.csv",
            "timings-summary.csv",
            "timings-trials.csv",
            "timings.json",
            "trials.csv"
        ]
    );
    assert_eq!(manifest_files(&d.join("o")), listing(&d.join("o")));
    // The manifest lists what a checkout of committed results has; timings.json the rest.
    let (committed, local): (Vec<String>, Vec<String>) =
        listing(&d.join("o")).into_iter().partition(|n| !git_ignored(n));
    assert_eq!(files_of(&d.join("o"), "manifest.json"), committed);
    assert_eq!(files_of(&d.join("o"), "timings.json"), local);
    assert_eq!(
        listing(d),
        ["a.json", "b.json", "o"],
        "nothing hidden left beside it"
    );
}

/// Issue 21 item 4: committed manifests listed git-ignored files (`timings*`, `*-cost.svg`)
/// that a checkout does not have. Every committed manifest lists only files the folder holds in
/// a checkout, none of them wall-clock files, and records the version of the build that wrote it.
#[test]
fn committed_manifests_list_only_files_a_checkout_has() {
    let results = Path::new(env!("CARGO_MANIFEST_DIR")).join("results");
    let mut seen = 0;
    for e in std::fs::read_dir(&results).unwrap() {
        let dir = e.unwrap().path();
        if !dir.join("manifest.json").is_file() {
            continue;
        }
        seen += 1;
        for f in files_of(&dir, "manifest.json") {
            assert!(
                !git_ignored(&f),
                "{}: lists {f}, which is not committed",
                dir.display()
            );
            assert!(
                dir.join(&f).is_file(),
                "{}: lists {f}, which it does not hold",
                dir.display()
            );
        }
        let m: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.join("manifest.json")).unwrap()).unwrap();
        assert_eq!(
            m["workbench_version"],
            env!("CARGO_PKG_VERSION"),
            "{}: the version of the build that wrote it",
            dir.display()
        );
        // Issue 30 item 8: no commit in a committed manifest (it lives in timings.json).
        for k in ["workbench_commit", "workbench_dirty", "workbench_changes"] {
            assert!(m.get(k).is_none(), "{}: records {k}", dir.display());
        }
    }
    assert!(seen >= 10, "{seen} committed result folders");
}

/// Issue 30 item 8: the README's main command (`run experiments/cos3.json`) dirtied a fresh
/// clone, because the manifest it rewrote recorded the commit of the build. Run with this build,
/// it writes every committed file of `results/cos3` byte for byte — manifest included — and no
/// other file that is not git-ignored, so `git status` stays clean.
#[test]
fn readme_main_command_rewrites_the_committed_cos3_results_byte_for_byte() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let fresh = dir.path().join("cos3");
    ok(&workbench(
        root,
        &[
            "run",
            "experiments/cos3.json",
            "-q",
            "--out",
            fresh.to_str().unwrap(),
        ],
    ));
    let committed = root.join("results/cos3");
    let tracked: Vec<String> = listing(&fresh).into_iter().filter(|n| !git_ignored(n)).collect();
    // The README's main command leaves its git-ignored timing files beside the committed ones:
    // what a checkout has is the rest.
    let committed_files: Vec<String> = listing(&committed)
        .into_iter()
        .filter(|n| !git_ignored(n))
        .collect();
    assert_eq!(tracked, committed_files, "the files a checkout has");
    for f in &tracked {
        assert!(
            std::fs::read(fresh.join(f)).unwrap() == std::fs::read(committed.join(f)).unwrap(),
            "results/cos3/{f} differs from a fresh run's"
        );
    }
}

/// A folder whose manifest a checkout replaced (the committed one lists no timing files) still
/// counts the timing files of its earlier run as ours: re-running into it works.
#[test]
fn committed_manifests_list_only_files_a_checkout_has_and_local_timings_stay_ours() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("a.json"), COS3).unwrap();
    ok(&workbench(d, &["run", "a.json", "-q", "--out", "o"]));
    // What a checkout does to a regenerated folder: the manifest comes back, timings.json
    // stays (a run of an older version wrote it without its list of files).
    std::fs::write(
        d.join("o/timings.json"),
        "{\"threads\": 1, \"wall_seconds\": 1.0}\n",
    )
    .unwrap();
    assert!(d.join("o/cos3-cost.svg").exists() && d.join("o/timings-trials.csv").exists());
    ok(&workbench(d, &["run", "a.json", "-q", "--out", "o"]));
    assert_eq!(listing(&d.join("o")), manifest_files(&d.join("o")));
    // A table likewise.
    std::fs::write(d.join("t.json"), TABLE).unwrap();
    ok(&workbench(d, &["render", "t.json", "--results-dir", "out", "-q"]));
    std::fs::remove_file(d.join("out/t/timings.json")).unwrap();
    assert!(d.join("out/t/timings.md").exists());
    ok(&workbench(d, &["render", "t.json", "--results-dir", "out", "-q"]));
    assert_eq!(listing(&d.join("out/t")), manifest_files(&d.join("out/t")));
}

#[test]
fn results_folder_holds_one_run_after_another_table() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("t.json"), TABLE).unwrap();
    ok(&workbench(d, &["render", "t.json", "--results-dir", "out", "-q"]));
    let t = d.join("out/t");
    assert!(t.join("bmc-1-4spp.png").exists());
    assert_eq!(listing(&t), manifest_files(&t));
    // Another table of the same name, with other variants and spp values.
    let other = TABLE
        .replace("\"BMC 1\"", "\"BMCP\"")
        .replace("\"bmc\"", "\"bmcp\"")
        .replace("[2, 4]", "[2, 3]");
    std::fs::write(d.join("t.json"), other).unwrap();
    ok(&workbench(d, &["render", "t.json", "--results-dir", "out", "-q"]));
    let files = listing(&t);
    assert!(files.contains(&"bmcp-3spp.png".to_string()), "{files:?}");
    assert!(
        !files
            .iter()
            .any(|f| f.starts_with("bmc-1") || f.ends_with("4spp.png")),
        "stale PNGs of the first table: {files:?}"
    );
    assert_eq!(files, manifest_files(&t));
    assert_eq!(listing(&d.join("out")), ["cache", "t"]);
}

#[test]
fn results_folder_holds_one_run_refuses_files_no_manifest_lists() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("a.json"), COS3).unwrap();
    ok(&workbench(d, &["run", "a.json", "-q", "--out", "o"]));
    std::fs::write(d.join("o/notes.txt"), "mine").unwrap();
    let before = snapshot(d);
    let o = workbench(d, &["run", "a.json", "-q", "--out", "o"]);
    refused(
        &o,
        "Error: --out o: holds notes.txt, which no workbench manifest there lists, and the results \
         replace the folder as a whole; move that elsewhere, or use another --out",
    );
    assert_eq!(snapshot(d), before);
    assert_eq!(hidden(d), Vec::<String>::new());

    // A folder of other things (here: other results) is not a results folder.
    ok(&workbench(d, &["run", "a.json", "-q", "--out", "many/x"]));
    std::fs::write(d.join("many/readme"), "").unwrap();
    let o = workbench(d, &["run", "a.json", "-q", "--out", "many"]);
    refused(
        &o,
        "--out many: holds readme and x/, which no workbench manifest there lists",
    );
    // Nor is a folder whose manifest.json is someone else's.
    std::fs::create_dir(d.join("theirs")).unwrap();
    std::fs::write(d.join("theirs/manifest.json"), "{}").unwrap();
    let o = workbench(d, &["run", "a.json", "-q", "--out", "theirs"]);
    refused(
        &o,
        "--out theirs: holds manifest.json, which no workbench manifest",
    );
    // The default folder is named as such.
    std::fs::create_dir_all(d.join("results/a")).unwrap();
    std::fs::write(d.join("results/a/x.txt"), "").unwrap();
    let o = workbench(d, &["run", "a.json", "-q"]);
    refused(&o, "results/a: holds x.txt, which");
    // And a file is not a folder.
    let o = workbench(d, &["run", "a.json", "-q", "--out", "a.json"]);
    refused(&o, "--out a.json: is a file, not a folder; use another --out");
}

/// Manifests committed before they listed their files (like `results/cos3/manifest.json`) are
/// read by what they describe, so re-running into a committed folder works.
#[test]
fn results_folder_holds_one_run_reads_manifests_from_before_the_file_list() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let committed = Path::new(env!("CARGO_MANIFEST_DIR")).join("results/cos3");
    std::fs::create_dir(d.join("cos3")).unwrap();
    for f in ["cos3.svg", "manifest.json", "summary.csv", "trials.csv"] {
        std::fs::copy(committed.join(f), d.join("cos3").join(f)).unwrap();
    }
    std::fs::write(d.join("cos3/timings.json"), "{}").unwrap();
    std::fs::write(d.join("b.json"), cos2()).unwrap();
    ok(&workbench(d, &["run", "b.json", "-q", "--out", "cos3"]));
    assert_eq!(listing(&d.join("cos3")), manifest_files(&d.join("cos3")));
    assert!(!d.join("cos3/cos3.svg").exists());

    let committed = Path::new(env!("CARGO_MANIFEST_DIR")).join("results/render-table");
    std::fs::create_dir(d.join("t")).unwrap();
    for e in std::fs::read_dir(&committed).unwrap() {
        let p = e.unwrap().path();
        std::fs::copy(&p, d.join("t").join(p.file_name().unwrap())).unwrap();
    }
    std::fs::write(d.join("t.json"), TABLE).unwrap();
    ok(&workbench(d, &["render", "t.json", "--results-dir", ".", "-q"]));
    assert_eq!(listing(&d.join("t")), manifest_files(&d.join("t")));
}

/// A second command into a folder another one is writing is refused, naming the holder; the
/// lock is released (and its file removed) when the holder ends.
#[test]
fn results_folder_holds_one_run_refuses_a_second_writer() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("a.json"), COS3).unwrap();
    ok(&workbench(d, &["run", "a.json", "-q", "--out", "o"]));
    // Hold the locks as running commands would.
    let locks: Vec<std::fs::File> = ["o", "img.exr", "r.json"]
        .iter()
        .map(|name| {
            let path = d.join(format!(".workbench-lock-{name}"));
            let f = std::fs::File::create(&path).unwrap();
            f.lock().unwrap();
            std::fs::write(&path, "12345").unwrap();
            f
        })
        .collect();
    let before = snapshot(d);
    let o = workbench(d, &["run", "a.json", "-q", "--out", "o"]);
    refused(
        &o,
        "Error: --out o: another workbench (pid 12345) is writing it; wait for it to finish, or use another --out",
    );
    let o = workbench(d, &render_args(&["--out", "img.exr"]));
    refused(&o, "--out img.exr: another workbench (pid 12345) is writing it");
    let o = workbench(d, &["rule", "--n", "4", "--summary", "r.json"]);
    refused(
        &o,
        "--summary r.json: another workbench (pid 12345) is writing it",
    );
    assert_eq!(snapshot(d), before);
    drop(locks);
    ok(&workbench(d, &["run", "a.json", "-q", "--out", "o"]));
    ok(&workbench(d, &render_args(&["--out", "img.exr"])));
    assert_eq!(hidden(d), Vec::<String>::new());
}

/// Two runs started together into one folder: whichever way they interleave, each either
/// finishes or is refused, and the folder ends up holding one run's complete set.
#[test]
fn results_folder_holds_one_run_with_two_concurrent_runs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("a.json"), COS3).unwrap();
    std::fs::write(d.join("b.json"), cos2()).unwrap();
    let spawn = |spec: &str| {
        Command::new(BIN)
            .args(["run", spec, "-q", "--out", "o"])
            .current_dir(d)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (a, b) = (spawn("a.json"), spawn("b.json"));
    let outs = [a.wait_with_output().unwrap(), b.wait_with_output().unwrap()];
    for o in &outs {
        let err = stderr(o);
        assert!(
            o.status.success() || (o.status.code() == Some(2) && err.contains("another workbench")),
            "{err}"
        );
    }
    assert!(outs.iter().any(|o| o.status.success()));
    let files = listing(&d.join("o"));
    assert_eq!(files, manifest_files(&d.join("o")));
    let svgs: Vec<&String> = files.iter().filter(|f| f.ends_with(".svg")).collect();
    let (_, trials) = read_csv(&d.join("o/trials.csv"));
    let integrands: std::collections::BTreeSet<String> = trials.iter().map(|r| r[0].clone()).collect();
    // Each integrand's error plot and calibration plot (sorted as the listing is).
    let mut expected: Vec<String> = integrands
        .iter()
        .flat_map(|i| {
            [
                format!("{i}.svg"),
                format!("{i}-coverage.svg"),
                format!("{i}-cost.svg"),
            ]
        })
        .collect();
    expected.sort();
    assert_eq!(
        svgs,
        expected.iter().collect::<Vec<_>>(),
        "plots and CSV from one run"
    );
    assert_eq!(hidden(d), Vec::<String>::new());
}

/// What a killed command leaves — its lock file, its staging folder, temporary files — is
/// taken over or removed by the next command, and live writers' files are left alone.
#[test]
fn results_folder_holds_one_run_takes_over_what_a_killed_run_left() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("a.json"), COS3).unwrap();
    let dead = workbench::files::atomic::writer(DEAD_PID);
    std::fs::write(d.join(".workbench-lock-o"), DEAD_PID.to_string()).unwrap();
    let staging = d.join(format!(".workbench-{dead}-staging-o"));
    std::fs::create_dir(&staging).unwrap();
    std::fs::write(staging.join("trials.csv"), "half").unwrap();
    std::fs::write(d.join(format!(".workbench-{dead}-x1.tmp")), "").unwrap();
    std::fs::write(d.join(".workbench-lock-other"), "").unwrap();
    // The test process is alive: its files must stay. So must another host's (its pid means
    // nothing here) and an earlier version's, which do not say their host.
    let alive = format!(
        ".workbench-{}-x2.tmp",
        workbench::files::atomic::writer(std::process::id())
    );
    let elsewhere = format!(".workbench-{DEAD_PID}.0123456789ab-staging-p");
    let unknown_host = format!(".workbench-{DEAD_PID}-x3.tmp");
    for name in [&alive, &elsewhere, &unknown_host] {
        std::fs::write(d.join(name), "").unwrap();
    }
    let mut kept = vec![alive.clone(), elsewhere.clone(), unknown_host.clone()];
    kept.sort();
    ok(&workbench(d, &["run", "a.json", "-q", "--out", "o"]));
    assert_eq!(hidden(d), kept);
    assert_eq!(listing(&d.join("o")), manifest_files(&d.join("o")));

    // Beside single files too.
    std::fs::write(d.join(format!(".workbench-{dead}-y.tmp")), "").unwrap();
    ok(&workbench(d, &render_args(&["--out", "img.exr"])));
    assert_eq!(hidden(d), kept);
}

/// Every file of the earlier run is as it was when a later run fails partway through writing
/// its outputs (here, a full disk at summary.csv, after trials.csv), and nothing is left over.
#[test]
fn half_replaced_result_set_run_failing_midway_keeps_the_earlier_set() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("a.json"), COS3).unwrap();
    std::fs::write(d.join("b.json"), cos2()).unwrap();
    ok(&workbench(d, &["run", "a.json", "-q", "--out", "o"]));
    let before = snapshot(d);
    for file in ["summary.csv", "manifest.json"] {
        let o = workbench_env(
            d,
            &["run", "b.json", "-q", "--out", "o"],
            &[("WORKBENCH_TEST_FAIL_WRITE", file)],
        );
        refused(
            &o,
            &format!(
                "Error: writing o/{file} (o is left as it was): No space left on device (injected by \
                 WORKBENCH_TEST_FAIL_WRITE)"
            ),
        );
        // The earlier set as it was, and beside it the failed run's units, for --resume.
        let mut after = snapshot(d);
        let log = after
            .remove(&d.join("o/trials.partial.csv"))
            .expect("the unit log");
        assert_eq!(after, before, "{file}");
        assert_eq!(listing(d), ["a.json", "b.json", "o"], "{file}");
        assert_eq!(
            String::from_utf8(log).unwrap().lines().count(),
            2 + 2 * 2 * 2 * 40
        );
    }
    // A first run that fails leaves only its units, which --resume turns into the set without
    // running them again.
    let o = workbench_env(
        d,
        &["run", "b.json", "-q", "--out", "new/o"],
        &[("WORKBENCH_TEST_FAIL_WRITE", "trials.csv")],
    );
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(listing(&d.join("new/o")), ["trials.partial.csv"]);
    let o = workbench(d, &["run", "b.json", "-q", "--out", "new/o", "--resume"]);
    ok(&o);
    assert!(stderr(&o).contains("resumed: 80 of 80 units"), "{}", stderr(&o));
    assert_eq!(listing(&d.join("new/o")), manifest_files(&d.join("new/o")));
}

/// The same with a real write error from the kernel (a file-size limit, like a full disk:
/// the write fails partway with EFBIG), without the test hook.
#[test]
fn half_replaced_result_set_run_hitting_a_real_write_error_keeps_the_earlier_set() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("a.json"), COS3).unwrap();
    std::fs::write(d.join("b.json"), cos2()).unwrap();
    ok(&workbench(d, &["run", "a.json", "-q", "--out", "o"]));
    let before = snapshot(d);
    // trials.csv is over 4 KB; the limit is 1 block (512 or 1024 bytes, by shell).
    let o = workbench_sh(
        d,
        "trap '' XFSZ; ulimit -f 1",
        &["run", "b.json", "-q", "--out", "o"],
    );
    // The unit log, appended as the run goes, is the first file to outgrow the limit.
    refused(&o, "Error: appending to o/trials.partial.csv: File too large");
    let mut after = snapshot(d);
    after
        .remove(&d.join("o/trials.partial.csv"))
        .expect("the unit log");
    assert_eq!(after, before);
    assert_eq!(listing(d), ["a.json", "b.json", "o"]);
}

/// A single render that fails after its EXR is written (the PNG, or the error image) leaves
/// the earlier EXR and PNGs together, as they were.
#[test]
fn half_replaced_result_set_single_render_failing_after_the_exr() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&workbench(d, &render_args(&["--out", "ref.exr"])));
    ok(&workbench(
        d,
        &render_args(&["--reference", "ref.exr", "--out", "img.exr"]),
    ));
    let before = snapshot(d);
    for file in ["img.png", "img-error.png"] {
        let o = workbench_env(
            d,
            &render_args(&["--seed", "9", "--reference", "ref.exr", "--out", "img.exr"]),
            &[("WORKBENCH_TEST_FAIL_WRITE", file)],
        );
        refused(&o, &format!("Error: writing {file}: No space left on device"));
        assert_eq!(snapshot(d), before, "{file}");
        assert_eq!(hidden(d), Vec::<String>::new());
    }
    // The rule and its summary likewise.
    ok(&workbench(
        d,
        &["rule", "--n", "8", "--out", "r.csv", "--summary", "r.json"],
    ));
    let before = snapshot(d);
    let o = workbench_env(
        d,
        &["rule", "--n", "9", "--out", "r.csv", "--summary", "r.json"],
        &[("WORKBENCH_TEST_FAIL_WRITE", "r.json")],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(snapshot(d), before);
    assert_eq!(hidden(d), Vec::<String>::new());
    // A render without --reference removes the error image of the image it replaces.
    let o = workbench(d, &render_args(&["--seed", "9", "--out", "img.exr"]));
    ok(&o);
    assert!(stderr(&o).contains("removed img-error.png"), "{}", stderr(&o));
    assert!(!d.join("img-error.png").exists());
}

/// A table that fails after its renders keeps the earlier table whole, and the rows it measured
/// in rounds.partial.csv beside it.
#[test]
fn half_replaced_result_set_table_failing_at_the_end_keeps_its_rows_apart() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("t.json"), TABLE).unwrap();
    ok(&workbench(d, &["render", "t.json", "--results-dir", "out", "-q"]));
    let before = snapshot(&d.join("out/t"));
    std::fs::write(d.join("t.json"), TABLE.replace("\"seed\": 3", "\"seed\": 4")).unwrap();
    let o = workbench_env(
        d,
        &["render", "t.json", "--results-dir", "out", "-q"],
        &[("WORKBENCH_TEST_FAIL_WRITE", "table.csv")],
    );
    // A new seed, so a new reference (its status line comes first) and new numbers.
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(
        err.lines()
            .last()
            .unwrap()
            .starts_with("Error: writing out/t/table.csv (out/t is left as it was): No space left"),
        "{err}"
    );
    let mut after = snapshot(&d.join("out/t"));
    let partial = after
        .remove(&d.join("out/t/rounds.partial.csv"))
        .expect("the partial rows");
    assert_eq!(after, before);
    let partial = String::from_utf8(partial).unwrap();
    assert_eq!(
        partial.lines().count(),
        2 + 2 * 3,
        "the identity and column lines, every render's row: {partial}"
    );
    assert!(partial.starts_with("# workbench unit log: "), "{partial}");
    assert_eq!(
        partial.lines().nth(1),
        Some(
            "variant,integrator,gps,rotate,spp,repetition,seed,rmse,rmse_edges,coverage95,coverage95_edges,seconds,digest"
        )
    );
    assert_eq!(listing(&d.join("out")), ["cache", "t"]);
    // The next complete table replaces the folder, partial rows included.
    ok(&workbench(d, &["render", "t.json", "--results-dir", "out", "-q"]));
    assert_eq!(listing(&d.join("out/t")), manifest_files(&d.join("out/t")));
}

/// A table killed midway (SIGKILL: no clean-up runs) leaves the earlier table whole, with the
/// rows measured so far in rounds.partial.csv; the next run clears what the killed one left.
#[test]
fn half_replaced_result_set_table_killed_midway() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("t.json"), TABLE).unwrap();
    ok(&workbench(d, &["render", "t.json", "--results-dir", "out", "-q"]));
    let t = d.join("out/t");
    let before = snapshot(&t);
    // Minutes of work, killed as soon as its first round is measured.
    let long = TABLE
        .replace("\"width\": 16, \"height\": 12", "\"width\": 256, \"height\": 256")
        .replace("\"spp\": [2, 4]", "\"spp\": [32]")
        .replace("\"repetitions\": [2, 1]", "\"repetitions\": [2000]");
    std::fs::write(d.join("long.json"), long).unwrap();
    let mut child = Command::new(BIN)
        .args(["render", "long.json", "--results-dir", "out", "-q"])
        .current_dir(d)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // The log exists from the start: wait for its first round (its two header lines and a row).
    let rounds = t.join("rounds.partial.csv");
    while std::fs::read_to_string(&rounds).map_or(0, |s| s.lines().count()) < 3 {
        assert!(child.try_wait().unwrap().is_none(), "the long table ended early");
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    child.kill().unwrap();
    let status = child.wait().unwrap();
    assert!(!status.success(), "killed before the end");

    let mut after = snapshot(&t);
    let partial = after.remove(&t.join("rounds.partial.csv")).unwrap();
    assert_eq!(after, before, "the earlier table is whole");
    assert!(String::from_utf8(partial).unwrap().lines().count() >= 3);
    // Its lock file and staging folder are left behind, hidden.
    assert!(hidden(&d.join("out")).len() >= 2, "{:?}", listing(&d.join("out")));
    ok(&workbench(d, &["render", "t.json", "--results-dir", "out", "-q"]));
    assert_eq!(listing(&d.join("out")), ["cache", "t"]);
    assert_eq!(listing(&t), manifest_files(&t));
}

#[test]
fn output_overwrites_input_through_an_absent_folder() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.csv"), "x,y,z\n0,0,1\n0.6,0,0.8\n0,0.6,0.8\n").unwrap();
    let o = workbench(d, &["rule", "--points", "p.csv", "--out", "absent/../p.csv"]);
    refused(
        &o,
        "Error: --out absent/../p.csv: would overwrite --points p.csv; choose another --out",
    );
    ok(&workbench(d, &render_args(&["--out", "ref.exr"])));
    let o = workbench(
        d,
        &render_args(&["--reference", "ref.exr", "--out", "absent/../ref.exr"]),
    );
    refused(&o, "--out absent/../ref.exr: would overwrite --reference ref.exr");
    // The PNG beside an output may not be an input either.
    let o = workbench(
        d,
        &render_args(&["--env", "absent/../sky.png", "--out", "absent/../sky.exr"]),
    );
    refused(&o, "--out (its PNG) absent/../sky.png: would overwrite --env");
    assert_eq!(listing(d), ["p.csv", "ref.exr", "ref.png"]);
}

#[test]
fn output_overwrites_input_through_links() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A dangling link to the summary's file: both outputs would land in one file.
    std::os::unix::fs::symlink("s.json", d.join("link.csv")).unwrap();
    let o = workbench(
        d,
        &["rule", "--n", "4", "--out", "link.csv", "--summary", "s.json"],
    );
    refused(
        &o,
        "--summary s.json: is the same file as --out link.csv; give each output its own name",
    );
    assert!(!d.join("s.json").exists());
    // A hard link to the points.
    std::fs::write(d.join("p.csv"), "x,y,z\n0,0,1\n").unwrap();
    std::fs::hard_link(d.join("p.csv"), d.join("h.csv")).unwrap();
    let o = workbench(d, &["rule", "--points", "p.csv", "--out", "h.csv"]);
    refused(&o, "--out h.csv: would overwrite --points p.csv");
    assert_eq!(
        std::fs::read_to_string(d.join("p.csv")).unwrap(),
        "x,y,z\n0,0,1\n"
    );
}

/// `run D/manifest.json --out D`, and a table whose spec sits in its own results folder: the
/// folder is replaced as a whole, so an input inside it is refused.
#[test]
fn output_overwrites_input_inside_the_results_folder() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("D")).unwrap();
    std::fs::write(d.join("D/manifest.json"), COS3).unwrap();
    let o = workbench(d, &["run", "D/manifest.json", "-q", "--out", "D"]);
    refused(
        &o,
        "Error: --out D: would replace the experiment file D/manifest.json, which lies inside it; move \
         that file elsewhere, or use another --out",
    );
    let o = workbench(d, &["run", "D/manifest.json", "-q", "--out", "D/../D/."]);
    refused(&o, "would replace the experiment file D/manifest.json");
    assert_eq!(std::fs::read_to_string(d.join("D/manifest.json")).unwrap(), COS3);

    std::fs::create_dir_all(d.join("out/t")).unwrap();
    std::fs::write(d.join("out/t/spec.json"), TABLE).unwrap();
    let o = workbench(d, &["render", "out/t/spec.json", "--results-dir", "out", "-q"]);
    refused(
        &o,
        "out/t: would replace the render-table file out/t/spec.json, which lies inside it",
    );
    // A table named "cache" would replace the reference cache.
    std::fs::write(d.join("c.json"), TABLE.replace("\"t\"", "\"cache\"")).unwrap();
    let o = workbench(d, &["render", "c.json", "--results-dir", "out", "-q"]);
    refused(
        &o,
        "out/cache: would replace the reference cache out/cache/reference-",
    );
    assert_eq!(listing(&d.join("out/t")), ["spec.json"]);
    assert_eq!(listing(&d.join("out")), ["t"]);
}

fn mode(p: &Path) -> u32 {
    use std::os::unix::fs::PermissionsExt;
    std::fs::metadata(p).unwrap().permissions().mode() & 0o777
}

#[test]
fn results_respect_the_umask() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("a.json"), COS3).unwrap();
    for (umask, file, folder) in [
        ("077", 0o600, 0o700),
        ("022", 0o644, 0o755),
        ("002", 0o664, 0o775),
    ] {
        let sub = d.join(umask);
        std::fs::create_dir(&sub).unwrap();
        let u = format!("umask {umask}");
        ok(&workbench_sh(&sub, &u, &["run", "../a.json", "-q", "--out", "o"]));
        ok(&workbench_sh(&sub, &u, &render_args(&["--out", "img.exr"])));
        ok(&workbench_sh(
            &sub,
            &u,
            &["rule", "--n", "4", "--out", "r.csv", "--summary", "r.json"],
        ));
        assert_eq!(mode(&sub.join("o")), folder, "umask {umask}");
        for f in [
            "o/trials.csv",
            "o/manifest.json",
            "img.exr",
            "img.png",
            "r.csv",
            "r.json",
        ] {
            assert_eq!(mode(&sub.join(f)), file, "{f} under umask {umask}");
        }
    }
}

#[test]
fn non_utf8_output_names_keep_their_bytes() {
    use std::ffi::OsStr;
    use std::os::unix::ffi::OsStrExt;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&workbench(d, &render_args(&["--out", "ref.exr"])));
    let name = OsStr::from_bytes(b"img\xff.exr");
    let o = Command::new(BIN)
        .args(render_args(&["--reference", "ref.exr", "--out"]))
        .arg(name)
        .current_dir(d)
        .output()
        .unwrap();
    ok(&o);
    for n in [&b"img\xff.exr"[..], b"img\xff.png", b"img\xff-error.png"] {
        assert!(
            d.join(OsStr::from_bytes(n)).is_file(),
            "{}",
            String::from_utf8_lossy(n)
        );
    }
    assert!(!d.join("img\u{FFFD}.png").exists());
    // A results folder of such a name, and its lock and staging names.
    std::fs::write(d.join("a.json"), COS3).unwrap();
    let o = Command::new(BIN)
        .args(["run", "a.json", "-q", "--out"])
        .arg(OsStr::from_bytes(b"o\xfe"))
        .current_dir(d)
        .output()
        .unwrap();
    ok(&o);
    assert!(d.join(OsStr::from_bytes(b"o\xfe/trials.csv")).is_file());
    assert_eq!(hidden(d), Vec::<String>::new());
}

/// Issue 21, item 1: shards on two hosts write beside each other in one shared folder
/// (`--out shards/1`, `--out shards/2`). A shard starting on one host deleted the staging folder
/// of a shard still running on another, whose pid it could not see, and that shard then failed
/// at its end. A second pid namespace stands in for the second host (`unshare`, as root on the
/// project's machines): a shard there is stopped mid-run, so its staging folder stays as a
/// running shard's would, and a shard here must leave it alone. The same leftover made here is
/// a dead writer's and is swept.
#[test]
fn shared_parent_a_shard_leaves_another_hosts_staging_folder_alone() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let spec = r#"{"name": "k", "integrands": ["cos3"], "estimators": [{"label": "MC", "method": "mc"},
        {"label": "BMC", "method": "bmc"}], "samples": [512, 1024], "trials": 20000, "seed": 11}"#;
    std::fs::write(d.join("s.json"), spec).unwrap();
    std::fs::create_dir(d.join("shards")).unwrap();
    let bin = env!("CARGO_BIN_EXE_workbench");
    let staging_of = |shard: &str| -> Vec<String> {
        hidden(&d.join("shards"))
            .into_iter()
            .filter(|n| n.ends_with(&format!("-staging-{shard}")))
            .collect()
    };
    // "Host" B: a few processes first, so that the shard's pid is not one of this namespace's
    // low ones; stopped after two seconds, long before 10 000 trials of BMC at N = 1024 are
    // done (minutes of work on any machine), so the staging folder is a running shard's.
    let script = format!(
        "for i in 1 2 3 4 5 6 7 8 9; do /bin/true; done; \
         timeout --foreground -s KILL 2 {bin} run s.json --shard 2/2 --threads 1 --out shards/2 -q; exit 0"
    );
    let status = std::process::Command::new("unshare")
        .args(["--pid", "--fork", "--mount-proc", "sh", "-c", &script])
        .current_dir(d)
        .status()
        .expect("unshare runs (util-linux, as root)");
    assert!(status.success(), "unshare: {status}");
    let b = staging_of("2");
    assert_eq!(
        b.len(),
        1,
        "the other host's shard left no staging folder: {:?}",
        hidden(&d.join("shards"))
    );
    // Here: a run beside it, which sweeps the shared folder for dead writers' leftovers as it
    // starts (B's pid is not alive in this namespace: the old rule removed the folder).
    let small = spec.replace("20000", "4");
    std::fs::write(d.join("s.json"), &small).unwrap();
    ok(&workbench(
        d,
        &["run", "s.json", "--threads", "1", "--out", "shards/1", "-q"],
    ));
    assert_eq!(
        staging_of("2"),
        b,
        "a shard here removed the other host's staging folder"
    );

    // The same kind of leftover from this host is a dead writer's: swept by the next run.
    std::fs::write(d.join("s.json"), spec).unwrap();
    let status = std::process::Command::new("timeout")
        .args([
            "--foreground",
            "-s",
            "KILL",
            "2",
            bin,
            "run",
            "s.json",
            "--shard",
            "2/2",
            "--threads",
            "1",
        ])
        .args(["--out", "shards/3", "-q"])
        .current_dir(d)
        .status()
        .unwrap();
    assert!(!status.success(), "the shard was to be stopped mid-run");
    assert_eq!(staging_of("3").len(), 1);
    std::fs::write(d.join("s.json"), &small).unwrap();
    ok(&workbench(
        d,
        &["run", "s.json", "--threads", "1", "--out", "shards/4", "-q"],
    ));
    assert!(staging_of("3").is_empty(), "{:?}", hidden(&d.join("shards")));
    assert_eq!(staging_of("2"), b);
}
