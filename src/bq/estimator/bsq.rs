//! Bayes–Sard quadrature: BMC with an unknown constant prior mean (math.md §8).

use crate::bq::weights::BmcWeights;

/// `Î = w_BSᵀ Y` with `w_BS = w + u (2π − 1ᵀw) / (1ᵀu)`, `u = Q⁻¹1`: the GP prior
/// `f ~ GP(β, k)` with a flat prior on `β` integrated out (Karvonen, Oates & Särkkä, "A
/// Bayes–Sard cubature method", NeurIPS 2018). Equivalently `Î = 2πβ̂ + zᵀQ⁻¹(Y − β̂1)` with
/// `β̂ = 1ᵀQ⁻¹Y / 1ᵀQ⁻¹1`. The weights sum to `2π`, so constants are integrated exactly; unlike
/// BMCP's oracle constant, `β̂` comes from the data. Computed as `wᵀY + shift · uᵀY` in O(N)
/// from BMC's weights and `u` (no second factorisation).
///
/// # Panics
/// If the lengths differ.
pub fn estimate(weights: &BmcWeights, values: &[f64]) -> f64 {
    assert_eq!(
        weights.weights.len(),
        values.len(),
        "weights and values differ in length"
    );
    let shift = weights.bayes_sard_shift();
    weights
        .weights
        .iter()
        .zip(&weights.ones_solve)
        .zip(values)
        .map(|((w, u), y)| (w + shift * u) * y)
        .sum()
}
