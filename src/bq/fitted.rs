//! The fitted model (math.md §9): among a grid of models, per weight set and integrand values,
//! the one with the largest profiled log marginal likelihood gives the estimate, the weights and
//! the `ml` interval.
//!
//! With the amplitude `λ` at its `ml` value `λ̂ = rᵀQ⁻¹r / d` (`r` the residuals of §7, `d` the
//! `ml` degrees of freedom: `N`, or `N − 1` for Bayes–Sard),
//!
//! `ℓ = −(d/2) log(rᵀQ⁻¹r / d) − ½ log det Q`, and for Bayes–Sard (restricted likelihood)
//! additionally `− ½ log(1ᵀQ⁻¹1)`.
//!
//! The constant `−(d/2)(1 + log 2π)` is the same for every model and left out. The weights now
//! depend on the values: the estimator is no longer linear in `Y`, so a caller keeps every
//! candidate's factor (or weights and solves) and chooses per integrand, pixel or channel.

use crate::bq::estimator::Method;
use crate::bq::factor::{NotPositiveDefinite, SpdWorkspace};
use crate::bq::model::BmcModel;
use crate::bq::weights::{BmcWeights, Scale, Solved};
use crate::sampling::Design;
use crate::util::geometry::Vec3;

/// `ℓ` of one candidate for `method` on values `y` with prior constant `prior` (BMCP), given the
/// candidate's weights (for `u = Q⁻¹1`), `Q⁻¹Y` and `log det Q`; `+∞` when every residual is 0
/// (every candidate then ties), None for MC.
///
/// Scale-invariant (issue 30): values `c·Y` (with the prior `c·prior`) shift every candidate's
/// `ℓ` by the same `−d log c`, so they choose the same model. When `λ̂` is not a normal number
/// (values near 1e155 overflow `rᵀQ⁻¹r` to `∞`, and every `ℓ` was `−∞`, so the first model won;
/// values near 1e-160 underflow it) it is computed on `Y / 2^k`, `2^k` the largest magnitude's
/// power of two, and `log λ̂ = log λ̂(Y/2^k) + 2k log 2`. Otherwise `λ̂` is used directly, so
/// every ℓ computed before keeps its bits.
pub fn log_marginal_likelihood(
    method: Method,
    y: &[f64],
    values_solve: &[f64],
    weights: &BmcWeights,
    prior: f64,
    log_det: f64,
) -> Option<f64> {
    let dof = method.ml_dof(y.len());
    let amplitude = |y: &[f64], solve: &[f64], prior: f64| {
        method.amplitude(Scale::Ml, y, Solved::Full(solve), Some(weights), prior, None)
    };
    let direct = amplitude(y, values_solve, prior)?;
    let log_amplitude = if direct.is_normal() {
        direct.ln()
    } else {
        let mut all = y.to_vec();
        all.push(prior);
        let k = crate::bq::weights::power_of_two_scale(&all);
        let ys: Vec<f64> = y.iter().map(|v| v / k).collect();
        let ss: Vec<f64> = values_solve.iter().map(|v| v / k).collect();
        amplitude(&ys, &ss, prior / k)?.ln() + 2.0 * k.ln()
    };
    let mut ell = -0.5 * dof as f64 * log_amplitude - 0.5 * log_det;
    if method == Method::Bsq {
        ell -= 0.5 * weights.ones_solve.iter().sum::<f64>().ln();
    }
    Some(ell)
}

/// The index of the largest log likelihood, the first on ties; NaNs never win (all NaN: the
/// first).
pub fn best(log_likelihoods: &[f64]) -> usize {
    let mut best = 0;
    for (i, &l) in log_likelihoods.iter().enumerate() {
        if l > log_likelihoods[best] || (log_likelihoods[best].is_nan() && !l.is_nan()) {
            best = i;
        }
    }
    best
}

/// One candidate of a fitted model on a point set: its weights, `Q⁻¹Y` for each values vector
/// (integrand or colour channel) and `log det Q`.
#[derive(Clone, Debug)]
pub struct Candidate {
    pub weights: BmcWeights,
    pub values_solves: Vec<Vec<f64>>,
    pub log_det: f64,
}

/// The candidate chosen for `method` on values vector `k` (`y`), with every candidate's `ℓ`.
pub fn choose(
    method: Method,
    y: &[f64],
    k: usize,
    prior: f64,
    candidates: &[Candidate],
) -> (usize, Vec<f64>) {
    let ells: Vec<f64> = candidates
        .iter()
        .map(|c| {
            log_marginal_likelihood(method, y, &c.values_solves[k], &c.weights, prior, c.log_det)
                .unwrap_or(f64::NAN)
        })
        .collect();
    (best(&ells), ells)
}

/// A fitted model's choice on one point set and one values vector.
#[derive(Clone, Debug)]
pub struct Choice {
    /// The index of the chosen model in [`BmcModel::candidates`].
    pub chosen: usize,
    /// Every candidate's `ℓ`, in grid order.
    pub log_likelihoods: Vec<f64>,
    /// The chosen model's BMC weights (Bayes–Sard's follow with [`BmcWeights::bayes_sard`]).
    pub weights: BmcWeights,
}

/// Chooses among a fitted `model`'s grid for `method` on `points` (drawn with `design`: the ring
/// solver on ring sets) with values `y` and prior constant `prior`: one factorisation per
/// candidate, each solving `Q⁻¹Y` and giving `log det Q`. `rng` as in
/// [`BmcModel::weights_for_design`] (unused: a fitted model has exact kernel means).
pub fn choose_on_points<R: rand::Rng + ?Sized>(
    model: &BmcModel,
    points: &[Vec3],
    design: Design,
    method: Method,
    y: &[f64],
    prior: f64,
    rng: &mut R,
) -> Result<Choice, NotPositiveDefinite> {
    assert!(model.is_fitted(), "a fitted model");
    assert_eq!(points.len(), y.len(), "one value per point");
    let mut workspace = SpdWorkspace::new();
    let mut candidates = Vec::with_capacity(model.candidates().len());
    for m in model.candidates() {
        let weights = m.weights_for_design(points, design, rng, &mut workspace)?;
        let mut solve = y.to_vec();
        workspace.solve_in_place(&mut solve);
        candidates.push(Candidate {
            weights,
            values_solves: vec![solve],
            log_det: workspace.log_det(),
        });
    }
    let (chosen, log_likelihoods) = choose(method, y, 0, prior, &candidates);
    Ok(Choice {
        chosen,
        log_likelihoods,
        weights: candidates.swap_remove(chosen).weights,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_best_is_the_first_largest_and_never_a_nan() {
        assert_eq!(best(&[1.0, 3.0, 3.0, 2.0]), 1);
        assert_eq!(best(&[f64::NAN, -5.0, -7.0]), 1);
        assert_eq!(best(&[f64::INFINITY, f64::INFINITY]), 0);
        assert_eq!(best(&[f64::NAN, f64::NAN]), 0);
        assert_eq!(best(&[-1.0, f64::NAN, 0.5]), 2);
    }
}
