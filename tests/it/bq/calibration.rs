//! The kernel amplitude (math.md §7) and Bayes–Sard quadrature (§8): accuracy against an
//! independent dense implementation (nalgebra, an explicit inverse and the augmented
//! Bayes–Sard system, in this test only), and coverage where it is exact in law.

use nalgebra::{DMatrix, DVector};
use rand::RngExt;
use std::f64::consts::TAU;
use workbench::bq::weights::{BmcWeights, Scale, bmc_weights, fit_amplitude};

/// `Q⁻¹ v` with the workspace's factor.
fn solve(ws: &SpdWorkspace, v: &[f64]) -> Vec<f64> {
    let mut a = v.to_vec();
    ws.solve_in_place(&mut a);
    a
}
use workbench::bq::estimator::Method;
use workbench::bq::factor::SpdWorkspace;
use workbench::bq::kernel::{Kernel, Sobolev, SquaredExponential};
use workbench::bq::kernel_mean::KernelMeanTable;
use workbench::bq::weights::Solved;
use workbench::sampling::Density;
use workbench::util::geometry::Vec3;
use workbench::util::rng::stream;

fn kernels() -> Vec<Kernel> {
    vec![
        Kernel::Sobolev(Sobolev::new(1.4).unwrap()),
        Kernel::SquaredExponential(SquaredExponential::new(1.0, 0.5).unwrap()),
    ]
}

/// Everything the dense reference needs for one point set.
struct Dense {
    q: DMatrix<f64>,
    qinv: DMatrix<f64>,
    z: DVector<f64>,
    v: f64,
}

fn dense(kernel: &Kernel, noise: f64, pts: &[Vec3], table: &KernelMeanTable) -> Dense {
    let n = pts.len();
    let q = DMatrix::from_fn(n, n, |i, j| {
        kernel.eval(&pts[i], &pts[j]) + if i == j { noise } else { 0.0 }
    });
    // A direct inverse (LU), independent of the library's Cholesky path.
    let qinv = q.clone().try_inverse().expect("Q is invertible");
    let z = DVector::from_iterator(n, pts.iter().map(|p| table.z(p.z)));
    Dense {
        q,
        qinv,
        z,
        v: table.prior_variance(),
    }
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

fn library(
    kernel: &Kernel,
    noise: f64,
    pts: &[Vec3],
    table: &KernelMeanTable,
    ws: &mut SpdWorkspace,
) -> BmcWeights {
    let z: Vec<f64> = pts.iter().map(|p| table.z(p.z)).collect();
    bmc_weights(pts, &z, table.prior_variance(), kernel, noise, ws).unwrap()
}

/// On fixed point sets: BMC's Var₁, the `ml` and `loo` amplitudes (BMC, BMCP, BSQ residuals),
/// and Bayes–Sard's weights, estimate and Var₁ agree with a dense implementation to 1e-9
/// relative. Bayes–Sard's weights come from the augmented system
/// `[[Q, 1], [1ᵀ, 0]] [w; μ] = [z; 2π]` (Karvonen, Oates & Särkkä 2018, eq. 2.5), solved by LU.
#[test]
fn amplitudes_and_bayes_sard_match_a_dense_reference() {
    const TOL: f64 = 1e-9;
    for kernel in kernels() {
        let table = KernelMeanTable::new(&kernel);
        for (n, noise) in [(5, 0.01), (24, 0.01), (60, 0.001)] {
            let pts = Density::Uniform.sample_set(n, &mut stream(41, &[n as u64]));
            let mut ws = SpdWorkspace::new();
            let w = library(&kernel, noise, &pts, &table, &mut ws);
            let d = dense(&kernel, noise, &pts, &table);
            let y = DVector::from_iterator(n, pts.iter().map(|p| p.z.powi(3) + 0.3 * p.x));
            let values: Vec<f64> = y.iter().copied().collect();
            let ones = DVector::from_element(n, 1.0);

            // BMC.
            let wd = &d.qinv * &d.z;
            for (a, b) in w.weights.iter().zip(wd.iter()) {
                assert!(rel(*a, *b) < TOL, "{kernel} n={n}: w {a} vs {b}");
            }
            let var1 = d.v - d.z.dot(&wd);
            assert!(
                rel(w.diagnostics.posterior_variance, var1) < TOL,
                "{kernel} n={n}: Var₁"
            );

            // Bayes–Sard by the augmented system.
            let mut a = DMatrix::zeros(n + 1, n + 1);
            a.view_mut((0, 0), (n, n)).copy_from(&d.q);
            for i in 0..n {
                a[(i, n)] = 1.0;
                a[(n, i)] = 1.0;
            }
            let mut rhs = DVector::zeros(n + 1);
            rhs.rows_mut(0, n).copy_from(&d.z);
            rhs[n] = TAU;
            let sol = a.lu().solve(&rhs).expect("augmented system is regular");
            let bs = w.bayes_sard();
            for i in 0..n {
                assert!(rel(bs.weights[i], sol[i]) < TOL, "{kernel} n={n}: w_BS[{i}]");
            }
            assert!((bs.diagnostics.weight_sum - TAU).abs() < 1e-12);
            let est_dense: f64 = (0..n).map(|i| sol[i] * y[i]).sum();
            let est = Method::Bsq.estimate(Density::Uniform, &pts, &values, Some(&w), 0.0);
            assert!(rel(est, est_dense) < TOL, "{kernel} n={n}: BSQ estimate");
            let u = &d.qinv * &ones;
            let var_bs = var1 + (TAU - ones.dot(&wd)).powi(2) / ones.dot(&u);
            assert!(
                rel(w.bayes_sard_variance(), var_bs) < TOL,
                "{kernel} n={n}: BSQ Var₁"
            );
            // The same variance as the augmented system's: V̂ − [z; 2π]ᵀ A⁻¹ [z; 2π].
            assert!(rel(var_bs, d.v - rhs.dot(&sol)) < 1e-8, "{kernel} n={n}");

            // Amplitudes for each method's residuals.
            let inv_diag = ws.inverse_diagonal();
            for (i, got) in inv_diag.iter().enumerate() {
                assert!(rel(*got, d.qinv[(i, i)]) < TOL, "{kernel} n={n}: diag {i}");
            }
            let c = 0.25;
            let beta = ones.dot(&(&d.qinv * &y)) / ones.dot(&u);
            for (method, r_dense, dof) in [
                (Method::Bmc, y.clone(), n),
                (Method::Bmcp, y.add_scalar(-c), n),
                (Method::Bsq, y.add_scalar(-beta), n - 1),
            ] {
                let r = method.residuals(&values, Some(&w), c).unwrap();
                assert_eq!(method.ml_dof(n), dof);
                let qr = &d.qinv * &r_dense;
                let ml = r_dense.dot(&qr) / dof as f64;
                let loo = (0..n).map(|i| qr[i] * qr[i] / d.qinv[(i, i)]).sum::<f64>() / n as f64;
                // The runner's path: one solve Q⁻¹Y shared by the methods, Q⁻¹r = Q⁻¹Y − o·u.
                let values_solve = solve(&ws, &values);
                let amp = |scale| {
                    method
                        .amplitude(
                            scale,
                            &values,
                            Solved::Full(&values_solve),
                            Some(&w),
                            c,
                            Some(&inv_diag),
                        )
                        .unwrap()
                };
                let (got_ml, got_loo) = (amp(Scale::Ml), amp(Scale::Loo));
                assert!(
                    rel(got_ml, ml) < TOL,
                    "{kernel} n={n} {method}: ml {got_ml} vs {ml}"
                );
                assert!(
                    rel(got_loo, loo) < TOL,
                    "{kernel} n={n} {method}: loo {got_loo} vs {loo}"
                );
                assert_eq!(amp(Scale::Unit), 1.0);
                // And with the residuals solved directly.
                let direct = fit_amplitude(Scale::Ml, &r, &solve(&ws, &r), dof, None);
                assert!(rel(direct, ml) < TOL, "{kernel} n={n} {method}: direct ml");
            }
        }
    }
}

/// `loo`'s `(Q⁻¹r)_i / (Q⁻¹)_ii` is the leave-one-out residual `r_i − m₋ᵢ(x_i)`, whose
/// unit-amplitude variance is `1/(Q⁻¹)_ii`: checked against refitting without point `i`.
#[test]
fn loo_amplitude_is_the_mean_standardised_leave_one_out_residual() {
    let kernel = Kernel::Sobolev(Sobolev::new(1.4).unwrap());
    let table = KernelMeanTable::new(&kernel);
    let n = 12;
    let pts = Density::Uniform.sample_set(n, &mut stream(42, &[]));
    let d = dense(&kernel, 0.01, &pts, &table);
    let r: Vec<f64> = pts.iter().map(|p| p.z * p.z - 0.2).collect();
    let mut sum = 0.0;
    for i in 0..n {
        let keep: Vec<usize> = (0..n).filter(|&j| j != i).collect();
        let qm = DMatrix::from_fn(n - 1, n - 1, |a, b| d.q[(keep[a], keep[b])]);
        let k_i = DVector::from_iterator(n - 1, keep.iter().map(|&j| d.q[(i, j)]));
        let r_m = DVector::from_iterator(n - 1, keep.iter().map(|&j| r[j]));
        let qm_inv = qm.try_inverse().unwrap();
        let mean = k_i.dot(&(&qm_inv * &r_m));
        let var = d.q[(i, i)] - k_i.dot(&(&qm_inv * &k_i));
        sum += (r[i] - mean).powi(2) / var;
    }
    let mut ws = SpdWorkspace::new();
    library(&kernel, 0.01, &pts, &table, &mut ws);
    let got = fit_amplitude(Scale::Loo, &r, &solve(&ws, &r), n, Some(&ws.inverse_diagonal()));
    assert!(rel(got, sum / n as f64) < 1e-9, "{got} vs {}", sum / n as f64);
}

/// All residuals 0 give an amplitude of exactly 0 (math.md §7's `zero_amplitude` case).
#[test]
fn zero_residuals_give_zero_amplitude() {
    let kernel = Kernel::Sobolev(Sobolev::new(1.4).unwrap());
    let table = KernelMeanTable::new(&kernel);
    let pts = Density::Uniform.sample_set(8, &mut stream(43, &[]));
    let mut ws = SpdWorkspace::new();
    library(&kernel, 0.01, &pts, &table, &mut ws);
    let zeros = vec![0.0; 8];
    for method in [Method::Bmc, Method::Bsq] {
        for scale in [Scale::Ml, Scale::Loo] {
            let w = library(&kernel, 0.01, &pts, &table, &mut ws);
            let amp = method
                .amplitude(
                    scale,
                    &zeros,
                    Solved::Full(&zeros),
                    Some(&w),
                    0.0,
                    Some(&ws.inverse_diagonal()),
                )
                .unwrap();
            assert_eq!(amp, 0.0, "{method} {scale:?}");
        }
    }
    assert_eq!(fit_amplitude(Scale::Ml, &zeros, &zeros, 8, None), 0.0);
}

fn normal(rng: &mut impl RngExt) -> f64 {
    // Box–Muller.
    let u1: f64 = 1.0 - rng.random::<f64>();
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (TAU * u2).cos()
}

/// Coverage where it is exact in law. If `Y = f(X) + ε` with `f ~ GP(β, λk)` and
/// `ε ~ N(0, λσ_n²)`, then `(Y, I)` is jointly Gaussian with `Cov Y = λQ`, `Cov(Y, I) = λz`,
/// `Var I = λV̂`, and `(I − Î)/sqrt(λ̂ Var₁)` is Student-t with `N` (BMC, β = 0) or `N − 1`
/// (Bayes–Sard, any β) degrees of freedom, whatever λ: the `ml` intervals then cover at exactly
/// their level, and the `unit` interval does only when λ = 1. Drawn exactly (Cholesky of the
/// joint covariance); the tolerance is 4 binomial standard errors of the trial count.
#[test]
fn ml_intervals_cover_at_their_level_on_gp_draws() {
    let kernel = Kernel::Sobolev(Sobolev::new(1.4).unwrap());
    let table = KernelMeanTable::new(&kernel);
    let (n, trials, lambda, noise) = (16, 3000, 40.0, 0.01);
    let pts = Density::Uniform.sample_set(n, &mut stream(44, &[]));
    let d = dense(&kernel, noise, &pts, &table);
    let mut joint = DMatrix::zeros(n + 1, n + 1);
    joint.view_mut((0, 0), (n, n)).copy_from(&(&d.q * lambda));
    for i in 0..n {
        joint[(i, n)] = lambda * d.z[i];
        joint[(n, i)] = lambda * d.z[i];
    }
    joint[(n, n)] = lambda * d.v;
    let l = joint.cholesky().expect("joint covariance is SPD").l();
    let mut ws = SpdWorkspace::new();
    let w = library(&kernel, noise, &pts, &table, &mut ws);
    let mut rng = stream(45, &[]);
    for (method, beta) in [(Method::Bmc, 0.0), (Method::Bsq, 2.5)] {
        let mut hits = [0usize; 3];
        let mut unit_hits = 0usize;
        for _ in 0..trials {
            let e = DVector::from_iterator(n + 1, (0..=n).map(|_| normal(&mut rng)));
            let draw = &l * e;
            let values: Vec<f64> = (0..n).map(|i| beta + draw[i]).collect();
            let truth = TAU * beta + draw[n];
            let est = method.estimate(Density::Uniform, &pts, &values, Some(&w), 0.0);
            let lam = method
                .amplitude(
                    Scale::Ml,
                    &values,
                    Solved::Full(&solve(&ws, &values)),
                    Some(&w),
                    0.0,
                    None,
                )
                .unwrap();
            let u = method
                .uncertainty(Density::Uniform, &pts, &values, Some(&w), Scale::Ml, lam)
                .unwrap();
            assert_eq!(u.dof, Some(method.ml_dof(n)));
            for (k, level) in [0.5, 0.8, 0.95].into_iter().enumerate() {
                if (est - truth).abs() <= u.quantile(level) * u.sd {
                    hits[k] += 1;
                }
            }
            let unit = method
                .uncertainty(Density::Uniform, &pts, &values, Some(&w), Scale::Unit, 1.0)
                .unwrap();
            if (est - truth).abs() <= unit.quantile(0.95) * unit.sd {
                unit_hits += 1;
            }
        }
        for (k, level) in [0.5, 0.8, 0.95].into_iter().enumerate() {
            let cov = hits[k] as f64 / trials as f64;
            let se = (level * (1.0 - level) / trials as f64).sqrt();
            assert!(
                (cov - level).abs() < 4.0 * se,
                "{method}: coverage {cov} at {level} (se {se})"
            );
        }
        // With λ = 40 the unit interval is sqrt(40) ≈ 6.3 times too narrow: |T| ≤ 1.96/6.3
        // has probability ≈ 0.24.
        let unit = unit_hits as f64 / trials as f64;
        assert!(
            unit < 0.4,
            "{method}: unit coverage {unit} should be far below 0.95"
        );
    }
}

/// MC's interval is Student-t on the sample standard deviation of its terms: on cos³θ with
/// N = 64 uniform points its 95% coverage is within 4 binomial standard errors of 0.95 (the
/// terms are bounded, so the t interval is accurate at this N).
#[test]
fn mc_interval_covers_at_its_level() {
    let f = workbench::integrand::CosPower::new(3);
    let (n, trials) = (64, 3000);
    let mut rng = stream(46, &[]);
    let mut hits = 0;
    for _ in 0..trials {
        let pts = Density::Uniform.sample_set(n, &mut rng);
        let values: Vec<f64> = pts.iter().map(|p| f.value(p)).collect();
        let est = Method::Mc.estimate(Density::Uniform, &pts, &values, None, 0.0);
        let u = Method::Mc
            .uncertainty(Density::Uniform, &pts, &values, None, Scale::Unit, 1.0)
            .unwrap();
        assert_eq!(u.dof, Some(n - 1));
        if (est - f.integral()).abs() <= u.quantile(0.95) * u.sd {
            hits += 1;
        }
    }
    let cov = hits as f64 / trials as f64;
    let se = (0.95 * 0.05 / trials as f64).sqrt();
    assert!((cov - 0.95).abs() < 4.0 * se, "coverage {cov} (se {se})");
    assert!(
        Method::Mc
            .uncertainty(
                Density::Uniform,
                &[Vec3::new(0.0, 0.0, 1.0)],
                &[1.0],
                None,
                Scale::Unit,
                1.0
            )
            .is_none()
    );
}

/// Issue 20 item 4: an interval of width 0 (a fitted amplitude of 0, or an MC sample sd of 0,
/// when no sample saw the light) counts as a miss in `summary.csv`'s coverage unless its
/// estimate is exact. A 25° cap light 45° off the zenith, × cos θ, at N = 8: about half the
/// trials see no light. The coverage95 of each estimator is recounted from `trials.csv`, the
/// zero-width trials apart. A light below the horizon is 0 on every sample and in truth: each
/// zero-width interval holds the exact estimate, and covers.
#[test]
fn zero_width_intervals_count_as_misses_unless_exact() {
    use crate::common::{read_csv, stderr, workbench};
    let dir = tempfile::tempdir().unwrap();
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let spec = format!(
        r#"{{"name": "zero", "integrands": [{{"type": "cap", "axis": [{s}, 0, {s}], "half_angle": 25, "cosine": true}},
                                             {{"type": "cap", "axis": [0, 0, -1], "half_angle": 10}}],
            "estimators": [{{"label": "BMC", "method": "bmc"}}, {{"label": "MC", "method": "mc"}}],
            "samples": [8], "trials": 80, "seed": 4}}"#
    );
    std::fs::write(dir.path().join("z.json"), spec).unwrap();
    let o = workbench(dir.path(), &["run", "z.json", "-q", "--out", "o"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (th, trials) = read_csv(&dir.path().join("o/trials.csv"));
    let (sh, summary) = read_csv(&dir.path().join("o/summary.csv"));
    let t = |name: &str| th.iter().position(|c| c == name).unwrap();
    let c = |name: &str| sh.iter().position(|c| c == name).unwrap();
    for label in ["BMC", "MC"] {
        let below = |r: &&Vec<String>| r[0] == "cap10-tilt180" && r[t("estimator")] == label;
        assert!(
            trials
                .iter()
                .filter(below)
                .all(|r| r[t("posterior_sd")] == "0.0" && r[t("abs_error")] == "0.0")
        );
        let row = summary.iter().find(below).unwrap();
        assert_eq!(
            row[c("coverage95")],
            "1.0",
            "{label}: exact estimates with zero width cover"
        );

        let mine: Vec<_> = trials
            .iter()
            .filter(|r| r[0] == "cap25-tilt45-cos" && r[t("estimator")] == label)
            .collect();
        let (mut zero, mut hits) = (0, 0);
        for r in &mine {
            let sd: f64 = r[t("posterior_sd")].parse().unwrap();
            let err: f64 = r[t("abs_error")].parse().unwrap();
            if sd == 0.0 {
                zero += 1;
                assert!(
                    err > 0.0,
                    "{label}: the light was missed, so the estimate is not exact"
                );
                if label == "BMC" {
                    assert_eq!(r[t("amplitude")], "0.0", "{label}: {r:?}");
                }
            } else {
                let dof: usize = r[t("dof")].parse().unwrap();
                let q = workbench::util::stats::interval_quantile(Some(dof), 0.95);
                hits += usize::from(err <= q * sd);
            }
        }
        assert!(
            zero >= 10,
            "{label}: the scenario needs zero-width intervals ({zero})"
        );
        let row = summary
            .iter()
            .find(|r| r[0] == "cap25-tilt45-cos" && r[c("estimator")] == label)
            .unwrap();
        let coverage: f64 = row[c("coverage95")].parse().unwrap();
        assert!(
            (coverage - hits as f64 / mine.len() as f64).abs() < 1e-12,
            "{label}: coverage95 {coverage}, {hits} hits of {} with {zero} zero-width misses",
            mine.len()
        );
    }
}
