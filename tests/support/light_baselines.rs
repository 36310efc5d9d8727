//! The renderer's baselines (math.md §11) checked for bias, shared by the test binaries (`it`
//! and `data`, each includes this file by path).

use workbench::bq::estimator::bq_pss::{PssOptions, PssWeights};
use workbench::bq::estimator::mis::{
    BSDF_TECHNIQUE, Heuristic, LIGHT_TECHNIQUE, LightEstimator, LightMethod,
};
use workbench::bq::kernel::primary::SobolevOrder;
use workbench::experiment::runner::primary_samples;
use workbench::integrand::Integrand;
use workbench::sampling::primary::Sampler;

/// Every baseline of the issue (names for messages).
pub fn baselines() -> Vec<(&'static str, LightEstimator)> {
    let e = |method, heuristic, compensation, sampler| LightEstimator {
        method,
        heuristic,
        compensation,
        sampler,
        pss: PssOptions::default(),
    };

    use Heuristic::*;
    use LightMethod::*;
    use Sampler::{Sobol, Uniform};
    vec![
        ("mc-light", e(McLight, Power, false, Uniform)),
        ("mc-bsdf", e(McBsdf, Power, false, Uniform)),
        ("mis", e(Mis, Power, false, Uniform)),
        ("mis balance", e(Mis, Balance, false, Uniform)),
        ("mis compensation", e(Mis, Power, true, Uniform)),
        ("mis sobol", e(Mis, Power, false, Sobol)),
        ("mc-light sobol", e(McLight, Power, false, Sobol)),
        ("mis balance compensation sobol", e(Mis, Balance, true, Sobol)),
    ]
}

/// Every variant of `bq-pss` (math.md §11 (a)): both orders, both quadratures, both ablations.
/// Their weights depend on the points (BMC's sum to `1ᵀQ⁻¹1 < 1`, Bayes–Sard's and the control
/// variate's are ratios), so they are unbiased only as the set grows: measured at N = 16 (8
/// points) the ratio bias reaches about 1.6% of the truth (4.8 SE over 1500 trials) on a sunny
/// map, so they are checked at N = 128.
pub fn pss_variants() -> Vec<(&'static str, LightEstimator)> {
    let pss = |order, weights| LightEstimator {
        method: LightMethod::BqPss,
        heuristic: Heuristic::Power,
        compensation: false,
        sampler: Sampler::Sobol,
        pss: PssOptions { order, weights },
    };
    use PssWeights::*;
    use SobolevOrder::*;
    vec![
        ("bq-pss", pss(One, Bmc)),
        ("bq-pss bsq", pss(One, Bsq)),
        ("bq-pss order 2", pss(Two, Bmc)),
        ("bq-pss order 2 bsq", pss(Two, Bsq)),
        ("bq-pss equal", pss(One, Equal)),
        ("bq-pss cv", pss(Two, Cv)),
    ]
}

/// The mean and its standard error over `trials` trials of `N = n` (the runner's primary
/// samples, trial by trial), checked to lie within 4 SE of the truth; the SE must be positive
/// (a test that cannot fail would pass on a constant).
pub fn check_unbiased(f: &Integrand, n: usize, trials: usize, seed: u64) {
    check_unbiased_with(&baselines(), f, n, trials, seed)
}

/// [`check_unbiased`] of the estimators `list`.
pub fn check_unbiased_with(
    list: &[(&'static str, LightEstimator)],
    f: &Integrand,
    n: usize,
    trials: usize,
    seed: u64,
) {
    let lit = f.lit().unwrap();
    let truth = f.integral();
    for &(name, e) in list {
        let (nl, nb) = e.method.counts(n);
        let estimates: Vec<f64> = (0..trials)
            .map(|t| {
                let light = primary_samples(seed, e.sampler, LIGHT_TECHNIQUE, nl, n, t);
                let bsdf = primary_samples(seed, e.sampler, BSDF_TECHNIQUE, nb, n, t);
                e.estimate(lit, &light, &bsdf).0
            })
            .collect();
        let mean = estimates.iter().sum::<f64>() / trials as f64;
        let var = estimates.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (trials - 1) as f64;
        let se = (var / trials as f64).sqrt();
        assert!(se > 0.0, "{name} on {}: no spread", f.name());
        assert!(
            (mean - truth).abs() < 4.0 * se,
            "{name} on {}: mean {mean} vs truth {truth} (SE {se}, {:.1} SE)",
            f.name(),
            (mean - truth).abs() / se
        );
    }
}
