//! The estimators compared by the workbench (math.md §3–4), shared by `run` and `render`:
//! every estimator turns a sample set and the integrand's values on it into an estimate of
//! `I = ∫_H f dω`. Experiments call it once per integrand; the renderer once per colour channel.
//!
//! Adding an estimator (see the README): one file here with its `estimate` function, one arm in
//! [`Method`] and in [`Method::ALL`]; every `match` on `Method` is exhaustive, so the compiler
//! lists every place that must decide what the new estimator does (its name, whether it needs
//! BMC weights or a prior, how it estimates, its posterior). Experiments (`"method": "<name>"`)
//! and the renderer (`--integrator <name>`) then accept it, and the conformance tests in
//! `tests/estimators.rs` walk [`Method::ALL`].

pub mod bmc;
pub mod bmcp;
pub mod bsq;
pub mod mc;

use crate::bmc::BmcWeights;
use crate::geometry::Vec3;
use crate::sampling::Design;
use serde::{Deserialize, Serialize};

/// An estimator of `∫_H f dω` from values on a sample set.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Deserialize, Serialize)]
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
        density: Design,
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

    /// The posterior standard deviation of the integral, for the estimators that have one.
    pub fn posterior_sd(self, weights: Option<&BmcWeights>) -> Option<f64> {
        match self {
            Method::Mc => None,
            Method::Bmc | Method::Bmcp => weights.map(BmcWeights::posterior_sd),
            Method::Bsq => weights.map(|w| w.bayes_sard_variance().max(0.0).sqrt()),
        }
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}
