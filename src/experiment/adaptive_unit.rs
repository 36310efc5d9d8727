//! The tolerance estimators of one (N, trial) unit ([`crate::bq::stages`]): each extends the
//! unit's set for its design to `max_n` and stops at its tolerance; called by
//! [`super::runner`].

use super::plan::{Plan, PlannedEstimator};
use crate::bq::stages::{self, Outcome};
use crate::bq::weights::Scale;
use crate::sampling::Design;
use crate::util::geometry::Vec3;

/// What one tolerance estimator produced in one unit.
#[derive(Debug, Clone)]
pub struct UnitRun {
    /// One outcome per integrand.
    pub outcomes: Vec<Outcome>,
    /// The diagnostics of the largest weight set built (None for MC).
    pub diagnostics: Option<crate::bq::weights::Diagnostics>,
    /// Whether the amplitude was fitted (`ml`, `loo`).
    pub fitted: bool,
    /// A fitted model's choice per integrand (the grid index at the last stage used).
    pub chosen: Option<Vec<usize>>,
}

/// A unit's nested set for one (design, max_n), and every integrand's values on it.
type NestedSetValues = ((Design, usize), Vec<Vec3>, Vec<Vec<f64>>);

/// Runs every tolerance estimator of the plan in the unit of sample count `n` (the first stage,
/// or the estimator's pilot `min_n` if larger; [`stages::Tolerance::stages`]); `draw(design,
/// count)` gives the unit's nested set for a design (the first `n` points are the unit's own).
/// Estimators with the same design, `max_n` and model share one nested set and its weight
/// sets. None for estimators without a tolerance.
pub fn run_unit(
    plan: &Plan,
    n: usize,
    trial: usize,
    draw: &dyn Fn(Design, usize) -> Vec<Vec3>,
) -> crate::Result<Vec<Option<UnitRun>>> {
    let mut out: Vec<Option<UnitRun>> = vec![None; plan.estimators.len()];
    // One set and its values per (design, max_n) in use.
    let mut sets: Vec<NestedSetValues> = Vec::new();
    for e in &plan.estimators {
        let Some(t) = e.tolerance else { continue };
        let key = (e.design, t.max_n);
        if !sets.iter().any(|(k, _, _)| *k == key) {
            let points = draw(e.design, t.max_n);
            let values = plan
                .integrands
                .iter()
                .map(|f| {
                    let what = format!("on a tolerance estimator's set of {} points: ", points.len());
                    f.trial_values(&points, trial, n, &what)
                })
                .collect::<crate::Result<Vec<Vec<f64>>>>()?;
            sets.push((key, points, values));
        }
    }
    for (key, points, values) in &sets {
        let stages_of = |e: &PlannedEstimator| e.tolerance.expect("a tolerance estimator").stages(n);
        let of_set = |e: &&PlannedEstimator| e.tolerance.is_some_and(|t| (e.design, t.max_n) == *key);
        // MC on the set.
        for (ei, e) in plan.estimators.iter().enumerate() {
            if !of_set(&e) || e.model.is_some() {
                continue;
            }
            let target = e.tolerance.expect("a tolerance estimator").target();
            out[ei] = Some(UnitRun {
                outcomes: values
                    .iter()
                    .map(|v| stages::mc(e.design.density(), points, v, &stages_of(e), target))
                    .collect(),
                diagnostics: None,
                fitted: false,
                chosen: None,
            });
        }
        // One nested weight family per model on the set, shared by its estimators.
        let mut models: Vec<usize> = plan
            .estimators
            .iter()
            .filter(of_set)
            .filter_map(|e| e.model)
            .collect();
        models.dedup();
        models.sort_unstable();
        models.dedup();
        for m in models {
            let users: Vec<usize> = (0..plan.estimators.len())
                .filter(|&ei| of_set(&&plan.estimators[ei]) && plan.estimators[ei].model == Some(m))
                .collect();
            let scales: Vec<Scale> = users
                .iter()
                .map(|&ei| plan.estimators[ei].scale.unwrap_or(Scale::Unit))
                .collect();
            let walkers: Vec<stages::Walker> = users
                .iter()
                .map(|&ei| {
                    let e = &plan.estimators[ei];
                    stages::Walker {
                        estimator: stages::WeightedEstimator {
                            method: e
                                .method
                                .points()
                                .expect("tolerance estimators are point-set methods"),
                            scale: e.scale.unwrap_or(Scale::Unit),
                        },
                        priors: plan
                            .integrands
                            .iter()
                            .map(|f| e.prior.map_or(0.0, |p| p.resolve(f.constant_prior())))
                            .collect(),
                        stages: stages_of(e),
                        target: e.tolerance.expect("a tolerance estimator").target(),
                    }
                })
                .collect();
            let numerical = |source| crate::Error::Numerical {
                what: format!(
                    "tolerance estimator {:?}, N₀ = {n}, trial {trial}",
                    plan.estimators[users[0]].label
                ),
                source,
            };
            // The estimators walk the stages together, so each stage is factored once (a
            // fitted model: once per grid model, every model's ℓ at every stage).
            let runs: Vec<(stages::WeightedRun, Option<Vec<usize>>)> = if plan.models[m].is_fitted() {
                let mut with_ml = scales.clone();
                with_ml.push(Scale::Ml);
                let mut candidates: Vec<stages::NestedWeights> = plan.models[m]
                    .candidates()
                    .iter()
                    .map(|model| stages::NestedWeights::new(model, points, values, &with_ml))
                    .collect();
                stages::fitted_together(&walkers, &mut candidates)
                    .map_err(numerical)?
                    .into_iter()
                    .map(|r| (r.run, Some(r.chosen)))
                    .collect()
            } else {
                let mut nested = stages::NestedWeights::new(&plan.models[m], points, values, &scales);
                stages::weighted_together(&walkers, &mut nested)
                    .map_err(numerical)?
                    .into_iter()
                    .map(|r| (r, None))
                    .collect()
            };
            for ((&ei, &scale), (r, chosen)) in users.iter().zip(&scales).zip(runs) {
                out[ei] = Some(UnitRun {
                    outcomes: r.outcomes,
                    diagnostics: Some(r.diagnostics),
                    fitted: scale != Scale::Unit,
                    chosen,
                });
            }
        }
    }
    Ok(out)
}
