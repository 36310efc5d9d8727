//! `z(μ)` tabulated once per kernel for O(1) lookups.

use super::exact::{kernel_mean_exact, prior_variance_exact};
use crate::kernel::Kernel;

/// The exact kernel mean tabulated over `μ ∈ [0, 1]`.
///
/// FIRST VERSION: dense table with linear interpolation.
#[derive(Clone, Debug)]
pub struct KernelMeanTable {
    kernel: Kernel,
    values: Vec<f64>,
    prior_variance: f64,
}

impl KernelMeanTable {
    const SIZE: usize = 4097;

    pub fn new(kernel: &Kernel) -> Self {
        let values = (0..Self::SIZE)
            .map(|i| kernel_mean_exact(kernel, i as f64 / (Self::SIZE - 1) as f64))
            .collect();
        KernelMeanTable {
            kernel: *kernel,
            values,
            prior_variance: prior_variance_exact(kernel),
        }
    }

    pub fn kernel(&self) -> &Kernel {
        &self.kernel
    }

    /// `z(μ)` for `μ ∈ [0, 1]`.
    #[inline]
    pub fn z(&self, mu: f64) -> f64 {
        let x = mu.clamp(0.0, 1.0) * (Self::SIZE - 1) as f64;
        let i = (x as usize).min(Self::SIZE - 2);
        let f = x - i as f64;
        self.values[i] * (1.0 - f) + self.values[i + 1] * f
    }

    /// `V̂ = ∫_H ∫_H k dω dω'`.
    pub fn prior_variance(&self) -> f64 {
        self.prior_variance
    }
}
