//! The model options shared by `rule` and `render`: flags → [`ModelSpec`], the same parser and
//! defaults as the JSON files.

use anyhow::bail;
use workbench::bq::model::BmcModel;
use workbench::bq::model::{KernelMeanName, KernelSpec, ModelField, ModelSpec, ResolvedModel};
use workbench::error::InputError;

/// Kernel, noise and kernel-mean options of the commands that build BMC weights.
///
/// Every option is optional so that one that does not apply (`--s` with `--kernel se`,
/// `--kernel-mean-samples` with the exact mean, any of them with an MC integrator) is an error
/// rather than silently ignored; defaults are [`ModelSpec::resolve`]'s.
#[derive(clap::Args, Debug, Clone)]
pub struct ModelArgs {
    /// Covariance kernel [default: sobolev]; `fitted` chooses among a grid of Sobolev kernels
    /// and noises by the marginal likelihood of the values (math.md §9).
    #[arg(long, value_parser = ["sobolev", "se", "fitted"])]
    kernel: Option<String>,
    /// The fitted kernel's smoothnesses, comma-separated [default: 1.2,1.6,2.75,3.75].
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    grid_s: Option<Vec<f64>>,
    /// The fitted kernel's noises σ_n², comma-separated [default: 1e-2,1e-8].
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    grid_noise: Option<Vec<f64>>,
    /// Sobolev smoothness s, in (1, 2), (2, 3) or (3, 4) (math.md §9) [default: 1.4].
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
    /// Kernel mean: exact (tabulated), the thesis's plain MC estimate per point (mc), or MC with
    /// one direction set shared by all points (mc-shared) [default: exact].
    #[arg(long, value_parser = ["exact", "mc", "mc-shared"])]
    kernel_mean: Option<String>,
    /// Uniform samples per kernel mean with `--kernel-mean mc` or `mc-shared` [default: 10000].
    #[arg(long)]
    kernel_mean_samples: Option<u64>,
}

impl ModelArgs {
    /// The flag of a model field, for messages.
    fn flag(field: ModelField) -> &'static str {
        match field {
            ModelField::Kernel => "--kernel",
            ModelField::Noise => "--noise",
            ModelField::KernelMean => "--kernel-mean",
            ModelField::KernelMeanSamples => "--kernel-mean-samples",
        }
    }

    /// The options as a [`ModelSpec`]; kernel parameters of the other kernel are errors.
    pub fn spec(&self) -> anyhow::Result<ModelSpec> {
        let fitted = self.kernel.as_deref() == Some("fitted");
        if !fitted
            && let Some(flag) = self
                .grid_s
                .as_ref()
                .map(|_| "--grid-s")
                .or(self.grid_noise.as_ref().map(|_| "--grid-noise"))
        {
            bail!(InputError::new(format!(
                "{flag}: applies to --kernel fitted only"
            )));
        }
        let kernel = match self.kernel.as_deref().unwrap_or("sobolev") {
            "fitted" => {
                if let Some(flag) = [
                    ("--s", self.s.is_some()),
                    ("--sigma", self.sigma.is_some()),
                    ("--length", self.length.is_some()),
                ]
                .into_iter()
                .find_map(|(f, given)| given.then_some(f))
                {
                    bail!(InputError::new(format!(
                        "{flag}: not used with --kernel fitted (its kernels are --grid-s)"
                    )));
                }
                let grid = (self.grid_s.is_some() || self.grid_noise.is_some()).then(|| {
                    workbench::bq::model::GridSpec {
                        s: self.grid_s.clone(),
                        noise: self.grid_noise.clone(),
                    }
                });
                Some(KernelSpec::Fitted { grid })
            }
            "se" => {
                if self.s.is_some() {
                    bail!(InputError::new("--s: applies to --kernel sobolev, not se"));
                }
                (self.sigma.is_some() || self.length.is_some() || self.kernel.is_some()).then_some(
                    KernelSpec::SquaredExponential {
                        sigma: self.sigma,
                        length: self.length,
                    },
                )
            }
            _ => {
                if let Some(flag) = self.sigma.map(|_| "--sigma").or(self.length.map(|_| "--length")) {
                    bail!(InputError::new(format!(
                        "{flag}: applies to --kernel se, not sobolev"
                    )));
                }
                (self.s.is_some() || self.kernel.is_some()).then_some(KernelSpec::Sobolev { s: self.s })
            }
        };
        let kernel_mean = self.kernel_mean.as_deref().map(|m| match m {
            "mc" => KernelMeanName::Mc,
            "mc-shared" => KernelMeanName::McShared,
            _ => KernelMeanName::Exact,
        });
        Ok(ModelSpec {
            kernel,
            noise: self.noise,
            kernel_mean,
            kernel_mean_samples: self.kernel_mean_samples,
        })
    }

    /// The validated model.
    pub fn resolve(&self) -> anyhow::Result<ResolvedModel> {
        let spec = self.spec()?;
        let model = spec.resolve().map_err(|e| {
            let fitted = self.kernel.as_deref() == Some("fitted");
            let message = match e.field {
                ModelField::Kernel if fitted && e.message.starts_with("grid.") => {
                    // "grid.s: …" / "grid.noise …": the flag of that list.
                    let rest = &e.message["grid.".len()..];
                    let (list, tail) = rest.split_at(rest.find([':', ' ']).unwrap_or(rest.len()));
                    format!("--grid-{list}{tail}")
                }
                ModelField::Noise if fitted => {
                    "--noise: not used with --kernel fitted (its noises are --grid-noise)".to_string()
                }
                ModelField::Kernel => format!(
                    "{} {}: {}",
                    Self::flag(e.field),
                    self.kernel.as_deref().unwrap_or("sobolev"),
                    e.message
                ),
                ModelField::KernelMeanSamples if e.message.starts_with("is only used") => {
                    format!("{}: applies to --kernel-mean mc, not exact", Self::flag(e.field))
                }
                _ => format!("{}: {}", Self::flag(e.field), e.message),
            };
            InputError::new(message)
        })?;
        Ok(model)
    }

    /// The validated model, built (its kernel-mean table tabulated), with the table's accuracy
    /// warning printed if it has one.
    pub fn build(&self) -> anyhow::Result<BmcModel> {
        let model = self.resolve()?.build();
        if let Some(w) = model.accuracy_warning() {
            super::output::status!("warning: {w}");
        }
        Ok(model)
    }

    /// The first model option given on the command line, if any (for commands and integrators
    /// that do not use a model).
    pub fn given(&self) -> Option<&'static str> {
        [
            ("--kernel", self.kernel.is_some()),
            ("--grid-s", self.grid_s.is_some()),
            ("--grid-noise", self.grid_noise.is_some()),
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
}
