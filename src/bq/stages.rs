//! Sequential estimation: grow a nested sample set by doubling until the estimator's own
//! uncertainty (math.md §7) meets a [`Target`]; README, "Stopping at a tolerance" and "Adaptive
//! sampling". One walker ([`walk`]) serves the experiments' tolerance estimators (a 95%
//! half-width per integrand) and the renderer's adaptive pixels (an sd per colour channel); the
//! weights of every stage come from one nested factor ([`NestedStages`]), and every stage's
//! estimate from [`Rule::estimate`], so any estimator with an interval can be staged.
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
use crate::bq::rule::{Estimate, Rule, Values};
use crate::bq::weights::Solved;
use crate::bq::weights::{BmcWeights, Diagnostics, Scale};
use crate::sampling::Density;
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

/// What a stage's stated uncertainty must meet for the walk to stop there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    /// The half-width of the 95% interval ([`half_width`]) at most this (a tolerance estimator).
    HalfWidth(f64),
    /// The stated sd at most this (an adaptive pixel's `--target-sd`, per channel).
    Sd(f64),
}

impl Target {
    /// Whether `u` meets the target; an estimator that states no uncertainty never does.
    pub fn met(&self, u: Option<&Uncertainty>) -> bool {
        u.is_some_and(|u| match *self {
            Target::HalfWidth(abs) => half_width(u) <= abs,
            Target::Sd(t) => u.sd <= t,
        })
    }
}

/// Where a walk stopped: what the last stage used gave, its size, and whether the target was met
/// there (rather than the stages running out).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stop<T> {
    pub at: T,
    pub n_used: usize,
    pub met: bool,
}

/// The one stopping rule: through `stages` (increasing sizes), `stage(m)` gives the stage's
/// result and whether it meets the target; the walk stops at the first stage that does, or at
/// the last. The rule looks at the stated uncertainty only, never at the truth.
///
/// # Panics
/// If `stages` is empty.
pub fn walk<T, E>(
    stages: &[usize],
    mut stage: impl FnMut(usize) -> Result<(T, bool), E>,
) -> Result<Stop<T>, E> {
    let (&last, _) = stages.split_last().expect("at least one stage");
    for &m in stages {
        let (at, met) = stage(m)?;
        if met || m == last {
            return Ok(Stop { at, n_used: m, met });
        }
    }
    unreachable!("the last stage returns")
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

/// Sequential MC on the nested set `points` (the largest stage; each point drawn from
/// `density`) with integrand values `values` (same length): the estimate and standard error of
/// each stage are [`Method::Mc`]'s on the stage's first points, so a trial that stops at `N` is
/// the fixed-N estimate at `N` exactly.
pub fn mc(density: Density, points: &[Vec3], values: &[f64], stages: &[usize], abs: f64) -> Outcome {
    let target = Target::HalfWidth(abs);
    let stop = walk(stages, |m| {
        let rule = Rule {
            density,
            points: &points[..m],
            weights: None,
            inverse_diagonal: None,
        };
        let values = Values {
            y: &values[..m],
            solved: None,
        };
        let e = rule.estimate(Method::Mc, values, 0.0, Scale::Unit);
        Ok::<_, std::convert::Infallible>((e, target.met(e.uncertainty.as_ref())))
    });
    let Ok(stop) = stop;
    Outcome::from(stop)
}

impl From<Stop<Estimate>> for Outcome {
    fn from(stop: Stop<Estimate>) -> Self {
        Outcome {
            estimate: stop.at.value,
            uncertainty: stop.at.uncertainty,
            n_used: stop.n_used,
            met: stop.met,
        }
    }
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
        let weights = stage_weights(&self.factor, m, &self.z[..m], self.model.prior_variance());
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
/// outcome per integrand, each (walker, integrand) walked on its own ([`walk`]). The stages are
/// built on demand and kept, so each is factored once, shared by every walker, and the factor
/// grows only as far as the slowest (walker, integrand) needs.
pub fn weighted_together(
    walkers: &[Walker],
    nested: &mut NestedWeights<'_>,
) -> Result<Vec<WeightedRun>, NotPositiveDefinite> {
    let mut runs = Vec::with_capacity(walkers.len());
    for walker in walkers {
        let WeightedEstimator { method, scale } = walker.estimator;
        let target = Target::HalfWidth(walker.abs);
        let mut outcomes = Vec::with_capacity(nested.values.len());
        for fi in 0..nested.values.len() {
            let stop = walk(&walker.stages, |m| {
                let i = nested.stage(m)?;
                let stage = &nested.stages[i].1;
                let rule = Rule {
                    density: Density::Uniform,
                    points: &nested.points[..m],
                    weights: Some(&stage.weights),
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
                    solved: solved.map(Solved::Full),
                };
                let e = rule.estimate(method, values, walker.priors[fi], scale);
                Ok((e, target.met(e.uncertainty.as_ref())))
            })?;
            outcomes.push(Outcome::from(stop));
        }
        // The diagnostics of the largest stage the walker used.
        let top = outcomes
            .iter()
            .map(|o| o.n_used)
            .max()
            .expect("at least one integrand");
        let i = nested.stage(top)?;
        let diagnostics = method
            .diagnostics(Some(&nested.stages[i].1.weights))
            .expect("a weighted method has diagnostics");
        runs.push(WeightedRun {
            outcomes,
            diagnostics,
        });
    }
    Ok(runs)
}

/// `w = Q⁻¹z`, `u = Q⁻¹1` and the diagnostics of stage `m` from the leading `m × m` block of a
/// nested factor (as [`crate::bq::weights::bmc_weights`] computes them from a full
/// factorisation); `z` holds the stage's `m` kernel means. The one stage-weights builder of the
/// experiments' tolerance estimators and the renderer's adaptive pixels.
pub fn stage_weights(factor: &NestedCholesky, m: usize, z: &[f64], prior_variance: f64) -> BmcWeights {
    let mut weights = z.to_vec();
    factor.solve_leading_in_place(m, &mut weights);
    let mut ones_solve = vec![1.0; m];
    factor.solve_leading_in_place(m, &mut ones_solve);
    crate::bq::weights::with_diagnostics(weights, ones_solve, factor.info(), z, prior_variance)
}
