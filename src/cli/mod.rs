//! The command line (binary only): options → validated plan → run → export, and the one place
//! that prints. Exit codes: 0 success, 1 a check failed (outputs still written), 2 any error.

mod data;
#[cfg(test)]
mod docs_commands;
mod image_files;
mod merge;
mod model_args;
mod output;
mod progress;
mod render;
mod render_adaptive;
mod reproduce;
mod rule;
mod run;
mod schema;
mod usage;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use output::{is_broken_pipe, status};
use std::process::ExitCode;

/// Shown under every `--help`.
const EXIT_CODES: &str = "Exit codes: 0 success; 1 a check failed (outputs are still written); \
                          2 any error (bad input, I/O). Results go to stdout; progress, status lines \
                          and warnings to stderr.";

#[derive(Parser, Debug)]
#[command(
    name = "workbench",
    version,
    about = "Monte Carlo vs Bayesian Monte Carlo over the hemisphere",
    after_help = EXIT_CODES
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// The folder of external data (maps named by catalogue name, e.g. `--env pisa`); default:
    /// the environment variable WORKBENCH_DATA. `workbench data` lists and checks it.
    #[arg(long, global = true, value_name = "DIR")]
    data: Option<std::path::PathBuf>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run an experiment file: parallel trials, CSV, SVG plots, summary and checks.
    Run(run::RunArgs),
    /// Check an experiment or render-table file and print the resolved plan, without running it.
    Validate(run::ValidateArgs),
    /// Merge the shard folders of a run (`run --shard i/n`) into the files of one run.
    Merge(merge::MergeArgs),
    /// Compute a BMC quadrature rule (points and weights) for use in other code.
    Rule(Box<rule::RuleArgs>),
    /// Render the sphere-on-a-plane scene with any estimator, or an RMSE-against-spp table.
    Render(Box<render::RenderArgs>),
    /// Print the JSON Schema (draft 2020-12) of experiment files or render tables.
    Schema(schema::SchemaArgs),
    /// List the catalogue of external data (maps, the thesis's images, Mitsuba's scenes) and
    /// check which files are present and intact in the data folder.
    Data(data::DataArgs),
    /// Regenerate every figure and table: run each experiment file and render table of a
    /// folder (default experiments/) in turn, with a time estimate and one summary.
    Reproduce(reproduce::ReproduceArgs),
}

/// Entry point of the binary.
pub fn main() -> ExitCode {
    let parsed = usage::with_negative_numbers(Cli::command())
        .try_get_matches()
        .and_then(|m| Cli::from_arg_matches(&m));
    let cli = match parsed {
        Ok(cli) => cli,
        // --help and --version, on stdout, exit 0.
        Err(e) if !e.use_stderr() => {
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        // A usage error is one line like any other bad input (exit 2).
        Err(e) => {
            status!("Error: {}", usage::one_line(&e));
            return ExitCode::from(2);
        }
    };
    workbench::data::name_setting("--data");
    if let Some(dir) = cli.data {
        workbench::data::set_folder(dir);
    }
    let result = match cli.command {
        Command::Data(args) => data::data(args),
        Command::Run(args) => run::run(args),
        Command::Validate(args) => run::validate(&args),
        Command::Merge(args) => merge::merge(args),
        Command::Rule(args) => rule::rule(*args),
        Command::Render(args) => render::render(*args),
        Command::Schema(args) => schema::schema(args),
        Command::Reproduce(args) => reproduce::reproduce(args),
    };
    match result {
        Ok(code) => code,
        // `workbench … | head`: the reader has all it wanted.
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            status!("Error: {e:#}");
            ExitCode::from(2)
        }
    }
}
