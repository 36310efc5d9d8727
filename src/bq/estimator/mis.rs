//! The renderer's baselines (math.md §11): light sampling (`mc-light`), BSDF sampling
//! (`mc-bsdf`) and multiple importance sampling of both (`mis`, Veach & Guibas 1995), on an
//! integrand that knows its light ([`crate::integrand::lit::Lit`]).
//!
//! With `n_L` light and `n_B` BSDF samples,
//!
//! `Î = Σ_i w_L(x_i) f(x_i)/(n_L p_L(x_i)) + Σ_j w_B(y_j) f(y_j)/(n_B p_B(y_j))`,
//!
//! balance heuristic `w_t = n_t p_t / Σ_s n_s p_s`, power heuristic (β = 2)
//! `w_t = (n_t p_t)² / Σ_s (n_s p_s)²`. `mc-light` is `n_B = 0` (`w_L = 1`), `mc-bsdf` is `n_L = 0`,
//! `mis` is `n_L = n_B = N/2` (N even), so that `Î` is the mean of the `N/2` independent pair terms
//! `τ_i = w_L(x_i) f(x_i)/p_L(x_i) + w_B(y_i) f(y_i)/p_B(y_i)` (weights with `n_L = n_B`): its
//! standard error is `s_τ/√(N/2)`, Student-t with `N/2 − 1` degrees of freedom (for `mc-light` and
//! `mc-bsdf`, `s/√N` of their `N` terms, as MC's). Unbiased wherever `Σ_t p_t > 0` on the support
//! of `f`: light sampling covers every direction of `L > 0`, BSDF sampling every direction of
//! `f_r > 0`. The *compensated* light density ([`crate::sampling::light`], Karlík et al. 2019)
//! covers only `Y > Ȳ`, so it is offered with `mis` alone.
//!
//! Each technique warps its own primary samples ([`crate::sampling::primary`]): independent, or
//! an Owen-scrambled Sobol set, a fresh scramble per technique and trial.

use super::Uncertainty;
use super::bq_pss::{PssOptions, PssRule};
use crate::integrand::lit::{Lit, Technique};
use crate::sampling::primary::Sampler;
use crate::util::geometry::Vec3;
use serde::{Deserialize, Serialize};

/// A light-aware estimator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Deserialize, Serialize, schemars::JsonSchema)]
pub enum LightMethod {
    /// Light sampling alone: `Î = (1/N) Σ f/p_L`.
    #[serde(rename = "mc-light")]
    McLight,
    /// BSDF sampling alone: `Î = (1/N) Σ f/p_B` (cosine for Lambert, the lobe for Phong).
    #[serde(rename = "mc-bsdf")]
    McBsdf,
    /// `N/2` light and `N/2` BSDF samples with MIS weights.
    #[serde(rename = "mis")]
    Mis,
    /// Bayesian quadrature in primary sample space on the one-sample MIS integrand, `N/2` points
    /// of two evaluations each ([`super::bq_pss`], math.md §11 (a)).
    #[serde(rename = "bq-pss")]
    BqPss,
}

impl LightMethod {
    /// Every light-aware estimator, in the order of the docs.
    pub const ALL: [LightMethod; 4] = [
        LightMethod::McLight,
        LightMethod::McBsdf,
        LightMethod::Mis,
        LightMethod::BqPss,
    ];

    /// The renderer's baselines: Monte Carlo averages of i.i.d. terms `f/p` (math.md §11).
    pub const BASELINES: [LightMethod; 3] = [LightMethod::McLight, LightMethod::McBsdf, LightMethod::Mis];

    /// The quadratures that compose with light sampling (math.md §11 (a)–(c)): weights on a
    /// point set rather than i.i.d. terms.
    pub const QUADRATURES: [LightMethod; 1] = [LightMethod::BqPss];

    /// Whether the estimator is one of [`LightMethod::BASELINES`].
    pub fn is_baseline(self) -> bool {
        Self::BASELINES.contains(&self)
    }

    /// The name in experiment files and CSVs.
    pub fn name(self) -> &'static str {
        match self {
            LightMethod::McLight => "mc-light",
            LightMethod::McBsdf => "mc-bsdf",
            LightMethod::Mis => "mis",
            LightMethod::BqPss => "bq-pss",
        }
    }

    /// Parses [`LightMethod::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// `(n_L, n_B)` primary samples drawn at `N` evaluations (`mis`: `N` even; `bq-pss`: `N/2`
    /// shared points, drawn in the light technique's stream, each warped by both techniques).
    pub fn counts(self, n: usize) -> (usize, usize) {
        match self {
            LightMethod::McLight => (n, 0),
            LightMethod::McBsdf => (0, n),
            LightMethod::Mis => (n / 2, n / 2),
            LightMethod::BqPss => (n / 2, 0),
        }
    }

    /// Whether `N` samples can be split as the estimator splits them (the message says why not).
    pub fn check_count(self, n: usize) -> Result<(), String> {
        match self {
            LightMethod::Mis if n < 2 || n % 2 == 1 => Err(format!(
                "N = {n}: mis draws N/2 light and N/2 BSDF samples, so N must be even and at least 2"
            )),
            LightMethod::BqPss if n < 2 || n % 2 == 1 => Err(format!(
                "N = {n}: bq-pss evaluates f twice at each of N/2 points, so N must be even and at least 2"
            )),
            _ => Ok(()),
        }
    }

    /// The independent terms whose mean is `Î` at `N` samples ([`LightMethod::counts`]).
    fn terms(self, n: usize) -> usize {
        match self {
            LightMethod::McLight | LightMethod::McBsdf => n,
            LightMethod::Mis | LightMethod::BqPss => n / 2,
        }
    }

    /// Whether the estimator states an interval at `N`: two terms or more.
    pub fn has_interval(self, n: usize) -> bool {
        self.check_count(n).is_ok() && self.terms(n) >= 2
    }
}

/// The MIS weighting heuristic.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Heuristic {
    /// `w_t = (n_t p_t)² / Σ_s (n_s p_s)²` (β = 2), Mitsuba's `direct`.
    #[default]
    Power,
    /// `w_t = n_t p_t / Σ_s n_s p_s`.
    Balance,
}

impl Heuristic {
    /// The name in files.
    pub fn name(self) -> &'static str {
        match self {
            Heuristic::Power => "power",
            Heuristic::Balance => "balance",
        }
    }

    /// The weight of the technique of density `p` against the other's `q` (equal counts).
    #[inline]
    pub fn weight(self, p: f64, q: f64) -> f64 {
        match self {
            Heuristic::Balance => p / (p + q),
            Heuristic::Power => {
                let (p2, q2) = (p * p, q * q);
                p2 / (p2 + q2)
            }
        }
    }
}

/// A light-aware estimator with its options.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LightEstimator {
    pub method: LightMethod,
    /// The MIS heuristic (`mis` only; [`Heuristic::Power`] otherwise, unused).
    pub heuristic: Heuristic,
    /// Light samples from the compensated density (`mis` only).
    pub compensation: bool,
    /// How every technique's primary samples are drawn.
    pub sampler: Sampler,
    /// `bq-pss`'s kernel order and weights (default otherwise, unused).
    pub pss: PssOptions,
}

/// Stream identifiers of the two techniques' primary samples.
pub const LIGHT_TECHNIQUE: u64 = 0;
pub const BSDF_TECHNIQUE: u64 = 1;

impl LightEstimator {
    /// The light technique (plain or compensated).
    pub fn light_technique(&self) -> Technique {
        Technique::Light {
            compensated: self.compensation,
        }
    }

    /// `Î` and its standard error from the light technique's primary samples `light_u` and the
    /// BSDF technique's `bsdf_u` (their lengths [`LightMethod::counts`]); the integrand's values
    /// are `N` evaluations of `f` (one ray each where there is visibility).
    ///
    /// `bq-pss` builds its rule from `light_u` here; a caller with several integrands on the same
    /// points builds it once ([`LightEstimator::pss_rule`]) and calls
    /// [`LightEstimator::estimate_on_rule`].
    pub fn estimate(
        &self,
        f: &dyn Lit,
        light_u: &[[f64; 2]],
        bsdf_u: &[[f64; 2]],
    ) -> (f64, Option<Uncertainty>) {
        let (value, uncertainty) = self.estimate_channels(&OneChannel(f), light_u, bsdf_u);
        (value[0], uncertainty.map(|u| u[0]))
    }

    /// [`LightEstimator::estimate`] for an integrand of `K` channels sharing their directions
    /// (a scene pixel's three colour channels: one ray per direction serves all three), each
    /// channel's estimate and standard error from the same terms `τ_i ∈ ℝ^K`. A quadrature
    /// (`bq-pss`) builds its rule on `light_u` and estimates on it
    /// ([`LightEstimator::estimate_channels_on_rule`]); a caller that reuses point sets builds
    /// their rules once instead.
    pub fn estimate_channels<const K: usize>(
        &self,
        f: &dyn Techniques<K>,
        light_u: &[[f64; 2]],
        bsdf_u: &[[f64; 2]],
    ) -> ([f64; K], Option<[Uncertainty; K]>) {
        if let Some(rule) = self.pss_rule(light_u) {
            return self.estimate_channels_on_rule(f, &rule);
        }
        let terms = self.baseline_terms(f, light_u, bsdf_u);
        let m = terms.len();
        let value = std::array::from_fn(|c| terms.iter().map(|t| t[c]).sum::<f64>() / m as f64);
        let uncertainty = (m >= 2).then(|| {
            std::array::from_fn(|c| {
                let channel: Vec<f64> = terms.iter().map(|t| t[c]).collect();
                Uncertainty {
                    sd: crate::util::stats::sample_sd(&channel) / (m as f64).sqrt(),
                    dof: Some(m - 1),
                    amplitude: None,
                }
            })
        });
        (value, uncertainty)
    }

    /// A baseline's i.i.d. terms (module docs), whose mean is `Î`: `f/p` of each sample for
    /// `mc-light` and `mc-bsdf`, the pair terms `τ_i` for `mis`. Empty for a quadrature, which
    /// has weights instead ([`LightEstimator::estimate_channels`] never asks it for terms).
    fn baseline_terms<const K: usize>(
        &self,
        f: &dyn Techniques<K>,
        light_u: &[[f64; 2]],
        bsdf_u: &[[f64; 2]],
    ) -> Vec<[f64; K]> {
        let light = self.light_technique();
        let nonzero = |v: &[f64; K]| v.iter().any(|&x| x != 0.0);
        // Every direction is drawn before any is evaluated: the light's tables are large (a
        // 1024×512 map's are 8 MiB), and a short loop of independent look-ups lets their cache
        // misses overlap, where one interleaved with a shadow ray each would wait for every one
        // in turn. The values are the same either way.
        let draw = |t: Technique, us: &[[f64; 2]]| -> Vec<(Vec3, f64)> {
            us.iter().map(|&u| f.sample(t, u)).collect()
        };
        match self.method {
            LightMethod::BqPss => Vec::new(),
            LightMethod::McLight => draw(light, light_u)
                .iter()
                .map(|(w, p)| f.value(w).map(|v| v / p))
                .collect(),
            LightMethod::McBsdf => draw(Technique::Bsdf, bsdf_u)
                .iter()
                .map(|(w, p)| f.value(w).map(|v| v / p))
                .collect(),
            LightMethod::Mis => {
                assert_eq!(light_u.len(), bsdf_u.len(), "mis pairs its samples");
                draw(light, light_u)
                    .into_iter()
                    .zip(draw(Technique::Bsdf, bsdf_u))
                    .map(|((x, p_l), (y, p_b))| {
                        let mut tau = [0.0; K];
                        let fx = f.value(&x);
                        if nonzero(&fx) {
                            let w = self.heuristic.weight(p_l, f.pdf(Technique::Bsdf, &x));
                            for (t, v) in tau.iter_mut().zip(fx) {
                                *t += w * v / p_l;
                            }
                        }
                        let fy = f.value(&y);
                        if nonzero(&fy) {
                            let w = self.heuristic.weight(p_b, f.pdf(light, &y));
                            for (t, v) in tau.iter_mut().zip(fy) {
                                *t += w * v / p_b;
                            }
                        }
                        tau
                    })
                    .collect()
            }
        }
    }
}

impl LightEstimator {
    /// `bq-pss`'s weights on the primary samples `points` (once per set; None for the other
    /// methods).
    pub fn pss_rule(&self, points: &[[f64; 2]]) -> Option<PssRule> {
        (self.method == LightMethod::BqPss).then(|| {
            PssRule::new(points.to_vec(), self.pss.order)
                .expect("the product Sobolev Gram matrix factors with the jitter ladder")
        })
    }

    /// `bq-pss`'s `Î` and sd on a rule built once for its points: `G` at each point (two
    /// evaluations of `f`), then the rule's weights.
    pub fn estimate_on_rule(&self, f: &dyn Lit, rule: &PssRule) -> (f64, Option<Uncertainty>) {
        let (value, uncertainty) = self.estimate_channels_on_rule(&OneChannel(f), rule);
        (value[0], uncertainty.map(|u| u[0]))
    }

    /// [`LightEstimator::estimate_on_rule`] for an integrand of `K` channels sharing their
    /// directions: `G(u) ∈ ℝ^K` at each of the rule's points ([`mis_integrand`], two
    /// evaluations of `f` serving every channel), then the rule's weights and amplitude per
    /// channel.
    pub fn estimate_channels_on_rule<const K: usize>(
        &self,
        f: &dyn Techniques<K>,
        rule: &PssRule,
    ) -> ([f64; K], Option<[Uncertainty; K]>) {
        let g: Vec<[f64; K]> = rule.points.iter().map(|&u| mis_integrand(f, u)).collect();
        let per_channel: [(f64, Option<Uncertainty>); K] = std::array::from_fn(|c| {
            let channel: Vec<f64> = g.iter().map(|v| v[c]).collect();
            rule.estimate(self.pss.weights, &channel)
        });
        let value = per_channel.map(|(v, _)| v);
        let uncertainty = per_channel
            .iter()
            .all(|(_, u)| u.is_some())
            .then(|| per_channel.map(|(_, u)| u.expect("checked")));
        (value, uncertainty)
    }
}

/// The one-sample MIS integrand `G(u)` of `f` at the primary sample `u`
/// ([`super::bq_pss`]'s module docs): `f(x_L) / (p_L(x_L) + p_B(x_L)) + f(x_B) / (p_L(x_B) +
/// p_B(x_B))`, `x_t = T_t(u)`, balance weights with `n_t = 1` (Veach's one-sample MIS; math.md
/// §11 (a)); two evaluations of `f` per channel-vector (one ray each where there is
/// visibility), the uncompensated light density.
pub fn mis_integrand<const K: usize>(f: &dyn Techniques<K>, u: [f64; 2]) -> [f64; K] {
    let light = Technique::Light { compensated: false };
    let mut g = [0.0; K];
    for t in [light, Technique::Bsdf] {
        let (x, p) = f.sample(t, u);
        let fx = f.value(&x);
        if fx.iter().any(|&v| v != 0.0) {
            let q = match t {
                Technique::Bsdf => f.pdf(light, &x),
                Technique::Light { .. } => f.pdf(Technique::Bsdf, &x),
            };
            for (gc, v) in g.iter_mut().zip(fx) {
                *gc += v / (p + q);
            }
        }
    }
    g
}

/// What a light-aware estimator needs of an integrand of `K` channels: the two techniques'
/// warps and densities ([`Lit::sample`], [`Lit::pdf`]) and the integrand's values at a local
/// direction (0 below the horizon). [`Lit`] integrands are the one-channel case; a scene pixel
/// ([`crate::render::integrator::light`]) the three-channel one.
pub trait Techniques<const K: usize> {
    /// The local direction technique `t` draws for the primary sample `u`, with its density.
    fn sample(&self, t: Technique, u: [f64; 2]) -> (Vec3, f64);
    /// The density with which technique `t` draws local direction `w`.
    fn pdf(&self, t: Technique, w: &Vec3) -> f64;
    /// `f(w)` per channel.
    fn value(&self, w: &Vec3) -> [f64; K];
}

/// A [`Lit`] integrand as the one-channel [`Techniques`].
struct OneChannel<'a>(&'a dyn Lit);

impl Techniques<1> for OneChannel<'_> {
    #[inline]
    fn sample(&self, t: Technique, u: [f64; 2]) -> (Vec3, f64) {
        self.0.sample(t, u)
    }
    #[inline]
    fn pdf(&self, t: Technique, w: &Vec3) -> f64 {
        self.0.pdf(t, w)
    }
    #[inline]
    fn value(&self, w: &Vec3) -> [f64; 1] {
        [self.0.integrand(w)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The heuristics' weights of the two techniques add up to 1, and balance is `p/(p + q)`.
    #[test]
    fn the_weights_of_two_techniques_add_up_to_one() {
        for (p, q) in [(1.0, 1.0), (0.3, 7.0), (1e6, 1e-3), (2.0, 0.0)] {
            for h in [Heuristic::Power, Heuristic::Balance] {
                assert!(
                    (h.weight(p, q) + h.weight(q, p) - 1.0).abs() < 1e-15,
                    "{h:?} {p} {q}"
                );
            }
        }
        assert_eq!(Heuristic::Balance.weight(1.0, 3.0), 0.25);
        assert_eq!(Heuristic::Power.weight(1.0, 3.0), 0.1);
    }

    #[test]
    fn names_round_trip_and_mis_needs_an_even_count() {
        for m in LightMethod::ALL {
            assert_eq!(LightMethod::from_name(m.name()), Some(m));
        }
        assert!(LightMethod::Mis.check_count(3).is_err());
        assert!(LightMethod::Mis.check_count(0).is_err());
        assert!(LightMethod::Mis.check_count(2).is_ok());
        assert!(!LightMethod::Mis.has_interval(2) && LightMethod::Mis.has_interval(4));
        assert!(LightMethod::McLight.has_interval(2) && !LightMethod::McLight.has_interval(1));
    }
}
