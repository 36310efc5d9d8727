//! Issue 31: the irradiance protocol sharded (units = rows of the grid of normals), merged and
//! resumed must end with the bytes of one run — every file but `timings.json`: irradiance.csv,
//! table.md, rms_vs_n.svg and its caption, exact.exr, manifest.json —; bad sets and flags are
//! refused in one line, exit 2, nothing merged. On synthetic maps (no data folder).

use crate::common::*;
use image::{ImageFormat, Rgb, Rgb32FImage};
use std::path::Path;
use std::process::Output;

fn write_map(path: &Path, w: u32, h: u32, f: impl Fn(u32, u32) -> [f32; 3]) {
    image::DynamicImage::ImageRgb32F(Rgb32FImage::from_fn(w, h, |x, y| Rgb(f(x, y))))
        .save_with_format(path, ImageFormat::OpenExr)
        .unwrap();
}

fn varied(x: u32, y: u32) -> [f32; 3] {
    [1.0 + (x * 7 % 5) as f32, 0.5 + y as f32, ((x + y) % 3) as f32]
}

/// A 12×6 grid (6 units of 12 normals), two N, every kind of estimator.
fn spec(seed: u64) -> String {
    format!(
        r#"{{ "kind": "irradiance", "name": "irr", "env": "v.exr", "grid": [12, 6], "n": [4, 16], "seed": {seed},
  "estimators": ["mc", "mc-cos", "bmc", "bmc-fitted"], "published": {{ "sh_l2": 0.5 }} }}"#
    )
}

/// A folder with the map and `irr.json`.
fn setup() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    write_map(&dir.path().join("v.exr"), 16, 8, varied);
    std::fs::write(dir.path().join("irr.json"), spec(3)).unwrap();
    dir
}

fn run(d: &Path, args: &[&str]) -> Output {
    let mut all = vec!["run", "-q"];
    all.extend(args);
    workbench(d, &all)
}

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", stderr(o));
}

/// Exit 2 with one line naming `what`.
fn refused(o: &Output, what: &str) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.contains(what), "{what:?} not in {err}");
}

/// Every file of `a` but timings.json is in `b` with the same bytes, and the other way round.
fn same_files(a: &Path, b: &Path) {
    let names = |d: &Path| {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .filter(|n| n != "timings.json")
            .collect();
        v.sort();
        v
    };
    let list = names(a);
    assert_eq!(list, names(b), "file lists");
    for want in [
        "irradiance.csv",
        "table.md",
        "exact.exr",
        "manifest.json",
        "rms_vs_n.svg",
    ] {
        assert!(list.contains(&want.to_string()), "{want} in {list:?}");
    }
    for n in list {
        assert!(
            std::fs::read(a.join(&n)).unwrap() == std::fs::read(b.join(&n)).unwrap(),
            "{n} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

/// One run on 1 thread and one on 2: the same bytes; then 1, 2, 3 and 4 shards (on 1 and 2
/// threads in turn, 4 shards of 6 units: two hold two units, two hold one) merged in reverse
/// order: the same bytes again, and the merge prints the run's table.
#[test]
fn irradiance_shards_merge_to_the_bytes_of_one_run_on_any_thread_count() {
    let dir = setup();
    let d = dir.path();
    ok(&run(d, &["irr.json", "--threads", "1", "--out", "one"]));
    ok(&run(d, &["irr.json", "--threads", "2", "--out", "two"]));
    same_files(&d.join("one"), &d.join("two"));
    assert!(!d.join("one/irradiance.partial.csv").exists());
    for count in 1..=4 {
        let mut shards = Vec::new();
        for index in 1..=count {
            let out = format!("shards/{count}-{index}");
            let threads = (1 + index % 2).to_string();
            let o = run(
                d,
                &[
                    "irr.json",
                    "--threads",
                    &threads,
                    "--shard",
                    &format!("{index}/{count}"),
                    "--out",
                    &out,
                ],
            );
            ok(&o);
            assert!(stdout(&o).is_empty(), "a shard has no table to print");
            shards.push(out);
        }
        let merged = format!("m{count}");
        let mut args = vec!["merge", merged.as_str(), "-q"];
        args.extend(shards.iter().rev().map(String::as_str));
        let o = workbench(d, &args);
        ok(&o);
        assert!(
            stdout(&o).contains("irr — RMS over the 12×6 grid"),
            "{}",
            stdout(&o)
        );
        same_files(&d.join("one"), &d.join(&merged));
    }
}

/// A log cut after two units and half a line, as a killed run leaves it: `--resume` reads those
/// units back and computes the rest — the same bytes as one run —, for a whole run and for a
/// shard; a log of another run (seed) is refused, in one line, and left in place.
#[test]
fn irradiance_runs_and_shards_resume_to_the_bytes_of_one_run() {
    let dir = setup();
    let d = dir.path();
    ok(&run(d, &["irr.json", "--out", "one"]));
    // The whole run's log: shard 1/1's units.csv is that log, finished.
    ok(&run(d, &["irr.json", "--shard", "1/1", "--out", "whole"]));
    let cut = |log: &str, units: usize| {
        let text = std::fs::read_to_string(d.join(log)).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let kept = 2 + units * 12;
        let mut cut: String = lines[..kept].iter().map(|l| format!("{l}\n")).collect();
        cut.push_str(&lines[kept][..20]);
        cut
    };
    std::fs::create_dir(d.join("r")).unwrap();
    std::fs::write(d.join("r/irradiance.partial.csv"), cut("whole/units.csv", 2)).unwrap();
    // Another seed: refused, the log kept.
    std::fs::write(d.join("seed4.json"), spec(4)).unwrap();
    refused(
        &run(d, &["seed4.json", "--out", "r", "--resume"]),
        "irradiance.partial.csv: was written for another run",
    );
    assert!(d.join("r/irradiance.partial.csv").is_file());
    let o = run(d, &["irr.json", "--out", "r", "--resume"]);
    ok(&o);
    assert!(stderr(&o).contains("resumed: 2 of 6 units"), "{}", stderr(&o));
    same_files(&d.join("one"), &d.join("r"));
    // A shard: 1/2 holds units 0, 2, 4; its log cut after one unit.
    for i in 1..=2 {
        ok(&run(
            d,
            &[
                "irr.json",
                "--shard",
                &format!("{i}/2"),
                "--out",
                &format!("s{i}"),
            ],
        ));
    }
    let log = cut("s1/units.csv", 1);
    std::fs::remove_dir_all(d.join("s1")).unwrap();
    std::fs::create_dir(d.join("s1")).unwrap();
    std::fs::write(d.join("s1/irradiance.partial.csv"), log).unwrap();
    refused(
        &run(d, &["irr.json", "--shard", "1/3", "--out", "s1", "--resume"]),
        "was written for another run",
    );
    let o = run(d, &["irr.json", "--shard", "1/2", "--out", "s1", "--resume"]);
    ok(&o);
    assert!(stderr(&o).contains("resumed: 1 of 3 units"), "{}", stderr(&o));
    ok(&workbench(d, &["merge", "m", "-q", "s1", "s2"]));
    same_files(&d.join("one"), &d.join("m"));
}

/// Shards of another seed, of another map under the same name, of another shard count, a
/// missing, a repeated and a half-written shard, an experiment's shard among them, and
/// `--shard 0/4`, `--shard 5/4`, `--trials`: exit 2, one line, nothing merged or written.
#[test]
fn irradiance_merge_and_shard_flags_refuse_bad_input_before_writing() {
    let dir = setup();
    let d = dir.path();
    let shard = |file: &str, s: &str, out: &str| ok(&run(d, &[file, "--shard", s, "--out", out]));
    shard("irr.json", "1/2", "a1");
    shard("irr.json", "2/2", "a2");
    std::fs::write(d.join("seed4.json"), spec(4)).unwrap();
    shard("seed4.json", "2/2", "seed");
    shard("irr.json", "2/3", "three");
    // The same file name, another map.
    std::fs::rename(d.join("v.exr"), d.join("v.keep")).unwrap();
    write_map(&d.join("v.exr"), 16, 8, |x, y| varied(y, x));
    shard("irr.json", "2/2", "map");
    std::fs::rename(d.join("v.keep"), d.join("v.exr")).unwrap();
    // Half-written: a units.csv cut in its last line.
    std::fs::create_dir(d.join("half")).unwrap();
    for f in std::fs::read_dir(d.join("a2")).unwrap() {
        let f = f.unwrap();
        std::fs::copy(f.path(), d.join("half").join(f.file_name())).unwrap();
    }
    let units = std::fs::read_to_string(d.join("a2/units.csv")).unwrap();
    std::fs::write(d.join("half/units.csv"), &units[..units.len() - 30]).unwrap();
    // An experiment's shard.
    std::fs::write(
        d.join("exp.json"),
        r#"{"name": "e", "integrands": ["cos"], "estimators": [{"label": "MC", "method": "mc"}],
            "samples": [4], "trials": 4, "seed": 1}"#,
    )
    .unwrap();
    shard("exp.json", "2/2", "exp");
    let merge = |dirs: &[&str]| {
        let mut args = vec!["merge", "out", "-q"];
        args.extend(dirs);
        workbench(d, &args)
    };
    for (dirs, what) in [
        (vec!["a1", "seed"], "different runs (seeds 3 and 4)"),
        (vec!["a1", "map"], "different runs (plans"),
        (vec!["a1", "three"], "shard counts 1/2 and 2/3"),
        (vec!["a1"], "shard 2/2 missing"),
        (vec!["a1", "a2", "a2"], "are both shard 2/2"),
        (vec!["a1", "half"], "ends before its last unit"),
        (
            vec!["a1", "exp"],
            "a1 is a shard of an irradiance protocol and exp a shard of an experiment",
        ),
    ] {
        refused(&merge(&dirs), what);
        assert!(!d.join("out").exists(), "{dirs:?} merged something");
    }
    for (args, what) in [
        (
            vec!["--shard", "0/4"],
            "--shard: \"0/4\": shards are numbered 1 to 4",
        ),
        (
            vec!["--shard", "5/4"],
            "--shard: \"5/4\": shards are numbered 1 to 4",
        ),
        (
            vec!["--trials", "3"],
            "--trials: does not apply to an irradiance protocol file",
        ),
    ] {
        let mut all = vec!["irr.json", "--out", "bad"];
        all.extend(args);
        refused(&run(d, &all), what);
        assert!(!d.join("bad").exists());
    }
    ok(&merge(&["a2", "a1"]));
}
