//! A certified adaptive quadrature of a pixel's illumination integral (math.md §1 "Scene
//! integrands", §6; render-scene.md "Shading"):
//!
//! `L_o = ∫_{H(n)} V(ω) · env(ω) · (albedo/π) · (ω·n) dω`, `V(ω) = 1` if the ray from
//! `x + 1e-4 n` towards `ω` escapes the scene.
//!
//! **Coordinates.** Directions are written about the world's up axis,
//! `ω = (sin θ cos φ, cos θ, sin θ sin φ)`, `dω = sin θ dθ dφ`. Every discontinuity of the
//! integrand is then either a line `θ = const` or, for fixed `θ`, a finite set of azimuths found
//! in closed form, because each boundary is a curve `A cos(φ − φ₀) = B`:
//!
//! - the sky's horizon `ω.y = 0` (a jump of `env`) is `θ = π/2`;
//! - the boundary of `H(n)`, `ω·n = 0` (a great circle: `sin θ (n_x cos φ + n_z sin φ) = −n_y cos θ`);
//! - the sphere's silhouette seen from `x' = x + 1e-4 n`, the cone `ω·c = cos β` with
//!   `c = (centre − x')/d`, `sin β = r/d` (`sin θ (c_x cos φ + c_z sin φ) = cos β − c_y cos θ`);
//! - the ground square's edges seen from `x'` above the ground: for `θ > π/2` the ray meets the
//!   plane at horizontal distance `ρ = x'_y tan(π − θ)`, so an edge `x = ±5` is
//!   `ρ cos φ = ±5 − x'_x` and an edge `z = ±5` is `ρ sin φ = ±5 − x'_z`;
//! - (environment maps are integrated by the texel sum of [`super::texel`], which uses these
//!   cuts with the map's rows as further θ breaks).
//!
//! For each `θ` the azimuths where any of these curves crosses split `[0, 2π)` into arcs; on
//! each arc visibility and `H(n)` membership are constant, and decided at the arc's midpoint by
//! the renderer's own test ([`Scene::occluded`], `ω·n > 0`), so the analytic geometry only
//! places the cuts. Visible arcs are merged and integrated in `φ` by adaptive Gauss–Kronrod.
//! The `θ` integral is split where the arc structure changes (tangencies `|B| = A`, the
//! square's corners, the horizon, map rows) and each piece is mapped by
//! `θ = c + h sin(πv/2)` so that the square-root behaviour of arc end points at tangencies
//! becomes smooth, then integrated adaptively too.
//!
//! **Error estimate.** Each adaptive interval compares the 21-point Gauss–Kronrod value with its
//! embedded 10-point Gauss value and accepts the Kronrod value when they differ by at most that
//! interval's share of the tolerance (halved per bisection, so the shares add up to the total). The reported error is the sum of those differences over the outer (θ) integral plus
//! the integral of the inner (φ) integrals' own error sums: an estimate, not a strict bound,
//! but one that the tests check against closed forms and an independent method.

pub use super::cuts::PixelIntegral;
use super::cuts::{Cuts, adaptive, sine_map};
use super::env::Environment;
use super::integrator::ShadingPoint;
use super::scene::Scene;
use crate::util::quadrature::GK21;
use std::f64::consts::PI;

/// Version of the quadrature, part of the exact reference's cache key: change it whenever a
/// change could move any pixel by more than the tolerance.
pub const VERSION: &str = "exact-quadrature v1";

/// Default absolute tolerance for a pixel integral (every channel).
pub const DEFAULT_TOLERANCE: f64 = 1e-9;

/// The default tolerance under `env`: [`DEFAULT_TOLERANCE`], or the texel sum's
/// ([`super::texel::DEFAULT_TOLERANCE`]) under a map.
pub fn default_tolerance(env: &Environment) -> f64 {
    match env {
        Environment::Map(_) => super::texel::DEFAULT_TOLERANCE,
        _ => DEFAULT_TOLERANCE,
    }
}

/// The version of the method [`integrate`] uses under `env`, for cache keys: [`VERSION`], or
/// the texel sum's ([`super::texel::VERSION`]) under a map.
pub fn version(env: &Environment) -> &'static str {
    match env {
        Environment::Map(_) => super::texel::VERSION,
        _ => VERSION,
    }
}

/// The smallest tolerance accepted: below it rounding in the integrand (~1e-16 relative per
/// value) dominates and the adaptive loop would split to its depth limit.
pub const MIN_TOLERANCE: f64 = 1e-13;

/// Share of the tolerance given to each inner (φ) integral: its error is integrated over θ with
/// weight `sin θ` (`∫ sin θ dθ ≤ 2`), so the inner errors add at most `2 · INNER_SHARE · tol`,
/// and the outer (θ) integral gets the rest, `(1 − 2 · INNER_SHARE) · tol`.
const INNER_SHARE: f64 = 0.1;

/// `L_o` at the shading point `p` (surface normal `p.frame.n`) in every channel, to the absolute
/// tolerance `tol` (see the module documentation for the method and what the error means).
///
/// Under a texel map the integral is the texel sum of [`super::texel`] instead (math.md §10).
pub fn integrate(p: &ShadingPoint, scene: &Scene, env: &Environment, tol: f64) -> PixelIntegral {
    if let Environment::Map(m) = env {
        return super::texel::integrate(p, scene, env, m, tol);
    }
    let cuts = Cuts::new(p, scene, env);
    let breaks = cuts.theta_breaks();
    let span = PI;
    let mut value = [0.0; 3];
    let mut error = 0.0;
    let mut limited = false;
    let mut evaluations = 0u64;
    let mut arcs = Vec::new();
    let inner_tol = INNER_SHARE * tol;
    for w in breaks.windows(2) {
        let (t0, t1) = (w[0], w[1]);
        if t1 <= t0 {
            continue;
        }
        let (c, h) = (0.5 * (t0 + t1), 0.5 * (t1 - t0));
        let piece_tol = (1.0 - 2.0 * INNER_SHARE) * tol * (t1 - t0) / span;
        // θ = c + h sin(πv/2): dθ = h (π/2) cos(πv/2) dv. Components 0–2: the channels;
        // 3: the inner error sum (integrated like the value, with |·|).
        let mut outer = |v: f64| -> [f64; 4] {
            let Some((_, jac, sin_t, cos_t)) = sine_map(c, h, v) else {
                return [0.0; 4];
            };
            cuts.arcs(cos_t, sin_t, &mut arcs);
            let mut s = [0.0; 4];
            let arc_tol = inner_tol / arcs.len().max(1) as f64;
            for &(a, b) in &arcs {
                let mut f = |phi: f64| -> [f64; 3] {
                    evaluations += 1;
                    let w = Cuts::dir(cos_t, sin_t, phi);
                    p.lit(env, &w, w.dot(&p.frame.n))
                };
                let (r, e, l) = adaptive(&GK21, a, b, arc_tol, 3, &mut f);
                limited |= l;
                for k in 0..3 {
                    s[k] += r[k];
                }
                s[3] += e;
            }
            s.map(|x| x * sin_t * jac)
        };
        let (r, e, l) = adaptive(&GK21, -1.0, 1.0, piece_tol, 3, &mut outer);
        limited |= l;
        for k in 0..3 {
            value[k] += r[k];
        }
        error += e + r[3];
    }
    PixelIntegral {
        value,
        error,
        depth_limited: limited,
        work_limited: false,
        evaluations,
    }
}
