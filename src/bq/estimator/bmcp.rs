//! BMC with a constant prior mean `c` (math.md §4, thesis §3.2.5).

use crate::bq::weights::BmcWeights;

/// `Î = 2πc + wᵀ (Y − c·1)`: the integral of the prior mean plus BMC on the residuals. The
/// weights are BMC's (the prior mean does not change `Q` or `z`), so BMC and BMCP on the same
/// points cost one Cholesky. `c = 0` is plain BMC.
///
/// # Panics
/// If the lengths differ.
pub fn estimate(weights: &BmcWeights, values: &[f64], c: f64) -> f64 {
    assert_eq!(
        weights.weights.len(),
        values.len(),
        "weights and values differ in length"
    );
    let centred: f64 = weights.weights.iter().zip(values).map(|(w, y)| w * (y - c)).sum();
    std::f64::consts::TAU * c + centred
}
