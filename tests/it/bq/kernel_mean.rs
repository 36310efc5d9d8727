//! Verification of the exact kernel mean `z(μ) = ∫_H k(x, ω) dω`, its table and `V̂`
//! (math.md §4) against references that share no code with the implementation:
//!
//! * a 2-D adaptive Gauss–Kronrod quadrature in pole coordinates (no arc function `Φ`),
//! * Legendre (Funk–Hecke) series: with `κ(t) = Σ c_l P_l(t)` and `F_l = ∫_0^1 P_l`,
//!   `z(μ) = 2π Σ c_l F_l P_l(μ)` and `V̂ = 4π² Σ c_l F_l²`,
//! * closed forms (pole, whole-sphere mean) and plain Monte Carlo.

use std::collections::BinaryHeap;
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use workbench::bq::kernel::{Kernel, Sobolev, SquaredExponential};
use workbench::bq::kernel_mean::{KernelMeanTable, kernel_mean_exact, kernel_mean_mc, prior_variance_exact};
use workbench::sampling::Density;
use workbench::util::geometry::Vec3;
use workbench::util::rng::stream;

fn sobolev(s: f64) -> Kernel {
    Kernel::Sobolev(Sobolev::new(s).expect("valid s"))
}

fn se(sigma: f64, l: f64) -> Kernel {
    Kernel::SquaredExponential(SquaredExponential::new(sigma, l).expect("valid parameters"))
}

/// The kernels every test runs on.
fn kernels() -> Vec<Kernel> {
    vec![
        sobolev(1.05),
        sobolev(1.4),
        sobolev(1.9),
        sobolev(2.5),
        sobolev(3.5),
        se(1.0, 0.5),
        se(1.0, 0.2),
        se(2.0, 0.1),
    ]
}

/// [`kernels`] plus edge cases of the parameter ranges, for the two accuracy tests: `s` near 1
/// (weakest singularity exponent) and 2, `s = 1.5` (`2s` an integer), very short and long
/// squared-exponential length scales.
fn kernels_and_edge_cases() -> Vec<Kernel> {
    let mut k = kernels();
    k.extend([
        sobolev(1.001),
        sobolev(1.5),
        sobolev(1.999),
        sobolev(2.25),
        sobolev(2.75),
        sobolev(3.25),
        sobolev(3.75),
        se(1.0, 0.05),
        se(5.0, 10.0),
    ]);
    k
}

fn rel(got: f64, want: f64) -> f64 {
    (got - want).abs() / want.abs()
}

/// Uniform numbers in `[0, 1)` from a fixed xorshift, for "random" μ without extra crates.
fn pseudo_random(n: usize, mut state: u64) -> Vec<f64> {
    (0..n)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Adaptive Gauss–Kronrod (7/15, QUADPACK's qk15 constants), global subdivision.
// The constants keep QUADPACK's published digits, hence the lint exception.

#[allow(clippy::excessive_precision)]
const XGK: [f64; 8] = [
    0.991455371120812639206854697526329,
    0.949107912342758524526189684047851,
    0.864864423359769072789712788640926,
    0.741531185599394439863864773280788,
    0.586087235467691130294144845693013,
    0.405845151377397166906606412076961,
    0.207784955007898467600689403773245,
    0.0,
];
#[allow(clippy::excessive_precision)]
const WGK: [f64; 8] = [
    0.022935322010529224963732008058970,
    0.063092092629978553290700663189204,
    0.104790010322250183839876322541518,
    0.140653259715525918745189590510238,
    0.169004726639267902826583426598550,
    0.190350578064785409913256402421014,
    0.204432940075298892414161999234649,
    0.209482141084727828012999174891714,
];
/// Gauss weights of the nodes `XGK[1], XGK[3], XGK[5], XGK[7]`.
#[allow(clippy::excessive_precision)]
const WG: [f64; 4] = [
    0.129484966168869693270611432679082,
    0.279705391489276667901467771423780,
    0.381830050505118944950369775488975,
    0.417959183673469387755102040816327,
];

/// `(K15, |K15 − G7|)` on `[a, b]`. The plain difference overestimates the error of smooth
/// panels by orders of magnitude, which only makes the reference more conservative.
fn gk15(f: &mut impl FnMut(f64) -> f64, a: f64, b: f64) -> (f64, f64) {
    let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
    let fc = f(c);
    let (mut k, mut g) = (WGK[7] * fc, WG[3] * fc);
    for i in 0..7 {
        let pair = f(c - h * XGK[i]) + f(c + h * XGK[i]);
        k += WGK[i] * pair;
        if i % 2 == 1 {
            g += WG[i / 2] * pair;
        }
    }
    (k * h, ((k - g) * h).abs())
}

struct Panel {
    a: f64,
    b: f64,
    value: f64,
    error: f64,
}

impl PartialEq for Panel {
    fn eq(&self, other: &Self) -> bool {
        self.error == other.error
    }
}
impl Eq for Panel {}
impl PartialOrd for Panel {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Panel {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.error.total_cmp(&other.error)
    }
}

/// `∫ f` over consecutive `breaks`, bisecting the panel with the largest error estimate until
/// the summed estimate is below `rel_tol · |∫ f| + abs_tol`. Panics if that is not reached, so
/// a reference that did not converge can never pass a test.
fn integrate(mut f: impl FnMut(f64) -> f64, breaks: &[f64], rel_tol: f64, abs_tol: f64) -> f64 {
    let mut heap = BinaryHeap::new();
    for w in breaks.windows(2) {
        let (value, error) = gk15(&mut f, w[0], w[1]);
        heap.push(Panel {
            a: w[0],
            b: w[1],
            value,
            error,
        });
    }
    for _ in 0..20_000 {
        let (total, error) = neumaier(heap.iter().map(|p| (p.value, p.error)));
        if error <= rel_tol * total.abs() + abs_tol {
            return total;
        }
        let worst = heap.pop().expect("at least one panel");
        let m = 0.5 * (worst.a + worst.b);
        for (a, b) in [(worst.a, m), (m, worst.b)] {
            let (value, error) = gk15(&mut f, a, b);
            heap.push(Panel { a, b, value, error });
        }
    }
    panic!("adaptive Gauss–Kronrod did not converge on {breaks:?}");
}

/// Compensated sums of values and of error estimates.
fn neumaier(items: impl Iterator<Item = (f64, f64)>) -> (f64, f64) {
    let (mut sum, mut comp, mut err) = (0.0f64, 0.0f64, 0.0f64);
    for (v, e) in items {
        let t = sum + v;
        comp += if sum.abs() >= v.abs() {
            (sum - t) + v
        } else {
            (v - t) + sum
        };
        sum = t;
        err += e;
    }
    (sum + comp, err)
}

#[test]
fn gauss_kronrod_reference_rule_is_exact_for_polynomials() {
    // K15 is exact to degree 22, G7 to degree 13.
    for p in 0..=22 {
        let (k, e) = gk15(&mut |x: f64| x.powi(p), -1.0, 1.0);
        let want = if p % 2 == 0 { 2.0 / (p as f64 + 1.0) } else { 0.0 };
        assert!((k - want).abs() < 1e-15, "K15, degree {p}: {k} vs {want}");
        if p <= 13 {
            assert!(e < 1e-15, "G7, degree {p}: |K − G| = {e}");
        }
    }
    let got = integrate(|x: f64| x.sqrt(), &[0.0, 1.0], 1e-14, 0.0);
    assert!(rel(got, 2.0 / 3.0) < 1e-14, "{got}");
}

// ---------------------------------------------------------------------------------------------
// Reference 1: 2-D quadrature in pole coordinates.

/// `z(μ) = ∫_0^{π/2} sin θ dθ · 2 ∫_0^π κ(d²) dφ` with `ω = (θ, φ)` in pole coordinates and
/// `x = (sin θ_x, 0, cos θ_x)`, where
/// `d² = ‖x − ω‖² = 4 sin²((θ_x − θ)/2) + 4 sin θ_x sin θ sin²(φ/2)` (a sum of non-negative
/// terms, so no cancellation near `ω = x`). The outer integral is split at `θ = θ_x`, the inner
/// has the Sobolev point singularity at its end `φ = 0`; both adapt to it.
fn reference_z(kernel: &Kernel, mu: f64) -> f64 {
    let theta_x = mu.acos();
    let sin_x = theta_x.sin();
    let inner = |theta: f64| {
        let along = 4.0 * (0.5 * (theta_x - theta)).sin().powi(2);
        let across = 4.0 * sin_x * theta.sin();
        let f = |phi: f64| kernel.of_squared_distance(along + across * (0.5 * phi).sin().powi(2));
        2.0 * integrate(f, &[0.0, PI], 1e-14, 1e-300)
    };
    let mut breaks = vec![0.0];
    if theta_x > 0.0 && theta_x < FRAC_PI_2 {
        breaks.push(theta_x);
    }
    breaks.push(FRAC_PI_2);
    integrate(|theta| theta.sin() * inner(theta), &breaks, 1e-13, 1e-300)
}

/// The μ at which the exact kernel mean is checked against the 2-D reference.
fn check_points() -> Vec<f64> {
    let mut mus = vec![
        1.0, 0.9, 0.5, 0.1, 1e-2, 1e-3, 1e-6, 0.0, -1e-6, -0.3, -0.6, -0.9, -1.0,
    ];
    mus.extend(pseudo_random(3, 0x5eed));
    mus
}

/// Test 1: `kernel_mean_exact` against the independent 2-D quadrature, relative 1e-10, for μ on
/// both sides of the horizon.
#[test]
fn exact_matches_two_dimensional_quadrature() {
    let mut report = Vec::new();
    for k in kernels_and_edge_cases() {
        let mut worst: (f64, f64) = (0.0, f64::NAN);
        for mu in check_points() {
            let got = kernel_mean_exact(&k, mu);
            let want = reference_z(&k, mu);
            let e = rel(got, want);
            assert!(
                e <= 1e-10,
                "{k} μ={mu}: exact {got:.17e} vs 2-D {want:.17e} (rel {e:.2e})"
            );
            if e > worst.0 || worst.1.is_nan() {
                worst = (e, mu);
            }
        }
        report.push(format!("{k}: max rel {:.2e} at μ={}", worst.0, worst.1));
    }
    println!("exact vs 2-D reference:\n  {}", report.join("\n  "));
}

// ---------------------------------------------------------------------------------------------
// Reference 2: Legendre series.

/// `F_l = ∫_0^1 P_l(t) dt` for `l = 0..n`: `F_0 = 1`, `F_l = 0` for even `l > 0`,
/// `F_1 = ½`, `F_{2k+3} = −F_{2k+1} (2k + 1) / (2 (k + 2))`.
fn half_legendre_integrals(n: usize) -> Vec<f64> {
    let mut f = vec![0.0; n + 1];
    f[0] = 1.0;
    if n >= 1 {
        f[1] = 0.5;
    }
    let mut l = 3;
    while l <= n {
        let k = ((l - 3) / 2) as f64;
        f[l] = -f[l - 2] * (2.0 * k + 1.0) / (2.0 * (k + 2.0));
        l += 2;
    }
    f
}

/// Legendre coefficients `c_l = (2l + 1)/2 ∫_{−1}^{1} κ(2 − 2t) P_l(t) dt`, `l = 0..=n`.
///
/// Sobolev: `κ = C − 2^λ (1 − t)^λ`, `λ = s − 1`, and
/// `∫ (1 − t)^λ P_l = 2^(λ+1) R_l`, `R_0 = 1/(λ + 1)`, `R_{l+1} = R_l (l − λ)/(l + λ + 2)`
/// (the Gamma-function closed form, as a ratio recurrence).
/// Squared exponential: `κ = σ² e^(−β) e^(βt)`, `β = 1/l²`, and `∫ e^(βt) P_l = 2 i_l(β)`
/// (modified spherical Bessel functions, by Miller's backward recurrence normalised with
/// `i_0(β) = sinh β / β`).
fn legendre_coefficients(kernel: &Kernel, n: usize) -> Vec<f64> {
    match kernel {
        Kernel::Sobolev(k) => {
            // κ = Σ_{l<3} L_l P_l(t) ± 2^λ (1 − t)^λ: L = [C, 0, 0] for s < 2, the kernel's
            // C₀, C₁, C₂ above (math.md §9).
            let s = k.s();
            let lambda = s - 1.0;
            let low = if s < 2.0 {
                [2f64.powf(2.0 * s - 1.0) / s, 0.0, 0.0]
            } else {
                k.legendre_coefficients()
            };
            let sign = k.power_sign();
            let mut c = Vec::with_capacity(n + 1);
            let mut r = 1.0 / (lambda + 1.0);
            for l in 0..=n {
                let lf = l as f64;
                let power_part = 2f64.powf(lambda) * 2f64.powf(lambda + 1.0) * r;
                let low_part = low.get(l).copied().unwrap_or(0.0);
                c.push(low_part + sign * (2.0 * lf + 1.0) / 2.0 * power_part);
                r *= (lf - lambda) / (lf + lambda + 2.0);
            }
            c
        }
        Kernel::SquaredExponential(k) => {
            let beta = 1.0 / (k.length() * k.length());
            let start = n.max((2.0 * beta) as usize + 60);
            // Backward: i_{m−1} = i_{m+1} + (2m + 1)/β i_m, from i_{start+1} = 0, i_start = tiny.
            let mut values = vec![0.0; start + 2];
            values[start] = 1e-280;
            for m in (1..=start).rev() {
                values[m - 1] = values[m + 1] + (2.0 * m as f64 + 1.0) / beta * values[m];
                if values[m - 1] > 1e250 {
                    values.iter_mut().for_each(|v| *v *= 1e-250);
                }
            }
            // e^(−β) i_0(β) = (1 − e^(−2β)) / (2β).
            let norm = -(-2.0 * beta).exp_m1() / (2.0 * beta) / values[0];
            let variance = k.sigma() * k.sigma();
            (0..=n)
                .map(|l| (2.0 * l as f64 + 1.0) * variance * values[l] * norm)
                .collect()
        }
    }
}

/// The coefficient recurrences against direct quadrature for the first few `l`.
#[test]
fn legendre_coefficients_match_quadrature() {
    for k in kernels() {
        let c = legendre_coefficients(&k, 6);
        for (l, &cl) in c.iter().enumerate() {
            let f = |t: f64| {
                // P_l by the three-term recurrence.
                let (mut p0, mut p1) = (1.0, t);
                for m in 1..l {
                    let mf = m as f64;
                    let p2 = ((2.0 * mf + 1.0) * t * p1 - mf * p0) / (mf + 1.0);
                    p0 = p1;
                    p1 = p2;
                }
                let p = if l == 0 { 1.0 } else { p1 };
                k.of_squared_distance(2.0 - 2.0 * t) * p
            };
            // The reference's absolute tolerance scales with the kernel (s > 2 kernels are ~100).
            let abs_tol = 1e-16 * c[0].abs().max(1.0);
            let want = (2.0 * l as f64 + 1.0) / 2.0 * integrate(f, &[-1.0, 0.0, 1.0], 1e-14, abs_tol);
            assert!(
                (cl - want).abs() <= 1e-12 * c[0].abs(),
                "{k} l={l}: {cl} vs {want}"
            );
        }
    }
}

/// `V̂ = 4π² Σ_l c_l F_l²` (only `l = 0` and odd `l` contribute). The Sobolev terms decay like
/// `l^(−2s−2)`, so 2·10⁶ terms leave a tail below 1e-18 even for `s = 1.05`.
fn prior_variance_series(kernel: &Kernel) -> f64 {
    let n = match kernel {
        Kernel::Sobolev(_) => 2_000_000,
        Kernel::SquaredExponential(_) => 400,
    };
    let c = legendre_coefficients(kernel, n);
    let f = half_legendre_integrals(n);
    // Smallest terms first, for the rounding.
    let sum: f64 = (0..=n).rev().map(|l| c[l] * f[l] * f[l]).sum();
    4.0 * PI * PI * sum
}

/// Test 5: `V̂` from the exact z (both the reference function and the table) against the
/// Legendre series, which uses neither `z` nor any quadrature over the hemisphere.
#[test]
fn prior_variance_matches_legendre_series() {
    for k in kernels() {
        let want = prior_variance_series(&k);
        let exact = prior_variance_exact(&k);
        let table = KernelMeanTable::new(&k).prior_variance();
        println!(
            "{k}: V̂ series {want:.15e}, exact {exact:.15e} ({:.1e}), table {table:.15e} ({:.1e})",
            rel(exact, want),
            rel(table, want)
        );
        assert!(
            rel(exact, want) <= 1e-9,
            "{k}: prior_variance_exact {exact} vs series {want}"
        );
        assert!(rel(table, want) <= 1e-9, "{k}: table V̂ {table} vs series {want}");
    }
}

/// The squared-exponential series converges fast for every μ, so it is a second, fully
/// independent reference for `z` itself (for the Sobolev kernel it converges too slowly).
///
/// Below the horizon `z` can be many orders of magnitude smaller than the terms of the series,
/// which then cancel: the series itself is only good to ~ε Σ|terms| there, and that rounding
/// bound is added to the 1e-10 relative tolerance (it is below 1e-10 z except at μ = −0.6 for
/// `l = 0.1`, where `z ≈ 4e-11`; the 2-D test covers that point at full relative accuracy).
#[test]
fn exact_matches_legendre_series_for_squared_exponential() {
    for k in [se(1.0, 0.5), se(1.0, 0.2), se(2.0, 0.1)] {
        let n = 400;
        let c = legendre_coefficients(&k, n);
        let f = half_legendre_integrals(n);
        for mu in [1.0, 0.7, 0.2, 1e-3, 0.0, -0.05, -0.6] {
            let (mut p0, mut p1) = (1.0, mu);
            let mut series = c[0] * f[0] + c[1] * f[1] * mu;
            let mut magnitude = series.abs();
            for l in 1..n {
                let lf = l as f64;
                let p2 = ((2.0 * lf + 1.0) * mu * p1 - lf * p0) / (lf + 1.0);
                p0 = p1;
                p1 = p2;
                series += c[l + 1] * f[l + 1] * p1;
                magnitude += (c[l + 1] * f[l + 1] * p1).abs();
            }
            let want = TAU * series;
            let rounding = 16.0 * f64::EPSILON * TAU * magnitude;
            let got = kernel_mean_exact(&k, mu);
            assert!(
                (got - want).abs() <= 1e-10 * want.abs() + rounding,
                "{k} μ={mu}: {got} vs series {want} (series rounding {rounding:.1e})"
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Closed forms.

/// Test 2: at the pole the hemisphere is a cap around `x`:
/// `z(1) = 2π ∫_0^1 κ = (2π/s)(2^(2s−1) − 2^(s−1))` for the Sobolev kernel.
#[test]
fn sobolev_pole_closed_form() {
    for s in [1.05, 1.2, 1.4, 1.6, 1.9, 1.99] {
        let want = TAU / s * (2f64.powf(2.0 * s - 1.0) - 2f64.powf(s - 1.0));
        let got = kernel_mean_exact(&sobolev(s), 1.0);
        assert!(rel(got, want) <= 1e-13, "s={s}: {got} vs {want}");
        let table = KernelMeanTable::new(&sobolev(s)).z(1.0);
        assert!(rel(table, want) <= 1e-13, "s={s}: table {table} vs {want}");
    }
}

/// Test 3: the upper hemisphere seen from `−μ` is the lower one seen from `μ`, so
/// `z(μ) + z(−μ) = ∫_{S²} k(x, ω) dω = sphere_mean` (`4π · 2^(2s−2)/s` for Sobolev).
#[test]
fn mean_over_both_hemispheres_is_the_sphere_mean() {
    let s = 1.4;
    let closed = 4.0 * PI * 2f64.powf(2.0 * s - 2.0) / s;
    assert!(rel(sobolev(s).sphere_mean(), closed) < 1e-14);
    let mut mus = vec![0.0, 1e-12, 1e-6, 1e-3, 0.01, 0.1, 0.5, 0.9, 0.999, 1.0];
    mus.extend((0..40).map(|i| (i as f64 + 0.5) / 40.0));
    for k in kernels() {
        let whole = k.sphere_mean();
        for &mu in &mus {
            let sum = kernel_mean_exact(&k, mu) + kernel_mean_exact(&k, -mu);
            assert!(rel(sum, whole) <= 1e-13, "{k} μ={mu}: {sum} vs {whole}");
        }
    }
}

/// At the horizon `z(0)` is half the sphere mean by the same symmetry, and `z` is increasing
/// on `[−1, 1]` (the kernels decrease with distance), checked on a grid as a cheap guard against
/// sign slips. Only up to rounding: for short length scales `z` is flat to the last bits near the
/// pole (`2π σ² l² (1 − e^(−2/l²)·…)`), where consecutive values differ by ±1 ulp.
#[test]
fn horizon_value_and_monotonicity() {
    for k in kernels() {
        assert!(
            rel(kernel_mean_exact(&k, 0.0), 0.5 * k.sphere_mean()) <= 1e-13,
            "{k}"
        );
        let values: Vec<f64> = (0..=400)
            .map(|i| kernel_mean_exact(&k, -1.0 + i as f64 / 200.0))
            .collect();
        assert!(
            values
                .windows(2)
                .all(|w| w[0] <= w[1] * (1.0 + 4.0 * f64::EPSILON)),
            "{k}: z not increasing"
        );
        assert!(values[0] < values[200] && values[200] < values[400], "{k}");
    }
}

// ---------------------------------------------------------------------------------------------
// The table.

/// Test 4: the table against the exact z on a dense grid (uniform, logarithmic toward the
/// horizon, octave boundaries and their neighbouring floats), relative 1e-10.
#[test]
fn table_matches_exact() {
    let mut mus: Vec<f64> = (0..=2000).map(|i| i as f64 / 2000.0).collect();
    mus.extend((0..=1200).map(|i| 10f64.powf(-12.0 + 12.0 * i as f64 / 1200.0)));
    mus.extend(pseudo_random(500, 0xface));
    for k in 0..=30 {
        let b = 0.5f64.powi(k);
        mus.extend([
            b,
            f64::from_bits(b.to_bits() - 1),
            f64::from_bits(b.to_bits() + 1),
        ]);
    }
    mus.extend([0.0, 1e-300, 1e-12, 1e-6, 1e-3, 1.0]);
    mus.retain(|m| (0.0..=1.0).contains(m));
    let mut report = Vec::new();
    for k in kernels_and_edge_cases() {
        let table = KernelMeanTable::new(&k);
        assert_eq!(table.kernel(), &k);
        let mut worst: (f64, f64) = (0.0, 0.0);
        for &mu in &mus {
            let (got, want) = (table.z(mu), kernel_mean_exact(&k, mu));
            let e = rel(got, want);
            assert!(
                e <= 1e-10,
                "{k} μ={mu:e}: table {got} vs exact {want} (rel {e:.2e})"
            );
            if e > worst.0 {
                worst = (e, mu);
            }
        }
        report.push(format!("{k}: max rel {:.2e} at μ={:e}", worst.0, worst.1));
    }
    println!(
        "table vs exact ({} points):\n  {}",
        mus.len(),
        report.join("\n  ")
    );
}

// ---------------------------------------------------------------------------------------------
// Monte Carlo mode.

/// Test 6: `kernel_mean_mc` with M uniform directions is within 5 standard errors of the exact z
/// (the standard error estimated from the same sample).
#[test]
fn monte_carlo_mode_agrees_within_standard_errors() {
    let m = 20_000;
    for (i, k) in kernels().into_iter().enumerate() {
        let mut rng = stream(77, &[i as u64]);
        let dirs = Density::Uniform.sample_set(m, &mut rng);
        for mu in [0.95f64, 0.5, 0.05] {
            let x = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let samples: Vec<f64> = dirs.iter().map(|w| TAU * k.eval(&x, w)).collect();
            let mean = samples.iter().sum::<f64>() / m as f64;
            let var = samples.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (m - 1) as f64;
            let se = (var / m as f64).sqrt();
            let got = kernel_mean_mc(&k, &x, &dirs);
            let want = kernel_mean_exact(&k, mu);
            assert!(se > 0.0);
            assert!(
                (got - want).abs() <= 5.0 * se,
                "{k} μ={mu}: MC {got} ± {se} vs exact {want}"
            );
        }
    }
}

/// The smoother kernels of math.md §9 are positive definite where it matters: a dense Gram
/// matrix of 1024 uniform points with the nugget σ_n² = 1e-8 factors without jitter, and its
/// condition estimate stays below the ill-conditioning warning.
#[test]
fn smoother_kernels_are_positive_definite_at_n_1024() {
    use workbench::bq::factor::{ILL_CONDITIONED, SpdWorkspace};
    let points = Density::Uniform.sample_set(1024, &mut stream(77, &[]));
    for s in [2.25, 2.75, 3.25, 3.75] {
        let info = SpdWorkspace::new()
            .factor_gram(&points, &sobolev(s), 1e-8)
            .expect("positive definite");
        assert_eq!(info.jitter, 0.0, "s={s}: needed jitter");
        assert!(
            info.condition_estimate < ILL_CONDITIONED,
            "s={s}: condition {:e}",
            info.condition_estimate
        );
    }
}
