//! workbench: Monte Carlo versus Bayesian Monte Carlo over the hemisphere.
//!
//! The formulas follow `docs/math.md` of the project's shared documentation; each module
//! names the section it implements.

pub mod bmc;
pub mod cli;
pub mod estimator;
pub mod experiment;
pub mod geometry;
pub mod integrand;
pub mod io;
pub mod kernel;
pub mod kernel_mean;
pub mod linalg;
pub mod quadrature;
pub mod render;
pub mod rng;
pub mod rule;
pub mod sampling;
pub mod stats;
