//! `workbench reproduce`: every experiment file and render table of a folder (by default the
//! shipped `experiments/`), one after another, into `results/` — the whole regeneration in one
//! command, with a time estimate up front, a line per file and one summary at the end.
//!
//! Order: each path in the order given; a folder gives its experiment files by file name, then
//! its render tables by file name (the tables take longest and share the reference cache).

use super::output::{status, stdout};
use super::progress::Bar;
use super::run::print_run_warnings;
use anyhow::Context;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;
use workbench::error::InputError;
use workbench::experiment as ex;
use workbench::files::spec_json::{self, SpecKind};
use workbench::table::{self, TablePlan};

#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:\n  \
    workbench reproduce --list                      (the plan and its time estimate; runs nothing)\n  \
    workbench reproduce                             (every file of experiments/ into results/)\n  \
    workbench reproduce experiments/cos3.json experiments/render-table.json\n  \
    workbench reproduce my-experiments/ --results-dir /tmp/results -q\n\n\
    A folder gives its experiment files by file name, then its render tables by file name. Every \
    file is validated before the first one runs; a *.json that is not a regular file (a dangling \
    symlink, a symlink loop, a FIFO, a device) is refused by name. Estimates come from an earlier \
    run's timings of the same plan in the output folder where there are some, else, for a shipped \
    file as shipped, from a table measured on a 2-core machine.\n\n\
    Exit codes: 0 every file ran and every check passed; 1 a check failed (every file still ran \
    and wrote its outputs); 2 any error (bad input before anything runs; a failure while running \
    stops at that file, naming it, and keeps the outputs of the files before it).")]
pub struct ReproduceArgs {
    /// Experiment files, render-table files or folders of them [default: experiments].
    paths: Vec<PathBuf>,
    /// Where the outputs go: <dir>/<name>/ for every file, and the render tables' reference
    /// cache <dir>/cache/ [default: results].
    #[arg(long)]
    results_dir: Option<PathBuf>,
    /// Worker threads, 1 to 256 [default: one per core]. Results do not depend on it.
    #[arg(long, value_parser = super::usage::parse_threads)]
    threads: Option<usize>,
    /// Print the files in order with their outputs and time estimates, and run nothing.
    #[arg(long)]
    list: bool,
    /// No progress bars (the line per file and the summary are still printed).
    #[arg(long, short)]
    quiet: bool,
}

/// Wall-clock seconds each shipped file took on this project's 2-core machine on 2026-11-25
/// while other builds and render tables shared it (load average 5–10, so they overstate an idle
/// machine's times), by the name of its output folder and the hash of its plan
/// ([`ex::job::plan_hash`], [`table::export::plan_hash`]): the estimate for a file whose
/// output folder holds no timings of an earlier run of the same plan. Only the shipped plan gets
/// it (issue 30: a file of the same name with other trials or N got "about 1.4 s" for hours); a
/// test lists the shipped files and fails when one has no estimate, i.e. when its plan (or the
/// plan's JSON form) changed and the hash here must follow.
const MEASURED: &[(&str, &str, f64)] = &[
    ("adaptive", "298442784c9af9ef", 210.0),
    ("calibration", "323d9d52ff4cb6dc", 13.0),
    ("cos", "4a3445482a8ab423", 2.6),
    ("cos2", "a1daf28dd015f3c6", 2.6),
    ("cos3-designs", "97c5a9457a7023df", 8.9),
    ("cos3-thesis-kernel-mean", "993ddf34a8f79d5c", 56.0),
    ("cos3", "7441f968e91e9cbf", 1.4),
    // Four envmap integrands under Pisa and Park (truths by the texel sum), 13 estimators (5 of
    // them bq-pss) × 3 N × 100 trials; 2026-12-02, 1.6 s on 2 threads, the machine shared by 5 helpers.
    ("envmap-vs-renderers", "1791113eb8ca86ac", 1.6),
    ("glossy", "632cf3cccbbbc598", 2.9),
    // Probulator's irradiance protocol on a 256×128 map, every estimator and N (about 80 s of
    // CPU each); 2026-11-27, the machine shared (load average ≈ 12).
    ("irradiance-grace", "cdefaa95a87baa28", 285.0),
    ("irradiance-pisa", "44232ee79130932e", 167.0),
    ("learned-kernel", "ea110df5a06e4e99", 87.0),
    ("lights", "72d6ef159ac2503b", 2.8),
    ("pixels", "71e6a39cf4560e62", 3.6),
    ("render-adaptive", "112b9c7dcc882fec", 174.0),
    // The real-light tables (128×128, exact reference under a 1024×512 map, 120 renders):
    // 110–155 s of CPU each, 2026-11-27 on the shared machine; the estimate is half of it.
    ("real-light-integrands", "4bf3342bfb204059", 3.0),
    ("real-light-thesis-forest", "d76c4ac125800558", 78.0),
    ("real-light-thesis-park", "7b60afda70f668ea", 75.0),
    ("real-light-thesis-pisa", "3e10939690e8e6b3", 77.0),
    ("real-light-thesis-studio", "6400e1d16396b8bc", 76.0),
    ("real-light-workbench-forest", "b8f7c9e34af28959", 60.0),
    ("real-light-workbench-park", "b437035229f8a5a9", 56.0),
    ("real-light-workbench-park-clamped", "f20504fe83e907af", 60.0),
    ("real-light-workbench-pisa", "bddcca7cedfeb918", 58.0),
    ("real-light-workbench-studio", "3373720443fcbb63", 61.0),
    ("render-table", "9f441aeb230a527c", 313.0),
    ("rings", "75fdd1903622f6f1", 1.9),
    // The exact reference under a 1024×512 map (about 950 s of CPU, 8 min on the idle 2 cores)
    // plus 200 renders (6 min 20 s, reference cached); 2026-11-27, the machine shared.
    ("thesis-images", "f9e7fc339178b8ba", 860.0),
    // The exact reference under Pisa (about 860 s of CPU) plus 120 renders (3 min 40 s).
    ("thesis-table-4-1", "353c191c83777ada", 650.0),
    // The renderer's baselines and bq-pss against BMC (issue 40.4), 48×48 tables, exact
    // reference included; 2026-12-02, the machine nearly idle (load average ≈ 1).
    ("vs-renderers-thesis-archi", "ce896ac8c0912b48", 5.2),
    ("vs-renderers-thesis-forest", "cc12a765cfd83823", 5.7),
    ("vs-renderers-thesis-grace", "27fa9833a726b00a", 2.4),
    ("vs-renderers-thesis-park", "0717e949d687fa83", 5.0),
    ("vs-renderers-thesis-pisa", "38706c55859e4698", 4.6),
    ("vs-renderers-thesis-sky", "6ca5da810dd9ca32", 5.5),
    ("vs-renderers-thesis-studio", "57562926a01b60d3", 4.9),
    ("vs-renderers-workbench-archi", "5ff7fd7694e4beb7", 3.6),
    ("vs-renderers-workbench-forest", "a465095dd9b6a9c2", 4.3),
    ("vs-renderers-workbench-grace", "237f939ecc946aeb", 1.8),
    ("vs-renderers-workbench-park", "c75cb3d4f614f878", 3.8),
    ("vs-renderers-workbench-pisa", "60c299651a58ed25", 3.5),
    ("vs-renderers-workbench-sky", "9713e22b64a44b8f", 4.0),
    ("vs-renderers-workbench-studio", "37a1fdaf7d3337b0", 4.0),
];

enum Job {
    Experiment(Box<ex::plan::Plan>),
    Table(Box<TablePlan>),
    Irradiance(Box<workbench::irradiance::IrradiancePlan>),
}

struct Item {
    file: PathBuf,
    job: Job,
    out: PathBuf,
    estimate: Option<Estimate>,
}

#[derive(Clone, Copy)]
struct Estimate {
    seconds: f64,
    /// From the output folder's own timings (an earlier run here), not the built-in table.
    here: bool,
}

impl Item {
    fn verb(&self) -> &'static str {
        match self.job {
            Job::Experiment(_) | Job::Irradiance(_) => "run",
            Job::Table(_) => "render",
        }
    }
}

pub fn reproduce(args: ReproduceArgs) -> anyhow::Result<ExitCode> {
    if let Some(t) = args.threads {
        workbench::util::threads::check_threads(t, "--threads")?;
    }
    let results = args
        .results_dir
        .clone()
        .unwrap_or_else(|| PathBuf::from("results"));
    let paths = if args.paths.is_empty() {
        vec![PathBuf::from("experiments")]
    } else {
        args.paths.clone()
    };
    let (items, skipped) = plan(&paths, &results, args.threads)?;
    let total = items
        .iter()
        .filter_map(|i| i.estimate)
        .fold(0.0, |t, e| t + e.seconds);
    if args.list {
        let mut text = list(&items, &results, total);
        for (file, why) in &skipped {
            text.push_str(&format!("  -  skip   {}  ({why})\n", file.display()));
        }
        stdout(&text)?;
        return Ok(ExitCode::SUCCESS);
    }
    status!("reproduce: {}", headline(&items, &results, total));
    for (file, why) in &skipped {
        status!("reproduce: skipping {} ({why})", file.display());
    }
    let start = Instant::now();
    let mut done = Vec::with_capacity(items.len());
    let mut estimated_done = 0.0;
    for (k, item) in items.iter().enumerate() {
        let elapsed = start.elapsed().as_secs_f64();
        let to_go = (total - estimated_done).max(0.0);
        status!(
            "[{}/{}] {} {} → {} ({}; {} elapsed{})",
            k + 1,
            items.len(),
            item.verb(),
            item.file.display(),
            item.out.display(),
            item.estimate.map_or("no estimate".to_string(), |e| format!(
                "about {}",
                duration(e.seconds)
            )),
            duration(elapsed),
            if total > 0.0 {
                format!(", about {} to go", duration(to_go))
            } else {
                String::new()
            }
        );
        let item_start = Instant::now();
        let outcome = run_item(item, &results, args.threads, args.quiet).with_context(|| {
            format!(
                "reproduce stopped at {} ({} of {}; the outputs of the files before it are written)",
                item.file.display(),
                k + 1,
                items.len()
            )
        })?;
        let seconds = item_start.elapsed().as_secs_f64();
        status!("        done in {}{}", duration(seconds), outcome.checks_phrase());
        estimated_done += item.estimate.map_or(0.0, |e| e.seconds);
        done.push((item, seconds, outcome));
    }
    let failed = done.iter().filter(|(_, _, o)| o.failed > 0).count();
    stdout(&summary(&done, start.elapsed().as_secs_f64(), total))?;
    Ok(if failed > 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

/// A file found in a folder (not named) that reads a catalogue file while no data folder is set:
/// why it is skipped. Named files are validated, and refused, as usual.
fn needs_data(text: &str) -> Option<String> {
    fn names(v: &serde_json::Value, out: &mut Vec<String>) {
        match v {
            serde_json::Value::String(s)
                if workbench::data::catalog::find(s).is_some() && !Path::new(s).exists() =>
            {
                out.push(s.clone())
            }
            serde_json::Value::Array(a) => a.iter().for_each(|x| names(x, out)),
            serde_json::Value::Object(o) => o.values().for_each(|x| names(x, out)),
            _ => {}
        }
    }
    if !matches!(workbench::data::folder(), Ok(None)) {
        return None;
    }
    let mut found = Vec::new();
    names(&serde_json::from_str(text).ok()?, &mut found);
    let first = found.first()?;
    Some(format!(
        "it reads the catalogue's `{first}` and no data folder is set: pass --data DIR or set WORKBENCH_DATA; \
         docs/guide/data.md"
    ))
}

/// A file of a folder skipped for want of the data folder, and why.
type Skipped = (PathBuf, String);

/// The files in order, each validated, with its output folder and estimate; and the files of
/// a folder skipped for want of the data folder, with the reason.
fn plan(
    paths: &[PathBuf],
    results: &Path,
    threads: Option<usize>,
) -> anyhow::Result<(Vec<Item>, Vec<Skipped>)> {
    let mut files = Vec::new();
    let mut skipped = Vec::new();
    for path in paths {
        if path.is_dir() {
            for file in folder_files(path)? {
                let text = spec_json::read_spec(&file).unwrap_or_default();
                match needs_data(&text) {
                    Some(why) => skipped.push((file, why)),
                    None => files.push(file),
                }
            }
        } else {
            regular_file(path)?;
            files.push(path.clone());
        }
    }
    let mut items: Vec<Item> = Vec::with_capacity(files.len());
    for file in files {
        let text = spec_json::read_spec(&file).unwrap_or_default();
        let (job, out) = match spec_json::spec_kind(&text) {
            Some(SpecKind::RenderTable) => {
                let plan = table::load(&file)?;
                let out = table::output_dir(results, &plan);
                (Job::Table(Box::new(plan)), out)
            }
            Some(SpecKind::Irradiance) => {
                let plan = workbench::irradiance::load(&file)?;
                let out = results.join(&plan.name);
                (Job::Irradiance(Box::new(plan)), out)
            }
            // Anything else, unreadable files included, gets the experiment's messages.
            _ => {
                let plan = ex::load_plan(
                    &file,
                    &ex::Overrides {
                        threads,
                        names: super::output::JOB_FLAGS,
                        ..Default::default()
                    },
                )?;
                let out = results.join(&plan.name);
                (Job::Experiment(Box::new(plan)), out)
            }
        };
        if let Some(other) = items.iter().find(|i| i.out == out) {
            return Err(InputError::new(format!(
                "{}: writes {}, as {} does; give one of them",
                file.display(),
                out.display(),
                other.file.display()
            ))
            .into());
        }
        let estimate = estimate(&job, &out);
        items.push(Item {
            file,
            job,
            out,
            estimate,
        });
    }
    Ok((items, skipped))
}

/// A folder's `*.json` files: experiment files by file name, then render tables by file name.
fn folder_files(dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let entries = std::fs::read_dir(dir).with_context(|| format!("reading the folder {}", dir.display()))?;
    let mut files = Vec::new();
    for entry in entries {
        let path = entry
            .with_context(|| format!("reading the folder {}", dir.display()))?
            .path();
        // Every *.json is refused unless it is a regular file (or a symlink to one): skipping a
        // dangling symlink, a loop or a FIFO would regenerate less than asked and say nothing,
        // and reading a FIFO would wait for a writer.
        if path.extension().is_some_and(|e| e == "json") {
            regular_file(&path)?;
            files.push(path);
        }
    }
    if files.is_empty() {
        return Err(InputError::new(format!(
            "{}: holds no *.json files (experiment files or render tables)",
            dir.display()
        ))
        .into());
    }
    files.sort();
    let is_table = |p: &PathBuf| {
        spec_json::read_spec(p)
            .ok()
            .and_then(|t| spec_json::spec_kind(&t))
            == Some(SpecKind::RenderTable)
    };
    // A stable sort keeps the file names' order within each kind.
    files.sort_by_key(is_table);
    Ok(files)
}

/// Refuses, by name, a file given to `reproduce` that is not a regular file once symlinks are
/// followed: a dangling symlink, a symlink loop, a folder, a FIFO, a device or a socket.
fn regular_file(path: &Path) -> Result<(), InputError> {
    let refuse = |what: String| {
        Err(InputError::new(format!(
            "{}: {what}; reproduce reads experiment files and render tables, which are regular files",
            path.display()
        )))
    };
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() => Ok(()),
        Ok(m) => {
            use std::os::unix::fs::FileTypeExt;
            let t = m.file_type();
            let kind = if t.is_dir() {
                "a folder"
            } else if t.is_fifo() {
                "a FIFO (named pipe)"
            } else if t.is_socket() {
                "a socket"
            } else if t.is_block_device() || t.is_char_device() {
                "a device"
            } else {
                "not a regular file"
            };
            refuse(format!("is {kind}"))
        }
        Err(e) => match std::fs::symlink_metadata(path) {
            Ok(l) if l.file_type().is_symlink() => {
                if e.raw_os_error() == Some(40) {
                    // ELOOP
                    refuse("is a symlink loop".into())
                } else {
                    let target = std::fs::read_link(path).map_or("?".into(), |t| t.display().to_string());
                    refuse(format!("is a symlink to {target}, which does not exist ({e})"))
                }
            }
            _ => refuse(format!("cannot be read ({e})")),
        },
    }
}

/// The seconds an earlier run of the same plan wrote into the output folder (`timings.json` of
/// an experiment, the per-render `timings.csv` of a table, with the plan's hash in
/// `timings.json`), else the built-in measurement of a shipped file as shipped.
fn estimate(job: &Job, out: &Path) -> Option<Estimate> {
    let hash = match job {
        Job::Experiment(p) => ex::job::plan_hash(p),
        Job::Table(p) => table::export::plan_hash(p),
        Job::Irradiance(p) => workbench::irradiance::plan_hash(p),
    };
    let timings = std::fs::read(out.join("timings.json"))
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        .filter(|v| v["plan_hash"].as_str() == Some(hash.as_str()));
    let here = timings.and_then(|timings| match job {
        Job::Experiment(_) | Job::Irradiance(_) => timings["wall_seconds"].as_f64(),
        Job::Table(_) => std::fs::read_to_string(out.join("timings.csv"))
            .ok()
            .and_then(|t| {
                let seconds: Option<Vec<f64>> = t
                    .lines()
                    .skip(1)
                    .map(|l| l.rsplit(',').next().and_then(|s| s.parse().ok()))
                    .collect();
                seconds.map(|s| s.iter().sum())
            }),
    });
    let name = match job {
        Job::Experiment(p) => &p.name,
        Job::Table(p) => &p.name,
        Job::Irradiance(p) => &p.name,
    };
    here.filter(|s| s.is_finite() && *s >= 0.0)
        .map(|seconds| Estimate { seconds, here: true })
        .or_else(|| {
            MEASURED
                .iter()
                .find(|(n, h, _)| n == name && *h == hash)
                .map(|&(_, _, seconds)| Estimate { seconds, here: false })
        })
}

fn headline(items: &[Item], results: &Path, total: f64) -> String {
    let unknown = items.iter().filter(|i| i.estimate.is_none()).count();
    let here = items
        .iter()
        .filter(|i| i.estimate.is_some_and(|e| e.here))
        .count();
    let files = |n: usize| format!("{n} file{}", if n == 1 { "" } else { "s" });
    let mut s = format!("{} into {}, ", files(items.len()), results.display());
    if unknown == items.len() {
        s.push_str("no time estimate (no earlier timings here, none built in)");
        return s;
    }
    s.push_str(&format!("about {} in all", duration(total)));
    if unknown > 0 {
        s.push_str(&format!(" plus {} without an estimate", files(unknown)));
    }
    s.push_str(&format!(
        " ({here} estimate{} from earlier runs' timings here, {} measured on a 2-core machine)",
        if here == 1 { "" } else { "s" },
        items.len() - unknown - here
    ));
    s
}

fn list(items: &[Item], results: &Path, total: f64) -> String {
    let width = items
        .iter()
        .map(|i| i.file.display().to_string().chars().count())
        .max()
        .unwrap_or(0);
    let out_width = items
        .iter()
        .map(|i| i.out.display().to_string().chars().count())
        .max()
        .unwrap_or(0);
    let mut s = format!("reproduce: {}\n", headline(items, results, total));
    for (k, item) in items.iter().enumerate() {
        let file = item.file.display().to_string();
        let out = item.out.display().to_string();
        s.push_str(&format!(
            "{:>3}. {:<6} {file}{} → {out}{}  {}\n",
            k + 1,
            item.verb(),
            " ".repeat(width - file.chars().count()),
            " ".repeat(out_width - out.chars().count()),
            match item.estimate {
                Some(e) => format!(
                    "about {}{}",
                    duration(e.seconds),
                    if e.here { " (here)" } else { "" }
                ),
                None => "no estimate".to_string(),
            }
        ));
    }
    s
}

/// What one file's run came to.
struct Outcome {
    checks: usize,
    failed: usize,
    /// The run's report, kept to be printed in full when one of its checks failed.
    report: Option<String>,
}

impl Outcome {
    fn checks_phrase(&self) -> String {
        match (self.checks, self.failed) {
            (0, _) => String::new(),
            (n, 0) => format!(": {n} check{} passed", if n == 1 { "" } else { "s" }),
            (n, f) => format!(": {f} of {n} check{} FAILED", if n == 1 { "" } else { "s" }),
        }
    }
}

fn run_item(item: &Item, results: &Path, threads: Option<usize>, quiet: bool) -> anyhow::Result<Outcome> {
    match &item.job {
        Job::Experiment(plan) => {
            let overrides = ex::Overrides {
                out: Some(item.out.clone()),
                threads,
                spec: Some(item.file.clone()),
                names: super::output::JOB_FLAGS,
                ..Default::default()
            };
            for w in plan.models.iter().filter_map(|m| m.accuracy_warning()) {
                status!("warning: {w}");
            }
            let report = ex::run_plan(plan, &overrides, &Bar::new(quiet))?;
            print_run_warnings(&report);
            let passed = report.checks.iter().map(|c| c.passed());
            let passed = passed
                .chain(report.calibration.iter().map(|c| c.passed()))
                .chain(report.tolerance_checks.iter().map(|c| c.passed()));
            let (checks, failed) = passed.fold((0, 0), |(n, f), p| (n + 1, f + usize::from(!p)));
            let text = (failed > 0).then(|| {
                ex::format_report(plan, &report)
                    + &ex::adaptive::format_report(plan, &report.stopping, &report.tolerance_checks)
            });
            Ok(Outcome {
                checks,
                failed,
                report: text,
            })
        }
        Job::Irradiance(plan) => {
            let report = workbench::irradiance::run(
                plan,
                &item.out,
                Some(&item.file),
                threads,
                false,
                &super::output::JOB_FLAGS,
                &Bar::new(quiet),
            )?;
            if !quiet {
                stdout(&workbench::irradiance::export::summary(plan, &report.rows))?;
            }
            Ok(Outcome {
                checks: 0,
                failed: 0,
                report: None,
            })
        }
        Job::Table(plan) => {
            if let Some(w) = plan.model.as_ref().and_then(|m| m.accuracy_warning()) {
                status!("warning: {w}");
            }
            let pool = workbench::util::threads::pool(threads)?;
            pool.install(|| table::run(plan, results, false, &super::output::JOB_FLAGS, &Bar::new(quiet)))?;
            Ok(Outcome {
                checks: 0,
                failed: 0,
                report: None,
            })
        }
    }
}

fn summary(done: &[(&Item, f64, Outcome)], seconds: f64, estimated: f64) -> String {
    let mut s = String::new();
    for (item, _, outcome) in done {
        if let Some(report) = &outcome.report {
            s.push_str(&format!("{}:{report}\n", item.file.display()));
        }
    }
    s.push_str(&format!(
        "reproduced {} file{} in {}{}:\n",
        done.len(),
        if done.len() == 1 { "" } else { "s" },
        duration(seconds),
        if estimated > 0.0 {
            format!(" (estimated {})", duration(estimated))
        } else {
            String::new()
        }
    ));
    let width = done
        .iter()
        .map(|(i, _, _)| i.out.display().to_string().chars().count())
        .max()
        .unwrap_or(0);
    for (item, seconds, outcome) in done {
        let out = item.out.display().to_string();
        s.push_str(&format!(
            "  {out}{}  {:>10}{}\n",
            " ".repeat(width - out.chars().count()),
            duration(*seconds),
            outcome.checks_phrase().replacen(':', "  ", 1)
        ));
    }
    let checks: usize = done.iter().map(|(_, _, o)| o.checks).sum();
    let failed: Vec<String> = done
        .iter()
        .filter(|(_, _, o)| o.failed > 0)
        .map(|(i, _, _)| i.file.display().to_string())
        .collect();
    if failed.is_empty() {
        s.push_str(&format!("every check passed ({checks})\n"));
    } else {
        s.push_str(&format!(
            "checks failed in {} (their reports are above; every output was written)\n",
            failed.join(", ")
        ));
    }
    s
}

/// `0.4 s`, `25 s`, `3 min 05 s`, `1 h 02 min`.
fn duration(seconds: f64) -> String {
    if seconds < 9.95 {
        format!("{seconds:.1} s")
    } else if seconds < 59.5 {
        format!("{seconds:.0} s")
    } else if seconds < 3600.0 {
        let s = seconds.round() as u64;
        format!("{} min {:02} s", s / 60, s % 60)
    } else {
        let m = (seconds / 60.0).round() as u64;
        format!("{} h {:02} min", m / 60, m % 60)
    }
}

#[cfg(test)]
mod tests {
    use super::duration;

    #[test]
    fn durations_read_as_people_write_them() {
        assert_eq!(duration(0.04), "0.0 s");
        assert_eq!(duration(9.94), "9.9 s");
        assert_eq!(duration(9.96), "10 s");
        assert_eq!(duration(25.4), "25 s");
        assert_eq!(duration(59.7), "1 min 00 s");
        assert_eq!(duration(185.0), "3 min 05 s");
        assert_eq!(duration(3725.0), "1 h 02 min");
    }
}
