//! The leaves every other module stands on: vectors, random streams, statistics, quadrature and
//! cubature, progress reporting, thread pools and the memory budget. None of them imports from
//! the rest of the crate.

pub mod cubature;
pub mod geometry;
pub mod hash;
pub mod memory;
pub mod quadrature;
pub mod report;
pub mod rng;
pub mod shown;
pub mod stats;
pub mod threads;
