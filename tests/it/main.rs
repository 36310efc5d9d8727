//! The integration tests, in one binary (as ripgrep's `tests/tests.rs`): after a change to the
//! library one test executable is linked instead of one per file.
//!
//! `cargo test --release --test it` runs them all; `cargo test --release --test it golden` one
//! module. The groups follow the source tree: the Bayesian-quadrature core and its inputs, the
//! experiment runner and its outputs, the renderer, and the `rule` command with the docs.

mod bq;
#[path = "../support/brute_force.rs"]
mod brute_force;
mod cli;
mod common;
mod experiment;
#[path = "../support/light_baselines.rs"]
mod light_baselines;
mod render;
