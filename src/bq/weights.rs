//! Bayesian Monte Carlo weights, posterior variance and diagnostics (math.md §4).
//!
//! `Q = K + σ_n² I`, `w = Q⁻¹ z` by Cholesky, `Var(I | D) = V̂ − zᵀ Q⁻¹ z = V̂ − zᵀ w`.
//! BMC is `Î = wᵀ Y`; BMCP with constant prior `c` is `Î = 2πc + wᵀ (Y − c·1)`; both use the
//! same weights.

use crate::bq::factor::{FactorInfo, ILL_CONDITIONED, NotPositiveDefinite, SpdWorkspace};
use crate::bq::kernel::Kernel;
use crate::util::geometry::Vec3;
use serde::{Deserialize, Serialize};

/// The thesis's observation noise σ_n².
pub const DEFAULT_NOISE: f64 = 0.01;

/// The kernel amplitude `λ` of the prior `f ~ GP(f̄, λk)` (nugget scaled too, so `Q` becomes
/// `λQ`): the weights and estimates do not depend on it, only the posterior variance
/// `λ · Var₁` does (math.md §7).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Scale {
    /// `λ = 1` (the thesis): `Î ± z sqrt(Var₁)`. Not equivariant: multiplying `f` by 1000
    /// multiplies the error by 1000 but leaves the interval as it was.
    Unit,
    /// Maximum marginal likelihood, `λ̂ = rᵀQ⁻¹r / N` (`N − 1` for Bayes–Sard); with `λ`
    /// integrated out under `p(λ) ∝ 1/λ` the interval is Student-t with that many degrees of
    /// freedom (Briol et al., "Probabilistic integration: a role in statistical computation?",
    /// Statist. Sci. 2019, §4.1; Karvonen & Oates, "Maximum likelihood estimation in Gaussian
    /// process regression is ill-posed", JMLR 2023, for why only the amplitude is fitted).
    /// O(N²) per trial: one solve with the existing factor.
    Ml,
    /// Leave-one-out, `λ̂ = (1/N) Σ_i (Q⁻¹r)_i² / (Q⁻¹)_ii` (the mean squared LOO residual
    /// standardised by its unit-amplitude variance); normal interval. Needs `diag(Q⁻¹)`:
    /// O(N³) per weight set.
    Loo,
}

impl Scale {
    pub const ALL: [Scale; 3] = [Scale::Unit, Scale::Ml, Scale::Loo];
    /// What an estimator gets without a `"scale"`: see docs/guide/findings.md ("How far to trust the
    /// error bars").
    pub const DEFAULT: Scale = Scale::Ml;

    pub fn name(self) -> &'static str {
        match self {
            Scale::Unit => "unit",
            Scale::Ml => "ml",
            Scale::Loo => "loo",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }
}

/// The fitted amplitude `λ̂` for residuals `r = Y − F̄` (math.md §7), given `solved = Q⁻¹r`
/// (from the factor the weights came from): `ml` is `rᵀQ⁻¹r / dof`, `loo` is
/// `(1/N) Σ (Q⁻¹r)_i² / (Q⁻¹)_ii` with `inverse_diagonal = diag(Q⁻¹)` (see
/// [`SpdWorkspace::inverse_diagonal`]); `unit` is 1. O(N) given the solve. All residuals exactly
/// 0 give exactly 0 (a [`NumericalWarning::ZeroAmplitude`] for the caller to count).
///
/// Never 0 by overflow (issue 30): `rᵀQ⁻¹r` is summed on `r / 2^k` (`2^k` the largest `|r_i|`'s
/// power of two, an exact scaling, so every finite result keeps its bits) and scaled back, so
/// values near 1e155 give `+∞` instead of `∞ − ∞ = NaN`, which `max(0)` turned into 0; and a NaN
/// left by an overflowed solve of finite residuals is `+∞` ([`overflowed_to_infinity`]).
///
/// # Panics
/// With `loo` and no `inverse_diagonal`, or mismatched lengths.
pub fn fit_amplitude(
    scale: Scale,
    residuals: &[f64],
    solved: &[f64],
    dof: usize,
    inverse_diagonal: Option<&[f64]>,
) -> f64 {
    if let Some(amplitude) = fixed_amplitude(scale, residuals) {
        return amplitude;
    }
    match scale {
        Scale::Unit => unreachable!("fixed_amplitude returns it"),
        // rᵀQ⁻¹r ≥ 0 for SPD Q; the clamp only guards rounding (and keeps a NaN a NaN).
        Scale::Ml => {
            let k = power_of_two_scale(residuals);
            let scaled: f64 = residuals.iter().zip(solved).map(|(r, s)| (r / k) * s).sum();
            let v = scaled / dof as f64 * k;
            overflowed_to_infinity(if v < 0.0 { 0.0 } else { v }, residuals)
        }
        Scale::Loo => {
            let d = inverse_diagonal.expect("loo needs diag(Q⁻¹)");
            assert_eq!(d.len(), solved.len(), "one diagonal entry per point");
            let v = solved.iter().zip(d).map(|(ai, di)| ai * ai / di).sum::<f64>() / solved.len() as f64;
            overflowed_to_infinity(v, residuals)
        }
    }
}

/// The power of two `2^k ≤ max |x_i| < 2^(k+1)`, 1 when that is 0, subnormal or not finite:
/// dividing by it is exact, so it rescales sums of products without changing a finite result's
/// bits.
pub fn power_of_two_scale(x: &[f64]) -> f64 {
    let m = x.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    if m.is_normal() {
        // Clearing the mantissa leaves the largest power of two not above m.
        f64::from_bits(m.to_bits() & 0x7ff0_0000_0000_0000)
    } else {
        1.0
    }
}

/// A fitted amplitude of finite residuals is `rᵀQ⁻¹r / d ≥ 0`; NaN there comes only from an
/// overflow in the solve or the sum (`∞ − ∞`), so it is `+∞`: a stated sd that overflows is
/// infinite, never 0 (issue 30). Non-finite residuals keep their NaN.
fn overflowed_to_infinity(amplitude: f64, residuals: &[f64]) -> f64 {
    if amplitude.is_nan() && residuals.iter().all(|r| r.is_finite()) {
        f64::INFINITY
    } else {
        amplitude
    }
}

/// The amplitudes that need no solve: 1 for `unit`, and exactly 0 when every residual is 0
/// (whatever the scale fitted).
fn fixed_amplitude(scale: Scale, residuals: &[f64]) -> Option<f64> {
    if scale == Scale::Unit {
        Some(1.0)
    } else if residuals.iter().all(|&r| r == 0.0) {
        Some(0.0)
    } else {
        None
    }
}

/// `Y` solved with a factor `Q = L Lᵀ`.
#[derive(Clone, Copy, Debug)]
pub enum Solved<'a> {
    /// `Q⁻¹Y`: every amplitude (`ml`, `loo`).
    Full(&'a [f64]),
    /// `L⁻¹Y` and `L⁻¹1`: what a pixel extends stage by stage on a nested factor (the leading
    /// rows of `L⁻¹Y` are the earlier stages' own), enough for `ml`, whose `rᵀQ⁻¹r = ‖L⁻¹r‖²`.
    Half { y: &'a [f64], ones: &'a [f64] },
}

/// [`fit_amplitude`] from `half = L⁻¹r` (`Q = L Lᵀ`) instead of `Q⁻¹r`: `ml` is
/// `‖L⁻¹r‖² / dof` (`rᵀQ⁻¹r = ‖L⁻¹r‖²`); `unit` is 1; all residuals exactly 0 give exactly 0.
///
/// # Panics
/// With `loo`, which needs `Q⁻¹r` itself.
pub fn fit_amplitude_half(scale: Scale, residuals: &[f64], half: &[f64], dof: usize) -> f64 {
    if let Some(amplitude) = fixed_amplitude(scale, residuals) {
        return amplitude;
    }
    match scale {
        Scale::Unit => unreachable!("fixed_amplitude returns it"),
        Scale::Ml => overflowed_to_infinity(half.iter().map(|y| y * y).sum::<f64>() / dof as f64, residuals),
        Scale::Loo => panic!("the loo amplitude needs Q⁻¹r, not L⁻¹r"),
    }
}

/// A numerical event worth telling the user about; counted per weight set.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum NumericalWarning {
    /// The factorisation needed jitter on the diagonal.
    Jitter { amount: f64 },
    /// The condition estimate of `Q` exceeds [`ILL_CONDITIONED`].
    IllConditioned { estimate: f64 },
    /// `V̂ − zᵀ Q⁻¹ z` came out negative (`value`, kept raw in
    /// [`Diagnostics::posterior_variance`]); it is reported as 0 (math.md §7: "clamp a negative
    /// `Var₁` to 0 and count a warning"). A true posterior variance cannot be negative: with
    /// exact `z` and `V̂` it is `≥ 0` up to rounding. It happens when the `z_i` are MC estimates
    /// `ẑ = z + δ` (the thesis's mode) while `V̂` is exact: `ẑᵀQ⁻¹ẑ = zᵀQ⁻¹z + 2wᵀδ + δᵀQ⁻¹δ`,
    /// and the last term is positive on average, `E = tr(Q⁻¹ Cov δ)`, and large because `Q⁻¹`
    /// has eigenvalues up to `1/σ_n²` (`rule --n 512 --kernel-mean mc`: −2.3 with fresh
    /// directions per point, −0.058 with one shared set).
    NegativePosteriorVariance { value: f64 },
    /// A fitted amplitude (`ml` or `loo`, math.md §7) is exactly 0: every residual vanished
    /// (e.g. no sample saw a small light, so `Y ≡ 0` for BMC), so the interval is a point.
    /// That is absence of evidence, not certainty; the trial is kept in coverage.
    ZeroAmplitude,
}

impl NumericalWarning {
    /// One line with the remedy.
    pub fn message(&self) -> String {
        match self {
            NumericalWarning::Jitter { amount } => format!(
                "Cholesky of Q needed jitter {amount:.3e} on the diagonal; \
                 increase the noise σ_n² or avoid (near-)duplicate points"
            ),
            NumericalWarning::IllConditioned { estimate } => format!(
                "Q is ill-conditioned (condition estimate {estimate:.3e}); \
                 increase the noise σ_n² or use fewer points"
            ),
            // The words before " (" are the same for every value: experiment reports group
            // warnings by them.
            NumericalWarning::NegativePosteriorVariance { value } => format!(
                "the posterior variance V̂ − zᵀQ⁻¹z is negative ({value:.3e}) and is reported as 0, \
                 so the posterior sd and credible intervals mean nothing; MC kernel means cause \
                 this: use the exact kernel mean (\"kernel_mean\": \"exact\"), \
                 or, if it is already exact, increase the noise σ_n²"
            ),
            NumericalWarning::ZeroAmplitude => "zero_amplitude: every residual is 0, so the fitted \
                 amplitude λ̂ is 0 and the interval is a single point (absence of evidence, not \
                 certainty); use more samples, or the unit scale for this integrand"
                .to_string(),
        }
    }
}

/// Everything worth knowing about one weight set.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Diagnostics {
    pub n: usize,
    /// `Σ w_i`; the integral of the constant 1 is 2π, which it approaches as N grows.
    pub weight_sum: f64,
    pub negative_weights: usize,
    pub min_weight: f64,
    pub max_weight: f64,
    /// Jitter added to the diagonal of `Q` (0 when none).
    pub jitter: f64,
    /// See [`FactorInfo::condition_estimate`].
    pub condition_estimate: f64,
    /// `V̂`.
    pub prior_variance: f64,
    /// `V̂ − zᵀ Q⁻¹ z` as computed, so possibly negative (then a
    /// [`NumericalWarning::NegativePosteriorVariance`] is among the warnings). Everything
    /// reported as a variance or sd uses [`Diagnostics::posterior_variance_clamped`].
    pub posterior_variance: f64,
    pub warnings: Vec<NumericalWarning>,
}

impl Diagnostics {
    /// The diagnostics of `weights` from a factor with `info`: their statistics, `V̂`, the
    /// posterior variance, and the factor's `warnings` with the negative-variance one if due.
    fn of(
        weights: &[f64],
        posterior_variance: f64,
        mut warnings: Vec<NumericalWarning>,
        info: FactorInfo,
        prior_variance: f64,
    ) -> Self {
        warnings.extend(negative_variance_warning(posterior_variance));
        let stats = WeightStats::of(weights);
        Diagnostics {
            n: weights.len(),
            weight_sum: stats.sum,
            negative_weights: stats.negative,
            min_weight: stats.min,
            max_weight: stats.max,
            jitter: info.jitter,
            condition_estimate: info.condition_estimate,
            prior_variance,
            posterior_variance,
            warnings,
        }
    }

    /// The posterior variance as reported: `max(V̂ − zᵀ Q⁻¹ z, 0)` (math.md §7).
    pub fn posterior_variance_clamped(&self) -> f64 {
        self.posterior_variance.max(0.0)
    }
}

/// BMC weights for a point set, with their diagnostics.
#[derive(Clone, Debug)]
pub struct BmcWeights {
    pub weights: Vec<f64>,
    /// `u = Q⁻¹ 1`, for Bayes–Sard quadrature (math.md §8) and its residuals `Y − β̂ 1`.
    pub ones_solve: Vec<f64>,
    pub diagnostics: Diagnostics,
}

impl BmcWeights {
    /// Posterior standard deviation of the integral (0 if rounding made the variance negative).
    pub fn posterior_sd(&self) -> f64 {
        // sqrt(max(V̂ − zᵀQ⁻¹z, 0)): 0 also when MC kernel means made the variance negative;
        // a NegativePosteriorVariance warning then says so.
        self.diagnostics.posterior_variance_clamped().sqrt()
    }

    /// `(2π − 1ᵀw) / 1ᵀu`: the multiple of `u = Q⁻¹1` that Bayes–Sard quadrature adds to the
    /// BMC weights so that they sum to `2π` (math.md §8).
    pub fn bayes_sard_shift(&self) -> f64 {
        let sum_u: f64 = self.ones_solve.iter().sum();
        (std::f64::consts::TAU - self.diagnostics.weight_sum) / sum_u
    }

    /// `β̂ = 1ᵀQ⁻¹Y / 1ᵀQ⁻¹1`, the generalised-least-squares constant of Bayes–Sard quadrature.
    pub fn bayes_sard_constant(&self, values: &[f64]) -> f64 {
        dot(&self.ones_solve, values) / self.ones_solve.iter().sum::<f64>()
    }

    /// Bayes–Sard quadrature's unit-amplitude posterior variance (math.md §8; Karvonen, Oates &
    /// Särkkä, "A Bayes–Sard cubature method", NeurIPS 2018, Theorem 2.7 with a constant
    /// function space): `Var₁ = V̂ − zᵀQ⁻¹z + (2π − 1ᵀQ⁻¹z)² / (1ᵀQ⁻¹1)`, raw (not clamped).
    pub fn bayes_sard_variance(&self) -> f64 {
        let sum_u: f64 = self.ones_solve.iter().sum();
        let gap = std::f64::consts::TAU - self.diagnostics.weight_sum;
        self.diagnostics.posterior_variance + gap * gap / sum_u
    }

    /// The Bayes–Sard rule on the same points: weights `w_BS = w + u (2π − 1ᵀw) / (1ᵀu)` (sum
    /// `2π` to rounding, so constants are integrated exactly) and diagnostics with §8's `Var₁`
    /// as the posterior variance (Karvonen, Oates & Särkkä 2018).
    pub fn bayes_sard(&self) -> BmcWeights {
        let shift = self.bayes_sard_shift();
        let weights: Vec<f64> = self
            .weights
            .iter()
            .zip(&self.ones_solve)
            .map(|(w, u)| w + shift * u)
            .collect();
        let posterior_variance = self.bayes_sard_variance();
        let warnings: Vec<NumericalWarning> = self
            .diagnostics
            .warnings
            .iter()
            .filter(|w| !matches!(w, NumericalWarning::NegativePosteriorVariance { .. }))
            .cloned()
            .collect();
        let factor = FactorInfo {
            jitter: self.diagnostics.jitter,
            condition_estimate: self.diagnostics.condition_estimate,
        };
        let diagnostics = Diagnostics::of(
            &weights,
            posterior_variance,
            warnings,
            factor,
            self.diagnostics.prior_variance,
        );
        BmcWeights {
            weights,
            ones_solve: self.ones_solve.clone(),
            diagnostics,
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "weights and values differ in length");
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The worst-case error of a quadrature rule in the kernel's RKHS (K without noise):
///
/// `e(w) = sqrt(V̂ − 2 wᵀz + wᵀ K w)`, the norm of the error functional `f ↦ ∫_H f − Σ w_i f(x_i)`,
/// so `|∫_H f dω − Σ w_i f(x_i)| ≤ ‖f‖_H · e(w)` for every `f` in the RKHS (Cauchy–Schwarz; see
/// Briol et al., "Probabilistic integration", Statist. Sci. 2019, §2). Costs N² kernel evaluations.
pub fn worst_case_error(
    points: &[Vec3],
    weights: &[f64],
    z: &[f64],
    prior_variance: f64,
    kernel: &Kernel,
) -> f64 {
    let soa = crate::bq::kernel::PointsSoa::new(points);
    let mut column = vec![0.0; points.len()];
    let mut wkw = 0.0;
    for (j, wj) in weights.iter().enumerate() {
        kernel.fill_column(&soa, j, 0, &mut column);
        wkw += wj * dot(weights, &column);
    }
    (prior_variance - 2.0 * dot(weights, z) + wkw).max(0.0).sqrt()
}

/// `Σ w_i`, how many are negative, the smallest and the largest weight.
struct WeightStats {
    sum: f64,
    negative: usize,
    min: f64,
    max: f64,
}

impl WeightStats {
    fn of(weights: &[f64]) -> Self {
        WeightStats {
            sum: weights.iter().sum(),
            negative: weights.iter().filter(|&&w| w < 0.0).count(),
            min: weights.iter().copied().fold(f64::INFINITY, f64::min),
            max: weights.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        }
    }
}

/// The counted warning for a negative raw posterior variance (math.md §7: clamp it to 0, count
/// it), if it is one.
fn negative_variance_warning(posterior_variance: f64) -> Option<NumericalWarning> {
    (posterior_variance < 0.0).then_some(NumericalWarning::NegativePosteriorVariance {
        value: posterior_variance,
    })
}

/// The noise σ_n² must be finite and ≥ 0.
pub fn validate_noise(noise: f64) -> Result<f64, String> {
    if noise.is_finite() && noise >= 0.0 {
        Ok(noise)
    } else {
        Err(format!(
            "noise must be finite and >= 0, got {}",
            crate::util::shown::shown(noise)
        ))
    }
}

/// Computes `w = Q⁻¹ z` for `points` with kernel means `z` and prior variance `V̂`.
///
/// `Q` is assembled from its lower triangle only; the workspace is reused between calls.
pub fn bmc_weights(
    points: &[Vec3],
    z: &[f64],
    prior_variance: f64,
    kernel: &Kernel,
    noise: f64,
    workspace: &mut SpdWorkspace,
) -> Result<BmcWeights, NotPositiveDefinite> {
    let n = points.len();
    assert_eq!(z.len(), n, "one kernel mean per point");
    let info = workspace.factor_gram(points, kernel, noise)?;
    let mut weights = z.to_vec();
    workspace.solve_in_place(&mut weights);
    // One more O(N²) solve, for Bayes–Sard and its residuals.
    let mut ones_solve = vec![1.0; n];
    workspace.solve_in_place(&mut ones_solve);
    Ok(with_diagnostics(weights, ones_solve, info, z, prior_variance))
}

/// The weights on a ring set ([`crate::sampling::rings`]) by the `J × J` solve of
/// [`crate::bq::factor::rings`]: the same numbers as [`bmc_weights`] to rounding, in `O(N J²)`
/// instead of `O(N³)`. `z` must be constant on each ring (exact kernel means are, since they
/// depend on the height only); otherwise this falls back to [`bmc_weights`]. The ring factor
/// stays in `workspace` for later solves (`Q⁻¹Y`, `diag(Q⁻¹)`).
pub fn bmc_weights_on_rings(
    points: &[Vec3],
    layout: crate::sampling::rings::RingLayout,
    z: &[f64],
    prior_variance: f64,
    kernel: &Kernel,
    noise: f64,
    workspace: &mut SpdWorkspace,
) -> Result<BmcWeights, NotPositiveDefinite> {
    let per_ring = layout.per_ring;
    assert_eq!(z.len(), layout.rings * per_ring, "one kernel mean per point");
    let ring_constant = z.chunks(per_ring).all(|ring| ring.iter().all(|&v| v == ring[0]));
    if !ring_constant {
        return bmc_weights(points, z, prior_variance, kernel, noise, workspace);
    }
    let factor = crate::bq::factor::rings::RingFactor::new(points, layout, kernel, noise)?;
    let z_ring: Vec<f64> = z.iter().step_by(per_ring).copied().collect();
    let weights = factor.solve_ring_constant(&z_ring);
    let ones_solve = factor.solve_ring_constant(&vec![1.0; layout.rings]);
    let info = factor.info();
    workspace.hold_rings(factor);
    Ok(with_diagnostics(weights, ones_solve, info, z, prior_variance))
}

/// Weights and `u = Q⁻¹1` with their diagnostics and warnings (for every factorisation: dense,
/// ring, and the nested one of [`crate::bq::stages`]).
pub(crate) fn with_diagnostics(
    weights: Vec<f64>,
    ones_solve: Vec<f64>,
    info: FactorInfo,
    z: &[f64],
    prior_variance: f64,
) -> BmcWeights {
    let FactorInfo {
        jitter,
        condition_estimate,
    } = info;
    let mut warnings = Vec::new();
    if jitter > 0.0 {
        warnings.push(NumericalWarning::Jitter { amount: jitter });
    }
    if condition_estimate > ILL_CONDITIONED {
        warnings.push(NumericalWarning::IllConditioned {
            estimate: condition_estimate,
        });
    }
    let posterior_variance = prior_variance - dot(z, &weights);
    let diagnostics = Diagnostics::of(&weights, posterior_variance, warnings, info, prior_variance);
    BmcWeights {
        weights,
        ones_solve,
        diagnostics,
    }
}
