//! `bq-pss` at a scene pixel (math.md §11 (a); issue 40): Bayesian quadrature in primary
//! sample space on the one-sample MIS integrand
//! `G(u) = f(x_L)/(p_L(x_L) + p_B(x_L)) + f(x_B)/(p_L(x_B) + p_B(x_B))`, `x_t = T_t(u)`, per
//! colour channel ([`crate::bq::estimator::mis::mis_integrand`] on the pixel's
//! [`super::light::PixelLight`]).
//!
//! Its weights depend on the points only (the product Sobolev kernels' mean is the constant 1,
//! [`crate::bq::kernel::primary`]), so they are computed once per point set, never per pixel: `K`
//! (`gps`) sets of `M = spp/2` primary samples, each drawn by the estimator's sampler (a fresh
//! Owen scramble per set, or independent points) and factored once
//! ([`crate::bq::estimator::bq_pss::point_sets`]). A pixel picks one set from its own stream, as
//! the hemisphere rules' pixels do ([`super::sets::BmcSets::choose`]). The points are used as
//! drawn: a per-pixel shift would change a non-periodic kernel's `Q` and so the weights.
//!
//! Each point costs two evaluations of `f`, so a pixel at `spp = N` evaluates `f` `N` times, as
//! `mis` does with its `N/2` light and `N/2` BSDF samples, and traces at most `N` shadow rays
//! (none below the horizon or where the light is black, [`super::light`]).

use crate::bq::estimator::bq_pss::{PssRule, point_sets};
use crate::bq::estimator::mis::LightEstimator;
use crate::bq::factor::NotPositiveDefinite;
use crate::util::rng::WorkbenchRng;
use std::sync::Arc;

/// `bq-pss`'s point sets with their weights, shared by every pixel (and by clones).
#[derive(Clone, Debug)]
pub struct PssSets {
    pub rules: Arc<Vec<PssRule>>,
}

impl PssSets {
    /// `gps` sets of `spp/2` points for `estimator`, set `k` depending only on
    /// `(seed, spp/2, k)` and the sampler (streams of their own, apart from the pixels').
    pub fn generate(
        estimator: &LightEstimator,
        spp: usize,
        gps: usize,
        seed: u64,
    ) -> Result<Self, NotPositiveDefinite> {
        let (points, _) = estimator.method.counts(spp);
        let rules = point_sets(seed, estimator.sampler, gps.max(1), points, estimator.pss.order)?;
        Ok(PssSets {
            rules: Arc::new(rules),
        })
    }

    /// The set for a pixel, picked uniformly from its stream (no draw with one set).
    #[inline]
    pub fn pick(&self, rng: &mut WorkbenchRng) -> &PssRule {
        &self.rules[super::sets::choose_set(self.rules.len(), rng)]
    }

    /// The bytes the sets keep: each a factor of `M²` doubles and `O(M)` besides.
    pub fn bytes(points: usize, gps: usize) -> u64 {
        let per_set = 8 * (points as u64).saturating_mul(points as u64) + 48 * points as u64;
        per_set.saturating_mul(gps as u64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bq::estimator::bq_pss::PssWeights;
    use crate::render::integrator::IntegratorKind;

    /// Every set has `spp/2` points in `[0, 1)²`, the sets differ, and the same seed gives the
    /// same sets (the weights are the points', computed once).
    #[test]
    fn sets_are_drawn_once_from_the_seed() {
        for kind in IntegratorKind::light_quadratures() {
            let l = kind.light.unwrap();
            let a = PssSets::generate(&l, 16, 3, 5).unwrap();
            let b = PssSets::generate(&l, 16, 3, 5).unwrap();
            assert_eq!(a.rules.len(), 3);
            for (x, y) in a.rules.iter().zip(b.rules.iter()) {
                assert_eq!(x.points, y.points);
                assert_eq!(x.weights(PssWeights::Bmc), y.weights(PssWeights::Bmc));
                assert_eq!(x.points.len(), 8);
                assert!(x.points.iter().flatten().all(|&c| (0.0..1.0).contains(&c)));
            }
            assert_ne!(a.rules[0].points, a.rules[1].points, "{kind}");
        }
    }
}
