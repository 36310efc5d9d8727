//! Sequential estimation: grow a nested sample set by doubling until the estimator's own
//! uncertainty (math.md §7) meets a [`Target`]; docs/guide/run.md, "Stopping at a tolerance",
//! and docs/guide/render.md, "Adaptive sampling". One walker ([`walk`]) serves the experiments'
//! tolerance estimators (a half-width per integrand) and the renderer's adaptive pixels (an sd
//! per colour channel); the weights of
//! every stage come from one nested factor ([`NestedWeights`]), and every stage's estimate from
//! [`Rule::estimate`], so any estimator with an interval can be staged.
//!
//! Stages `N₀, 2N₀, 4N₀, …` up to `max_n` (the last stage is the largest of these not above
//! `max_n`); a tolerance's first stage is the larger of the caller's first size and its pilot
//! `min_n` ([`Tolerance::stages`]). After each stage the estimator states its interval
//! `Î ± q·sd` (the same law as a fixed-N run: Student-t for MC and for the `ml` amplitude, normal
//! otherwise) and stops when the half-width `inflate · q_level · sd ≤ abs` (by default `level`
//! 0.95 and `inflate` 1, as QMCPy's `CubMCCLT` states its rule), or at the last stage. The rule
//! looks at the interval only, never at the truth. For MC this is the classical sequential CLT
//! rule (stop when `t_{0.975, N−1} s/√N ≤ abs`; `CubMCCLT` fixes the sample count after a pilot
//! instead of doubling). For BMC, BMCP and Bayes–Sard the point set is nested, so each stage's
//! factor extends the previous one by blocks ([`crate::bq::factor::nested`]) and the weights,
//! `Var₁` and the fitted amplitude `λ̂ = rᵀQ⁻¹r/N` are recomputed from it.
//!
//! **The guard** (math.md §9, "Stopping with a guard"): a stage whose fitted amplitude is exactly
//! 0 (every residual 0) or whose MC sample sd is exactly 0 states a zero-width interval from no
//! evidence of variation at all — typically a small feature none of its samples saw — so it
//! never meets a target ([`Verdict::ZeroEvidence`]); the walk doubles on and counts the stage.
//! A fitted amplitude on samples that are all equal is zero evidence too ([`Target::judge_stage`]):
//! BMCP's prior constant makes its residuals non-zero when every sample is 0, and its interval
//! then rests on that constant, not on anything the samples saw.
//! An integrand that really is constant on the samples therefore runs to the last stage.
//!
//! Caveat, as for every interval built from the samples (math.md §7): when the samples miss a
//! small feature but see some variation elsewhere, the interval is too narrow and the rule can
//! still stop too early; the pilot `min_n` is the remedy there.

use crate::bq::estimator::{Method, Uncertainty};
use crate::bq::factor::NotPositiveDefinite;
use crate::bq::factor::nested::NestedCholesky;
use crate::bq::model::BmcModel;
use crate::bq::rule::{Estimate, Rule, Values};
use crate::bq::weights::Solved;
use crate::bq::weights::{BmcWeights, Diagnostics, Scale};
use crate::sampling::Density;
use crate::util::geometry::Vec3;

/// The pilot when a tolerance names none: a feature covering a share `p` of the hemisphere is
/// seen by one of `N` uniform points with probability `1 − (1 − p)^N`, so 64 points see a share
/// of 4.6% with 95% (math.md §9).
pub const DEFAULT_MIN_N: usize = 64;
/// The interval level of a tolerance's half-width when it names none.
pub const DEFAULT_LEVEL: f64 = 0.95;
/// The factor on a tolerance's half-width when it names none.
pub const DEFAULT_INFLATE: f64 = 1.0;

/// Stop when `inflate ×` the half-width of the interval at `level` is at most `abs`, or at
/// `max_n` points; never before `min_n` points.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Tolerance {
    /// The absolute tolerance on the (inflated) half-width (> 0).
    pub abs: f64,
    /// The most points a trial may use (≥ the first stage and ≥ `min_n`).
    pub max_n: usize,
    /// The pilot: the fewest points a stage may have (1 ≤ `min_n` ≤ `max_n`).
    pub min_n: usize,
    /// The level of the interval whose half-width is compared with `abs` (in (0, 1)).
    pub level: f64,
    /// The factor on that half-width (≥ 1).
    pub inflate: f64,
}

impl Tolerance {
    /// `abs` and `max_n` with the default pilot ([`DEFAULT_MIN_N`]; [`Tolerance::stages`]
    /// panics if `max_n` is below it), level and inflation.
    pub fn new(abs: f64, max_n: usize) -> Self {
        Tolerance {
            abs,
            max_n,
            min_n: DEFAULT_MIN_N,
            level: DEFAULT_LEVEL,
            inflate: DEFAULT_INFLATE,
        }
    }

    /// The stage sizes from the first stage `first` or the pilot `min_n`, whichever is larger:
    /// [`doubling`] from there up to `max_n`.
    ///
    /// # Panics
    /// If `first` is 0 or either start is above `max_n`.
    pub fn stages(&self, first: usize) -> Vec<usize> {
        assert!(first <= self.max_n, "first stage {first}, max_n {}", self.max_n);
        doubling(first.max(self.min_n), self.max_n)
    }

    /// The half-width the rule compares with `abs`: `inflate · q_level · sd`.
    pub fn half_width(&self, u: &Uncertainty) -> f64 {
        self.inflate * u.quantile(self.level) * u.sd
    }

    /// The target of every stage.
    pub fn target(&self) -> Target {
        Target::HalfWidth(*self)
    }
}

/// Stage sizes `first · 2^k ≤ max_n`.
///
/// # Panics
/// If `first` is 0 or above `max_n`.
pub fn doubling(first: usize, max_n: usize) -> Vec<usize> {
    assert!(first >= 1 && first <= max_n, "first stage {first}, max_n {max_n}");
    let mut out = vec![first];
    while let Some(next) = out.last().unwrap().checked_mul(2).filter(|&m| m <= max_n) {
        out.push(next);
    }
    out
}

/// The half-width `q₀.₉₇₅ · sd` of the 95% interval, whatever a tolerance's level and
/// inflation (`stopping_trials.csv`'s `half_width95`).
pub fn half_width(u: &Uncertainty) -> f64 {
    u.quantile(0.95) * u.sd
}

/// Whether `u` comes from zero evidence: a fitted amplitude of exactly 0 (every residual 0), or
/// an MC sample sd of exactly 0 (every term equal). A unit amplitude is never zero evidence.
pub fn zero_evidence(u: &Uncertainty) -> bool {
    match u.amplitude {
        Some(amplitude) => amplitude == 0.0,
        None => u.sd == 0.0,
    }
}

/// Whether the sample values `y` are all the same (none, or one, count as the same): the
/// samples saw no variation at all.
pub fn flat(y: &[f64]) -> bool {
    y.iter().all(|&v| v == y[0])
}

/// What a stage's stated uncertainty must meet for the walk to stop there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    /// The tolerance's half-width ([`Tolerance::half_width`]) at most its `abs` (a tolerance
    /// estimator; its stages are not part of the target).
    HalfWidth(Tolerance),
    /// The stated sd at most this (an adaptive pixel's `--target-sd`, per channel).
    Sd(f64),
}

/// What a stage's stated uncertainty says about a [`Target`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// The target is met: the walk stops here.
    Met,
    /// Not met: the walk goes on (an estimator that states no uncertainty is never met).
    Short,
    /// A zero-width interval from zero evidence ([`zero_evidence`]): not met, and counted.
    ZeroEvidence,
}

impl Verdict {
    /// The verdict on quantities judged together (an adaptive pixel's colour channels): zero
    /// evidence if any has zero evidence, met if every one is met, short otherwise.
    pub fn all(verdicts: impl IntoIterator<Item = Verdict>) -> Verdict {
        let mut out = Verdict::Met;
        for v in verdicts {
            match v {
                Verdict::ZeroEvidence => return Verdict::ZeroEvidence,
                Verdict::Short => out = Verdict::Short,
                Verdict::Met => {}
            }
        }
        out
    }
}

impl Target {
    /// The verdict on `u`: zero evidence never meets the target, whatever its width.
    pub fn judge(&self, u: Option<&Uncertainty>) -> Verdict {
        let Some(u) = u else {
            return Verdict::Short;
        };
        if zero_evidence(u) {
            return Verdict::ZeroEvidence;
        }
        let met = match self {
            Target::HalfWidth(t) => t.half_width(u) <= t.abs,
            Target::Sd(t) => u.sd <= *t,
        };
        if met { Verdict::Met } else { Verdict::Short }
    }

    /// The verdict on a stage whose weighted estimator stated `u` with amplitude `scale` from
    /// the sample values `y`: as [`Target::judge`], and zero evidence too when the amplitude is
    /// fitted (not [`Scale::Unit`], whose interval never rests on the values) and every value is
    /// the same ([`flat`]). BMCP's residuals `Y − c` are not 0 when every sample is 0, so its
    /// fitted amplitude is not 0 either, but its samples saw no more than BMC's: a BMCP trial
    /// whose pilot missed a light must not stop there on the prior constant alone.
    pub fn judge_stage(&self, u: Option<&Uncertainty>, y: &[f64], scale: Scale) -> Verdict {
        if u.is_some() && scale != Scale::Unit && flat(y) {
            return Verdict::ZeroEvidence;
        }
        self.judge(u)
    }

    /// Whether `u` meets the target ([`Target::judge`] says [`Verdict::Met`]).
    pub fn met(&self, u: Option<&Uncertainty>) -> bool {
        self.judge(u) == Verdict::Met
    }
}

/// Where a walk stopped: what the last stage used gave, its size, whether the target was met
/// there (rather than the stages running out), and how many of the stages walked had zero
/// evidence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stop<T> {
    pub at: T,
    pub n_used: usize,
    pub met: bool,
    pub zero_evidence: usize,
}

/// The one stopping rule: through `stages` (increasing sizes), `stage(m)` gives the stage's
/// result and its [`Verdict`]; the walk stops at the first stage that is met, or at the last.
/// Zero-evidence stages are never met, only counted. The rule looks at the stated uncertainty
/// only, never at the truth.
///
/// # Panics
/// If `stages` is empty.
pub fn walk<T, E>(
    stages: &[usize],
    mut stage: impl FnMut(usize) -> Result<(T, Verdict), E>,
) -> Result<Stop<T>, E> {
    let (&last, _) = stages.split_last().expect("at least one stage");
    let mut zero_evidence = 0;
    for &m in stages {
        let (at, verdict) = stage(m)?;
        zero_evidence += usize::from(verdict == Verdict::ZeroEvidence);
        let met = verdict == Verdict::Met;
        if met || m == last {
            return Ok(Stop {
                at,
                n_used: m,
                met,
                zero_evidence,
            });
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
    /// Whether the rule stopped it (half-width ≤ abs, with evidence) rather than `max_n`.
    pub met: bool,
    /// The stages walked whose interval came from zero evidence (each one doubled on).
    pub zero_evidence: usize,
}

/// Sequential MC on the nested set `points` (the largest stage; each point drawn from
/// `density`) with integrand values `values` (same length): the estimate and standard error of
/// each stage are [`Method::Mc`]'s on the stage's first points, so a trial that stops at `N` is
/// the fixed-N estimate at `N` exactly.
pub fn mc(density: Density, points: &[Vec3], values: &[f64], stages: &[usize], target: Target) -> Outcome {
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
        Ok::<_, std::convert::Infallible>((e, target.judge(e.uncertainty.as_ref())))
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
            zero_evidence: stop.zero_evidence,
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
    /// `log det Q` of the stage (a fitted model's choice, math.md §9).
    log_det: f64,
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
                log_det: self.factor.log_det(),
            },
        ));
        Ok(self.stages.len() - 1)
    }
}

/// One sequential weighted estimator on a [`NestedWeights`]: its method and amplitude, the
/// prior constant per integrand (BMCP), its stages and the target every stage is judged by.
#[derive(Clone, Debug)]
pub struct Walker {
    pub estimator: WeightedEstimator,
    pub priors: Vec<f64>,
    pub stages: Vec<usize>,
    pub target: Target,
}

impl NestedWeights<'_> {
    /// The estimate of `walker` on integrand `fi` at stage `m` (built already, at index `i`),
    /// with the stage's verdict on it.
    fn stage_estimate(&self, i: usize, m: usize, fi: usize, walker: &Walker) -> (Estimate, Verdict) {
        let WeightedEstimator { method, scale } = walker.estimator;
        let stage = &self.stages[i].1;
        let rule = Rule {
            density: Density::Uniform,
            points: &self.points[..m],
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
        let y = &self.values[fi][..m];
        let values = Values {
            y,
            solved: solved.map(Solved::Full),
        };
        let e = rule.estimate(method, values, walker.priors[fi], scale);
        let verdict = walker.target.judge_stage(e.uncertainty.as_ref(), y, scale);
        (e, verdict)
    }

    /// `ℓ` of this model for `walker`'s method on integrand `fi` at stage `m` (built already,
    /// at index `i`; its values solved): math.md §9.
    fn log_likelihood(&self, i: usize, m: usize, fi: usize, walker: &Walker) -> f64 {
        let stage = &self.stages[i].1;
        let solve = &stage
            .values_solve
            .as_ref()
            .expect("a fitted model's candidates solve their values")[fi];
        crate::bq::fitted::log_marginal_likelihood(
            walker.estimator.method,
            &self.values[fi][..m],
            solve,
            &stage.weights,
            walker.priors[fi],
            stage.log_det,
        )
        .unwrap_or(f64::NAN)
    }

    /// The diagnostics of stage `m` (built already) as `method` sees them.
    fn diagnostics(&mut self, m: usize, method: Method) -> Result<Diagnostics, NotPositiveDefinite> {
        let i = self.stage(m)?;
        Ok(method
            .diagnostics(Some(&self.stages[i].1.weights))
            .expect("a weighted method has diagnostics"))
    }
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
        let mut outcomes = Vec::with_capacity(nested.values.len());
        for fi in 0..nested.values.len() {
            let stop = walk(&walker.stages, |m| {
                let i = nested.stage(m)?;
                Ok(nested.stage_estimate(i, m, fi, walker))
            })?;
            outcomes.push(Outcome::from(stop));
        }
        // The diagnostics of the largest stage the walker used.
        let top = outcomes
            .iter()
            .map(|o| o.n_used)
            .max()
            .expect("at least one integrand");
        let diagnostics = nested.diagnostics(top, walker.estimator.method)?;
        runs.push(WeightedRun {
            outcomes,
            diagnostics,
        });
    }
    Ok(runs)
}

/// What a sequential run with a fitted model produced: the run, and per integrand the index of
/// the grid model chosen at the last stage used.
#[derive(Clone, Debug)]
pub struct FittedRun {
    pub run: WeightedRun,
    pub chosen: Vec<usize>,
}

/// Sequential estimation with a fitted model (math.md §9): `candidates` holds one
/// [`NestedWeights`] per grid model, in grid order, on the same nested set and values (each
/// made with [`Scale::Ml`] among its scales, so that every stage solves its values). At every
/// stage each (walker, integrand) takes the model of largest `ℓ` on the stage's points and
/// values ([`crate::bq::fitted`]; ties: the first), whose estimate and interval the target
/// judges — the choice a fixed-N run makes on that many points — and the walk goes on as
/// [`weighted_together`]'s. Every candidate's factor grows with the stages walked.
pub fn fitted_together(
    walkers: &[Walker],
    candidates: &mut [NestedWeights<'_>],
) -> Result<Vec<FittedRun>, NotPositiveDefinite> {
    let integrands = candidates[0].values.len();
    let mut runs = Vec::with_capacity(walkers.len());
    for walker in walkers {
        let mut outcomes = Vec::with_capacity(integrands);
        let mut chosen = Vec::with_capacity(integrands);
        for fi in 0..integrands {
            let mut choice = 0;
            let stop = walk(&walker.stages, |m| {
                let mut ells = Vec::with_capacity(candidates.len());
                let mut at = Vec::with_capacity(candidates.len());
                for c in candidates.iter_mut() {
                    let i = c.stage(m)?;
                    ells.push(c.log_likelihood(i, m, fi, walker));
                    at.push(i);
                }
                choice = crate::bq::fitted::best(&ells);
                Ok(candidates[choice].stage_estimate(at[choice], m, fi, walker))
            })?;
            outcomes.push(Outcome::from(stop));
            chosen.push(choice);
        }
        // The diagnostics of the largest stage used, of the model chosen there.
        let top = (0..integrands)
            .rev()
            .max_by_key(|&fi| outcomes[fi].n_used)
            .expect("at least one integrand");
        let diagnostics =
            candidates[chosen[top]].diagnostics(outcomes[top].n_used, walker.estimator.method)?;
        runs.push(FittedRun {
            run: WeightedRun {
                outcomes,
                diagnostics,
            },
            chosen,
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
