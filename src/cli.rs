//! Command-line interface: options → validated plan → run → export.

use crate::bmc::{BmcModel, DEFAULT_NOISE, validate_noise};
use crate::io::{InputError, write_atomic};
use crate::kernel::{Kernel, Sobolev, SquaredExponential};
use crate::kernel_mean::KernelMeanMode;
use crate::sampling::Design;
use clap::{Parser, Subcommand, ValueEnum};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(
    name = "workbench",
    version,
    about = "Monte Carlo vs Bayesian Monte Carlo over the hemisphere"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Compute a BMC quadrature rule (points and weights) for use in other code.
    Rule(RuleArgs),
    /// Run an experiment file: parallel trials, CSV, SVG plots, summary and checks.
    Run(RunArgs),
    /// Check an experiment file and print the resolved plan, without running it.
    Validate(ValidateArgs),
    /// Render the sphere-on-a-plane scene with MC, BMC or BMCP, or an RMSE-vs-spp table.
    Render(crate::render::cli::RenderArgs),
}

#[derive(clap::Args, Debug)]
struct RunArgs {
    /// The experiment file (JSON).
    file: PathBuf,
    /// Output folder (default: results/<name>/).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Override the number of trials.
    #[arg(long)]
    trials: Option<u64>,
    /// Worker threads (default: one per core). Results do not depend on it.
    #[arg(long)]
    threads: Option<usize>,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(clap::Args, Debug)]
struct ValidateArgs {
    /// The experiment file (JSON).
    file: PathBuf,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq)]
enum KernelName {
    Sobolev,
    Se,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq)]
enum KernelMeanName {
    Exact,
    Mc,
}

/// Kernel, noise and kernel-mean options shared by the commands that build BMC weights.
#[derive(clap::Args, Debug, Clone)]
pub struct ModelArgs {
    /// Covariance kernel.
    #[arg(long, value_enum, default_value = "sobolev")]
    kernel: KernelName,
    /// Sobolev smoothness s, in (1, 2).
    #[arg(long, allow_negative_numbers = true, default_value_t = Sobolev::DEFAULT_S)]
    s: f64,
    /// Squared-exponential σ_f.
    #[arg(long, allow_negative_numbers = true, default_value_t = 1.0)]
    sigma: f64,
    /// Squared-exponential length scale l.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.5)]
    length: f64,
    /// Observation noise σ_n² added to the diagonal of K.
    #[arg(long, allow_negative_numbers = true, default_value_t = DEFAULT_NOISE)]
    noise: f64,
    /// Kernel mean: exact (tabulated) or the thesis's plain MC estimate per point.
    #[arg(long, value_enum, default_value = "exact")]
    kernel_mean: KernelMeanName,
    /// Uniform samples per kernel mean in `--kernel-mean mc`.
    #[arg(long, default_value_t = KernelMeanMode::THESIS_SAMPLES)]
    kernel_mean_samples: usize,
}

impl ModelArgs {
    fn kernel(&self) -> Result<Kernel, InputError> {
        let k = match self.kernel {
            KernelName::Sobolev => Sobolev::new(self.s).map(Kernel::Sobolev),
            KernelName::Se => {
                SquaredExponential::new(self.sigma, self.length).map(Kernel::SquaredExponential)
            }
        };
        k.map_err(|e| InputError::new(format!("--kernel {}: {e}", k_name(self.kernel))))
    }

    fn mode(&self) -> Result<KernelMeanMode, InputError> {
        match self.kernel_mean {
            KernelMeanName::Exact => Ok(KernelMeanMode::Exact),
            KernelMeanName::Mc => KernelMeanMode::monte_carlo(self.kernel_mean_samples as u64)
                .map_err(|m| InputError::new(format!("--kernel-mean-samples: {m}"))),
        }
    }

    /// The validated model (builds the kernel-mean table).
    pub fn model(&self) -> Result<BmcModel, InputError> {
        let kernel = self.kernel()?;
        let noise = validate_noise(self.noise).map_err(|m| InputError::new(format!("--noise: {m}")))?;
        Ok(BmcModel::new(kernel, noise, self.mode()?))
    }

    fn mode_name(&self) -> &'static str {
        match self.kernel_mean {
            KernelMeanName::Exact => "exact",
            KernelMeanName::Mc => "mc",
        }
    }
}

fn k_name(k: KernelName) -> &'static str {
    match k {
        KernelName::Sobolev => "sobolev",
        KernelName::Se => "se",
    }
}

#[derive(clap::Args, Debug)]
struct RuleArgs {
    /// Number of points to generate (ignored with --points).
    #[arg(long, default_value_t = 64, conflicts_with = "points")]
    n: usize,
    /// Seed of the generated points (and of the MC kernel means).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Sampling design of the generated points.
    #[arg(long, value_enum, default_value = "uniform", conflicts_with = "points")]
    design: DesignName,
    /// Read the points from a CSV with header `x,y,z` instead of generating them.
    #[arg(long)]
    points: Option<PathBuf>,
    #[command(flatten)]
    model: ModelArgs,
    /// Write the rule (CSV `x,y,z,weight`) here instead of to stdout.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write the diagnostics as JSON here.
    #[arg(long)]
    summary: Option<PathBuf>,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq)]
enum DesignName {
    Uniform,
    Cosine,
}

impl From<DesignName> for Design {
    fn from(d: DesignName) -> Design {
        match d {
            DesignName::Uniform => Design::Uniform,
            DesignName::Cosine => Design::Cosine,
        }
    }
}

/// Entry point of the binary.
pub fn main() -> anyhow::Result<ExitCode> {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if e.use_stderr() => {
            // Usage errors (exit 2) in clap's own words.
            e.print()?;
            return Ok(ExitCode::from(2));
        }
        Err(e) => {
            e.print()?;
            return Ok(ExitCode::SUCCESS);
        }
    };
    match cli.command {
        Command::Rule(args) => rule(args),
        Command::Run(args) => run(args),
        Command::Validate(args) => {
            let plan = crate::experiment::load_plan(&args.file, &Default::default())?;
            print!("{}", crate::experiment::describe(&plan));
            Ok(ExitCode::SUCCESS)
        }
        Command::Render(args) => crate::render::cli::run(args),
    }
}

fn rule(args: RuleArgs) -> anyhow::Result<ExitCode> {
    let points = match &args.points {
        Some(path) => crate::rule::read_points_csv(path)?,
        None => {
            crate::rule::check_point_count(args.n, "--n")?;
            crate::rule::generate_points(args.n, args.seed, args.design.into())
        }
    };
    crate::rule::check_point_count(points.len(), "--points")?;
    let model = args.model.model()?;
    let weights = crate::rule::compute_rule(&points, &model, args.seed)?;
    for w in &weights.diagnostics.warnings {
        eprintln!("warning: {}", w.message());
    }
    let csv = crate::rule::rule_csv(&points, &weights.weights);
    let summary = crate::rule::rule_summary(&model, args.model.mode_name(), &points, &weights);
    match &args.out {
        Some(path) => write_atomic(path, &csv)?,
        None => std::io::Write::write_all(&mut std::io::stdout().lock(), &csv)?,
    }
    if let Some(path) = &args.summary {
        write_atomic(path, &serde_json::to_vec_pretty(&summary)?)?;
    }
    if args.out.is_some() {
        let d = &weights.diagnostics;
        eprintln!(
            "rule: n = {}, Σw = {:.6} (2π = {:.6}), posterior sd = {:.3e}, {} negative weights",
            d.n,
            d.weight_sum,
            std::f64::consts::TAU,
            d.posterior_variance.max(0.0).sqrt(),
            d.negative_weights
        );
    }
    Ok(ExitCode::SUCCESS)
}

fn run(args: RunArgs) -> anyhow::Result<ExitCode> {
    use crate::experiment as ex;
    let overrides = ex::Overrides {
        out: args.out,
        trials: args.trials,
        threads: args.threads,
        quiet: args.quiet,
    };
    let plan = ex::load_plan(&args.file, &overrides)?;
    let report = ex::run_plan(&plan, &overrides)?;
    print!("{}", ex::format_report(&plan, &report));
    for (message, count) in &report.warnings {
        eprintln!("warning: {count} weight set(s): {message}");
    }
    println!(
        "wrote {} ({:.2} s on {} threads)",
        report.out_dir.display(),
        report.wall_seconds,
        report.threads
    );
    let failed = report.checks.iter().any(|c| !c.passed());
    Ok(if failed {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}
