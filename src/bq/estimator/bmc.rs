//! Bayesian Monte Carlo with zero prior mean (math.md §4, thesis §2.3).

use crate::bq::weights::BmcWeights;

/// `Î = wᵀ Y`, with `w = Q⁻¹ z` the BMC weights of the sample set and `Y` the integrand's
/// values on it (O'Hagan 1991; Rasmussen & Ghahramani 2003).
///
/// # Panics
/// If the lengths differ.
pub fn estimate(weights: &BmcWeights, values: &[f64]) -> f64 {
    assert_eq!(
        weights.weights.len(),
        values.len(),
        "weights and values differ in length"
    );
    weights.weights.iter().zip(values).map(|(w, y)| w * y).sum()
}
