//! The estimators compared by the workbench (math.md §3–4), shared by `run` and `render`:
//! every estimator turns a sample set and the integrand's values on it into an estimate of
//! `I = ∫_H f dω`. Experiments call it once per integrand; the renderer once per colour channel.
//!
//! Adding an estimator (see docs/guide/extending.md): one file here with its `estimate` function, one arm in
//! [`Method`] and in [`Method::ALL`]; every `match` on `Method` is exhaustive, so the compiler
//! lists every place that must decide what the new estimator does (its name, whether it needs
//! BMC weights or a prior, how it estimates, its posterior). Experiments (`"method": "<name>"`)
//! and the renderer (`--integrator <name>`) then accept it, and the conformance tests in
//! `tests/it/bq/estimators.rs` walk [`Method::ALL`].
//!
//! The light-aware estimators ([`mis`]: `mc-light`, `mc-bsdf`, `mis`) do not take values on a
//! given point set: they draw their own directions from the integrand's techniques
//! ([`crate::integrand::lit`]). An experiment names either kind by [`MethodName`].

pub mod bmc;
pub mod bmc_light;
pub mod bmcp;
pub mod bq_pss;
pub mod bsq;
pub mod mc;
pub mod mis;

use crate::bq::weights::{BmcWeights, Diagnostics, Scale, Solved};
use crate::sampling::Density;
use crate::util::geometry::Vec3;
use serde::{Deserialize, Serialize};

/// An estimator of `∫_H f dω` from values on a sample set.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Classical Monte Carlo, `Î = (1/N) Σ f(ω_i)/p(ω_i)` ([`mc`]).
    Mc,
    /// Bayesian Monte Carlo with zero prior mean, `Î = wᵀ Y` ([`bmc`]).
    Bmc,
    /// BMC with a constant prior mean `c`, `Î = 2πc + wᵀ (Y − c·1)` ([`bmcp`]).
    Bmcp,
    /// Bayes–Sard quadrature, BMC with an unknown constant prior mean, `Î = w_BSᵀ Y` ([`bsq`]).
    Bsq,
}

impl Method {
    /// Every estimator, in the order of the docs: the list the conformance tests walk and that
    /// names are parsed from.
    pub const ALL: [Method; 4] = [Method::Mc, Method::Bmc, Method::Bmcp, Method::Bsq];

    /// The name in experiment files, on the command line and in CSVs.
    pub fn name(self) -> &'static str {
        match self {
            Method::Mc => "mc",
            Method::Bmc => "bmc",
            Method::Bmcp => "bmcp",
            Method::Bsq => "bsq",
        }
    }

    /// Parses [`Method::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// Whether the estimate needs BMC weights (a kernel, noise and kernel means).
    pub fn needs_weights(self) -> bool {
        match self {
            Method::Mc => false,
            Method::Bmc | Method::Bmcp | Method::Bsq => true,
        }
    }

    /// The fewest points the estimator accepts: Bayes–Sard fits a constant, so it needs two
    /// points for a residual (its `ml` amplitude has N − 1 degrees of freedom).
    pub fn min_points(self) -> usize {
        match self {
            Method::Mc | Method::Bmc | Method::Bmcp => 1,
            Method::Bsq => 2,
        }
    }

    /// Whether the estimator states an interval at `n` points ([`Method::uncertainty`] is
    /// `Some`): MC needs two terms for a sample standard deviation.
    pub fn has_interval(self, n: usize) -> bool {
        match self {
            Method::Mc => n >= 2,
            Method::Bmc | Method::Bmcp | Method::Bsq => n >= self.min_points(),
        }
    }

    /// The fewest points at which the estimator states an interval ([`Method::has_interval`]).
    pub fn min_interval_points(self) -> usize {
        (1..)
            .find(|&n| self.has_interval(n))
            .expect("every estimator states an interval at some N")
    }

    /// Whether the estimate is a Monte Carlo average of `f/p` terms, whose error falls as
    /// `N^(−1/2)`: the error plots draw their `N^(−1/2)` guide through such a series.
    pub fn is_monte_carlo(self) -> bool {
        match self {
            Method::Mc => true,
            Method::Bmc | Method::Bmcp | Method::Bsq => false,
        }
    }

    /// Whether the estimator has a Gaussian-process posterior, whose sd `sqrt(λ Var₁)` it
    /// states ([`Method::uncertainty`]): what `render --sd-out` draws.
    pub fn has_posterior(self) -> bool {
        match self {
            Method::Mc => false,
            Method::Bmc | Method::Bmcp | Method::Bsq => true,
        }
    }

    /// Whether the estimator's `Var₁` and diagnostics are its own rather than its weight set's
    /// ([`Method::diagnostics`], [`Method::unit_variance`]): Bayes–Sard's (math.md §8) can be
    /// negative where BMC's is not (MC kernel means), so its warnings are reported besides the
    /// weight set's.
    pub fn states_own_unit_variance(self) -> bool {
        match self {
            Method::Mc | Method::Bmc | Method::Bmcp => false,
            Method::Bsq => true,
        }
    }

    /// Whether the estimate takes a constant prior mean `c`.
    pub fn uses_prior(self) -> bool {
        match self {
            Method::Mc | Method::Bmc | Method::Bsq => false,
            Method::Bmcp => true,
        }
    }

    /// The estimate from the sample set `points` (each point drawn from `density`), the
    /// integrand values `values`, the weights (when [`Method::needs_weights`]) and the prior
    /// constant `c` (used when [`Method::uses_prior`]; `c = 0` makes BMCP plain BMC).
    ///
    /// # Panics
    /// If a method that needs weights is given none, or the lengths differ.
    pub fn estimate(
        self,
        density: Density,
        points: &[Vec3],
        values: &[f64],
        weights: Option<&BmcWeights>,
        prior: f64,
    ) -> f64 {
        match self {
            Method::Mc => mc::estimate(density, points, values),
            Method::Bmc => bmc::estimate(weights.expect("BMC needs weights"), values),
            Method::Bmcp => bmcp::estimate(weights.expect("BMCP needs weights"), values, prior),
            Method::Bsq => bsq::estimate(weights.expect("BSQ needs weights"), values),
        }
    }

    /// The constant `o` of the residuals `r = Y − o·1` whose size the `ml` and `loo`
    /// amplitudes measure (math.md §7–8): 0 for BMC (`r = Y`), the prior `c` for BMCP,
    /// `β̂ = 1ᵀQ⁻¹Y / 1ᵀQ⁻¹1` for Bayes–Sard; None for MC.
    pub fn residual_offset(self, values: &[f64], weights: Option<&BmcWeights>, prior: f64) -> Option<f64> {
        match self {
            Method::Mc => None,
            Method::Bmc => Some(0.0),
            Method::Bmcp => Some(prior),
            Method::Bsq => Some(weights.expect("BSQ needs weights").bayes_sard_constant(values)),
        }
    }

    /// The residuals `r = Y − o·1` ([`Method::residual_offset`]); None for MC.
    pub fn residuals(self, values: &[f64], weights: Option<&BmcWeights>, prior: f64) -> Option<Vec<f64>> {
        let o = self.residual_offset(values, weights, prior)?;
        Some(values.iter().map(|y| y - o).collect())
    }

    /// The fitted amplitude `λ̂` ([`crate::bq::weights::fit_amplitude`]) of this estimator's
    /// residuals, from `Y` solved with the factor: with `Q⁻¹Y`, `Q⁻¹r = Q⁻¹Y − o·u` (`u = Q⁻¹1`);
    /// with `L⁻¹Y` (`ml` only), `L⁻¹r = L⁻¹Y − o·L⁻¹1`. So one solve per integrand and weight set
    /// serves BMC, BMCP and Bayes–Sard alike (O(N) each after it). None for MC.
    pub fn amplitude(
        self,
        scale: Scale,
        values: &[f64],
        solved: Solved<'_>,
        weights: Option<&BmcWeights>,
        prior: f64,
        inverse_diagonal: Option<&[f64]>,
    ) -> Option<f64> {
        let w = weights?;
        let o = self.residual_offset(values, weights, prior)?;
        let r: Vec<f64> = values.iter().map(|y| y - o).collect();
        let shift = |solved: &[f64], ones: &[f64]| -> Vec<f64> {
            if o == 0.0 {
                solved.to_vec()
            } else {
                solved.iter().zip(ones).map(|(a, u)| a - o * u).collect()
            }
        };
        let dof = self.ml_dof(values.len());
        Some(match solved {
            Solved::Full(values_solve) => crate::bq::weights::fit_amplitude(
                scale,
                &r,
                &shift(values_solve, &w.ones_solve),
                dof,
                inverse_diagonal,
            ),
            Solved::Half { y, ones } => {
                crate::bq::weights::fit_amplitude_half(scale, &r, &shift(y, ones), dof)
            }
        })
    }

    /// Degrees of freedom of the `ml` amplitude and of its Student-t interval: `N` for BMC and
    /// BMCP, `N − 1` for Bayes–Sard (one more parameter, `β`, fitted).
    pub fn ml_dof(self, n: usize) -> usize {
        match self {
            Method::Mc | Method::Bmc | Method::Bmcp => n,
            Method::Bsq => n.saturating_sub(1),
        }
    }

    /// The weight set's diagnostics as this estimator sees them: Bayes–Sard reports its own
    /// weights (Σ = 2π) and §8's `Var₁`; None for MC.
    pub fn diagnostics(self, weights: Option<&BmcWeights>) -> Option<Diagnostics> {
        match self {
            Method::Mc => None,
            Method::Bmc | Method::Bmcp => weights.map(|w| w.diagnostics.clone()),
            Method::Bsq => weights.map(|w| w.bayes_sard().diagnostics),
        }
    }

    /// The unit-amplitude posterior variance `Var₁`, clamped at 0 (math.md §7): `V̂ − zᵀQ⁻¹z`
    /// for BMC and BMCP, §8's for Bayes–Sard; None for MC.
    pub fn unit_variance(self, weights: Option<&BmcWeights>) -> Option<f64> {
        match self {
            Method::Mc => None,
            Method::Bmc | Method::Bmcp => weights.map(|w| w.diagnostics.posterior_variance_clamped()),
            Method::Bsq => weights.map(|w| w.bayes_sard_variance().max(0.0)),
        }
    }

    /// The estimator's stated uncertainty: the standard deviation it attaches to `Î` and the
    /// law of its interval.
    ///
    /// - MC: the standard error `s/√N` of the mean of the `N` terms `f/p` (`s` the sample
    ///   standard deviation), Student-t with `N − 1` degrees of freedom; None for `N < 2`.
    /// - BMC, BMCP, BSQ: the posterior sd `sqrt(λ Var₁)` with `λ = amplitude` (1 for `unit`,
    ///   `λ̂` from [`crate::bq::weights::fit_amplitude`] otherwise); Student-t with [`Method::ml_dof`]
    ///   degrees of freedom for `ml`, normal otherwise (math.md §7).
    #[allow(clippy::too_many_arguments)]
    pub fn uncertainty(
        self,
        density: Density,
        points: &[Vec3],
        values: &[f64],
        weights: Option<&BmcWeights>,
        scale: Scale,
        amplitude: f64,
    ) -> Option<Uncertainty> {
        match self {
            Method::Mc => {
                let n = points.len();
                if n < 2 {
                    return None;
                }
                let terms: Vec<f64> = points
                    .iter()
                    .zip(values)
                    .map(|(w, f)| f / density.pdf(w))
                    .collect();
                Some(Uncertainty {
                    sd: crate::util::stats::sample_sd(&terms) / (n as f64).sqrt(),
                    dof: Some(n - 1),
                    amplitude: None,
                })
            }
            Method::Bmc | Method::Bmcp | Method::Bsq => {
                let var1 = self.unit_variance(weights)?;
                Some(Uncertainty {
                    sd: (amplitude * var1).sqrt(),
                    dof: (scale == Scale::Ml).then(|| self.ml_dof(values.len())),
                    amplitude: Some(amplitude),
                })
            }
        }
    }
}

/// An estimator's method as experiment files name it: an estimator of values on a point set
/// ([`Method`]) or a light-aware one ([`mis::LightMethod`]). The questions the experiment runner
/// asks of a method are answered for both; a light-aware estimator is a Monte Carlo average
/// without weights, prior or posterior.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum MethodName {
    Points(Method),
    Light(mis::LightMethod),
}

impl MethodName {
    /// The names of every method: [`Method::ALL`]'s, then [`mis::LightMethod::ALL`]'s (a test
    /// keeps them so), for messages.
    pub const NAMES: [&'static str; 8] = ["mc", "bmc", "bmcp", "bsq", "mc-light", "mc-bsdf", "mis", "bq-pss"];

    /// Parses a name of [`Method`] or [`mis::LightMethod`].
    pub fn from_name(name: &str) -> Option<Self> {
        Method::from_name(name)
            .map(MethodName::Points)
            .or_else(|| mis::LightMethod::from_name(name).map(MethodName::Light))
    }

    /// The name in files and CSVs.
    pub fn name(self) -> &'static str {
        match self {
            MethodName::Points(m) => m.name(),
            MethodName::Light(m) => m.name(),
        }
    }

    /// The estimator of values on a point set, if it is one.
    pub fn points(self) -> Option<Method> {
        match self {
            MethodName::Points(m) => Some(m),
            MethodName::Light(_) => None,
        }
    }

    /// The light-aware estimator, if it is one.
    pub fn light(self) -> Option<mis::LightMethod> {
        match self {
            MethodName::Points(_) => None,
            MethodName::Light(m) => Some(m),
        }
    }

    /// [`Method::needs_weights`]; light-aware estimators have none.
    pub fn needs_weights(self) -> bool {
        self.points().is_some_and(Method::needs_weights)
    }

    /// [`Method::uses_prior`]; light-aware estimators have none.
    pub fn uses_prior(self) -> bool {
        self.points().is_some_and(Method::uses_prior)
    }

    /// [`Method::min_points`]; `mis` needs one sample of each technique.
    pub fn min_points(self) -> usize {
        match self {
            MethodName::Points(m) => m.min_points(),
            MethodName::Light(mis::LightMethod::Mis | mis::LightMethod::BqPss) => 2,
            MethodName::Light(_) => 1,
        }
    }

    /// [`Method::has_interval`]; [`mis::LightMethod::has_interval`].
    pub fn has_interval(self, n: usize) -> bool {
        match self {
            MethodName::Points(m) => m.has_interval(n),
            MethodName::Light(m) => m.has_interval(n),
        }
    }

    /// [`Method::is_monte_carlo`]; light-aware estimators are Monte Carlo averages but for
    /// `bq-pss` (a quadrature).
    pub fn is_monte_carlo(self) -> bool {
        match self {
            MethodName::Points(m) => m.is_monte_carlo(),
            MethodName::Light(m) => m != mis::LightMethod::BqPss,
        }
    }

    /// [`Method::states_own_unit_variance`]; false for light-aware estimators.
    pub fn states_own_unit_variance(self) -> bool {
        self.points().is_some_and(Method::states_own_unit_variance)
    }

    /// [`Method::diagnostics`]; None for light-aware estimators.
    pub fn diagnostics(self, weights: Option<&BmcWeights>) -> Option<Diagnostics> {
        self.points().and_then(|m| m.diagnostics(weights))
    }
}

impl<'de> Deserialize<'de> for MethodName {
    /// By name, with every name in the error.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        MethodName::from_name(&name)
            .ok_or_else(|| serde::de::Error::unknown_variant(&name, &MethodName::NAMES))
    }
}

impl std::fmt::Display for MethodName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl From<Method> for MethodName {
    fn from(m: Method) -> Self {
        MethodName::Points(m)
    }
}

/// The standard deviation an estimator states for its estimate and the law of its interval
/// `Î ± q · sd` ([`Method::uncertainty`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Uncertainty {
    /// The stated standard deviation of `Î` (posterior sd, or MC's standard error).
    pub sd: f64,
    /// Student-t degrees of freedom of the interval; None for a normal interval.
    pub dof: Option<usize>,
    /// The kernel amplitude `λ` used (None for MC).
    pub amplitude: Option<f64>,
}

impl Uncertainty {
    /// The two-sided quantile `q` of the interval `Î ± q · sd` at `level` (e.g. 0.95).
    pub fn quantile(&self, level: f64) -> f64 {
        crate::util::stats::interval_quantile(self.dof, level)
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`MethodName::NAMES`] lists every method in order, and each parses back.
    #[test]
    fn method_names_list_every_method() {
        let names: Vec<&str> = Method::ALL
            .map(|m| m.name())
            .into_iter()
            .chain(mis::LightMethod::ALL.map(|m| m.name()))
            .collect();
        assert_eq!(names, MethodName::NAMES);
        for n in MethodName::NAMES {
            assert_eq!(MethodName::from_name(n).map(MethodName::name), Some(n));
        }
    }
}
