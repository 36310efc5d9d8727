//! The leaves every other module stands on: vectors, random streams, statistics, quadrature,
//! progress reporting and thread pools. None of them imports from the rest of the crate.

pub mod geometry;
pub mod quadrature;
pub mod report;
pub mod rng;
pub mod stats;
pub mod threads;
