//! Runs a plan: trials in parallel (rayon map, indexed collect), results in a fixed order.
//!
//! The unit of parallel work is one (N, trial) pair. Within it every design draws one sample
//! set, every BMC model computes its weights once, and every integrand and estimator reuses
//! them — so estimators with the same design are compared on the same points (paired), and BMC
//! and BMCP with the same model cost one Cholesky between them.

use super::plan::Plan;
use crate::bmc::BmcWeights;
use crate::linalg::SpdWorkspace;
use crate::rng::stream;
use crate::sampling::SetDesign;
use rayon::prelude::*;

/// Stream identifiers under the experiment's seed.
const SAMPLES_STREAM: u64 = 1;
const KERNEL_MEAN_STREAM: u64 = 2;

/// What one (N, trial) unit produced.
#[derive(Debug, Clone)]
pub struct UnitResult {
    /// `estimates[integrand][estimator]`.
    pub estimates: Vec<Vec<f64>>,
    /// Posterior standard deviation per estimator (None for MC).
    pub posterior_sd: Vec<Option<f64>>,
    /// The diagnostics of each estimator's weight set (None for MC).
    pub diagnostics: Vec<Option<crate::bmc::Diagnostics>>,
    /// Numerical warnings of each estimator's weight set.
    pub warnings: Vec<u32>,
    /// The warnings' messages, once per weight set.
    pub messages: Vec<String>,
}

impl UnitResult {
    /// Warnings of estimator `ei` on integrand `fi`: its weight set's, plus one if the estimate
    /// is not finite.
    pub fn warnings_for(&self, fi: usize, ei: usize) -> u32 {
        self.warnings[ei] + u32::from(!self.estimates[fi][ei].is_finite())
    }
}

/// All results: `units[n_index * trials + trial]`.
#[derive(Debug, Clone)]
pub struct Results {
    pub units: Vec<UnitResult>,
}

impl Results {
    pub fn unit(&self, plan: &Plan, n_index: usize, trial: usize) -> &UnitResult {
        &self.units[n_index * plan.trials + trial]
    }
}

/// Runs every unit; `tick` is called once per finished unit (for a progress bar).
pub fn run(plan: &Plan, tick: &(dyn Fn() + Sync)) -> crate::Result<Results> {
    let units = plan.samples.len() * plan.trials;
    thread_local! {
        // One workspace per worker thread for the whole run (map_init would make one per
        // work split, churning allocations of n_max² matrices).
        static WORKSPACE: std::cell::RefCell<SpdWorkspace> = std::cell::RefCell::new(SpdWorkspace::new());
    }
    let results: Vec<crate::Result<UnitResult>> = (0..units)
        .into_par_iter()
        .map(|u| {
            let r = WORKSPACE.with_borrow_mut(|ws| run_unit(plan, u / plan.trials, u % plan.trials, ws));
            tick();
            r
        })
        .collect();
    Ok(Results {
        units: results.into_iter().collect::<crate::Result<_>>()?,
    })
}

/// One (N, trial) unit. Depends only on the plan, `n_index` and `trial`.
pub fn run_unit(
    plan: &Plan,
    n_index: usize,
    trial: usize,
    workspace: &mut SpdWorkspace,
) -> crate::Result<UnitResult> {
    let n = plan.samples[n_index];
    let sets: Vec<Vec<crate::geometry::Vec3>> = plan
        .designs
        .iter()
        .map(|&d| {
            d.sample_set(
                n,
                &mut stream(
                    plan.seed,
                    &[SAMPLES_STREAM, d.stream_id(), n as u64, trial as u64],
                ),
            )
        })
        .collect();
    let set_of = |d: SetDesign| {
        &sets[plan
            .designs
            .iter()
            .position(|&x| x == d)
            .expect("design is planned")]
    };

    // Weights per (model, design) pair in use, computed once.
    let mut weights: Vec<((usize, SetDesign), BmcWeights)> = Vec::new();
    for e in &plan.estimators {
        let Some(m) = e.model else { continue };
        if weights.iter().any(|(k, _)| *k == (m, e.design)) {
            continue;
        }
        let mut rng = stream(
            plan.seed,
            &[
                KERNEL_MEAN_STREAM,
                m as u64,
                e.design.stream_id(),
                n as u64,
                trial as u64,
            ],
        );
        let w = plan.models[m]
            .weights(set_of(e.design), &mut rng, workspace)
            .map_err(|source| crate::Error::Numerical {
                what: format!("estimator {:?}, N = {n}, trial {trial}", e.label),
                source,
            })?;
        weights.push(((m, e.design), w));
    }
    let weights_of = |e: &super::plan::PlannedEstimator| {
        e.model.map(|m| {
            &weights
                .iter()
                .find(|(k, _)| *k == (m, e.design))
                .expect("computed above")
                .1
        })
    };

    let mut estimates = Vec::with_capacity(plan.integrands.len());
    for f in &plan.integrands {
        let values: Vec<Vec<f64>> = sets
            .iter()
            .map(|s| s.iter().map(|w| f.value(w)).collect())
            .collect();
        let row: Vec<f64> = plan
            .estimators
            .iter()
            .map(|e| {
                let d = plan
                    .designs
                    .iter()
                    .position(|&x| x == e.design)
                    .expect("design is planned");
                let prior = e.prior.map_or(0.0, |p| p.resolve(f.constant_prior()));
                e.method
                    .estimate(e.design.density(), &sets[d], &values[d], weights_of(e), prior)
            })
            .collect();
        estimates.push(row);
    }
    let warnings: Vec<u32> = plan
        .estimators
        .iter()
        .map(|e| weights_of(e).map_or(0, |w| w.diagnostics.warnings.len() as u32))
        .collect();
    let mut messages: Vec<String> = weights
        .iter()
        .flat_map(|(_, w)| w.diagnostics.warnings.iter().map(|m| m.message()))
        .collect();
    // A NaN or infinite estimate is numerical trouble too: reported here, and counted per
    // (integrand, estimator) row by [`UnitResult::warnings_for`].
    for (fi, row) in estimates.iter().enumerate() {
        for (ei, est) in row.iter().enumerate() {
            if !est.is_finite() {
                messages.push(format!(
                    "non-finite estimate ({est}) from {:?} on {}; check the integrand and raise the noise σ_n²",
                    plan.estimators[ei].label,
                    plan.integrands[fi].name()
                ));
            }
        }
    }
    Ok(UnitResult {
        estimates,
        posterior_sd: plan
            .estimators
            .iter()
            .map(|e| e.method.posterior_sd(weights_of(e)))
            .collect(),
        diagnostics: plan
            .estimators
            .iter()
            .map(|e| weights_of(e).map(|w| w.diagnostics.clone()))
            .collect(),
        warnings,
        messages,
    })
}
