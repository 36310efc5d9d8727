//! workbench: Monte Carlo versus Bayesian Monte Carlo over the hemisphere.
//!
//! The formulas follow `docs/math.md` of the project's shared documentation; each module
//! names the section it implements. The library never prints: long work reports through a
//! [`report::Reporter`], and errors are [`Error`]s. The command line lives in the binary.

pub mod bmc;
pub mod error;
pub mod estimator;
pub mod experiment;
pub mod geometry;
pub mod integrand;
pub mod io;
pub mod json;
pub mod kernel;
pub mod kernel_mean;
pub mod linalg;
pub mod model_spec;
pub mod nested_cholesky;
pub mod output_set;
pub mod plot_style;
pub mod quadrature;
pub mod render;
pub mod report;
pub mod ring_solver;
pub mod rng;
pub mod rule;
pub mod sampling;
pub mod schema;
pub mod sequential;
pub mod stats;
pub mod threads;

pub use error::{Error, InputError, Result};
