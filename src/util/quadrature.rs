//! Gauss–Legendre and Gauss–Jacobi quadrature rules and Chebyshev interpolation on `[-1, 1]`.

/// Nodes and weights of the `n`-point Gauss–Legendre rule on `[-1, 1]`.
///
/// Newton iteration on `P_n` from Tricomi's initial guesses (Golub & Welsch would do as well);
/// nodes are accurate to a few ulps for the `n ≤ 200` used here.
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    assert!(n >= 1, "Gauss–Legendre needs at least one node");
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    let nf = n as f64;
    for i in 0..n.div_ceil(2) {
        let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (nf + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (p, d) = legendre_and_derivative(n, z);
            dp = d;
            let dz = p / d;
            z -= dz;
            if dz.abs() < 1e-16 {
                break;
            }
        }
        let (_, d) = legendre_and_derivative(n, z);
        dp = if d != 0.0 { d } else { dp };
        x[i] = -z;
        x[n - 1 - i] = z;
        let wi = 2.0 / ((1.0 - z * z) * dp * dp);
        w[i] = wi;
        w[n - 1 - i] = wi;
    }
    (x, w)
}

/// `(P_n(z), P_n'(z))` by the three-term recurrence.
fn legendre_and_derivative(n: usize, z: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, z);
    for k in 2..=n {
        let kf = k as f64;
        let p2 = ((2.0 * kf - 1.0) * z * p1 - (kf - 1.0) * p0) / kf;
        p0 = p1;
        p1 = p2;
    }
    if n == 0 {
        return (1.0, 0.0);
    }
    let d = n as f64 * (z * p1 - p0) / (z * z - 1.0);
    (p1, d)
}

/// Nodes and weights of the `n`-point Gauss rule for `∫₀¹ u^β f(u) du` (`β > −1`): exact for
/// polynomials `f` of degree up to `2n − 1`.
///
/// Golub & Welsch: the nodes are the eigenvalues of the Jacobi matrix of the monic Jacobi
/// polynomials `P_k^(0, β)` on `[−1, 1]` (weight `(1 + y)^β`), with diagonal
/// `a_k = (β² − 0)/((2k + β)(2k + β + 2))` (`a₀ = β/(β + 2)`) and off-diagonal
/// `b_k = √(4k²(k + β)² / ((2k + β)² (2k + β + 1)(2k + β − 1)))`; the weights are
/// `μ₀ v₀²` with `μ₀ = 2^(β+1)/(β + 1)` and `v` the unit eigenvectors. Then `u = (1 + y)/2` and
/// the weights carry `2^−(β+1)` (DLMF 18.9.2 for the recurrence).
pub fn gauss_jacobi_unit(n: usize, beta: f64) -> (Vec<f64>, Vec<f64>) {
    assert!(n >= 1 && beta > -1.0, "Gauss–Jacobi needs n ≥ 1 and β > −1");
    let diagonal = |k: usize| {
        let s = 2.0 * k as f64 + beta;
        if k == 0 {
            beta / (beta + 2.0)
        } else {
            beta * beta / (s * (s + 2.0))
        }
    };
    let off = |k: usize| {
        let (kf, s) = (k as f64, 2.0 * k as f64 + beta);
        (4.0 * kf * kf * (kf + beta) * (kf + beta) / (s * s * (s + 1.0) * (s - 1.0))).sqrt()
    };
    let jacobi = nalgebra::DMatrix::from_fn(n, n, |i, j| match i.abs_diff(j) {
        0 => diagonal(i),
        1 => off(i.max(j)),
        _ => 0.0,
    });
    let eigen = nalgebra::SymmetricEigen::new(jacobi);
    // ∫₀¹ u^β du = 1/(β + 1): the weights' sum.
    let mu0 = 1.0 / (beta + 1.0);
    let mut rule: Vec<(f64, f64)> = (0..n)
        .map(|m| {
            (
                0.5 * (1.0 + eigen.eigenvalues[m]),
                mu0 * eigen.eigenvectors[(0, m)].powi(2),
            )
        })
        .collect();
    rule.sort_by(|x, y| x.0.total_cmp(&y.0));
    rule.into_iter().unzip()
}

/// A Gauss–Legendre rule ready to integrate over any interval.
#[derive(Clone, Debug)]
pub struct GaussLegendre {
    nodes: Vec<f64>,
    weights: Vec<f64>,
}

impl GaussLegendre {
    pub fn new(n: usize) -> Self {
        let (nodes, weights) = gauss_legendre(n);
        GaussLegendre { nodes, weights }
    }

    /// `∫_a^b f(x) dx`.
    // Inlined into its callers: the exact kernel mean's integrand (`bq::kernel_mean::exact`) is
    // a few multiplications and a power, and called out of line the sum's call overhead was 4%
    // of the kernel-mean table's instructions (callgrind, issue 43 item 7). Same sums, same bits.
    #[inline]
    pub fn integrate(&self, a: f64, b: f64, mut f: impl FnMut(f64) -> f64) -> f64 {
        let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
        self.nodes
            .iter()
            .zip(&self.weights)
            .map(|(&x, &w)| w * f(c + h * x))
            .sum::<f64>()
            * h
    }

    /// The nodes on `[-1, 1]`, ascending.
    pub fn nodes(&self) -> &[f64] {
        &self.nodes
    }

    /// The weights belonging to [`GaussLegendre::nodes`].
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }
}

/// The `n` Chebyshev points of the first kind, `x_j = cos(π (j + ½) / n)`, `j = 0..n` (descending).
///
/// They exclude the end points, so an interpolant never needs a function value exactly at a
/// panel boundary; evaluating it there is still accurate (Lebesgue constant `O(log n)`).
pub fn chebyshev_points(n: usize) -> Vec<f64> {
    let nf = n as f64;
    (0..n)
        .map(|j| (std::f64::consts::PI * (j as f64 + 0.5) / nf).cos())
        .collect()
}

/// Coefficients `c_k` of the interpolant `p(x) = Σ_k c_k T_k(x)` through `values[j] = f(x_j)` at
/// the points of [`chebyshev_points`] (a DCT-II, done directly: `n` is small here).
pub fn chebyshev_coefficients(values: &[f64]) -> Vec<f64> {
    let n = values.len();
    let nf = n as f64;
    (0..n)
        .map(|k| {
            let sum: f64 = values
                .iter()
                .enumerate()
                .map(|(j, &v)| v * (std::f64::consts::PI * k as f64 * (j as f64 + 0.5) / nf).cos())
                .sum();
            if k == 0 { sum / nf } else { 2.0 * sum / nf }
        })
        .collect()
}

/// `Σ_k c_k T_k(x)` by Clenshaw's recurrence (backward-stable for `x ∈ [-1, 1]`).
#[inline]
pub fn chebyshev_eval(coefficients: &[f64], x: f64) -> f64 {
    let (mut b1, mut b2) = (0.0, 0.0);
    let x2 = 2.0 * x;
    for &c in coefficients.iter().skip(1).rev() {
        let b0 = c + x2 * b1 - b2;
        b2 = b1;
        b1 = b0;
    }
    coefficients.first().copied().unwrap_or(0.0) + x * b1 - b2
}

/// [`chebyshev_eval`] at every `xs[j]` into `out[j]`, four points at a time: the same operations
/// per point (so the same values), four independent recurrences in flight instead of one chain.
pub fn chebyshev_eval_into(coefficients: &[f64], xs: &[f64], out: &mut [f64]) {
    assert_eq!(xs.len(), out.len());
    let c0 = coefficients.first().copied().unwrap_or(0.0);
    let mut points = xs.chunks_exact(4);
    let mut values = out.chunks_exact_mut(4);
    for (x, value) in (&mut points).zip(&mut values) {
        let x2 = [0, 1, 2, 3].map(|l| 2.0 * x[l]);
        let (mut b1, mut b2) = ([0.0; 4], [0.0; 4]);
        for &c in coefficients.iter().skip(1).rev() {
            for l in 0..4 {
                let b0 = c + x2[l] * b1[l] - b2[l];
                b2[l] = b1[l];
                b1[l] = b0;
            }
        }
        for l in 0..4 {
            value[l] = c0 + x[l] * b1[l] - b2[l];
        }
    }
    for (x, value) in points.remainder().iter().zip(values.into_remainder()) {
        *value = chebyshev_eval(coefficients, *x);
    }
}

/// `∫_{-1}^{1} Σ_k c_k T_k(x) dx = Σ_{k even} 2 c_k / (1 − k²)`.
pub fn chebyshev_integral(coefficients: &[f64]) -> f64 {
    coefficients
        .iter()
        .enumerate()
        .step_by(2)
        .map(|(k, &c)| {
            let k = k as f64;
            2.0 * c / (1.0 - k * k)
        })
        .sum()
}

/// The 21-point Gauss–Kronrod rule on `[-1, 1]` and its embedded 10-point Gauss–Legendre rule
/// (QUADPACK's `qk21`; Piessens et al., *QUADPACK*, Springer 1983): `(nodes, Kronrod weights,
/// Gauss weights)` for the non-negative nodes, the node 0 last. The Gauss nodes are the odd
/// entries (indices 1, 3, …, 9); the Kronrod rule is exact for polynomials of degree ≤ 31, the
/// Gauss rule for degree ≤ 19, and `|K21 − G10|` estimates G10's error (so K21's is far smaller).
// QUADPACK's published digits, kept verbatim so that they can be checked against the source;
// the compiler rounds each to the nearest f64.
#[allow(clippy::excessive_precision)]
pub const KRONROD21: ([f64; 11], [f64; 11], [f64; 5]) = (
    [
        0.995_657_163_025_808_080_735_527_280_689_003,
        0.973_906_528_517_171_720_077_964_012_084_452,
        0.930_157_491_355_708_226_001_207_180_059_508,
        0.865_063_366_688_984_510_732_096_688_423_493,
        0.780_817_726_586_416_897_063_717_578_345_042,
        0.679_409_568_299_024_406_234_327_365_114_874,
        0.562_757_134_668_604_683_339_000_099_272_694,
        0.433_395_394_129_247_190_799_265_943_165_784,
        0.294_392_862_701_460_198_131_126_603_103_866,
        0.148_874_338_981_631_210_884_826_001_129_720,
        0.0,
    ],
    [
        0.011_694_638_867_371_874_278_064_396_062_192,
        0.032_558_162_307_964_727_478_818_972_459_390,
        0.054_755_896_574_351_996_031_381_300_244_580,
        0.075_039_674_810_919_952_767_043_140_916_190,
        0.093_125_454_583_697_605_535_065_465_083_366,
        0.109_387_158_802_297_641_899_210_590_325_805,
        0.123_491_976_262_065_851_077_600_525_634_580,
        0.134_709_217_311_473_325_928_054_001_771_707,
        0.142_775_938_577_060_080_797_094_273_138_717,
        0.147_739_104_901_338_491_374_841_515_972_068,
        0.149_445_554_002_916_905_664_936_468_389_821,
    ],
    [
        0.066_671_344_308_688_137_593_568_809_893_332,
        0.149_451_349_150_580_593_145_776_339_657_697,
        0.219_086_362_515_982_043_995_534_934_228_163,
        0.269_266_719_309_996_355_091_226_921_569_469,
        0.295_524_224_714_752_870_173_892_994_651_338,
    ],
);

/// A Gauss–Kronrod pair on `[-1, 1]` for adaptive quadrature: the non-negative nodes with the
/// node 0 last, the Kronrod weights of each, and the Gauss weights of the odd-indexed nodes
/// (indices 1, 3, …) and of the centre (0 when the Gauss rule has no node at 0).
#[derive(Clone, Copy, Debug)]
pub struct Kronrod {
    pub nodes: &'static [f64],
    pub kronrod: &'static [f64],
    pub gauss: &'static [f64],
    pub gauss_centre: f64,
}

/// [`KRONROD21`] as a [`Kronrod`] pair (K21/G10).
pub const GK21: Kronrod = Kronrod {
    nodes: &KRONROD21.0,
    kronrod: &KRONROD21.1,
    gauss: &KRONROD21.2,
    gauss_centre: 0.0,
};

/// The 7-point Kronrod extension of the 3-point Gauss rule (exact for degree ≤ 11; the Gauss
/// rule for degree ≤ 5; Kronrod 1965, Laurie 1997): nodes `±0.96049…` and `±0.43424…` added to
/// Gauss's `±√(3/5)` and 0. For narrow pieces of a smooth integrand, where 21 points are
/// wasted (the texel sum's map rows).
#[allow(clippy::excessive_precision)]
pub const GK7: Kronrod = Kronrod {
    nodes: &[
        0.960_491_268_708_020_2,
        0.774_596_669_241_483_4,
        0.434_243_749_346_802_6,
        0.0,
    ],
    kronrod: &[
        0.104_656_226_026_467_3,
        0.268_488_089_868_333_4,
        0.401_397_414_775_962_2,
        0.450_916_538_658_474_1,
    ],
    gauss: &[0.555_555_555_555_555_6],
    gauss_centre: 0.888_888_888_888_888_8,
};

#[cfg(test)]
mod tests {
    use super::*;

    /// Four points at a time give exactly the one-at-a-time values, remainder included.
    #[test]
    fn chebyshev_eval_into_matches_chebyshev_eval_bit_for_bit() {
        let c: Vec<f64> = (0..18).map(|k| ((k * 7919) % 23) as f64 / 23.0 - 0.4).collect();
        for n in [0, 1, 3, 4, 5, 11] {
            let xs: Vec<f64> = (0..n)
                .map(|j| -1.0 + 2.0 * (j as f64 + 0.37) / (n as f64 + 0.5))
                .collect();
            let mut out = vec![f64::NAN; n];
            chebyshev_eval_into(&c, &xs, &mut out);
            for (x, v) in xs.iter().zip(&out) {
                assert_eq!(v.to_bits(), chebyshev_eval(&c, *x).to_bits(), "n {n}, x {x}");
            }
        }
    }

    /// The Gauss–Jacobi rule for `u^β` on `[0, 1]` integrates `u^k` to `1/(β + k + 1)` for every
    /// `k ≤ 2n − 1` (to `1e-13`: the eigensolver's few ulps in the nodes, times `k ≤ 17`), and
    /// not `u^(2n)`.
    #[test]
    fn gauss_jacobi_is_exact_to_degree_2n_minus_1() {
        for &beta in &[0.0, 0.01, 0.3, 0.9, 1.5, 7.25] {
            for n in [1, 4, 9] {
                let (u, w) = gauss_jacobi_unit(n, beta);
                assert!(u.iter().all(|&x| x > 0.0 && x < 1.0));
                let moment = |k: i32| u.iter().zip(&w).map(|(x, w)| w * x.powi(k)).sum::<f64>();
                for k in 0..2 * n as i32 {
                    let exact = 1.0 / (beta + k as f64 + 1.0);
                    assert!(
                        (moment(k) - exact).abs() <= 1e-13 * exact,
                        "β {beta}, n {n}, k {k}: {} vs {exact}",
                        moment(k)
                    );
                }
                // (Past n = 4 the rule's error on u^(2n) is itself below 1e-10.)
                let k = 2 * n as i32;
                let exact = 1.0 / (beta + k as f64 + 1.0);
                assert!(
                    n > 4 || (moment(k) - exact).abs() > 1e-10 * exact,
                    "β {beta}, n {n}: exact past 2n − 1"
                );
            }
        }
    }

    /// The 7-point pair: Kronrod exact to degree 11 and not 12, Gauss to degree 5 and not 6.
    #[test]
    fn kronrod_7_is_exact_to_degree_11() {
        let moment = |rule: &Kronrod, gauss: bool, k: i32| -> f64 {
            let m = rule.nodes.len() - 1;
            let mut s = 0.0;
            for i in 0..m {
                let w = if gauss {
                    if i % 2 == 1 { rule.gauss[i / 2] } else { 0.0 }
                } else {
                    rule.kronrod[i]
                };
                s += w * (rule.nodes[i].powi(k) + (-rule.nodes[i]).powi(k));
            }
            let centre = if gauss { rule.gauss_centre } else { rule.kronrod[m] };
            s + if k == 0 { centre } else { 0.0 }
        };
        let exact = |k: i32| if k % 2 == 1 { 0.0 } else { 2.0 / (k as f64 + 1.0) };
        for k in 0..=11 {
            assert!(
                (moment(&GK7, false, k) - exact(k)).abs() < 1e-15,
                "Kronrod, degree {k}"
            );
            if k <= 5 {
                assert!(
                    (moment(&GK7, true, k) - exact(k)).abs() < 1e-15,
                    "Gauss, degree {k}"
                );
            }
        }
        assert!((moment(&GK7, false, 12) - exact(12)).abs() > 1e-6);
        assert!((moment(&GK7, true, 6) - exact(6)).abs() > 1e-3);
        // The 21-point pair through the same view.
        for k in 0..=31 {
            assert!(
                (moment(&GK21, false, k) - exact(k)).abs() < 1e-15,
                "K21, degree {k}"
            );
        }
    }

    /// The Kronrod constants: the Gauss nodes and weights agree with [`gauss_legendre`]`(10)`,
    /// and the rules integrate `x^k` exactly up to degree 31 (Kronrod) and 19 (Gauss).
    #[test]
    fn kronrod_21_is_exact_to_degree_31() {
        let (x, wk, wg) = KRONROD21;
        let (gx, gw) = gauss_legendre(10);
        for (m, i) in (1..10).step_by(2).enumerate() {
            assert!(
                (x[i] - gx[9 - m]).abs() < 1e-15 && (wg[m] - gw[9 - m]).abs() < 1e-15,
                "node {i}"
            );
        }
        let kronrod = |k: i32| {
            (0..10)
                .map(|i| wk[i] * (x[i].powi(k) + (-x[i]).powi(k)))
                .sum::<f64>()
                + wk[10] * if k == 0 { 1.0 } else { 0.0 }
        };
        let gauss = |k: i32| {
            (0..5)
                .map(|m| wg[m] * (x[2 * m + 1].powi(k) + (-x[2 * m + 1]).powi(k)))
                .sum::<f64>()
        };
        for k in 0..=31 {
            let exact = if k % 2 == 1 { 0.0 } else { 2.0 / (k as f64 + 1.0) };
            assert!((kronrod(k) - exact).abs() < 1e-15, "Kronrod, degree {k}");
            if k <= 19 {
                assert!((gauss(k) - exact).abs() < 1e-15, "Gauss, degree {k}");
            }
        }
        // Not exact beyond: the test can tell a wrong constant from a right one.
        assert!((kronrod(32) - 2.0 / 33.0).abs() > 1e-12);
    }

    #[test]
    fn integrates_polynomials_exactly() {
        for n in [1, 2, 5, 20, 64] {
            let q = GaussLegendre::new(n);
            for p in 0..(2 * n) {
                let got = q.integrate(0.0, 1.0, |x| x.powi(p as i32));
                let want = 1.0 / (p as f64 + 1.0);
                assert!((got - want).abs() < 1e-14, "n={n} p={p}: {got} vs {want}");
            }
        }
    }

    /// Nodes ascending in `(-1, 1)`, symmetric, weights positive and summing to 2.
    #[test]
    fn nodes_are_ordered_and_symmetric() {
        for n in [1, 2, 7, 20, 30, 64] {
            let q = GaussLegendre::new(n);
            let (x, w) = (q.nodes(), q.weights());
            assert!(x.windows(2).all(|p| p[0] < p[1]), "n={n}");
            assert!(x.iter().all(|&x| x > -1.0 && x < 1.0));
            for i in 0..n {
                assert_eq!(x[i], -x[n - 1 - i]);
                assert!(w[i] > 0.0);
            }
            assert!((w.iter().sum::<f64>() - 2.0).abs() < 1e-14, "n={n}");
        }
    }

    /// A smooth non-polynomial integrand converges to machine precision: `∫_{-1}^{1} e^x dx`.
    #[test]
    fn integrates_exponential() {
        let want = 1f64.exp() - (-1f64).exp();
        for n in [12, 20, 30] {
            let got = GaussLegendre::new(n).integrate(-1.0, 1.0, f64::exp);
            assert!((got - want).abs() < 4e-16 * want, "n={n}: {got} vs {want}");
        }
    }

    /// The interpolant reproduces polynomials of degree `< n` (coefficients exactly `T_k`'s),
    /// converges for smooth functions, and its integral is exact.
    #[test]
    fn chebyshev_interpolation() {
        let n = 12;
        let x = chebyshev_points(n);
        for k in 0..n {
            // T_k(x_j) = cos(k θ_j): the coefficients must be the unit vector e_k.
            let v: Vec<f64> = x.iter().map(|&x| (k as f64 * x.acos()).cos()).collect();
            let c = chebyshev_coefficients(&v);
            for (i, &ci) in c.iter().enumerate() {
                let want = if i == k { 1.0 } else { 0.0 };
                assert!((ci - want).abs() < 1e-14, "k={k} i={i}: {ci}");
            }
        }
        let n = 24;
        let v: Vec<f64> = chebyshev_points(n).iter().map(|&x| (2.0 * x).exp()).collect();
        let c = chebyshev_coefficients(&v);
        for i in 0..=200 {
            let t = -1.0 + 2.0 * i as f64 / 200.0;
            let got = chebyshev_eval(&c, t);
            assert!(
                (got - (2.0 * t).exp()).abs() < 1e-14 * (2.0 * t).exp().max(1.0),
                "x={t}"
            );
        }
        let want = ((2.0f64).exp() - (-2.0f64).exp()) / 2.0;
        assert!((chebyshev_integral(&c) - want).abs() < 1e-14 * want);
        assert_eq!(chebyshev_eval(&[], 0.3), 0.0);
        assert_eq!(chebyshev_eval(&[1.5], 0.3), 1.5);
    }
}
