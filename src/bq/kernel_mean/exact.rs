//! The exact kernel mean by one-dimensional quadrature over the circles `x·y = t` (math.md §4).
//!
//! For `x` at polar angle `θ_x` (`μ = cos θ_x`) the circle `{y : x·y = t}` meets the upper
//! hemisphere `H` in an arc of azimuthal measure
//! `Φ(t) = 2 arccos(clamp(−t cos θ_x / (sin θ_x √(1 − t²)), −1, 1))`, so
//! `z(μ) = ∫_{−1}^{1} κ(2 − 2t) Φ(t) dt`.
//!
//! With `a = sin θ_x = √(1 − μ²)` the clamp is active for `|t| ≥ a`: for `μ ≥ 0` the arc is the
//! whole circle (`Φ = 2π`) on `[a, 1]` and empty on `[−1, −a]` (the other way round for `μ < 0`).
//! That "cap" part has a closed form; only `t ∈ [−a, a]` needs quadrature.
//!
//! The middle part is awkward near the horizon (`μ → 0`): `Φ` has square-root kinks at
//! `t = ±a`, which approach `t = ±1` like `μ²`, right where the Sobolev profile has its
//! `(1 − t)^(s−1)` singularity. A plain split in `t` silently loses digits there. So we
//! integrate in angles instead: write `t = cos γ` on the half `t ∈ [0, a]` and `t = −cos γ` on
//! `[−a, 0]`, with `γ = δ + u`, `δ = π/2 − θ_x = asin |μ|` and `u ∈ [0, θ_x]` the angular
//! distance from the kink. Both halves then share one variable `u`, in which
//!
//! * the kinks of both halves sit at `u = 0` and behave like `√u`,
//! * every other singularity (the Sobolev point singularity at `γ = 0`, the branch points of
//!   `arccos` at `γ = −δ` and `γ = π − δ`) is at distance `≥ min(δ, θ_x)` from `[0, θ_x]`,
//! * `2 − 2t = 4 sin²(γ/2)` (resp. `4 cos²(γ/2)`) and `Φ` come out without cancellation.
//!
//! Panels are graded geometrically (ratio 2) away from `u = 0` starting at width
//! `w₀ = min(δ, θ_x)` (smaller for a fast-decaying squared exponential, see [`decay_width`]), so
//! each panel is as far from the nearest singularity as it is wide; the
//! first panel uses `u = w₀ v²`, which turns the `√u` kink into a polynomial factor. Gauss–Legendre
//! then converges geometrically on every panel, uniformly in `μ`.

use crate::bq::kernel::Kernel;
use crate::util::quadrature::GaussLegendre;
use std::f64::consts::TAU;
use std::sync::LazyLock;

/// Gauss–Legendre points per panel. With every singularity at least one panel width away the
/// error shrinks by a factor `≲ 1/4.6²` per point; against the 2-D reference 12 points already
/// give ~1e-15 for the Sobolev kernel, but squared exponentials with short length scales below
/// the horizon (where `z` is tiny) need ~16, so 24 leaves a margin.
const POINTS_PER_PANEL: usize = 24;

/// The panel rule, built once (Newton iteration for the nodes is not free).
static RULE: LazyLock<GaussLegendre> = LazyLock::new(|| GaussLegendre::new(POINTS_PER_PANEL));

/// Smallest first-panel width. For `|μ| < 1e-20` the kink region is thinner than this, and the
/// bounded integrand over it contributes `O(1e-20)`, far below double precision of `z`; the floor
/// keeps the number of panels (`≈ log₂(θ_x / w₀)`) at most ~70.
const MIN_FIRST_PANEL: f64 = 1e-20;

/// `z(μ) = ∫_H k(x, ω) dω` for a point `x` with `x·n = μ` (math.md §4).
///
/// `μ ∈ [−1, 1]`; `μ < 0` is a point below the horizon, still integrated over the upper
/// hemisphere. Values outside are clamped to `[−1, 1]`; NaN gives NaN.
///
/// `z(μ) = 2π ∫_{cap} κ(2 − 2t) dt + ∫_{−a}^{a} κ(2 − 2t) Φ(t) dt`, the cap being `[a, 1]` for
/// `μ ≥ 0` and `[−1, −a]` for `μ < 0`, `a = √(1 − μ²)`; the second integral by graded
/// Gauss–Legendre in the angle variable described in the module docs. Relative accuracy is
/// ~1e-15; a call costs `O(log(1/|μ|))` panels of 24 points, ≲ 0.15 ms (μ = 1e-12).
pub fn kernel_mean_exact(kernel: &Kernel, mu: f64) -> f64 {
    if mu.is_nan() {
        return f64::NAN;
    }
    let mu = mu.clamp(-1.0, 1.0);
    let above = mu >= 0.0;
    let m = mu.abs();
    // a = sin θ_x = cos δ; the product form keeps it accurate near |μ| = 1.
    let a = ((1.0 - m) * (1.0 + m)).sqrt();
    // 1 − a without cancellation near the horizon.
    let one_minus_a = m * m / (1.0 + a);
    let cap = TAU * cap_integral(kernel, one_minus_a, above);

    // θ_x for the upper point (the lower one mirrors it, `π − θ_x`), and δ = π/2 − θ_x, each
    // computed directly rather than as a difference.
    let theta = m.acos();
    let delta = m.asin();
    if theta == 0.0 || a == 0.0 {
        return cap;
    }

    // Both halves of [−a, a] at distance u from their kink. The arc for the half with t > 0 on
    // the side of x is 2π − A(u), the one with t < 0 is A(u), where A = 2 arccos(r),
    // r = tan δ / tan γ, and 1 − r = sin u / (cos δ sin γ) exactly.
    let integrand = |u: f64| {
        let g = delta + u;
        let (sh, ch) = (0.5 * g).sin_cos();
        let sin_g = 2.0 * sh * ch;
        // (1 − r)/2 ∈ [0, ½]; the clamp only guards rounding at u = θ_x.
        let half_one_minus_r = (u.sin() / (2.0 * a * sin_g)).clamp(0.0, 0.5);
        // 2 arccos(r) = 4 asin(√((1 − r)/2)), accurate for r near 1.
        let arc = 4.0 * half_one_minus_r.sqrt().asin();
        let near = kernel.of_squared_distance(4.0 * sh * sh);
        let far = kernel.of_squared_distance(4.0 * ch * ch);
        let (phi_near, phi_far) = if above { (TAU - arc, arc) } else { (arc, TAU - arc) };
        sin_g * (near * phi_near + far * phi_far)
    };

    let rule = &*RULE;
    let w0 = delta
        .min(theta)
        .min(decay_width(kernel, m))
        .max(MIN_FIRST_PANEL)
        .min(theta);
    // First panel [0, w0] with u = w0 v²: du = 2 w0 v dv, and √u = √w0 v is smooth in v.
    let mut middle = rule.integrate(0.0, 1.0, |v| 2.0 * w0 * v * integrand(w0 * v * v));
    let mut lo = w0;
    while lo < theta {
        let hi = (2.0 * lo).min(theta);
        middle += rule.integrate(lo, hi, integrand);
        lo = hi;
    }
    cap + middle
}

/// A width in `u` over which the profile near the kink may decay by `e^(−8)`, if shorter than the
/// singularity spacing `min(δ, θ_x)`.
///
/// Only the squared exponential decays: near `u = 0`, `1 − t ≈ (1 − cos δ) + u sin δ + u²/2`, so
/// `κ ∝ exp(−u |μ| / l²)`. Below the horizon (`μ < 0`) that near edge carries the whole of the
/// (then tiny) `z`, and a first panel much wider than `l²/|μ|` would resolve it to only ~1e-8
/// relative (seen for `l = 0.05`, `μ = −0.6`). The `u²/2` term needs no bound of its own: when
/// `δ > l` this width is already `< 4π l` (as `sin δ > 2δ/π`), and when `δ ≤ l` the first panel
/// is `δ`.
fn decay_width(kernel: &Kernel, m: f64) -> f64 {
    match kernel {
        Kernel::Sobolev(_) => f64::INFINITY,
        Kernel::SquaredExponential(k) => 8.0 * k.length() * k.length() / m,
    }
}

/// `∫ κ(2 − 2t) dt` over the cap where the whole circle lies in `H`: `[a, 1]` if `above`,
/// else `[−1, −a]`, given `e = 1 − a`.
///
/// The same closed forms as [`Kernel::integral_over_t`], rearranged so that a short cap
/// (`e → 0`, the horizon) is computed to full relative precision instead of as the
/// difference of two nearly equal terms.
fn cap_integral(kernel: &Kernel, e: f64, above: bool) -> f64 {
    match kernel {
        Kernel::Sobolev(k) => {
            // κ = P(t) ± (2 − 2t)^(s−1): the power integrates to [(2 − 2t)^s]/(2s) between the
            // ends; the polynomial part is the kernel's own (Sobolev::cap_integral).
            let s = k.s();
            let power_term = if above {
                // (2 − 2a)^s − 0.
                (2.0 * e).powf(s)
            } else {
                // 4^s − (2 + 2a)^s = 4^s (1 − (1 − e/2)^s).
                -(4f64.powf(s)) * (s * (-0.5 * e).ln_1p()).exp_m1()
            };
            k.cap_integral(e, above, power_term / (2.0 * s))
        }
        Kernel::SquaredExponential(k) => {
            // κ = σ² exp(−(1 − t)/l²): ∫ = σ² l² exp(−(1 − t)/l²) between the ends.
            let l2 = k.length() * k.length();
            let tail = -(-e / l2).exp_m1();
            let scale = k.sigma() * k.sigma() * l2;
            if above {
                scale * tail
            } else {
                // exp(−(1 + a)/l²) − exp(−2/l²) = exp(−(2 − e)/l²) (1 − exp(−e/l²)).
                scale * (-(2.0 - e) / l2).exp() * tail
            }
        }
    }
}

/// `V̂ = ∫_H ∫_H k dω dω' = 2π ∫_0^1 z(μ) dμ` (math.md §4), with `z` from [`kernel_mean_exact`].
///
/// Gauss–Legendre on panels graded geometrically toward `μ = 0`, where `z` has its
/// `μ^(2s)`-type endpoint singularity (`[2^−(k+1), 2^−k]`, `k < 30`, plus `[0, 2^−30]`), each cut
/// into pieces no wider than 1/16 so that short squared-exponential length scales stay resolved.
/// This is the reference; [`super::KernelMeanTable::prior_variance`] is the fast path.
pub fn prior_variance_exact(kernel: &Kernel) -> f64 {
    const OCTAVES: i32 = 30;
    const MAX_WIDTH: f64 = 1.0 / 16.0;
    let rule = GaussLegendre::new(20);
    let z = |mu: f64| kernel_mean_exact(kernel, mu);
    let mut sum = rule.integrate(0.0, 0.5f64.powi(OCTAVES), z);
    for k in 0..OCTAVES {
        let (lo, hi) = (0.5f64.powi(k + 1), 0.5f64.powi(k));
        let pieces = ((hi - lo) / MAX_WIDTH).ceil().max(1.0) as usize;
        let w = (hi - lo) / pieces as f64;
        for p in 0..pieces {
            let a = lo + p as f64 * w;
            sum += rule.integrate(a, a + w, z);
        }
    }
    TAU * sum
}
