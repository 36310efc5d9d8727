//! `workbench run` and `workbench validate`.

use super::output::{resumed, status, stdout, wrote};
use super::progress::Bar;
use std::path::PathBuf;
use std::process::ExitCode;
use workbench::experiment as ex;
use workbench::files::spec_json::SpecKind;

#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:\n  \
    workbench run experiments/cos3.json\n  \
    workbench run experiments/cos3.json --trials 50 --out /tmp/cos3 -q\n  \
    workbench run experiments/cos3.json --shard 2/4 --out shards/2   (then: workbench merge OUT shards/*)\n  \
    workbench run experiments/cos3.json --resume                       (after an interrupted run)\n\n\
    The fields of experiment files are documented in docs/guide/run.md (\"Experiment files\").\n\n\
    Exit codes: 0 every check passed; 1 a check failed (outputs are still written); 2 any error \
    (bad input, I/O), before anything is written for bad input.")]
pub struct RunArgs {
    /// The experiment file (JSON).
    file: PathBuf,
    /// Output folder [default: results/<name>/].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Override the number of trials.
    #[arg(long)]
    trials: Option<u64>,
    /// Worker threads, 1 to 256 [default: one per core]. Results do not depend on it.
    #[arg(long, value_parser = super::usage::parse_threads)]
    threads: Option<usize>,
    /// Run only shard i of n (1 <= i <= n) of the units — (N, trial) pairs; for an irradiance
    /// file, rows of the grid of normals — into a shard folder for `workbench merge`
    /// [default --out: results/<name>-shard-<i>-of-<n>/].
    #[arg(long, value_name = "i/n", allow_hyphen_values = true)]
    shard: Option<String>,
    /// Continue an interrupted run (or shard) from the units its folder's log holds
    /// (trials.partial.csv; irradiance.partial.csv for an irradiance file).
    #[arg(long)]
    resume: bool,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:\n  \
    workbench validate experiments/cos3.json\n  \
    workbench validate experiments/render-table.json\n\n\
    Exit codes: 0 the file is valid; 2 it is not (one line naming the file, field and value).")]
pub struct ValidateArgs {
    /// An experiment file or a render-table file (JSON).
    file: PathBuf,
}

pub fn run(args: RunArgs) -> anyhow::Result<ExitCode> {
    // One check for every kind of file, before anything is read or written.
    if let Some(t) = args.threads {
        workbench::util::threads::check_threads(t, "--threads")?;
    }
    let text = workbench::files::spec_json::read_spec(&args.file).unwrap_or_default();
    if workbench::files::spec_json::spec_kind(&text) == Some(SpecKind::Irradiance) {
        return run_irradiance(args);
    }
    let shard = shard_option(args.shard.as_deref())?;
    let overrides = ex::Overrides {
        out: args.out,
        trials: args.trials,
        threads: args.threads,
        spec: Some(args.file.clone()),
        shard,
        resume: args.resume,
        names: super::output::JOB_FLAGS,
    };
    let plan = ex::load_plan(&args.file, &overrides)?;
    for w in plan.models.iter().filter_map(|m| m.accuracy_warning()) {
        status!("warning: {w}");
    }
    let report = ex::run_plan(&plan, &overrides, &Bar::new(args.quiet))?;
    print_run_warnings(&report);
    if shard.is_some() {
        wrote(
            Some(&report.shard),
            &report.out_dir,
            report.wall_seconds,
            report.threads,
        );
        return Ok(ExitCode::SUCCESS);
    }
    stdout(&ex::format_report(&plan, &report))?;
    stdout(&ex::adaptive::format_report(
        &plan,
        &report.stopping,
        &report.tolerance_checks,
    ))?;
    wrote(None, &report.out_dir, report.wall_seconds, report.threads);
    let failed = report.checks.iter().any(|c| !c.passed())
        || report.calibration.iter().any(|c| !c.passed())
        || report.tolerance_checks.iter().any(|c| !c.passed());
    Ok(if failed {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

pub fn validate(args: &ValidateArgs) -> anyhow::Result<ExitCode> {
    let text = workbench::files::spec_json::read_spec(&args.file).unwrap_or_default();
    match workbench::files::spec_json::spec_kind(&text) {
        Some(SpecKind::RenderTable) => {
            let plan = workbench::table::load(&args.file)?;
            stdout(&workbench::table::describe(&plan))?;
        }
        Some(SpecKind::Irradiance) => {
            let plan = workbench::irradiance::load(&args.file)?;
            stdout(&workbench::irradiance::describe(&plan))?;
        }
        // Anything else, unreadable files included, gets the experiment's messages.
        _ => {
            let plan = ex::load_plan(&args.file, &Default::default())?;
            stdout(&ex::describe(&plan))?;
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// `workbench run` of an irradiance protocol file (`"kind": "irradiance"`): into `--out` or
/// `results/<name>/`, or with `--shard i/n` into a shard folder; `--resume` continues from the
/// log an interrupted run (or shard) left; `--trials` does not apply.
fn run_irradiance(args: RunArgs) -> anyhow::Result<ExitCode> {
    if args.trials.is_some() {
        return Err(workbench::InputError::new(format!(
            "--trials: does not apply to an irradiance protocol file ({})",
            args.file.display()
        ))
        .into());
    }
    let shard = shard_option(args.shard.as_deref())?;
    let plan = workbench::irradiance::load(&args.file)?;
    if let Some(shard) = shard {
        let out = args.out.clone().unwrap_or_else(|| {
            workbench::irradiance::shard::default_out(std::path::Path::new("results"), &plan, shard)
        });
        let report = workbench::irradiance::shard::run_shard(
            &plan,
            &args.file,
            shard,
            &out,
            args.threads,
            args.resume,
            &super::output::JOB_FLAGS,
            &Bar::new(args.quiet),
        )?;
        resumed(report.resumed, report.units);
        wrote(Some(&shard), &report.out_dir, report.wall_seconds, report.threads);
        return Ok(ExitCode::SUCCESS);
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("results").join(&plan.name));
    let report = workbench::irradiance::run(
        &plan,
        &out,
        Some(&args.file),
        args.threads,
        args.resume,
        &super::output::JOB_FLAGS,
        &Bar::new(args.quiet),
    )?;
    resumed(report.resumed, plan.height);
    stdout(&workbench::irradiance::export::summary(&plan, &report.rows))?;
    wrote(None, &report.out_dir, report.wall_seconds, report.threads);
    Ok(ExitCode::SUCCESS)
}

/// The status lines every run prints after its units: what a resume found, and the weight
/// sets' numerical warnings.
pub fn print_run_warnings(report: &ex::RunReport) {
    resumed(report.resumed, report.units);
    if report.resumed_row_warnings > 0 {
        status!(
            "warning: the resumed units' trial rows hold {} warning(s) from before the interruption \
             (counted in summary.csv's warnings column; the interrupted run printed their messages)",
            report.resumed_row_warnings
        );
    }
    for (message, count) in &report.warnings {
        status!("warning: {count} weight set(s): {message}");
    }
}

/// `--shard i/n`, parsed (`None` when not given).
fn shard_option(arg: Option<&str>) -> Result<Option<workbench::job::Shard>, workbench::InputError> {
    arg.map(workbench::job::Shard::parse)
        .transpose()
        .map_err(|m| workbench::InputError::new(format!("--shard: {m}")))
}
