//! `workbench reproduce`: a folder of experiment files and render tables, each in turn, with a
//! line per file and one summary. The full regeneration of the shipped files takes minutes, so
//! these tests run small files; the shipped ones only through `--list`.

use crate::common::*;
use std::path::Path;

const TINY_A: &str = r#"{"name": "tiny-a", "integrands": ["cos3"],
  "estimators": [{"label": "MC", "method": "mc"}, {"label": "BMC", "method": "bmc"}],
  "samples": [8, 16], "trials": 20, "seed": 1,
  "checks": [{"better": "BMC", "than": "MC", "from_n": 16}]}"#;

const TINY_B: &str = r#"{"name": "tiny-b", "integrands": ["cos"],
  "estimators": [{"label": "MC", "method": "mc"}], "samples": [4, 8], "trials": 10, "seed": 2}"#;

const TINY_TABLE: &str = r#"{"name": "tiny-table", "width": 16, "height": 16, "spp": [4],
  "repetitions": 1, "variants": [{"label": "MC", "integrator": "mc"},
  {"label": "BMC", "integrator": "bmc", "gps": 1}]}"#;

/// A folder `exps/` whose file names sort the table first, so that the order seen is the
/// documented one (experiments by name, then tables) and not the names' alone.
fn folder(dir: &Path, files: &[(&str, &str)]) {
    std::fs::create_dir_all(dir.join("exps")).unwrap();
    for (name, text) in files {
        std::fs::write(dir.join("exps").join(name), text).unwrap();
    }
}

fn shipped_files() -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut names: Vec<String> = std::fs::read_dir(root.join("experiments"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".json"))
        .collect();
    names.sort();
    names
}

#[test]
fn list_shows_every_shipped_file_in_order_with_an_estimate_and_runs_nothing() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = tempfile::tempdir().unwrap();
    let results = out.path().join("results");
    let o = workbench(
        root,
        &["reproduce", "--list", "--results-dir", results.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let all_lines: Vec<&str> = text.lines().collect();
    // Without a data folder the files that read catalogue files are listed last as skipped,
    // with the reason; with one (as in CI) every file is planned.
    let (skips, lines): (Vec<&str>, Vec<&str>) = all_lines.iter().partition(|l| l.contains("  skip  "));
    let with_data = std::env::var_os("WORKBENCH_DATA").is_some_and(|d| !d.is_empty());
    let needs_data = [
        "irradiance-grace.json",
        "irradiance-pisa.json",
        "render-thesis-images.json",
        "render-thesis-table-4-1.json",
    ];
    if with_data {
        assert!(skips.is_empty(), "{text}");
    } else {
        assert_eq!(skips.len(), needs_data.len(), "{text}");
        for (line, name) in skips.iter().zip(needs_data) {
            assert!(
                line.contains(&format!("experiments/{name}")) && line.contains("no data folder is set"),
                "{line}"
            );
        }
    }
    let files: Vec<String> = shipped_files()
        .into_iter()
        .filter(|f| with_data || !needs_data.contains(&f.as_str()))
        .collect();
    assert_eq!(lines.len(), 1 + files.len(), "{text}");
    assert!(
        lines[0].starts_with(&format!("reproduce: {} files into ", files.len()))
            && lines[0].contains(" in all "),
        "{}",
        lines[0]
    );
    let listed: Vec<String> = lines[1..]
        .iter()
        .map(|l| {
            // Every shipped file has an estimate, so a new experiment gets one too.
            assert!(l.contains(" about ") && !l.contains("no estimate"), "{l}");
            let file = l.split_whitespace().nth(2).unwrap();
            file.strip_prefix("experiments/").unwrap().to_string()
        })
        .collect();
    let tables: Vec<&String> = files.iter().filter(|f| f.starts_with("render-")).collect();
    let mut expected: Vec<&String> = files.iter().filter(|f| !f.starts_with("render-")).collect();
    expected.extend(tables);
    assert_eq!(listed.iter().collect::<Vec<_>>(), expected);
    for l in &lines[1..] {
        let verb = l.split_whitespace().nth(1).unwrap();
        assert_eq!(verb == "render", l.contains("experiments/render-"), "{l}");
    }
    assert!(!results.exists(), "--list wrote {}", results.display());
}

#[test]
fn a_folder_runs_each_file_in_turn_with_one_summary_and_the_files_of_run_and_render() {
    let dir = tempfile::tempdir().unwrap();
    folder(
        dir.path(),
        &[
            ("a-table.json", TINY_TABLE),
            ("b.json", TINY_A),
            ("c.json", TINY_B),
            ("notes.txt", "not a spec"),
        ],
    );
    let o = workbench(dir.path(), &["reproduce", "exps", "--results-dir", "out", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    let progress: Vec<&str> = err.lines().filter(|l| l.starts_with('[')).collect();
    assert_eq!(progress.len(), 3, "{err}");
    for (line, expected) in progress.iter().zip([
        "[1/3] run exps/b.json → out/tiny-a (",
        "[2/3] run exps/c.json → out/tiny-b (",
        "[3/3] render exps/a-table.json → out/tiny-table (",
    ]) {
        assert!(line.starts_with(expected), "{line}");
        assert!(line.contains(" elapsed"), "{line}");
    }
    assert_eq!(
        err.lines()
            .filter(|l| l.trim_start().starts_with("done in "))
            .count(),
        3,
        "{err}"
    );
    assert!(
        err.contains("done in ") && err.contains(": 1 check passed"),
        "{err}"
    );
    let text = stdout(&o);
    assert!(text.starts_with("reproduced 3 files in "), "{text}");
    assert!(text.contains("every check passed (1)"), "{text}");

    // The same files as `run` and `render` write.
    for (name, file) in [
        ("tiny-a", "summary.csv"),
        ("tiny-b", "fits.csv"),
        ("tiny-table", "table.csv"),
    ] {
        assert!(
            dir.path().join("out").join(name).join(file).is_file(),
            "{name}/{file}"
        );
    }
    let o = workbench(dir.path(), &["run", "exps/b.json", "--out", "direct", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    for file in [
        "trials.csv",
        "summary.csv",
        "fits.csv",
        "manifest.json",
        "cos3.svg",
    ] {
        assert_eq!(
            std::fs::read(dir.path().join("out/tiny-a").join(file)).unwrap(),
            std::fs::read(dir.path().join("direct").join(file)).unwrap(),
            "{file} differs from run's"
        );
    }

    // A second plan takes its estimates from the timings the run left.
    let o = workbench(
        dir.path(),
        &["reproduce", "exps", "--results-dir", "out", "--list"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("(3 estimates from earlier runs' timings here"),
        "{text}"
    );
    assert_eq!(
        text.lines().filter(|l| l.ends_with("(here)")).count(),
        3,
        "{text}"
    );
}

#[test]
fn a_bad_file_stops_everything_before_the_first_run() {
    let dir = tempfile::tempdir().unwrap();
    let bad = TINY_B
        .replace("\"tiny-b\"", "\"bad\"")
        .replace("[4, 8]", "[4, 0]");
    folder(dir.path(), &[("b.json", TINY_A), ("z.json", &bad)]);
    let o = workbench(dir.path(), &["reproduce", "exps", "--results-dir", "out", "-q"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("Error: exps/z.json: samples[1]: N must be at least 1, got 0"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.path().join("out").exists(), "an output was written");

    // Two files writing one folder.
    let o = workbench(dir.path(), &["reproduce", "exps/b.json", "exps/b.json", "--list"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("as exps/b.json does"), "{}", stderr(&o));

    // A folder without spec files.
    std::fs::create_dir(dir.path().join("empty")).unwrap();
    let o = workbench(dir.path(), &["reproduce", "empty"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("empty: holds no *.json files"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn a_failed_check_lets_every_file_run_and_exits_1_with_its_report() {
    let dir = tempfile::tempdir().unwrap();
    let wrong = TINY_A.replace(
        r#""better": "BMC", "than": "MC""#,
        r#""better": "MC", "than": "BMC""#,
    );
    folder(dir.path(), &[("a.json", &wrong), ("b.json", TINY_B)]);
    let o = workbench(dir.path(), &["reproduce", "exps", "--results-dir", "out", "-q"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains(": 1 of 1 check FAILED"), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(text.contains("FAIL check MC < BMC"), "{text}");
    assert!(text.contains("checks failed in exps/a.json"), "{text}");
    for name in ["tiny-a", "tiny-b"] {
        assert!(
            dir.path().join("out").join(name).join("summary.csv").is_file(),
            "{name}"
        );
    }
}

/// Issue 30 item 6: a `*.json` of the folder that is a dangling symlink, a symlink loop or a
/// FIFO was skipped with exit 0 (less regenerated than asked, and nothing said); each is refused
/// by name, exit 2, before anything runs — given in a folder or by name (a FIFO read would wait
/// for a writer for ever).
#[test]
fn a_json_that_is_no_regular_file_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mkfifo = |p: &Path| {
        let status = std::process::Command::new("mkfifo").arg(p).status().unwrap();
        assert!(status.success());
    };
    // (file name, how to make it, what the refusal says)
    type Make = dyn Fn(&Path);
    let cases: [(&str, &Make, &str); 3] = [
        (
            "dangling.json",
            &|p: &Path| std::os::unix::fs::symlink("missing.json", p).unwrap(),
            "is a symlink to missing.json, which does not exist",
        ),
        (
            "loop.json",
            &|p: &Path| std::os::unix::fs::symlink("loop.json", p).unwrap(),
            "is a symlink loop",
        ),
        ("pipe.json", &mkfifo, "is a FIFO (named pipe)"),
    ];
    for (name, make, what) in cases {
        let exps = d.join(format!("exps-{name}"));
        std::fs::create_dir(&exps).unwrap();
        std::fs::write(exps.join("a.json"), TINY_A).unwrap();
        make(&exps.join(name));
        let folder = exps.file_name().unwrap().to_str().unwrap().to_string();
        for arg in [folder.clone(), format!("{folder}/{name}")] {
            let o = workbench(d, &["reproduce", &arg, "--results-dir", "out", "-q"]);
            let err = stderr(&o);
            assert_eq!(o.status.code(), Some(2), "{arg}: {err}");
            assert!(err.contains(&format!("{folder}/{name}: {what}")), "{arg}: {err}");
            assert!(!d.join("out").exists(), "{arg}: an output was written");
        }
    }
}

/// Issue 30 item 6: the estimate reused an earlier run's timings whatever that run's plan was
/// ("about 0.0 s" for an hours-long file). Timings count only for the same plan.
#[test]
fn the_time_estimate_comes_only_from_timings_of_the_same_plan() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    folder(d, &[("a.json", TINY_A)]);
    let o = workbench(d, &["reproduce", "exps", "--results-dir", "out", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let list = || {
        let o = workbench(d, &["reproduce", "exps", "--results-dir", "out", "--list"]);
        assert!(o.status.success(), "{}", stderr(&o));
        stdout(&o)
    };
    assert!(list().contains("(here)"), "{}", list());
    // The same name and folder, 1000 times the trials: the old seconds say nothing about it.
    std::fs::write(
        d.join("exps/a.json"),
        TINY_A.replace("\"trials\": 20", "\"trials\": 20000"),
    )
    .unwrap();
    let text = list();
    assert!(!text.contains("(here)") && text.contains("no estimate"), "{text}");
    // A shipped file's name with another plan gets no built-in estimate either.
    std::fs::write(d.join("exps/a.json"), TINY_A.replace("\"tiny-a\"", "\"cos3\"")).unwrap();
    let text = list();
    assert!(text.contains("no estimate"), "{text}");
}
