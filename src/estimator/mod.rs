//! The estimators compared by the workbench: MC, BMC and BMCP (math.md §3–4).
//!
//! Adding an estimator: one file here, one arm in [`Method`], its JSON name in
//! `experiment::spec::MethodName` (options validated in `experiment::plan`), and one entry in
//! the conformance tests' list (`tests/estimators.rs`). See the README.

pub mod mc;

use crate::bmc::BmcWeights;
use crate::geometry::Vec3;
use crate::sampling::Design;

/// The constant prior mean of BMCP.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Prior {
    /// `c = I / (2π)` of the integrand (math.md §1).
    Analytic,
    /// A given constant.
    Value(f64),
}

impl Prior {
    /// The constant for an integrand whose analytic prior is `analytic`.
    pub fn resolve(self, analytic: f64) -> f64 {
        match self {
            Prior::Analytic => analytic,
            Prior::Value(c) => c,
        }
    }
}

/// Which estimate to form from a sample set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Method {
    /// `Î = (1/N) Σ f(ω_i)/p(ω_i)`.
    Mc,
    /// `Î = wᵀ Y`.
    Bmc,
    /// `Î = 2πc + wᵀ (Y − c·1)`.
    Bmcp(Prior),
}

impl Method {
    pub fn name(&self) -> &'static str {
        match self {
            Method::Mc => "mc",
            Method::Bmc => "bmc",
            Method::Bmcp(_) => "bmcp",
        }
    }

    /// Whether the estimate needs BMC weights.
    pub fn needs_weights(&self) -> bool {
        !matches!(self, Method::Mc)
    }

    /// The estimate from the sample set `points` (drawn with `design`), the integrand values
    /// `values`, the weights (for BMC-type methods) and the integrand's analytic prior constant.
    pub fn estimate(
        &self,
        design: Design,
        points: &[Vec3],
        values: &[f64],
        weights: Option<&BmcWeights>,
        analytic_prior: f64,
    ) -> f64 {
        match self {
            Method::Mc => mc::estimate(design, points, values),
            Method::Bmc => weights.expect("BMC needs weights").bmc(values),
            Method::Bmcp(prior) => weights
                .expect("BMCP needs weights")
                .bmcp(values, prior.resolve(analytic_prior)),
        }
    }
}
