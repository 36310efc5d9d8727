//! workbench: Monte Carlo versus Bayesian Monte Carlo over the hemisphere.
//!
//! The formulas follow `docs/math.md` of the project's shared documentation; each module
//! names the section it implements. The library never prints: long work reports through a
//! [`util::report::Reporter`], and errors are [`Error`]s. The command line lives in the binary.

pub mod bq;
pub mod data;
pub mod error;
pub mod experiment;
pub mod files;
pub mod integrand;
pub mod irradiance;
pub mod job;
pub mod plot;
pub mod provenance;
pub mod render;
pub mod sampling;
pub mod schema;
pub mod table;
pub mod util;

pub use error::{Error, InputError, Result};
