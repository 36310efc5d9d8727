//! Command-line interface: options → validated plan → run → export.

use crate::bmc::{BmcModel, DEFAULT_NOISE, validate_noise};
use crate::io::{InputError, write_atomic};
use crate::kernel::{Kernel, Sobolev, SquaredExponential};
use crate::kernel_mean::KernelMeanMode;
use crate::sampling::{Design, SetDesign};
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
///
/// Every option is optional so that one that does not apply (`--s` with `--kernel se`,
/// `--kernel-mean-samples` with the exact mean, any of them with an MC integrator) is an error
/// rather than silently ignored; defaults are filled in by [`ModelArgs::model`].
#[derive(clap::Args, Debug, Clone)]
pub struct ModelArgs {
    /// Covariance kernel [default: sobolev].
    #[arg(long, value_enum)]
    kernel: Option<KernelName>,
    /// Sobolev smoothness s, in (1, 2) [default: 1.4].
    #[arg(long, allow_negative_numbers = true)]
    s: Option<f64>,
    /// Squared-exponential σ_f [default: 1].
    #[arg(long, allow_negative_numbers = true)]
    sigma: Option<f64>,
    /// Squared-exponential length scale l [default: 0.5].
    #[arg(long, allow_negative_numbers = true)]
    length: Option<f64>,
    /// Observation noise σ_n² added to the diagonal of K [default: 0.01].
    #[arg(long, allow_negative_numbers = true)]
    noise: Option<f64>,
    /// Kernel mean: exact (tabulated) or the thesis's plain MC estimate per point [default: exact].
    #[arg(long, value_enum)]
    kernel_mean: Option<KernelMeanName>,
    /// Uniform samples per kernel mean with `--kernel-mean mc` [default: 10000].
    #[arg(long)]
    kernel_mean_samples: Option<usize>,
}

impl ModelArgs {
    fn kernel(&self) -> Result<Kernel, InputError> {
        let name = self.kernel.unwrap_or(KernelName::Sobolev);
        let k = match name {
            KernelName::Sobolev => {
                if let Some(flag) = self.sigma.map(|_| "--sigma").or(self.length.map(|_| "--length")) {
                    return Err(InputError::new(format!(
                        "{flag}: applies to --kernel se, not sobolev"
                    )));
                }
                Sobolev::new(self.s.unwrap_or(Sobolev::DEFAULT_S)).map(Kernel::Sobolev)
            }
            KernelName::Se => {
                if self.s.is_some() {
                    return Err(InputError::new("--s: applies to --kernel sobolev, not se"));
                }
                SquaredExponential::new(self.sigma.unwrap_or(1.0), self.length.unwrap_or(0.5))
                    .map(Kernel::SquaredExponential)
            }
        };
        k.map_err(|e| InputError::new(format!("--kernel {}: {e}", k_name(name))))
    }

    fn mode(&self) -> Result<KernelMeanMode, InputError> {
        match self.kernel_mean.unwrap_or(KernelMeanName::Exact) {
            KernelMeanName::Exact if self.kernel_mean_samples.is_some() => Err(InputError::new(
                "--kernel-mean-samples: applies to --kernel-mean mc, not exact",
            )),
            KernelMeanName::Exact => Ok(KernelMeanMode::Exact),
            KernelMeanName::Mc => {
                let m = self.kernel_mean_samples.unwrap_or(KernelMeanMode::THESIS_SAMPLES);
                KernelMeanMode::monte_carlo(m as u64)
                    .map_err(|msg| InputError::new(format!("--kernel-mean-samples: {msg}")))
            }
        }
    }

    /// The validated model (builds the kernel-mean table).
    pub fn model(&self) -> Result<BmcModel, InputError> {
        let kernel = self.kernel()?;
        let noise = validate_noise(self.noise.unwrap_or(DEFAULT_NOISE))
            .map_err(|m| InputError::new(format!("--noise: {m}")))?;
        let model = BmcModel::new(kernel, noise, self.mode()?);
        if let Some(w) = model.accuracy_warning() {
            crate::status!("warning: {w}");
        }
        Ok(model)
    }

    /// The first model option given on the command line, if any (for commands and integrators
    /// that do not use a model).
    pub fn given(&self) -> Option<&'static str> {
        [
            ("--kernel", self.kernel.is_some()),
            ("--s", self.s.is_some()),
            ("--sigma", self.sigma.is_some()),
            ("--length", self.length.is_some()),
            ("--noise", self.noise.is_some()),
            ("--kernel-mean", self.kernel_mean.is_some()),
            ("--kernel-mean-samples", self.kernel_mean_samples.is_some()),
        ]
        .into_iter()
        .find_map(|(flag, given)| given.then_some(flag))
    }

    fn mode_name(&self) -> &'static str {
        match self.kernel_mean.unwrap_or(KernelMeanName::Exact) {
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
    /// Independent uniform points.
    Uniform,
    /// Independent cosine-weighted points.
    Cosine,
    /// Shifted spherical Fibonacci lattice (evenly spread; `--seed` draws the shift).
    Fibonacci,
}

impl From<DesignName> for SetDesign {
    fn from(d: DesignName) -> SetDesign {
        match d {
            DesignName::Uniform => SetDesign::Iid(Design::Uniform),
            DesignName::Cosine => SetDesign::Iid(Design::Cosine),
            DesignName::Fibonacci => SetDesign::Fibonacci,
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
            crate::io::stdout(&crate::experiment::describe(&plan))?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Render(args) => crate::render::cli::run(args),
    }
}

fn rule(args: RuleArgs) -> anyhow::Result<ExitCode> {
    let outputs: Vec<(&str, &std::path::Path)> = [("--out", &args.out), ("--summary", &args.summary)]
        .into_iter()
        .filter_map(|(f, p)| p.as_deref().map(|p| (f, p)))
        .collect();
    let inputs: Vec<(&str, &std::path::Path)> = args
        .points
        .as_deref()
        .map(|p| ("--points", p))
        .into_iter()
        .collect();
    crate::io::check_distinct(&outputs, &inputs)?;
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
        crate::status!("warning: {}", w.message());
    }
    let csv = crate::rule::rule_csv(&points, &weights.weights);
    match &args.out {
        Some(path) => write_atomic(path, &csv)?,
        None => crate::io::stdout(std::str::from_utf8(&csv).expect("the CSV is ASCII"))?,
    }
    if let Some(path) = &args.summary {
        // Everything needed to make the same rule again.
        let source = match &args.points {
            Some(file) => serde_json::json!({ "points": file.display().to_string() }),
            None => {
                serde_json::json!({ "generated": { "n": args.n, "seed": args.seed, "design": SetDesign::from(args.design).name() } })
            }
        };
        let mut summary = crate::rule::rule_summary(&model, args.model.mode_name(), &points, &weights);
        summary["source"] = source;
        summary["seed"] = serde_json::json!(args.seed);
        if let KernelMeanMode::MonteCarlo { samples } = model.mode {
            summary["kernel_mean_samples"] = serde_json::json!(samples);
        }
        let mut bytes = serde_json::to_vec_pretty(&summary)?;
        bytes.push(b'\n');
        write_atomic(path, &bytes)?;
    }
    let d = &weights.diagnostics;
    crate::status!(
        "rule: n = {}, Σw = {:.6} (2π = {:.6}), posterior sd = {:.3e}, {} negative weights",
        d.n,
        d.weight_sum,
        std::f64::consts::TAU,
        d.posterior_variance.max(0.0).sqrt(),
        d.negative_weights
    );
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
    crate::io::stdout(&ex::format_report(&plan, &report))?;
    for (message, count) in &report.warnings {
        crate::status!("warning: {count} weight set(s): {message}");
    }
    crate::io::stdout(&format!(
        "wrote {} ({:.2} s on {} thread{})\n",
        report.out_dir.display(),
        report.wall_seconds,
        report.threads,
        if report.threads == 1 { "" } else { "s" }
    ))?;
    let failed = report.checks.iter().any(|c| !c.passed());
    Ok(if failed {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}
