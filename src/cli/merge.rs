//! `workbench merge OUT DIR…`.

use super::output::{status, stdout};
use super::progress::Bar;
use std::path::PathBuf;
use std::process::ExitCode;
use workbench::experiment as ex;

#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:\n  \
    workbench run experiments/cos3.json --shard 1/2 --out shards/1\n  \
    workbench run experiments/cos3.json --shard 2/2 --out shards/2\n  \
    workbench merge results/cos3 shards/1 shards/2\n  \
    workbench render experiments/render-table.json --shard 1/2 --out shards/t1\n  \
    workbench render experiments/render-table.json --shard 2/2 --out shards/t2\n  \
    workbench merge results/render-table shards/t1 shards/t2\n  \
    workbench run experiments/irradiance-pisa.json --shard 1/2 --out shards/i1   (and 2/2 into shards/i2)\n  \
    workbench merge results/irradiance-pisa shards/i1 shards/i2\n\n\
    The merged files are byte for byte those of one run of the whole file (the timings* files and \
    *-cost.svg aside). A render table's shards merge into the table's folder: OUT's parent is the \
    results folder whose cache/ its manifest names, as --results-dir is for one run.\n\n\
    Exit codes: 0 every check passed; 1 a check failed (outputs are still written); 2 any error \
    (shards of different runs, a shard missing or given twice, an unfinished shard, I/O), before \
    anything is written for bad input.")]
pub struct MergeArgs {
    /// The output folder (replaced as a whole, like `run`'s).
    out: PathBuf,
    /// The shard folders, every shard of the run once, in any order.
    #[arg(required = true)]
    dirs: Vec<PathBuf>,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

pub fn merge(args: MergeArgs) -> anyhow::Result<ExitCode> {
    let kind = workbench::job::shard_set::check_kinds(&args.dirs)?;
    if kind == workbench::irradiance::shard::KIND {
        let (plan, report) = workbench::irradiance::shard::merge(
            &args.out,
            &args.dirs,
            &super::output::JOB_FLAGS,
            &Bar::new(args.quiet),
        )?;
        stdout(&workbench::irradiance::export::summary(&plan, &report.rows))?;
        status!(
            "merged the irradiance protocol's shards into {} ({:.2} s)",
            report.out_dir.display(),
            report.wall_seconds
        );
        return Ok(ExitCode::SUCCESS);
    }
    if kind == workbench::table::shard::KIND {
        let report = workbench::table::shard::merge(&args.out, &args.dirs, &super::output::JOB_FLAGS)?;
        stdout(&report.table_md)?;
        stdout(&format!("\n{}", report.times_md))?;
        status!(
            "merged the render table's shards into {}",
            report.out_dir.display()
        );
        return Ok(ExitCode::SUCCESS);
    }
    let (plan, merged) = ex::job::merge(
        &args.out,
        &args.dirs,
        &super::output::JOB_FLAGS,
        &Bar::new(args.quiet),
    )?;
    let report = ex::RunReport {
        out_dir: merged.out_dir,
        cells: merged.findings.cells,
        checks: merged.findings.checks,
        calibration: merged.findings.calibration,
        stopping: merged.stopping,
        tolerance_checks: merged.tolerance_checks,
        wall_seconds: merged.wall_seconds,
        threads: 1,
        warnings: Vec::new(),
        shard: workbench::job::Shard::WHOLE,
        resumed: 0,
        resumed_row_warnings: 0,
        units: plan.samples.len() * plan.trials,
    };
    stdout(&ex::format_report(&plan, &report))?;
    stdout(&ex::adaptive::format_report(
        &plan,
        &report.stopping,
        &report.tolerance_checks,
    ))?;
    // Each shard printed its weight sets' messages when it ran; the merge has only the counts.
    let row_warnings: u64 = report.cells.iter().map(|c| c.warnings).sum();
    if row_warnings > 0 {
        status!(
            "warning: the shards' trial rows hold {row_warnings} warning(s) (counted in \
             summary.csv's warnings column; each shard printed their messages when it ran)"
        );
    }
    status!(
        "merged {} shards into {} ({:.2} s)",
        merged.shards,
        report.out_dir.display(),
        report.wall_seconds
    );
    let failed = report.checks.iter().any(|c| !c.passed())
        || report.calibration.iter().any(|c| !c.passed())
        || report.tolerance_checks.iter().any(|c| !c.passed());
    Ok(if failed {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}
