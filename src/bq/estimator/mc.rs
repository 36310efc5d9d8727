//! Classical Monte Carlo (math.md §3).

use crate::sampling::Density;
use crate::util::geometry::Vec3;

/// `Î = (1/N) Σ f(ω_i) / p(ω_i)` for directions drawn with `design`.
///
/// With uniform sampling this is `(2π/N) Σ f(ω_i)`. Unbiased, with standard deviation `σ/√N`,
/// `σ² = ∫ f²/p dω − I²`.
pub fn estimate(design: Density, points: &[Vec3], values: &[f64]) -> f64 {
    assert_eq!(points.len(), values.len(), "one value per point");
    let sum: f64 = points.iter().zip(values).map(|(w, f)| f / design.pdf(w)).sum();
    sum / points.len() as f64
}
