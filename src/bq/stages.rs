//! Sequential estimation: grow a nested sample set by doubling until the estimator's own 95%
//! interval (math.md §7) is narrow enough; README, "Stopping at a tolerance".
//!
//! Stages `N₀, 2N₀, 4N₀, …` up to `max_n` (the last stage is the largest of these not above
//! `max_n`). After each stage the estimator states its interval `Î ± q·sd` (the same law as a
//! fixed-N run: Student-t for MC and for the `ml` amplitude, normal otherwise) and stops when the
//! half-width `q₀.₉₇₅ · sd ≤ abs`, or at the last stage. The rule looks at the interval only,
//! never at the truth. For MC this is the classical sequential CLT rule (stop when
//! `t_{0.975, N−1} s/√N ≤ abs`; cf. QMCPy's `CubMCCLT`, which fixes the sample count after a
//! pilot instead of doubling). For BMC, BMCP and Bayes–Sard the point set is nested, so each
//! stage's factor extends the previous one by blocks ([`crate::bq::factor::nested`]) and the
//! weights, `Var₁` and the fitted amplitude `λ̂ = rᵀQ⁻¹r/N` are recomputed from it.
//!
//! Caveat, as for every interval built from the samples (math.md §7): when the samples miss a
//! small feature the interval is too narrow, and the rule stops too early; a fitted amplitude
//! of 0 (every residual 0) stops at the first stage.

use crate::bq::estimator::{Method, Uncertainty};
use crate::bq::factor::NotPositiveDefinite;
use crate::bq::factor::nested::NestedCholesky;
use crate::bq::model::BmcModel;
use crate::bq::rule::{Rule, Values};
use crate::bq::weights::{BmcWeights, Diagnostics, Scale};
use crate::sampling::Design;
use crate::util::geometry::Vec3;

/// The interval level whose half-width is compared with the tolerance.
pub const LEVEL: f64 = 0.95;

/// Stop when the 95% half-width is at most `abs`, or at `max_n` points.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Tolerance {
    /// The absolute tolerance on the 95% half-width (> 0).
    pub abs: f64,
    /// The most points a trial may use (≥ the first stage).
    pub max_n: usize,
}

impl Tolerance {
    /// The stage sizes from the first stage `first`: `first · 2^k ≤ max_n`.
    ///
    /// # Panics
    /// If `first` is 0 or above `max_n`.
    pub fn stages(&self, first: usize) -> Vec<usize> {
        assert!(
            first >= 1 && first <= self.max_n,
            "first stage {first}, max_n {}",
            self.max_n
        );
        let mut out = vec![first];
        while let Some(next) = out.last().unwrap().checked_mul(2).filter(|&m| m <= self.max_n) {
            out.push(next);
        }
        out
    }
}

/// The half-width `q · sd` of the interval at [`LEVEL`].
pub fn half_width(u: &Uncertainty) -> f64 {
    u.quantile(LEVEL) * u.sd
}

/// Where one integrand's sequential estimate stopped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outcome {
    /// The estimate at the last stage used.
    pub estimate: f64,
    /// Its stated uncertainty (None only if the estimator has none at that size).
    pub uncertainty: Option<Uncertainty>,
    /// The points used: the size of the last stage.
    pub n_used: usize,
    /// Whether the rule stopped it (half-width ≤ abs) rather than `max_n`.
    pub met: bool,
}

/// Whether `u`'s half-width meets `abs`.
fn meets(u: Option<&Uncertainty>, abs: f64) -> bool {
    u.is_some_and(|u| half_width(u) <= abs)
}

/// Sequential MC on the nested set `points` (the largest stage; each point drawn from
/// `density`) with integrand values `values` (same length): the estimate and standard error of
/// each stage are [`Method::Mc`]'s on the stage's first points, so a trial that stops at `N` is
/// the fixed-N estimate at `N` exactly.
pub fn mc(density: Design, points: &[Vec3], values: &[f64], stages: &[usize], abs: f64) -> Outcome {
    let mut last = None;
    for &m in stages {
        let (p, v) = (&points[..m], &values[..m]);
        let u = Method::Mc.uncertainty(density, p, v, None, Scale::Unit, 1.0);
        let outcome = Outcome {
            estimate: Method::Mc.estimate(density, p, v, None, 0.0),
            uncertainty: u,
            n_used: m,
            met: meets(u.as_ref(), abs),
        };
        if outcome.met {
            return outcome;
        }
        last = Some(outcome);
    }
    last.expect("at least one stage")
}

/// One weighted estimator (`bmc`, `bmcp`, `bsq`) with its amplitude.
#[derive(Clone, Copy, Debug)]
pub struct WeightedEstimator {
    pub method: Method,
    pub scale: Scale,
}

/// What a sequential weighted run produced.
#[derive(Clone, Debug)]
pub struct WeightedRun {
    /// One outcome per integrand.
    pub outcomes: Vec<Outcome>,
    /// The diagnostics of the largest weight set used (as the estimator sees them).
    pub diagnostics: Diagnostics,
}

/// One stage of a [`NestedWeights`]: its weights and the solves its estimators share, made
/// while the stage's factor is current (a later stage's extension overwrites nothing, but the
/// solves need the stage's own leading block, so they are made once, up front).
struct Stage {
    weights: BmcWeights,
    /// `diag(Q⁻¹)`, when a `loo` estimator uses the set.
    inverse_diagonal: Option<Vec<f64>>,
    /// `Q⁻¹Y` per integrand, when a fitted amplitude uses the set.
    values_solve: Option<Vec<Vec<f64>>>,
}

/// BMC weight sets on the growing prefixes of one nested point set, built on demand and shared
/// by every estimator that uses the set and model (a sweep over tolerances, BMC beside BMCP): the
/// factor is extended by blocks ([`NestedCholesky`]), never recomputed.
pub struct NestedWeights<'a> {
    model: &'a BmcModel,
    points: &'a [Vec3],
    values: &'a [Vec<f64>],
    soa: crate::bq::kernel::PointsSoa,
    z: Vec<f64>,
    factor: NestedCholesky,
    stages: Vec<(usize, Stage)>,
    /// Which per-stage solves the estimators need: `Q⁻¹Y` (`ml`, `loo`) and `diag(Q⁻¹)` (`loo`).
    needs: (bool, bool),
}

impl<'a> NestedWeights<'a> {
    /// For the nested set `points` (the largest stage) and the integrands' values on it. The
    /// model's kernel mean must be exact (the MC modes draw the `z_i` per set, so their sets are
    /// not nested); its table gives the `z_i`. `scales` are the amplitudes of the estimators
    /// that will use it (they decide which solves each stage makes).
    pub fn new(model: &'a BmcModel, points: &'a [Vec3], values: &'a [Vec<f64>], scales: &[Scale]) -> Self {
        NestedWeights {
            model,
            points,
            values,
            soa: crate::bq::kernel::PointsSoa::new(points),
            z: points.iter().map(|p| model.table().z(p.z)).collect(),
            factor: NestedCholesky::with_capacity(points.len()),
            stages: Vec::new(),
            needs: (
                scales.iter().any(|&s| s != Scale::Unit),
                scales.contains(&Scale::Loo),
            ),
        }
    }

    /// Full refactorisations forced by a failed block extension (see [`NestedCholesky`]).
    pub fn refactorisations(&self) -> usize {
        self.factor.refactorisations()
    }

    /// The index of stage `m` in `self.stages`, factoring up to it if needed. Stages are asked
    /// for in increasing order of `m` by each estimator, so the factor only grows.
    fn stage(&mut self, m: usize) -> Result<usize, NotPositiveDefinite> {
        if let Some(i) = self.stages.iter().position(|(n, _)| *n == m) {
            return Ok(i);
        }
        assert!(
            m > self.factor.n(),
            "stage {m} requested after {}",
            self.factor.n()
        );
        let diag = self.model.kernel.diagonal() + self.model.noise;
        let soa = &self.soa;
        let kernel = &self.model.kernel;
        self.factor.extend_to(m, |j, start, col| {
            kernel.fill_column(soa, j, start, col);
            if start == j {
                col[0] = diag;
            }
        })?;
        let weights = stage_weights(&self.factor, &self.z[..m], self.model.prior_variance());
        let values_solve = self.needs.0.then(|| {
            self.values
                .iter()
                .map(|v| {
                    let mut solved = v[..m].to_vec();
                    self.factor.solve_in_place(&mut solved);
                    solved
                })
                .collect()
        });
        let inverse_diagonal = self.needs.1.then(|| self.factor.inverse_diagonal());
        self.stages.push((
            m,
            Stage {
                weights,
                inverse_diagonal,
                values_solve,
            },
        ));
        Ok(self.stages.len() - 1)
    }
}

/// One sequential weighted estimator on a [`NestedWeights`]: its method and amplitude, the
/// prior constant per integrand (BMCP), its stages and its tolerance.
#[derive(Clone, Debug)]
pub struct Walker {
    pub estimator: WeightedEstimator,
    pub priors: Vec<f64>,
    pub stages: Vec<usize>,
    pub abs: f64,
}

/// Sequential BMC / BMCP / Bayes–Sard on the weight sets of `nested`, one run per walker and one
/// outcome per integrand. The walkers move through the stages together, so each stage is
/// factored once and the factor grows only as far as the slowest (walker, integrand) needs.
pub fn weighted_together(
    walkers: &[Walker],
    nested: &mut NestedWeights<'_>,
) -> Result<Vec<WeightedRun>, NotPositiveDefinite> {
    let count = nested.values.len();
    let mut all: Vec<usize> = walkers.iter().flat_map(|w| w.stages.iter().copied()).collect();
    all.sort_unstable();
    all.dedup();
    let mut outcomes: Vec<Vec<Option<Outcome>>> = vec![vec![None; count]; walkers.len()];
    let mut diagnostics: Vec<Option<Diagnostics>> = vec![None; walkers.len()];
    for m in all {
        if outcomes.iter().flatten().all(Option::is_some) {
            break;
        }
        let i = nested.stage(m)?;
        let stage = &nested.stages[i].1;
        for (wi, walker) in walkers.iter().enumerate() {
            if !walker.stages.contains(&m) || outcomes[wi].iter().all(Option::is_some) {
                continue;
            }
            let WeightedEstimator { method, scale } = walker.estimator;
            let final_stage = walker.stages.last() == Some(&m);
            let w = &stage.weights;
            for (fi, slot) in outcomes[wi].iter_mut().enumerate() {
                if slot.is_some() {
                    continue;
                }
                let rule = Rule {
                    density: Design::Uniform,
                    points: &nested.points[..m],
                    weights: Some(w),
                    inverse_diagonal: stage.inverse_diagonal.as_deref(),
                };
                let solved = (scale != Scale::Unit).then(|| {
                    stage
                        .values_solve
                        .as_ref()
                        .expect("NestedWeights::new was told the scale")[fi]
                        .as_slice()
                });
                let values = Values {
                    y: &nested.values[fi][..m],
                    solved,
                };
                let e = rule.estimate(method, values, walker.priors[fi], scale);
                let met = meets(e.uncertainty.as_ref(), walker.abs);
                if met || final_stage {
                    *slot = Some(Outcome {
                        estimate: e.value,
                        uncertainty: e.uncertainty,
                        n_used: m,
                        met,
                    });
                }
            }
            diagnostics[wi] = method.diagnostics(Some(w));
        }
    }
    Ok(outcomes
        .into_iter()
        .zip(diagnostics)
        .map(|(o, d)| WeightedRun {
            outcomes: o
                .into_iter()
                .map(|o| o.expect("the last stage decides"))
                .collect(),
            diagnostics: d.expect("at least one stage"),
        })
        .collect())
}

/// `w = Q⁻¹z`, `u = Q⁻¹1` and the diagnostics of the factored stage (as
/// [`crate::bq::weights::bmc_weights`] computes them from a full factorisation).
fn stage_weights(factor: &NestedCholesky, z: &[f64], prior_variance: f64) -> BmcWeights {
    let mut weights = z.to_vec();
    factor.solve_in_place(&mut weights);
    let mut ones_solve = vec![1.0; z.len()];
    factor.solve_in_place(&mut ones_solve);
    crate::bq::weights::with_diagnostics(weights, ones_solve, factor.info(), z, prior_variance)
}
