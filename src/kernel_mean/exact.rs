//! The exact kernel mean by one-dimensional quadrature over `t = x·y` (math.md §4).

use crate::kernel::Kernel;
use crate::quadrature::GaussLegendre;
use std::f64::consts::{PI, TAU};

/// `z(μ) = ∫_H k(x, ω) dω` for a point `x` with `x·n = μ ∈ [−1, 1]` (below the horizon for μ < 0).
///
/// FIRST VERSION: plain composite Gauss–Legendre over `t` with the split at `±sin θ_x`.
pub fn kernel_mean_exact(kernel: &Kernel, mu: f64) -> f64 {
    let mu = mu.clamp(-1.0, 1.0);
    let a = (1.0 - mu * mu).sqrt();
    let full = if mu >= 0.0 {
        kernel.integral_over_t(a, 1.0)
    } else {
        kernel.integral_over_t(-1.0, -a)
    };
    if a == 0.0 {
        return TAU * full;
    }
    let gl = GaussLegendre::new(64);
    let panels = 64;
    let h = 2.0 * a / panels as f64;
    let mut mid = 0.0;
    for p in 0..panels {
        let lo = -a + p as f64 * h;
        mid += gl.integrate(lo, lo + h, |t| {
            let arg = (-t * mu / (a * (1.0 - t * t).sqrt())).clamp(-1.0, 1.0);
            kernel.of_squared_distance(2.0 - 2.0 * t) * 2.0 * arg.acos()
        });
    }
    TAU * full + mid
}

/// `V̂ = 2π ∫_0^1 z(μ) dμ`.
pub fn prior_variance_exact(kernel: &Kernel) -> f64 {
    let gl = GaussLegendre::new(64);
    TAU * gl.integrate(0.0, 1.0, |mu| kernel_mean_exact(kernel, mu)) + 0.0 * PI
}
