//! The kernel mean `z(x) = ∫_H k(x, ω) dω` and `V̂ = ∫_H ∫_H k dω dω'` (math.md §4).
//!
//! Both kernels are isotropic, so `z` depends only on `μ = x·n = cos θ_x`.

mod exact;
mod table;

pub use exact::{kernel_mean_exact, prior_variance_exact};
pub use table::KernelMeanTable;

use crate::geometry::Vec3;
use crate::kernel::Kernel;

/// How the kernel means `z_i` of a sample set are obtained.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum KernelMeanMode {
    /// The exact `z(μ)`, tabulated once per kernel (the default).
    Exact,
    /// The thesis's estimate: each `z_i` by plain MC with `samples` uniform directions.
    MonteCarlo { samples: usize },
}

impl KernelMeanMode {
    /// The thesis's default number of MC samples per `z_i`.
    pub const THESIS_SAMPLES: usize = 10_000;
    /// Largest M: the directions of one weight set take 24 bytes each, per worker thread.
    pub const MAX_SAMPLES: usize = 10_000_000;

    /// The MC mode with `samples` directions, checked to lie in `1..=MAX_SAMPLES`.
    pub fn monte_carlo(samples: u64) -> Result<Self, String> {
        if samples == 0 || samples > Self::MAX_SAMPLES as u64 {
            return Err(format!(
                "must be in 1..={} (M uniform directions take 24 bytes each per worker thread), got {samples}",
                Self::MAX_SAMPLES
            ));
        }
        Ok(KernelMeanMode::MonteCarlo {
            samples: samples as usize,
        })
    }
}

/// `z(x) ≈ (2π/M) Σ_j k(x, ω_j)` over the given uniform directions (the thesis's mode).
///
/// # Panics
/// If there are no directions (the estimate is undefined; callers validate M ≥ 1).
pub fn kernel_mean_mc(kernel: &Kernel, x: &Vec3, uniform_directions: &[Vec3]) -> f64 {
    kernel_means_mc(
        kernel,
        std::slice::from_ref(x),
        &crate::kernel::PointsSoa::new(uniform_directions),
    )[0]
}

/// [`kernel_mean_mc`] for every point, sharing one set of directions (stored as arrays so the
/// kernel sums vectorise); the sums run in direction order, so results are reproducible.
pub fn kernel_means_mc(kernel: &Kernel, points: &[Vec3], directions: &crate::kernel::PointsSoa) -> Vec<f64> {
    let m = directions.len();
    assert!(m > 0, "an MC kernel mean needs at least one direction");
    let mut row = vec![0.0; m];
    points
        .iter()
        .map(|x| {
            kernel.fill_against(directions, 0, x, &mut row);
            std::f64::consts::TAU * row.iter().sum::<f64>() / m as f64
        })
        .collect()
}
