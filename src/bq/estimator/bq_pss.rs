//! `bq-pss`: Bayesian quadrature in primary sample space (math.md §11 (a)), on the one-sample
//! MIS integrand of a light-aware integrand ([`crate::integrand::lit::Lit`]).
//!
//! With one primary sample `u ∈ [0, 1)²` shared by the light and the BSDF technique (Crespo et
//! al. 2021) and balance weights with `n_t = 1`,
//!
//! `G(u) = f(x_L) / (p_L(x_L) + p_B(x_L)) + f(x_B) / (p_L(x_B) + p_B(x_B))`, `x_t = T_t(u)`,
//!
//! has `∫_{[0,1]²} G du = I` (Veach's one-sample MIS), and each term is at most `f / max_t p_t`:
//! the warp flattens the sun. Each point costs two evaluations of `f` (two rays), so `bq-pss` at a
//! budget of `N` evaluations uses `N/2` points, as `mis` pairs `N/2` light with `N/2` BSDF samples.
//!
//! The model is a GP on `G` with a product Sobolev kernel ([`crate::bq::kernel::primary`]),
//! whose kernel mean is the constant 1, so with `Q = K` (jitter only if Cholesky needs it) and
//! `u = Q⁻¹1` (by Cholesky) the weights depend on the points only:
//! - `bmc`: `Î = uᵀG`, `Var₁ = 1 − 1ᵀu`, amplitude `λ̂ = GᵀQ⁻¹G / M` (`M` points), Student-t
//!   with `M` degrees of freedom: today's BMC with its default `ml` scale (math.md §7);
//! - `bsq` (Bayes–Sard, §8): weights `u / 1ᵀu` (summing to 1), so `Î = β̂ = 1ᵀQ⁻¹G / 1ᵀQ⁻¹1`,
//!   `Var₁ = (1 − 1ᵀu) + (1 − 1ᵀu)² / 1ᵀu = (1 − 1ᵀu) / 1ᵀu`, `λ̂ = rᵀQ⁻¹r / (M − 1)`, `r = G − β̂`;
//! - `equal` (ablation: RQMC on the same points): `Î = mean G`, sd `s/√M` (the i.i.d. formula,
//!   which overstates the error of a scrambled net);
//! - `cv` (ablation: regression control variate, Salaün et al., "Regression-based Monte Carlo
//!   integration", SIGGRAPH 2022): a polynomial `P` of total degree ≤ the order fitted to `G` by
//!   least squares, `Î = ∫P + mean(G − P)`, sd `sqrt(Σ r² / (M − p)) / √M` with `p` coefficients —
//!   Bayes–Sard with the kernel switched off. With `M ≤ p` points it is `equal`.
//!
//! The points are an Owen-scrambled Sobol set, a fresh scramble per trial (or pixel), so each is
//! uniform and the estimate unbiased in practice (the tests check the mean within 4 SE of the
//! certified truth).

use super::Uncertainty;
use crate::bq::factor::dense::SpdWorkspace;
use crate::bq::factor::{Factor, NotPositiveDefinite};
use crate::bq::kernel::primary::SobolevOrder;
use serde::{Deserialize, Serialize};

/// How `bq-pss` weights its points: the two quadratures and the two ablations (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum PssWeights {
    /// BMC, `w = Q⁻¹1`.
    #[default]
    Bmc,
    /// Bayes–Sard, `w = Q⁻¹1 / 1ᵀQ⁻¹1`.
    Bsq,
    /// Equal weights `1/M` (RQMC).
    Equal,
    /// A least-squares polynomial control variate.
    Cv,
}

impl PssWeights {
    pub const ALL: [PssWeights; 4] = [
        PssWeights::Bmc,
        PssWeights::Bsq,
        PssWeights::Equal,
        PssWeights::Cv,
    ];

    /// The name in files.
    pub fn name(self) -> &'static str {
        match self {
            PssWeights::Bmc => "bmc",
            PssWeights::Bsq => "bsq",
            PssWeights::Equal => "equal",
            PssWeights::Cv => "cv",
        }
    }

    /// Whether the weights need the kernel's factor.
    pub fn needs_kernel(self) -> bool {
        matches!(self, PssWeights::Bmc | PssWeights::Bsq)
    }
}

/// `bq-pss`'s options.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PssOptions {
    pub order: SobolevOrder,
    pub weights: PssWeights,
}

impl Default for PssOptions {
    fn default() -> Self {
        PssOptions {
            order: SobolevOrder::One,
            weights: PssWeights::Bmc,
        }
    }
}

/// A point set in `[0, 1)²` with its kernel weights, computed once (the kernel mean is 1, so
/// they do not depend on the integrand): reuse it for every integrand, pixel and channel.
/// `G` is [`super::mis::mis_integrand`].
#[derive(Clone, Debug)]
pub struct PssRule {
    pub order: SobolevOrder,
    pub points: Vec<[f64; 2]>,
    /// `u = Q⁻¹1`, the BMC weights.
    pub bmc_weights: Vec<f64>,
    /// `1ᵀQ⁻¹1`.
    pub ones_sum: f64,
    /// The jitter added to `Q`'s diagonal (0 unless Cholesky needed it).
    pub jitter: f64,
    factor: Factor,
}

impl PssRule {
    /// Factors `Q = K(points, points)` (Cholesky, the shared jitter ladder) and solves `Q u = 1`.
    pub fn new(points: Vec<[f64; 2]>, order: SobolevOrder) -> Result<Self, NotPositiveDefinite> {
        let n = points.len();
        let mut ws = SpdWorkspace::new();
        let info = ws.factor_entries(n, |i, j| order.eval(&points[i], &points[j]))?;
        let mut u = vec![1.0; n];
        ws.solve_in_place(&mut u);
        Ok(PssRule {
            order,
            ones_sum: u.iter().sum(),
            bmc_weights: u,
            jitter: info.jitter,
            factor: ws.keep_factor(),
            points,
        })
    }

    /// The weights of `kind` (`equal`: `1/M`; `cv` has none independent of `G`: `equal`).
    pub fn weights(&self, kind: PssWeights) -> Vec<f64> {
        match kind {
            PssWeights::Bmc => self.bmc_weights.clone(),
            PssWeights::Bsq => self.bmc_weights.iter().map(|w| w / self.ones_sum).collect(),
            PssWeights::Equal | PssWeights::Cv => vec![1.0 / self.points.len() as f64; self.points.len()],
        }
    }

    /// The unit-amplitude posterior variance of `bmc` (`1 − 1ᵀQ⁻¹1`, raw) or `bsq`
    /// (`(1 − 1ᵀQ⁻¹1) / 1ᵀQ⁻¹1`); None for the ablations.
    pub fn unit_variance(&self, kind: PssWeights) -> Option<f64> {
        let gap = 1.0 - self.ones_sum;
        match kind {
            PssWeights::Bmc => Some(gap),
            PssWeights::Bsq => Some(gap / self.ones_sum),
            PssWeights::Equal | PssWeights::Cv => None,
        }
    }

    /// `Î` and its stated uncertainty from `G` at the points (module docs), O(M²) for the kernel
    /// weights (one solve for the amplitude), O(M) for the ablations.
    pub fn estimate(&self, kind: PssWeights, g: &[f64]) -> (f64, Option<Uncertainty>) {
        let m = self.points.len();
        assert_eq!(g.len(), m, "one value per point");
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        match kind {
            PssWeights::Bmc | PssWeights::Bsq => {
                let mut solved = g.to_vec();
                self.factor.solve_columns_in_place(&mut solved, 1);
                let (value, quad, dof) = if kind == PssWeights::Bmc {
                    (dot(&self.bmc_weights, g), dot(g, &solved), m)
                } else {
                    let beta = dot(&self.bmc_weights, g) / self.ones_sum;
                    // rᵀQ⁻¹r with Q⁻¹r = Q⁻¹G − β u.
                    let q: f64 = g
                        .iter()
                        .zip(&solved)
                        .zip(&self.bmc_weights)
                        .map(|((gi, si), ui)| (gi - beta) * (si - beta * ui))
                        .sum();
                    (beta, q, m.saturating_sub(1))
                };
                let var1 = self.unit_variance(kind).expect("kernel weights").max(0.0);
                let uncertainty = (dof >= 1).then(|| {
                    let amplitude = (quad / dof as f64).max(0.0);
                    Uncertainty {
                        sd: (amplitude * var1).sqrt(),
                        dof: Some(dof),
                        amplitude: Some(amplitude),
                    }
                });
                (value, uncertainty)
            }
            PssWeights::Equal => equal_weights(g),
            PssWeights::Cv => {
                let p = polynomial_terms(self.order);
                if m <= p {
                    return equal_weights(g);
                }
                control_variate(self.order, &self.points, g)
            }
        }
    }
}

fn equal_weights(g: &[f64]) -> (f64, Option<Uncertainty>) {
    let m = g.len();
    let value = g.iter().sum::<f64>() / m as f64;
    let uncertainty = (m >= 2).then(|| Uncertainty {
        sd: crate::util::stats::sample_sd(g) / (m as f64).sqrt(),
        dof: Some(m - 1),
        amplitude: None,
    });
    (value, uncertainty)
}

/// Coefficients of a polynomial of total degree ≤ the order in two variables.
fn polynomial_terms(order: SobolevOrder) -> usize {
    match order {
        SobolevOrder::One => 3,
        SobolevOrder::Two => 6,
    }
}

/// The centred monomials `1, a, b (, a², ab, b²)` at `u` (`a = u₁ − ½`, `b = u₂ − ½`), and
/// their integrals over `[0, 1]²` (`∫a² = 1/12`, the odd ones 0).
fn monomials(order: SobolevOrder, u: &[f64; 2]) -> Vec<f64> {
    let (a, b) = (u[0] - 0.5, u[1] - 0.5);
    match order {
        SobolevOrder::One => vec![1.0, a, b],
        SobolevOrder::Two => vec![1.0, a, b, a * a, a * b, b * b],
    }
}

fn monomial_integrals(order: SobolevOrder) -> Vec<f64> {
    match order {
        SobolevOrder::One => vec![1.0, 0.0, 0.0],
        SobolevOrder::Two => vec![1.0, 0.0, 0.0, 1.0 / 12.0, 0.0, 1.0 / 12.0],
    }
}

/// Least squares by the normal equations `(AᵀA) c = AᵀG`, factored by Cholesky (`p ≤ 6`
/// centred monomials: well conditioned on points spread over the square).
fn control_variate(order: SobolevOrder, points: &[[f64; 2]], g: &[f64]) -> (f64, Option<Uncertainty>) {
    let p = polynomial_terms(order);
    let rows: Vec<Vec<f64>> = points.iter().map(|u| monomials(order, u)).collect();
    let mut ws = SpdWorkspace::new();
    let fitted = ws.factor_entries(p, |i, j| rows.iter().map(|r| r[i] * r[j]).sum());
    if fitted.is_err() {
        return equal_weights(g);
    }
    let mut c: Vec<f64> = (0..p)
        .map(|i| rows.iter().zip(g).map(|(r, y)| r[i] * y).sum())
        .collect();
    ws.solve_in_place(&mut c);
    let residuals: Vec<f64> = rows
        .iter()
        .zip(g)
        .map(|(r, y)| y - r.iter().zip(&c).map(|(a, b)| a * b).sum::<f64>())
        .collect();
    let m = g.len();
    let integral: f64 = monomial_integrals(order).iter().zip(&c).map(|(a, b)| a * b).sum();
    let value = integral + residuals.iter().sum::<f64>() / m as f64;
    let dof = m - p;
    let rss: f64 = residuals.iter().map(|r| r * r).sum();
    let uncertainty = Some(Uncertainty {
        sd: (rss / dof as f64).sqrt() / (m as f64).sqrt(),
        dof: Some(dof),
        amplitude: None,
    });
    (value, uncertainty)
}

/// `K` rules of `M` points each drawn by `sampler` (Owen-scrambled Sobol, a fresh scramble per
/// set, or independent uniform points) from the streams `(seed, M, set)`: for a renderer that
/// reuses a few sets across pixels (pick one per pixel at random, math.md §11 (a)), weights
/// computed once here. The points are used as drawn: a shift would move them off the points
/// `Q` was factored for (the product Sobolev kernels are not periodic), so the weights would no
/// longer be the set's.
pub fn point_sets(
    seed: u64,
    sampler: crate::sampling::primary::Sampler,
    sets: usize,
    m: usize,
    order: SobolevOrder,
) -> Result<Vec<PssRule>, NotPositiveDefinite> {
    (0..sets)
        .map(|k| {
            let mut rng = crate::util::rng::stream(seed, &[PSS_SETS_STREAM, m as u64, k as u64]);
            PssRule::new(sampler.points(m, &mut rng), order)
        })
        .collect()
}

/// The stream tag of [`point_sets`].
const PSS_SETS_STREAM: u64 = 0x5053_5345_5453; // "PSSETS"

#[cfg(test)]
mod tests {
    use super::*;

    /// The weights integrate a function in the kernel's space well: on the polynomial
    /// `G = 1 + (u₁ − ½)` (integral 1), BMC and BSQ are within 1e-3 at 64 points, BSQ integrates
    /// constants exactly, and cv integrates a quadratic exactly.
    #[test]
    fn weights_integrate_smooth_functions() {
        let mut rng = crate::util::rng::stream(7, &[]);
        let pts = crate::sampling::primary::sobol_points(64, &mut rng);
        for order in SobolevOrder::ALL {
            let rule = PssRule::new(pts.clone(), order).unwrap();
            let g: Vec<f64> = pts.iter().map(|u| 1.0 + (u[0] - 0.5)).collect();
            for kind in [PssWeights::Bmc, PssWeights::Bsq] {
                let (v, sd) = rule.estimate(kind, &g);
                assert!((v - 1.0).abs() < 1e-3, "{order:?} {kind:?} {v}");
                assert!(sd.unwrap().sd >= 0.0);
            }
            let ones = vec![2.5; 64];
            assert!((rule.estimate(PssWeights::Bsq, &ones).0 - 2.5).abs() < 1e-12);
            let q: Vec<f64> = pts.iter().map(|u| 3.0 + u[0] * u[1] - u[1] * u[1]).collect();
            let exact = 3.0 + 0.25 - 1.0 / 3.0;
            let cv = rule.estimate(PssWeights::Cv, &q).0;
            if order == SobolevOrder::Two {
                assert!((cv - exact).abs() < 1e-12, "{cv}");
            }
            assert!(rule.unit_variance(PssWeights::Bmc).unwrap() > -1e-9);
        }
    }

    /// `bmc`'s estimate is `wᵀG` with the set's weights: the weights are the set's, the same for
    /// every integrand.
    #[test]
    fn the_estimate_is_the_sets_weights_times_the_values() {
        let rules = point_sets(
            3,
            crate::sampling::primary::Sampler::Sobol,
            2,
            16,
            SobolevOrder::One,
        )
        .unwrap();
        assert_ne!(rules[0].points, rules[1].points);
        for g in [vec![1.0; 16], (0..16).map(|i| i as f64).collect::<Vec<_>>()] {
            let w = rules[0].weights(PssWeights::Bmc);
            let dot: f64 = w.iter().zip(&g).map(|(a, b)| a * b).sum();
            assert!((rules[0].estimate(PssWeights::Bmc, &g).0 - dot).abs() < 1e-12);
        }
    }
}
