//! Runs a plan: trials in parallel (rayon map, indexed collect), results in a fixed order.
//!
//! The unit of parallel work is one (N, trial) pair. Within it every design draws one sample
//! set, every BMC model computes its weights once, and every integrand and estimator reuses
//! them — so estimators with the same design are compared on the same points (paired), and BMC
//! and BMCP with the same model cost one Cholesky between them.

use super::plan::Plan;
use crate::bq::factor::SpdWorkspace;
use crate::bq::rule::{Rule, Values};
use crate::bq::weights::Solved;
use crate::bq::weights::{BmcWeights, Scale};
use crate::sampling::Design;
use crate::util::rng::stream;
use rayon::prelude::*;
use std::time::Instant;

/// Stream identifiers under the experiment's seed.
const SAMPLES_STREAM: u64 = 1;
const KERNEL_MEAN_STREAM: u64 = 2;
const PRIMARY_STREAM: u64 = 3;

/// What one (N, trial) unit produced.
#[derive(Debug, Clone)]
pub struct UnitResult {
    /// `estimates[integrand][estimator]`.
    pub estimates: Vec<Vec<f64>>,
    /// `uncertainty[integrand][estimator]`: the stated sd and its interval's law (None when
    /// the estimator has none, e.g. MC with N = 1).
    pub uncertainty: Vec<Vec<Option<crate::bq::estimator::Uncertainty>>>,
    /// `diagnostics[integrand][estimator]`: of the weight set the estimate used (None for MC);
    /// the same on every integrand but for a fitted model, which chooses per integrand.
    pub diagnostics: Vec<Vec<Option<crate::bq::weights::Diagnostics>>>,
    /// `warnings[integrand][estimator]`: numerical warnings of that weight set.
    pub warnings: Vec<Vec<u32>>,
    /// The warnings' messages, once per weight set.
    pub messages: Vec<String>,
    /// `fitted[integrand][estimator]`: the amplitude was fitted (`ml` or `loo`).
    pub fitted: Vec<Vec<bool>>,
    /// `chosen[integrand][estimator]`: for a fitted model, the index of the grid's model that
    /// won (math.md §9; [`crate::bq::model::BmcModel::candidates`]).
    pub chosen: Vec<Vec<Option<usize>>>,
    /// `sequential[integrand][estimator]`: where a tolerance estimator stopped (None for the
    /// others; [`super::adaptive`]).
    pub sequential: Vec<Vec<Option<crate::bq::stages::Outcome>>>,
    /// What each estimator cost ([`Cost`]); wall-clock, so outside the byte-identical outputs.
    pub cost: Cost,
}

/// Wall-clock seconds of one unit, split so that work shared between estimators is visible.
#[derive(Debug, Clone, Default)]
pub struct Cost {
    /// `weight_set[estimator]`: seconds to compute the estimator's weight set (and the fitted
    /// amplitudes that use its factor); an estimator sharing the set with others shows the
    /// same figure (0 for MC).
    pub weight_set: Vec<f64>,
    /// `seconds[integrand][estimator]`: what the estimator alone would have cost on this
    /// integrand: drawing its points, its weight set, evaluating the integrand, combining.
    pub seconds: Vec<Vec<f64>>,
    /// `evaluations[integrand][estimator]`: integrand evaluations the estimator needs (a
    /// tolerance estimator: the points it used).
    pub evaluations: Vec<Vec<u64>>,
}

impl UnitResult {
    /// Warnings of estimator `ei` on integrand `fi`: its weight set's, plus one if the estimate
    /// is not finite, plus one if a fitted amplitude is 0 (`zero_amplitude`, math.md §7).
    pub fn warnings_for(&self, fi: usize, ei: usize) -> u32 {
        self.warnings[fi][ei]
            + u32::from(!self.estimates[fi][ei].is_finite())
            + u32::from(self.zero_amplitude(fi, ei))
    }

    /// Whether estimator `ei`'s fitted amplitude on integrand `fi` is exactly 0.
    pub fn zero_amplitude(&self, fi: usize, ei: usize) -> bool {
        self.fitted[fi][ei] && self.uncertainty[fi][ei].and_then(|u| u.amplitude) == Some(0.0)
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
    let units: Vec<usize> = (0..plan.samples.len() * plan.trials).collect();
    Ok(Results {
        units: run_units(plan, &units, tick)?,
    })
}

/// Runs the given units (`u = n_index · trials + trial`) in parallel; results in their order.
pub fn run_units(plan: &Plan, units: &[usize], tick: &(dyn Fn() + Sync)) -> crate::Result<Vec<UnitResult>> {
    thread_local! {
        // One workspace per worker thread for the whole run (map_init would make one per
        // work split, churning allocations of n_max² matrices).
        static WORKSPACE: std::cell::RefCell<SpdWorkspace> = std::cell::RefCell::new(SpdWorkspace::new());
    }
    let results: Vec<crate::Result<UnitResult>> = units
        .par_iter()
        .map(|&u| {
            // A unit's integrand may re-enter a run on this thread (a Python callable calling
            // `workbench.run`, or a rayon wait stealing another unit meanwhile): the thread's
            // workspace is then in use, and the nested unit gets a fresh one. A workspace is
            // scratch space only, so the numbers are the same either way.
            let r = WORKSPACE.with(|cell| match cell.try_borrow_mut() {
                Ok(mut ws) => run_unit(plan, u / plan.trials, u % plan.trials, &mut ws),
                Err(_) => run_unit(plan, u / plan.trials, u % plan.trials, &mut SpdWorkspace::new()),
            });
            tick();
            r
        })
        .collect();
    results.into_iter().collect()
}

/// The `n` points that `design` draws in trial `trial` of an experiment with master seed `seed`:
/// every estimator with that design sees them at that N (a tolerance estimator extends them,
/// the same stream). What lets a row of `trials.csv` be reproduced outside a run.
pub fn trial_points(seed: u64, design: Design, n: usize, trial: usize) -> Vec<crate::util::geometry::Vec3> {
    design.sample_set(n, &mut trial_stream(seed, design, n, trial))
}

/// The random stream of `design`'s points in trial `trial` at `n` ([`trial_points`]).
fn trial_stream(seed: u64, design: Design, n: usize, trial: usize) -> crate::util::rng::WorkbenchRng {
    stream(
        seed,
        &[SAMPLES_STREAM, design.stream_id(), n as u64, trial as u64],
    )
}

/// The `count` primary samples of a light-aware estimator's technique (`technique`: a stream id
/// of [`crate::bq::estimator::mis`]) in trial `trial` at `n`: every estimator with the same
/// sampler sees the same ones (their first `count`), so `mc-light`, `mis` and its variants are
/// compared on the same primary samples.
pub fn primary_samples(
    seed: u64,
    sampler: crate::sampling::primary::Sampler,
    technique: u64,
    count: usize,
    n: usize,
    trial: usize,
) -> Vec<[f64; 2]> {
    let mut rng = stream(
        seed,
        &[
            PRIMARY_STREAM,
            sampler.stream_id(),
            technique,
            n as u64,
            trial as u64,
        ],
    );
    sampler.points(count, &mut rng)
}

/// One (N, trial) unit. Depends only on the plan, `n_index` and `trial`. In steps: the designs'
/// sets ([`draw_and_evaluate`]), the tolerance estimators' stages, the weight sets
/// ([`weight_sets`]), the fitted models' choices ([`choose_models`]), the estimates
/// ([`estimate_all`]), the weight sets' diagnostics and messages ([`unit_messages`]).
pub fn run_unit(
    plan: &Plan,
    n_index: usize,
    trial: usize,
    workspace: &mut SpdWorkspace,
) -> crate::Result<UnitResult> {
    let n = plan.samples[n_index];
    let draws = draw_and_evaluate(plan, n, trial)?;
    // Tolerance estimators extend the unit's set of their design (same stream, nested).
    let adaptive_clock = Instant::now();
    let adaptive = super::adaptive_unit::run_unit(plan, n, trial, &|d, count| {
        d.sample_set(count, &mut trial_stream(plan.seed, d, n, trial))
    })?;
    // Every tolerance estimator's stages, on every integrand: one shared cost, shown as such.
    let adaptive_seconds = adaptive_clock.elapsed().as_secs_f64();
    let (weights, weight_seconds) = weight_sets(plan, n, trial, &draws, workspace)?;
    let chosen = choose_models(plan, &draws, &adaptive, &weights);
    // What each estimator's weight set cost (its stages, for a tolerance estimator).
    let weight_set_seconds: Vec<f64> = plan
        .estimators
        .iter()
        .map(|e| match set_index(&weights, e) {
            _ if e.tolerance.is_some() => adaptive_seconds,
            Some(i) => weight_seconds[i],
            None => 0.0,
        })
        .collect();
    let sets = UnitSets {
        weights: &weights,
        chosen: &chosen,
    };
    let estimated = estimate_all(
        plan,
        &draws,
        &adaptive,
        &sets,
        &weight_set_seconds,
        adaptive_seconds,
    );
    let ni = plan.integrands.len();
    let (diagnostics, warnings) = unit_diagnostics(plan, &adaptive, &sets);
    let messages = unit_messages(plan, &adaptive, &sets, &diagnostics, &estimated);
    let evaluations: Vec<Vec<u64>> = (0..ni)
        .map(|fi| {
            adaptive
                .iter()
                .map(|r| r.as_ref().map_or(n as u64, |r| r.outcomes[fi].n_used as u64))
                .collect()
        })
        .collect();
    Ok(UnitResult {
        fitted: estimated
            .amplitudes
            .iter()
            .map(|row| row.iter().map(Option::is_some).collect())
            .collect(),
        estimates: estimated.estimates,
        uncertainty: estimated.uncertainty,
        diagnostics,
        warnings,
        messages,
        chosen,
        sequential: (0..ni)
            .map(|fi| {
                adaptive
                    .iter()
                    .map(|r| r.as_ref().map(|r| r.outcomes[fi]))
                    .collect()
            })
            .collect(),
        cost: Cost {
            weight_set: weight_set_seconds,
            seconds: estimated.seconds,
            evaluations,
        },
    })
}

/// A unit's points and every integrand's values on them.
struct Draws {
    /// The unit's N and trial (light-aware estimators draw their own primary samples from them).
    n: usize,
    trial: usize,
    /// `sets[design]`: the points each design of the plan draws.
    sets: Vec<Vec<crate::util::geometry::Vec3>>,
    sample_seconds: Vec<f64>,
    /// `values[integrand][design]`.
    values: Vec<Vec<Vec<f64>>>,
    evaluate_seconds: Vec<Vec<f64>>,
}

impl Draws {
    fn design_index(plan: &Plan, d: Design) -> usize {
        plan.designs
            .iter()
            .position(|&x| x == d)
            .expect("design is planned")
    }
}

/// Every design's set of the unit, and every integrand on every set, once (a scene pixel traces
/// rays): the fitted amplitudes' solves and the estimates both use them. One batch per
/// (integrand, set): an external integrand (a Python callable) is called once per set, never
/// per point.
fn draw_and_evaluate(plan: &Plan, n: usize, trial: usize) -> crate::Result<Draws> {
    let mut sample_seconds = Vec::with_capacity(plan.designs.len());
    let sets: Vec<Vec<crate::util::geometry::Vec3>> = plan
        .designs
        .iter()
        .map(|&d| {
            let clock = Instant::now();
            let set = trial_points(plan.seed, d, n, trial);
            sample_seconds.push(clock.elapsed().as_secs_f64());
            set
        })
        .collect();
    let mut evaluate_seconds = vec![vec![0.0; sets.len()]; plan.integrands.len()];
    let mut values: Vec<Vec<Vec<f64>>> = Vec::with_capacity(plan.integrands.len());
    for (fi, f) in plan.integrands.iter().enumerate() {
        let mut per_set = Vec::with_capacity(sets.len());
        for (d, s) in sets.iter().enumerate() {
            let clock = Instant::now();
            per_set.push(f.trial_values(s, trial, n, "")?);
            evaluate_seconds[fi][d] = clock.elapsed().as_secs_f64();
        }
        values.push(per_set);
    }
    Ok(Draws {
        n,
        trial,
        sets,
        sample_seconds,
        values,
        evaluate_seconds,
    })
}

/// One entry per (model, design) weight set in use: its candidates (one for a fixed model; every
/// model of the grid for a fitted one, each with its own factor, solves and log det Q).
type WeightSets = Vec<((usize, Design), Vec<SetCandidate>)>;

/// Weights per (model, design) pair in use, computed once, with their seconds. While the
/// workspace still holds a weight set's Cholesky factor, what the fitted amplitudes of the
/// estimators that use it need is solved: one O(N²) `Q⁻¹Y` per (weight set, integrand), shared
/// by every estimator of the set (each fits its amplitude from it in O(N), in
/// `Rule::estimate`), plus diag(Q⁻¹) once per weight set (O(N³)) when an estimator uses `loo`.
fn weight_sets(
    plan: &Plan,
    n: usize,
    trial: usize,
    draws: &Draws,
    workspace: &mut SpdWorkspace,
) -> crate::Result<(WeightSets, Vec<f64>)> {
    let mut weights: WeightSets = Vec::new();
    let mut weight_seconds: Vec<f64> = Vec::new();
    for e in &plan.estimators {
        let Some(m) = e.model.filter(|_| e.tolerance.is_none()) else {
            continue;
        };
        if weights.iter().any(|(k, _)| *k == (m, e.design)) {
            continue;
        }
        let clock = Instant::now();
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
        let d = Draws::design_index(plan, e.design);
        let set = &draws.sets[d];
        let sharing = |x: &&super::plan::PlannedEstimator| {
            x.model == Some(m) && x.design == e.design && x.tolerance.is_none()
        };
        let fitted_model = plan.models[m].is_fitted();
        let fitted = |x: &super::plan::PlannedEstimator| x.scale.is_some_and(|s| s != Scale::Unit);
        // A fitted model's choice needs `Q⁻¹Y` of every candidate, whatever the scale.
        let solve_values = fitted_model || plan.estimators.iter().filter(sharing).any(fitted);
        let loo = plan
            .estimators
            .iter()
            .filter(sharing)
            .any(|x| x.scale == Some(Scale::Loo));
        let models: Vec<&crate::bq::model::BmcModel> = if fitted_model {
            plan.models[m].candidates().iter().collect()
        } else {
            vec![&plan.models[m]]
        };
        let mut candidates = Vec::with_capacity(models.len());
        for model in models {
            let w = model
                .weights_for_design(set, e.design, &mut rng, workspace)
                .map_err(|source| crate::Error::Numerical {
                    what: format!("estimator {:?}, N = {n}, trial {trial}", e.label),
                    source,
                })?;
            let mut solves = SetSolves::default();
            if solve_values {
                solves.inverse_diagonal = loo.then(|| workspace.inverse_diagonal());
                solves.values = (0..plan.integrands.len())
                    .map(|fi| {
                        let mut values_solve = draws.values[fi][d].clone();
                        workspace.solve_in_place(&mut values_solve);
                        values_solve
                    })
                    .collect();
            }
            let log_det = if fitted_model {
                workspace.log_det()
            } else {
                f64::NAN
            };
            candidates.push(SetCandidate {
                weights: w,
                solves,
                log_det,
            });
        }
        weights.push(((m, e.design), candidates));
        weight_seconds.push(clock.elapsed().as_secs_f64());
    }
    Ok((weights, weight_seconds))
}

/// The weight sets of a unit and the fitted models' choices among their candidates.
struct UnitSets<'a> {
    weights: &'a WeightSets,
    /// `chosen[fi][ei]` ([`choose_models`]).
    chosen: &'a [Vec<Option<usize>>],
}

impl UnitSets<'_> {
    /// The weight set of estimator `e` (None for MC and tolerance estimators).
    fn set_of(&self, e: &super::plan::PlannedEstimator) -> Option<&[SetCandidate]> {
        set_of(self.weights, e)
    }

    /// The candidate estimator `ei` uses on integrand `fi`.
    fn candidate_of(&self, plan: &Plan, fi: usize, ei: usize) -> Option<&SetCandidate> {
        self.set_of(&plan.estimators[ei])
            .map(|set| &set[self.chosen[fi][ei].unwrap_or(0)])
    }

    fn weights_of(&self, plan: &Plan, fi: usize, ei: usize) -> Option<&BmcWeights> {
        self.candidate_of(plan, fi, ei).map(|c| &c.weights)
    }
}

/// `diagnostics[fi][ei]`: of the weight set each estimate used (a fitted model's chosen one; a
/// tolerance estimator's largest), and `warnings[fi][ei]`, how many numerical warnings it has.
#[allow(clippy::type_complexity)]
fn unit_diagnostics(
    plan: &Plan,
    adaptive: &[Option<super::adaptive_unit::UnitRun>],
    sets: &UnitSets,
) -> (Vec<Vec<Option<crate::bq::weights::Diagnostics>>>, Vec<Vec<u32>>) {
    let ni = plan.integrands.len();
    // `diagnostics[fi][ei]`: the weight set each estimate used (a fitted model's chosen one).
    let diagnostics: Vec<Vec<Option<crate::bq::weights::Diagnostics>>> = (0..ni)
        .map(|fi| {
            plan.estimators
                .iter()
                .zip(adaptive)
                .enumerate()
                .map(|(ei, (e, run))| match run {
                    Some(run) => run.diagnostics.clone(),
                    None => e.method.diagnostics(sets.weights_of(plan, fi, ei)),
                })
                .collect()
        })
        .collect();
    let warnings: Vec<Vec<u32>> = diagnostics
        .iter()
        .map(|row| {
            row.iter()
                .map(|d| d.as_ref().map_or(0, |d| d.warnings.len() as u32))
                .collect()
        })
        .collect();
    (diagnostics, warnings)
}

/// The index in `weights` of estimator `e`'s weight set (None for MC and tolerance estimators).
fn set_index(weights: &WeightSets, e: &super::plan::PlannedEstimator) -> Option<usize> {
    e.model.filter(|_| e.tolerance.is_none()).map(|m| {
        weights
            .iter()
            .position(|(k, _)| *k == (m, e.design))
            .expect("computed above")
    })
}

/// The weight set of estimator `e` among `weights` (None for MC and tolerance estimators).
fn set_of<'a>(weights: &'a WeightSets, e: &super::plan::PlannedEstimator) -> Option<&'a [SetCandidate]> {
    set_index(weights, e).map(|i| weights[i].1.as_slice())
}

/// `chosen[fi][ei]`: the grid index a fitted model chose for the estimator on the integrand
/// (the largest marginal likelihood, math.md §9; a tolerance estimator's own choice).
fn choose_models(
    plan: &Plan,
    draws: &Draws,
    adaptive: &[Option<super::adaptive_unit::UnitRun>],
    weights: &WeightSets,
) -> Vec<Vec<Option<usize>>> {
    let mut chosen: Vec<Vec<Option<usize>>> = vec![vec![None; plan.estimators.len()]; plan.integrands.len()];
    for (fi, f) in plan.integrands.iter().enumerate() {
        for (ei, e) in plan.estimators.iter().enumerate() {
            if let Some(c) = adaptive[ei].as_ref().and_then(|r| r.chosen.as_ref()) {
                chosen[fi][ei] = Some(c[fi]);
                continue;
            }
            let Some(set) =
                set_of(weights, e).filter(|_| plan.models[e.model.expect("has a set")].is_fitted())
            else {
                continue;
            };
            let y = &draws.values[fi][Draws::design_index(plan, e.design)];
            let prior = e.prior.map_or(0.0, |p| p.resolve(f.constant_prior()));
            let ells: Vec<f64> = set
                .iter()
                .map(|c| {
                    crate::bq::fitted::log_marginal_likelihood(
                        e.method
                            .points()
                            .expect("an estimator with weights is a point-set method"),
                        y,
                        &c.solves.values[fi],
                        &c.weights,
                        prior,
                        c.log_det,
                    )
                    .unwrap_or(f64::NAN)
                })
                .collect();
            chosen[fi][ei] = Some(crate::bq::fitted::best(&ells));
        }
    }
    chosen
}

/// Every (integrand, estimator)'s estimate, stated uncertainty, fitted amplitude and seconds.
struct Estimated {
    estimates: Vec<Vec<f64>>,
    uncertainty: Vec<Vec<Option<crate::bq::estimator::Uncertainty>>>,
    amplitudes: Vec<Vec<Option<f64>>>,
    seconds: Vec<Vec<f64>>,
}

/// Every estimate of the unit: a tolerance estimator's from its stages, the others from their
/// weight set (`Rule::estimate`). An estimator's seconds are what it alone would have cost:
/// drawing its points, its weight set, evaluating the integrand, combining.
fn estimate_all(
    plan: &Plan,
    draws: &Draws,
    adaptive: &[Option<super::adaptive_unit::UnitRun>],
    sets: &UnitSets,
    weight_set_seconds: &[f64],
    adaptive_seconds: f64,
) -> Estimated {
    let ni = plan.integrands.len();
    let ne = plan.estimators.len();
    let mut out = Estimated {
        estimates: Vec::with_capacity(ni),
        uncertainty: Vec::with_capacity(ni),
        amplitudes: vec![vec![None; ne]; ni],
        seconds: Vec::with_capacity(ni),
    };
    // bq-pss's weights depend on its points only (math.md §11 (a)): once per unit, shared by
    // every integrand; each integrand's cost includes them, as it alone would have paid them.
    let pss_rules: Vec<Option<(crate::bq::estimator::bq_pss::PssRule, f64)>> = plan
        .estimators
        .iter()
        .map(|e| {
            let light = e.light?;
            let clock = Instant::now();
            let (n_light, _) = light.method.counts(draws.n);
            let points = primary_samples(
                plan.seed,
                light.sampler,
                crate::bq::estimator::mis::LIGHT_TECHNIQUE,
                n_light,
                draws.n,
                draws.trial,
            );
            let rule = light.pss_rule(&points)?;
            Some((rule, clock.elapsed().as_secs_f64()))
        })
        .collect();
    for (fi, f) in plan.integrands.iter().enumerate() {
        let (values, evaluate_seconds) = (&draws.values[fi], &draws.evaluate_seconds[fi]);
        let mut row = Vec::with_capacity(ne);
        let mut sds = Vec::with_capacity(ne);
        let mut costs = Vec::with_capacity(ne);
        for (ei, e) in plan.estimators.iter().enumerate() {
            if let Some(run) = &adaptive[ei] {
                let o = run.outcomes[fi];
                row.push(o.estimate);
                sds.push(o.uncertainty);
                if run.fitted {
                    out.amplitudes[fi][ei] = o.uncertainty.and_then(|u| u.amplitude);
                }
                costs.push(adaptive_seconds);
                continue;
            }
            if let Some(light) = &e.light {
                // Draws its own directions from the integrand's techniques (math.md §11).
                let clock = Instant::now();
                let lit = f
                    .lit()
                    .expect("the plan checks that every integrand knows its light");
                if let Some((rule, rule_seconds)) = &pss_rules[ei] {
                    let (value, sd) = light.estimate_on_rule(lit, rule);
                    row.push(value);
                    sds.push(sd);
                    costs.push(clock.elapsed().as_secs_f64() + rule_seconds);
                    continue;
                }
                let (n, trial) = (draws.n, draws.trial);
                let (n_light, n_bsdf) = light.method.counts(n);
                use crate::bq::estimator::mis::{BSDF_TECHNIQUE, LIGHT_TECHNIQUE};
                let primary =
                    |technique, count| primary_samples(plan.seed, light.sampler, technique, count, n, trial);
                let (value, sd) = light.estimate(
                    lit,
                    &primary(LIGHT_TECHNIQUE, n_light),
                    &primary(BSDF_TECHNIQUE, n_bsdf),
                );
                row.push(value);
                sds.push(sd);
                costs.push(clock.elapsed().as_secs_f64());
                continue;
            }
            let clock = Instant::now();
            let d = Draws::design_index(plan, e.design);
            let prior = e.prior.map_or(0.0, |p| p.resolve(f.constant_prior()));
            let solves = sets.candidate_of(plan, fi, ei).map(|c| &c.solves);
            let rule = Rule {
                density: e.design.density(),
                points: &draws.sets[d],
                weights: sets.weights_of(plan, fi, ei),
                inverse_diagonal: solves.and_then(|s| s.inverse_diagonal.as_deref()),
            };
            let values = Values {
                y: &values[d],
                solved: solves.and_then(|s| s.values.get(fi)).map(|v| Solved::Full(v)),
            };
            let method = e
                .method
                .points()
                .expect("light-aware estimators are handled above");
            let estimate = rule.estimate(method, values, prior, e.scale.unwrap_or(Scale::Unit));
            out.amplitudes[fi][ei] = estimate.fitted_amplitude;
            row.push(estimate.value);
            sds.push(estimate.uncertainty);
            costs.push(
                draws.sample_seconds[d]
                    + weight_set_seconds[ei]
                    + evaluate_seconds[d]
                    + clock.elapsed().as_secs_f64(),
            );
        }
        out.seconds.push(costs);
        out.estimates.push(row);
        out.uncertainty.push(sds);
    }
    out
}

/// The unit's warning messages: each weight set's once (a fixed model's set, and each candidate
/// a fitted model chose somewhere in the unit: a candidate nobody chose affected no estimate),
/// the tolerance estimators', Bayes–Sard's own negative Var₁, zero amplitudes and non-finite
/// estimates.
fn unit_messages(
    plan: &Plan,
    adaptive: &[Option<super::adaptive_unit::UnitRun>],
    sets: &UnitSets,
    diagnostics: &[Vec<Option<crate::bq::weights::Diagnostics>>],
    estimated: &Estimated,
) -> Vec<String> {
    let mut messages: Vec<String> = Vec::new();
    for ((m, _), set) in sets.weights {
        for (c, candidate) in set.iter().enumerate() {
            let used = !plan.models[*m].is_fitted()
                || sets
                    .chosen
                    .iter()
                    .flatten()
                    .zip(plan.estimators.iter().cycle())
                    .any(|(&ch, e)| ch == Some(c) && e.model == Some(*m) && e.tolerance.is_none());
            if used {
                messages.extend(candidate.weights.diagnostics.warnings.iter().map(|w| w.message()));
            }
        }
    }
    messages.extend(
        adaptive
            .iter()
            .flatten()
            .filter_map(|r| r.diagnostics.as_ref())
            .flat_map(|d| d.warnings.iter().map(|m| m.message())),
    );
    // An estimator's own Var₁ (Bayes–Sard's) can be negative where the weight set's is not (MC
    // kernel means).
    for (e, d) in plan.estimators.iter().zip(&diagnostics[0]) {
        if e.method.states_own_unit_variance() && e.tolerance.is_none() {
            let d = d.as_ref().expect("an estimator with its own Var₁ has weights");
            for w in &d.warnings {
                if matches!(
                    w,
                    crate::bq::weights::NumericalWarning::NegativePosteriorVariance { .. }
                ) {
                    messages.push(w.message());
                }
            }
        }
    }
    for (fi, row) in estimated.amplitudes.iter().enumerate() {
        for (ei, a) in row.iter().enumerate() {
            if *a == Some(0.0) {
                messages.push(format!(
                    "{} ({:?} on {})",
                    crate::bq::weights::NumericalWarning::ZeroAmplitude.message(),
                    plan.estimators[ei].label,
                    plan.integrands[fi].name()
                ));
            }
        }
    }
    // A NaN or infinite estimate is numerical trouble too: reported here, and counted per
    // (integrand, estimator) row by [`UnitResult::warnings_for`].
    for (fi, row) in estimated.estimates.iter().enumerate() {
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
    messages
}

/// One model's weight set on a unit's points: its weights, what its factor solved, and (fitted
/// models) `log det Q`.
struct SetCandidate {
    weights: BmcWeights,
    solves: SetSolves,
    log_det: f64,
}

/// What a weight set's factor solved for the fitted amplitudes of the estimators that use it,
/// while the workspace held it: `Q⁻¹Y` per integrand (empty when no estimator of the set fits
/// an amplitude) and `diag(Q⁻¹)` when one uses `loo`.
#[derive(Default)]
struct SetSolves {
    values: Vec<Vec<f64>>,
    inverse_diagonal: Option<Vec<f64>>,
}
