//! Statistical and exactness tests of the estimators (math.md §3–4). Fixed seeds; every
//! tolerance is a multiple of a known standard error, a floating-point bound, or the RKHS
//! worst-case-error bound `|∫f − Σ w_i f(x_i)| ≤ ‖f‖_H e(w)`.

use crate::common::{funk_hecke_0_1, rkhs_norms_of_one_and_cos};

use std::f64::consts::{PI, TAU};
use workbench::bq::estimator::{Method, bmc, bmcp, mc};
use workbench::bq::factor::SpdWorkspace;
use workbench::bq::kernel::{Kernel, Sobolev, SquaredExponential};
use workbench::bq::kernel_mean::{KernelMeanMode, KernelMeanTable};
use workbench::bq::model::BmcModel;
use workbench::bq::weights::{bmc_weights, worst_case_error};
use workbench::integrand::CosPower;
use workbench::sampling::{Density, Design};
use workbench::util::geometry::{Vec3, rotate_about_z};
use workbench::util::rng::stream;

fn sobolev() -> Kernel {
    Kernel::Sobolev(Sobolev::new(1.4).unwrap())
}

fn kernels() -> Vec<Kernel> {
    vec![
        sobolev(),
        Kernel::SquaredExponential(SquaredExponential::new(1.0, 0.5).unwrap()),
    ]
}

/// Uniform MC is unbiased, and its mean absolute error follows `sqrt(2/π) σ/√N` (math.md §3).
#[test]
fn mc_is_unbiased_and_follows_the_error_law() {
    let (n, trials) = (64, 3000);
    for k in 1..=3 {
        let f = CosPower::new(k);
        let sigma = f.uniform_mc_variance().sqrt();
        let mut rng = stream(11, &[k as u64]);
        let estimates: Vec<f64> = (0..trials)
            .map(|_| {
                let pts = Density::Uniform.sample_set(n, &mut rng);
                let vals: Vec<f64> = pts.iter().map(|w| f.value(w)).collect();
                mc::estimate(Density::Uniform, &pts, &vals)
            })
            .collect();
        let mean = estimates.iter().sum::<f64>() / trials as f64;
        let se_mean = sigma / ((n * trials) as f64).sqrt();
        assert!(
            (mean - f.integral()).abs() < 4.0 * se_mean,
            "k={k}: mean {mean} vs {}",
            f.integral()
        );

        let mae = estimates.iter().map(|e| (e - f.integral()).abs()).sum::<f64>() / trials as f64;
        let law = (2.0 / PI).sqrt() * sigma / (n as f64).sqrt();
        // |e| of a normal error has variance (1 − 2/π) σ²/N.
        let se_mae = ((1.0 - 2.0 / PI) * sigma * sigma / n as f64 / trials as f64).sqrt();
        assert!(
            (mae - law).abs() < 4.0 * se_mae,
            "k={k}: mean |e| {mae} vs law {law} (se {se_mae})"
        );
    }
}

/// Cosine-weighted sampling is perfect importance sampling for cos θ: every estimate is π.
#[test]
fn cosine_weighted_mc_on_cos_has_zero_variance() {
    let f = CosPower::new(1);
    let mut rng = stream(12, &[]);
    for n in [1, 7, 64] {
        let pts = Density::Cosine.sample_set(n, &mut rng);
        let vals: Vec<f64> = pts.iter().map(|w| f.value(w)).collect();
        let e = mc::estimate(Density::Cosine, &pts, &vals);
        assert!((e - PI).abs() < 1e-13, "n={n}: {e}");
    }
}

fn weights(kernel: Kernel, noise: f64, pts: &[Vec3]) -> workbench::bq::weights::BmcWeights {
    let model = BmcModel::new(kernel, noise, KernelMeanMode::Exact);
    model
        .weights(pts, &mut stream(0, &[]), &mut SpdWorkspace::new())
        .unwrap()
}

/// On a constant integrand BMCP with that constant as prior is exact, and BMC's `Σw` tends to
/// 2π, within the worst-case-error bound `|Σw − 2π| ≤ ‖1‖_H e(w)` at every N.
#[test]
fn bmc_on_a_constant_integrand() {
    for kernel in kernels() {
        let (norm_one, _) = rkhs_norms_of_one_and_cos(&kernel);
        let table = KernelMeanTable::new(&kernel);
        let mut last_gap = f64::INFINITY;
        for n in [16, 64, 256] {
            let pts = Density::Uniform.sample_set(n, &mut stream(13, &[n as u64]));
            let w = weights(kernel, 0.01, &pts);
            let values = vec![0.7; n];
            assert!((bmcp::estimate(&w, &values, 0.7) - TAU * 0.7).abs() < 1e-12);
            assert!((bmc::estimate(&w, &values) - 0.7 * w.diagnostics.weight_sum).abs() < 1e-12);
            let gap = (w.diagnostics.weight_sum - TAU).abs();
            assert!(
                gap < last_gap,
                "{kernel} n={n}: |Σw − 2π| = {gap} did not shrink from {last_gap}"
            );
            let z: Vec<f64> = pts.iter().map(|p| table.z(p.z)).collect();
            let e = worst_case_error(&pts, &w.weights, &z, table.prior_variance(), &kernel);
            assert!(
                gap <= norm_one * e * (1.0 + 1e-9),
                "{kernel} n={n}: gap {gap} > bound {}",
                norm_one * e
            );
            last_gap = gap;
        }
    }
}

/// The closed-form eigenvalues behind the bounds, against a midpoint rule in `t` (the
/// Sobolev singularity at t = 1 is integrable; 2·10⁶ points give ~1e-7 relative).
#[test]
fn funk_hecke_eigenvalues_match_quadrature() {
    for kernel in kernels() {
        let m = 2_000_000;
        let (mut q0, mut q1) = (0.0, 0.0);
        for i in 0..m {
            let t = -1.0 + 2.0 * (i as f64 + 0.5) / m as f64;
            let k = kernel.of_squared_distance(2.0 - 2.0 * t);
            q0 += k;
            q1 += k * t;
        }
        let h = TAU * 2.0 / m as f64;
        let (l0, l1) = funk_hecke_0_1(&kernel);
        assert!((q0 * h - l0).abs() < 1e-6 * l0, "{kernel}: λ0 {} vs {l0}", q0 * h);
        assert!((q1 * h - l1).abs() < 1e-6 * l0, "{kernel}: λ1 {} vs {l1}", q1 * h);
        assert!((l0 - kernel.sphere_mean()).abs() < 1e-12 * l0);
    }
}

/// Without noise BMC integrates every kernel section `k(·, x_j)` exactly:
/// `wᵀ k_j = zᵀ Q⁻¹ Q e_j = z_j`.
#[test]
fn bmc_is_exact_for_kernel_sections() {
    for kernel in kernels() {
        let pts = Density::Uniform.sample_set(24, &mut stream(14, &[]));
        let w = weights(kernel, 0.0, &pts);
        let table = KernelMeanTable::new(&kernel);
        for x in pts.iter().step_by(5) {
            let values: Vec<f64> = pts.iter().map(|p| kernel.eval(p, x)).collect();
            let exact = table.z(x.z);
            assert!(
                (bmc::estimate(&w, &values) - exact).abs() < 1e-9 * exact,
                "{kernel}"
            );
        }
    }
}

/// The posterior variance is ≥ 0 and falls as a nested design grows.
#[test]
fn posterior_variance_is_non_negative_and_shrinks_on_nested_sets() {
    for kernel in kernels() {
        let all = Density::Uniform.sample_set(256, &mut stream(15, &[]));
        let mut last = f64::INFINITY;
        for n in [1, 2, 4, 8, 16, 32, 64, 128, 256] {
            let v = weights(kernel, 0.01, &all[..n]).diagnostics.posterior_variance;
            assert!(v >= 0.0, "{kernel} n={n}: {v}");
            assert!(v < last, "{kernel} n={n}: {v} ≥ {last}");
            last = v;
        }
    }
}

/// Rotating a set about `+z` leaves every weight unchanged: the basis of re-use in rendering.
#[test]
fn weights_are_invariant_under_rotation_about_the_normal() {
    for kernel in kernels() {
        let pts = Density::Uniform.sample_set(64, &mut stream(16, &[]));
        let w0 = weights(kernel, 0.01, &pts);
        for phi in [0.3, 2.0, 5.5] {
            let rotated: Vec<Vec3> = pts.iter().map(|p| rotate_about_z(p, phi)).collect();
            let w1 = weights(kernel, 0.01, &rotated);
            for (a, b) in w0.weights.iter().zip(&w1.weights) {
                assert!((a - b).abs() < 1e-12, "{kernel} φ={phi}: {a} vs {b}");
            }
        }
    }
}

/// The diagnostics describe the weights they come with.
#[test]
fn diagnostics_match_the_weights() {
    let pts = Density::Uniform.sample_set(40, &mut stream(17, &[]));
    let table = KernelMeanTable::new(&sobolev());
    let z: Vec<f64> = pts.iter().map(|p| table.z(p.z)).collect();
    let w = bmc_weights(
        &pts,
        &z,
        table.prior_variance(),
        &sobolev(),
        0.01,
        &mut SpdWorkspace::new(),
    )
    .unwrap();
    let d = &w.diagnostics;
    assert_eq!(d.n, 40);
    assert!((d.weight_sum - w.weights.iter().sum::<f64>()).abs() < 1e-15);
    assert_eq!(d.negative_weights, w.weights.iter().filter(|&&x| x < 0.0).count());
    assert_eq!(
        d.min_weight,
        w.weights.iter().copied().fold(f64::INFINITY, f64::min)
    );
    let zw: f64 = z.iter().zip(&w.weights).map(|(a, b)| a * b).sum();
    assert!((d.posterior_variance - (d.prior_variance - zw)).abs() < 1e-12);
    assert_eq!(d.jitter, 0.0);
    assert!(d.condition_estimate >= 1.0 && d.warnings.is_empty());
}

/// Duplicate points without noise make Q singular: jitter is added and reported, never a panic.
#[test]
fn singular_q_gets_counted_jitter() {
    let mut pts = Density::Uniform.sample_set(10, &mut stream(18, &[]));
    pts.push(pts[3]);
    let w = weights(sobolev(), 0.0, &pts);
    assert!(w.diagnostics.jitter > 0.0);
    assert!(
        w.diagnostics
            .warnings
            .iter()
            .any(|x| matches!(x, workbench::bq::weights::NumericalWarning::Jitter { .. }))
    );
    assert!(w.weights.iter().all(|x| x.is_finite()));
}

/// Conformance, walking the one list of estimators and the one list of designs: every method
/// on every design gives a finite, reproducible estimate near the truth; its name parses back
/// (in experiment files, through serde, and as a render integrator); a prior reaches the
/// methods that use one, and a zero prior is no prior.
#[test]
fn every_method_conforms() {
    let f = CosPower::new(3);
    for design in Design::ALL {
        assert_eq!(Design::from_name(design.name()), Some(design));
        let pts = design.sample_set(32, &mut stream(19, &[design.stream_id()]));
        let vals: Vec<f64> = pts.iter().map(|w| f.value(w)).collect();
        let w = weights(sobolev(), 0.01, &pts);
        for m in Method::ALL {
            let estimate = |prior: f64| {
                m.estimate(
                    design.density(),
                    &pts,
                    &vals,
                    m.needs_weights().then_some(&w),
                    prior,
                )
            };
            let e = estimate(f.constant_prior());
            // Five standard errors of uniform MC at this N; the other estimators do better.
            let tolerance = 5.0 * (f.uniform_mc_variance() / 32.0).sqrt();
            assert!(
                e.is_finite() && (e - f.integral()).abs() < tolerance,
                "{m} on {design}: {e}"
            );
            assert_eq!(
                e,
                estimate(f.constant_prior()),
                "{m} on {design} is not reproducible"
            );
            if m.uses_prior() {
                assert_ne!(e, estimate(0.0), "{m}: the prior must reach the estimate");
                assert_eq!(
                    estimate(0.0),
                    Method::Bmc.estimate(design.density(), &pts, &vals, Some(&w), 0.0),
                    "{m} with c = 0 must equal BMC"
                );
            } else {
                assert_eq!(e, estimate(0.0), "{m} takes no prior");
            }
            // Every estimator states an uncertainty at N = 32 (MC its standard error), and the
            // methods with weights have a unit-amplitude posterior variance and residuals.
            let u = m
                .uncertainty(
                    design.density(),
                    &pts,
                    &vals,
                    m.needs_weights().then_some(&w),
                    workbench::bq::weights::Scale::Unit,
                    1.0,
                )
                .unwrap_or_else(|| panic!("{m} has no uncertainty"));
            assert!(u.sd.is_finite() && u.sd > 0.0, "{m} on {design}: sd {}", u.sd);
            assert_eq!(m.unit_variance(Some(&w)).is_some(), m.needs_weights(), "{m}");
            assert_eq!(
                m.residuals(&vals, Some(&w), 0.0).is_some(),
                m.needs_weights(),
                "{m}"
            );
        }
    }
    for m in Method::ALL {
        assert_eq!(Method::from_name(m.name()), Some(m));
        let json = serde_json::to_string(&m).unwrap();
        assert_eq!(json, format!("\"{}\"", m.name()));
        assert_eq!(serde_json::from_str::<Method>(&json).unwrap(), m);
        // Every estimator is a render integrator under its own name.
        let kind = workbench::render::IntegratorKind::from_name(m.name()).unwrap();
        assert_eq!(kind.method, m);
    }
}

/// The thesis's MC kernel means approach the exact ones: with `u = Q⁻¹1` the weight sums differ
/// by `uᵀ δz`, and each `δz_i = (2π/M) Σ_j k(x_i, ω_j) − z_i`, so the difference has standard
/// error `2π sd_ω(Σ_i u_i k(x_i, ω)) / √M`; it must stay within 5 of them at every M.
#[test]
fn mc_kernel_mean_mode_converges_to_exact() {
    let kernel = sobolev();
    let pts = Density::Uniform.sample_set(16, &mut stream(20, &[]));
    let exact = weights(kernel, 0.01, &pts);
    let ones = vec![1.0; pts.len()];
    let u = bmc_weights(&pts, &ones, 0.0, &kernel, 0.01, &mut SpdWorkspace::new())
        .unwrap()
        .weights;
    let g: Vec<f64> = Density::Uniform
        .sample_set(100_000, &mut stream(22, &[]))
        .iter()
        .map(|w| pts.iter().zip(&u).map(|(p, ui)| ui * kernel.eval(p, w)).sum())
        .collect();
    let sd = workbench::util::stats::sample_sd(&g);
    for m in [100, 10_000, 1_000_000] {
        // Shared directions: the standard error above is for δz_i from one direction set (the
        // per-point mode's version is in tests/it/bq/mc_kernel_means.rs).
        let model = BmcModel::new(kernel, 0.01, KernelMeanMode::MonteCarloShared { samples: m });
        let w = model
            .weights(&pts, &mut stream(21, &[m as u64]), &mut SpdWorkspace::new())
            .unwrap();
        let gap = (w.diagnostics.weight_sum - exact.diagnostics.weight_sum).abs();
        let se = TAU * sd / (m as f64).sqrt();
        assert!(gap < 5.0 * se, "M={m}: |ΔΣw| = {gap} vs se {se}");
    }
}

/// The shifted Fibonacci design (randomised QMC) keeps MC unbiased — each point is uniform —
/// and, the set being evenly spread, has a smaller error than i.i.d. MC on the same trials
/// (paired difference of absolute errors below zero by more than 5 standard errors).
#[test]
fn fibonacci_design_is_unbiased_and_beats_iid_mc() {
    use workbench::sampling::Design;
    let (n, trials) = (64, 2000);
    for k in 1..=3 {
        let f = CosPower::new(k);
        let mut rng = stream(23, &[k as u64]);
        let (mut qmc, mut diffs) = (Vec::new(), Vec::new());
        for _ in 0..trials {
            let mut estimate = |design: Design| {
                let pts = design.sample_set(n, &mut rng);
                let vals: Vec<f64> = pts.iter().map(|w| f.value(w)).collect();
                mc::estimate(design.density(), &pts, &vals)
            };
            let q = estimate(Design::Fibonacci);
            let m = estimate(Design::Iid(Density::Uniform));
            qmc.push(q);
            diffs.push((q - f.integral()).abs() - (m - f.integral()).abs());
        }
        let se = |x: &[f64]| workbench::util::stats::sample_sd(x) / (x.len() as f64).sqrt();
        let bias = workbench::util::stats::mean(&qmc) - f.integral();
        assert!(
            bias.abs() < 4.0 * se(&qmc),
            "k={k}: bias {bias} (se {})",
            se(&qmc)
        );
        let gain = workbench::util::stats::mean(&diffs);
        assert!(
            gain < -5.0 * se(&diffs),
            "k={k}: mean |e_qmc| − |e_mc| = {gain} (se {})",
            se(&diffs)
        );
    }
}
