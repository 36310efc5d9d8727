use super::KernelError;

/// Sobolev kernels on the sphere (RKHS `H^s(S²)`; Marques et al. 2019; math.md §4 and §9), as
/// functions of `d² = ‖x − y‖² = 2 − 2t`, `t = x·y`, `ν = s − 1`:
///
/// - `1 < s < 2` (thesis: `s = 1.4`): `k = 2^(2s−1)/s − d^(2ν)`; its mean over the whole sphere
///   is `4π · 2^(2s−2)/s` for every `x`.
/// - `2 < s < 3`: `k = C₀ + C₁ t + d^(2ν)`;
/// - `3 < s < 4`: `k = C₀ + C₁ t + C₂ P₂(t) − d^(2ν)`;
///
/// where the low-degree coefficients continue the eigenvalue decay `(1 + l(l+1))^(−s)` below the
/// first degree at which `±d^(2ν)` alone is positive (math.md §9, [`funk_hecke_power`]). `s = 2`
/// and `s = 3` are excluded (logarithmic limits).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sobolev {
    s: f64,
    /// `κ(0)`.
    constant: f64,
    half_exponent: f64,
    /// For `s > 2`: the polynomial part in `d²` and the sign of the power.
    smooth: Option<Smooth>,
}

/// The polynomial part of a Sobolev kernel with `s > 2`, `C₀ + C₁ t + C₂ P₂(t)` written in
/// `u = d²` (`t = 1 − u/2`, `P₂(t) = 1 − 3u/2 + 3u²/8`): `a₀ + a₁ u + a₂ u²`, and the sign of
/// `d^(2ν)` (`+` for `2 < s < 3`, `−` for `3 < s < 4`).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Smooth {
    legendre: [f64; 3],
    poly: [f64; 3],
    sign: f64,
}

/// `e_l(ν) = 2π ∫_{−1}^{1} (2 − 2t)^ν P_l(t) dt`, the Funk–Hecke eigenvalue of `d^(2ν)` at
/// degree `l`: `2π · 2^(2ν+1) · (−1)^l · ν(ν−1)…(ν−l+1) / ((ν+1)(ν+2)…(ν+l+1))`
/// (Gradshteyn & Ryzhik 7.127 with `t → −t`).
pub fn funk_hecke_power(nu: f64, l: usize) -> f64 {
    let mut ratio = 1.0 / (nu + 1.0);
    for j in 0..l {
        ratio *= -(nu - j as f64) / (nu + j as f64 + 2.0);
    }
    std::f64::consts::TAU * 2f64.powf(2.0 * nu + 1.0) * ratio
}

/// The largest relative rounding error of a Sobolev kernel's entries accepted
/// ([`Sobolev::rounding`]): beyond it `s` is refused as too close to 2 or 3 (issue 30).
///
/// Why (math.md §9): for `2 < s < 3` every eigenvalue of `k = C₀ + C₁ t + d^{2ν}` is a multiple of
/// `λ₂ = e₂(ν) = 2π · 2^{2ν+1} ν(ν − 1)/((ν + 1)(ν + 2)(ν + 3))`, which vanishes like `ν − 1 =
/// s − 2`; for `3 < s < 4`, of `λ₃ = −e₃(ν) ∝ ν − 2 = s − 3`. So the kernel's scale `k(x,x)`
/// vanishes at `s → 2⁺` (about `12.2 (s − 2)`) and `s → 3⁺` (about `221 (s − 3)`), while the terms
/// it is computed from stay of size `M ≈ 8` and `32`: every entry carries a relative error
/// `u M / k(x,x)` (`u = 2⁻⁵³`), about `7.3e-17/(s − 2)` and `1.6e-17/(s − 3)`. Measured with
/// `workbench rule --n 256 --noise 0` (docs/guide/rule.md, "Sobolev s near 2 or 3"): Σw and the
/// cos³θ error are those of `s = 2.001` up to a relative error of 7.3e-6 (`s − 2 = 1e-11`) and
/// gone at 7.3e-5 (`s − 2 = 1e-12`: Σw = 0); 1e-6 leaves a factor 7 of margin. From below
/// (`s → 2⁻`, `s → 3⁻`) the scale stays of order 1 and nothing is lost. Against a noise `σ_n²`
/// the scale fails sooner: [`Sobolev::scale_warning`].
pub const MAX_ROUNDING: f64 = 1e-6;

impl Sobolev {
    /// The thesis's smoothness.
    pub const DEFAULT_S: f64 = 1.4;

    /// Validates `s ∈ (1, 2) ∪ (2, 3) ∪ (3, 4)`.
    pub fn new(s: f64) -> Result<Self, KernelError> {
        if !(s > 1.0 && s < 4.0 && s != 2.0 && s != 3.0) {
            return Err(KernelError {
                kernel: "sobolev",
                message: format!(
                    "s must be in (1, 2), (2, 3) or (3, 4), got {}",
                    crate::util::shown::shown(s)
                ),
            });
        }
        let nu = s - 1.0;
        if s < 2.0 {
            return Ok(Sobolev {
                s,
                constant: 2f64.powf(2.0 * s - 1.0) / s,
                half_exponent: nu,
                smooth: None,
            });
        }
        let e = |l: usize| funk_hecke_power(nu, l);
        let decay = |l: usize| (1.0 + (l * (l + 1)) as f64).powf(-s);
        let four_pi = 2.0 * std::f64::consts::TAU;
        // The first degree at which ±d^(2ν) has a positive eigenvalue, and that sign.
        let (first, sign) = if s < 3.0 { (2, 1.0) } else { (3, -1.0) };
        let mut legendre = [0.0; 3];
        let lambda_first = sign * e(first);
        for (l, c) in legendre.iter_mut().enumerate().take(first) {
            // λ_l = λ_first · decay(l)/decay(first); C_l = (2l + 1)(λ_l − sign · e_l)/(4π).
            let lambda = lambda_first * decay(l) / decay(first);
            *c = (2 * l + 1) as f64 * (lambda - sign * e(l)) / four_pi;
        }
        let [c0, c1, c2] = legendre;
        let poly = [c0 + c1 + c2, -0.5 * c1 - 1.5 * c2, 0.375 * c2];
        let kernel = Sobolev {
            s,
            constant: poly[0],
            half_exponent: nu,
            smooth: Some(Smooth { legendre, poly, sign }),
        };
        let rounding = kernel.rounding();
        if rounding.is_nan() || rounding > MAX_ROUNDING {
            let limit = if s < 3.0 { 2.0 } else { 3.0 };
            // k(x,x) is linear in s − limit near the limit: the s whose rounding is the bound.
            let usable = limit + (s - limit) * rounding / MAX_ROUNDING;
            return Err(KernelError {
                kernel: "sobolev",
                message: format!(
                    "s = {s} is too close to {limit}: the kernel's scale k(x,x) = {:.3e} vanishes \
                     like s − {limit} there (math.md §9: every eigenvalue is a multiple of λ{} ∝ \
                     s − {limit}) while the terms it is computed from stay near {:.0}, so its entries \
                     carry a relative rounding error of {rounding:.1e} (more than {MAX_ROUNDING:e}) \
                     and the weights are noise (Σw far from 2π); use s − {limit} ≥ {:.1e}, or s \
                     below {limit} (e.g. {})",
                    kernel.constant,
                    if s < 3.0 { "₂" } else { "₃" },
                    kernel.term_size(),
                    usable - limit,
                    limit - 0.01,
                ),
            });
        }
        Ok(kernel)
    }

    /// The size of the terms `κ` is computed from over `d² ∈ [0, 4]`: `Σ |a_i| 4^i + 4^ν` (the
    /// polynomial's coefficients in `d²` and the power), what rounding is relative to.
    pub fn term_size(&self) -> f64 {
        let power = 4f64.powf(self.half_exponent);
        match &self.smooth {
            None => self.constant.abs() + power,
            Some(sm) => sm.poly[0].abs() + 4.0 * sm.poly[1].abs() + 16.0 * sm.poly[2].abs() + power,
        }
    }

    /// The relative rounding error of the kernel's entries: `u · M / k(x,x)` ([`MAX_ROUNDING`]
    /// explains it), `u = 2⁻⁵³`, `M` the [`Sobolev::term_size`]; about 2e-16 away from the
    /// limits `s → 2⁺` and `s → 3⁺`.
    pub fn rounding(&self) -> f64 {
        f64::EPSILON / 2.0 * self.term_size() / self.constant
    }

    /// A warning with its remedy when the kernel's scale `k(x,x)`, which vanishes like `s − 2`
    /// or `s − 3` just above those limits ([`MAX_ROUNDING`]), is below the noise `σ_n²`: the
    /// model then reads the integrand as noise and the weights shrink toward 0. Measured with
    /// `workbench rule --n 256` (docs/guide/rule.md, "Sobolev s near 2 or 3"), the shortfall of
    /// Σw depends on `k(x,x)/σ_n²` alone: 0.05% at 12, 0.45% at 1.2, 4% at 0.12, 82% at 0.0012
    /// (cos³θ's error 1.28 of 1.57). Only for `s > 2`: below 2 the scale is at least 2.
    pub fn scale_warning(&self, noise: f64) -> Option<String> {
        let scale = self.constant;
        if self.smooth.is_none() || scale >= noise {
            return None;
        }
        let limit = if self.s < 3.0 { 2.0 } else { 3.0 };
        // k(x,x) is linear in s − limit near the limit: the s whose scale is the noise.
        let usable = (self.s - limit) * noise / scale;
        Some(format!(
            "the sobolev kernel s = {} has scale k(x,x) = {:.2e}, below the noise σ_n² = {} (its scale \
             vanishes like s − {limit}, math.md §9), so the model reads the integrand as noise and \
             the weights shrink toward 0 (Σw falls short of 2π); use s − {limit} ≥ {:.1e} or a noise \
             below {:.1e}",
            self.s,
            scale,
            crate::util::shown::shown(noise),
            usable,
            scale
        ))
    }

    /// `s − 1`, the exponent of `d²` (for the vectorised assembly).
    pub(crate) fn half_exponent(&self) -> f64 {
        self.half_exponent
    }

    /// `κ(d²)` given `p = (d²)^(s−1)`: what the vectorised assembly combines its powers with.
    /// For `s < 2` exactly `2^(2s−1)/s − p`.
    #[inline(always)]
    pub(crate) fn combine(&self, d2: f64, p: f64) -> f64 {
        match &self.smooth {
            None => self.constant - p,
            Some(sm) => sm.poly[0] + d2 * (sm.poly[1] + d2 * sm.poly[2]) + sm.sign * p,
        }
    }

    pub fn s(&self) -> f64 {
        self.s
    }

    /// The Legendre coefficients `[C₀, C₁, C₂]` of the polynomial part (`s > 2`; zeros below).
    pub fn legendre_coefficients(&self) -> [f64; 3] {
        self.smooth.map_or([0.0; 3], |sm| sm.legendre)
    }

    /// The sign of `d^(2ν)` in the kernel: `−` for `1 < s < 2` and `3 < s < 4`, `+` for
    /// `2 < s < 3`.
    pub fn power_sign(&self) -> f64 {
        self.smooth.map_or(-1.0, |sm| sm.sign)
    }

    /// `κ(d²)`.
    #[inline]
    pub fn of_squared_distance(&self, d2: f64) -> f64 {
        // d² = 0 gives the constant exactly (pow(0, p) = 0).
        self.combine(d2, super::fast_pow::pow(d2, self.half_exponent))
    }

    /// `∫_a^b κ(2 − 2t) dt`: the polynomial part `C₀ t + C₁ t²/2 + C₂ (t³ − t)/2` between the
    /// ends, and `± [(2 − 2a)^s − (2 − 2b)^s] / (2s)` for the power.
    pub fn integral_over_t(&self, a: f64, b: f64) -> f64 {
        let s = self.s;
        let power = ((2.0 - 2.0 * a).powf(s) - (2.0 - 2.0 * b).powf(s)) / (2.0 * s);
        match &self.smooth {
            None => self.constant * (b - a) - power,
            Some(sm) => {
                let [c0, c1, c2] = sm.legendre;
                let antiderivative = |t: f64| c0 * t + c1 * t * t / 2.0 + c2 * (t * t * t - t) / 2.0;
                antiderivative(b) - antiderivative(a) + sm.sign * power
            }
        }
    }

    /// `∫ κ(2 − 2t) dt` over `[1 − e, 1]` (`above`) or `[−1, −1 + e]`, without cancellation for a
    /// short interval: the power part is given (`∫ (2 − 2t)^ν dt` over the interval), the
    /// polynomial part is formed from `e` directly.
    pub(crate) fn cap_integral(&self, e: f64, above: bool, power: f64) -> f64 {
        match &self.smooth {
            None => self.constant * e - power,
            Some(sm) => {
                let [c0, c1, c2] = sm.legendre;
                // ∫ t dt = ±e(2 − e)/2, ∫ P₂ dt = (1 − e) e (2 − e)/2 on either cap.
                let linear = e * (2.0 - e) / 2.0;
                let linear = if above { linear } else { -linear };
                c0 * e + c1 * linear + c2 * (1.0 - e) * e * (2.0 - e) / 2.0 + sm.sign * power
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::quadrature::GaussLegendre;

    /// `e_l(ν)` against Gauss–Legendre in `t` on graded panels toward the `(1 − t)^ν` end.
    #[test]
    fn funk_hecke_eigenvalues_match_quadrature() {
        let p = |l: usize, t: f64| match l {
            0 => 1.0,
            1 => t,
            2 => (3.0 * t * t - 1.0) / 2.0,
            _ => (5.0 * t * t * t - 3.0 * t) / 2.0,
        };
        for nu in [0.4, 1.2, 1.75, 2.5, 2.9] {
            for l in 0..4 {
                let sum = graded(-1.0, 1.0, |t| (2.0 - 2.0 * t).powf(nu) * p(l, t));
                let want = std::f64::consts::TAU * sum;
                let got = funk_hecke_power(nu, l);
                assert!(
                    (got - want).abs() <= 1e-12 * want.abs().max(1.0),
                    "ν={nu}, l={l}: {got} vs {want}"
                );
            }
        }
    }

    /// `∫_a^b f dt` by 30-point Gauss–Legendre on 16 equal panels, the part within 1/2 of `t = 1`
    /// on panels graded geometrically toward it (where `(1 − t)^ν` is singular).
    fn graded(a: f64, b: f64, f: impl Fn(f64) -> f64) -> f64 {
        let rule = GaussLegendre::new(30);
        let split = b.min(0.5).max(a);
        let w = (split - a) / 16.0;
        let mut sum: f64 = (0..16)
            .map(|i| rule.integrate(a + i as f64 * w, a + (i + 1) as f64 * w, &f))
            .sum();
        if b > split {
            // [split, b] toward 1: [1 − (1 − split)2^−k, 1 − (1 − split)2^−(k+1)], cut at b.
            for k in 0..60 {
                let lo = 1.0 - (1.0 - split) * 0.5f64.powi(k);
                let hi = (1.0 - (1.0 - split) * 0.5f64.powi(k + 1)).min(b);
                if lo >= b {
                    break;
                }
                sum += rule.integrate(lo, hi, &f);
            }
        }
        sum
    }

    /// The construction of math.md §9: the kernel's eigenvalue at degree `l`,
    /// `4π C_l/(2l + 1) ± e_l` (the power's by [`funk_hecke_power`], checked against quadrature
    /// above), is positive at every degree 0..=6 and follows the decay `(1 + l(l+1))^(−s)` below
    /// the first degree the power decides.
    #[test]
    fn smoother_kernels_have_positive_eigenvalues_with_the_sobolev_decay() {
        let four_pi = 2.0 * std::f64::consts::TAU;
        for s in [2.25, 2.75, 3.25, 3.75] {
            let k = Sobolev::new(s).unwrap();
            let c = k.legendre_coefficients();
            let eig = |l: usize| {
                let poly = if l < 3 {
                    four_pi * c[l] / (2 * l + 1) as f64
                } else {
                    0.0
                };
                poly + k.power_sign() * funk_hecke_power(s - 1.0, l)
            };
            let first = if s < 3.0 { 2 } else { 3 };
            let decay = |l: usize| (1.0 + (l * (l + 1)) as f64).powf(-s);
            for l in 0..7 {
                assert!(eig(l) > 0.0, "s={s}: eigenvalue {l} = {}", eig(l));
            }
            for l in 0..first {
                let want = eig(first) * decay(l) / decay(first);
                assert!(
                    (eig(l) - want).abs() < 1e-12 * want,
                    "s={s}, l={l}: {} vs {want}",
                    eig(l)
                );
            }
            // The kernel itself has that polynomial part: κ(2 − 2t) ∓ (2 − 2t)^ν at t = 0.3.
            let t: f64 = 0.3;
            let poly = c[0] + c[1] * t + c[2] * (3.0 * t * t - 1.0) / 2.0;
            let got = k.of_squared_distance(2.0 - 2.0 * t) - k.power_sign() * (2.0 - 2.0 * t).powf(s - 1.0);
            assert!((got - poly).abs() < 1e-12 * poly.abs(), "s={s}: {got} vs {poly}");
        }
    }

    #[test]
    fn integral_over_t_matches_quadrature() {
        for s in [1.4, 2.5, 3.5] {
            let k = Sobolev::new(s).unwrap();
            for (a, b) in [(-1.0, 1.0), (-0.3, 0.8), (0.5, 1.0)] {
                let want = graded(a, b, |t| k.of_squared_distance(2.0 - 2.0 * t));
                let got = k.integral_over_t(a, b);
                assert!(
                    (got - want).abs() < 1e-12 * want.abs().max(1.0),
                    "s={s} [{a},{b}]: {got} vs {want}"
                );
            }
        }
    }

    #[test]
    fn s_of_two_three_or_outside_one_to_four_is_refused() {
        for s in [1.0, 2.0, 3.0, 4.0, 0.5, 4.5, f64::NAN] {
            assert!(Sobolev::new(s).is_err(), "s = {s}");
        }
        for s in [1.01, 1.99, 2.01, 2.99, 3.01, 3.99] {
            assert!(Sobolev::new(s).is_ok(), "s = {s}");
        }
    }
}
