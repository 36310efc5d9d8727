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

use super::env::Environment;
use super::integrator::ShadingPoint;
use super::scene::{Rgb, Scene};
use crate::util::geometry::Vec3;
use crate::util::quadrature::{GK21, Kronrod};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

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

/// Deepest bisection of one interval (2⁻⁴⁰ of it).
const MAX_DEPTH: u32 = 40;

/// Share of the tolerance given to each inner (φ) integral: its error is integrated over θ with
/// weight `sin θ` (`∫ sin θ dθ ≤ 2`), so the inner errors add at most `2 · INNER_SHARE · tol`,
/// and the outer (θ) integral gets the rest, `(1 − 2 · INNER_SHARE) · tol`.
const INNER_SHARE: f64 = 0.1;

/// The value of a pixel integral per channel with its estimated absolute error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelIntegral {
    /// `L_o` per channel.
    pub value: Rgb,
    /// Estimated absolute error (the largest over the channels).
    pub error: f64,
    /// Whether some interval hit the bisection depth limit (the error estimate still counts it).
    pub depth_limited: bool,
    /// Integrand evaluations (for benchmarks).
    pub evaluations: u64,
}

/// The geometry of one shading point: what the cuts are computed from.
pub(super) struct Cuts<'a> {
    scene: &'a Scene,
    env: &'a Environment,
    p: &'a ShadingPoint,
    n: Vec3,
    /// The azimuths of one circle's cuts, kept between calls of [`Cuts::arcs`] (which runs at
    /// every quadrature node: no allocation there).
    scratch: std::cell::RefCell<Vec<f64>>,
}

/// Pushes the solutions `φ ∈ [0, 2π)` of `a_x cos φ + a_z sin φ = b` (none when `|b| > A`).
#[inline]
fn push_crossings(ax: f64, az: f64, b: f64, out: &mut Vec<f64>) {
    let a = ax.hypot(az);
    if a <= 0.0 || b.abs() > a {
        return;
    }
    let phi0 = az.atan2(ax);
    let d = (b / a).clamp(-1.0, 1.0).acos();
    out.push((phi0 + d).rem_euclid(TAU));
    out.push((phi0 - d).rem_euclid(TAU));
}

/// `θ ∈ (0, π)` where `sin θ · A = |B(θ)|` for `B = b₀ − c_y cos θ`, i.e. where the circle of
/// constant `θ` touches the cone `ω·c = b₀` (`c` unit; `b₀ = 0` for a great circle): `θ_c ± β`
/// reflected into `[0, π]`.
fn push_tangencies(c: &Vec3, cos_beta: f64, out: &mut Vec<f64>) {
    let theta_c = c.y.clamp(-1.0, 1.0).acos();
    let beta = cos_beta.clamp(-1.0, 1.0).acos();
    for t in [theta_c - beta, theta_c + beta] {
        let t = if t < 0.0 {
            -t
        } else if t > PI {
            TAU - t
        } else {
            t
        };
        out.push(t);
    }
}

impl<'a> Cuts<'a> {
    pub(super) fn new(p: &'a ShadingPoint, scene: &'a Scene, env: &'a Environment) -> Self {
        Cuts {
            scene,
            env,
            p,
            n: p.frame.n,
            scratch: std::cell::RefCell::new(Vec::with_capacity(16)),
        }
    }

    /// The θ values where the arc structure changes or the integrand jumps or kinks in θ
    /// (for a map, its rows too), sorted, within the band of θ that meets `H(n)`.
    pub(super) fn theta_breaks(&self) -> Vec<f64> {
        let mut t = vec![0.0, FRAC_PI_2, PI];
        let o = self.p.origin;
        push_tangencies(&self.n, 0.0, &mut t);
        if let Some(s) = &self.scene.sphere {
            let d = s.centre - o;
            let dist = d.norm();
            if dist > s.radius {
                let c = d / dist;
                let cos_beta = (1.0 - (s.radius / dist).powi(2)).sqrt();
                // Only a cone that reaches into H(n) (angle to n below π/2 + β, i.e.
                // c·n > −sin β) shapes the integrand; from the sphere itself it never does.
                if c.dot(&self.n) > -(s.radius / dist) {
                    push_tangencies(&c, cos_beta, &mut t);
                }
            }
        }
        if let Some(g) = &self.scene.ground
            && o.y > g.height
        {
            // ρ = y tan(π − θ) ⇔ θ = π − atan(ρ / y) (y the height above the ground):
            // tangencies to the edge lines and the corners (where the arc's end points move
            // from one edge to the next).
            let y = o.y - g.height;
            let mut radii = Vec::new();
            for e in [g.x[1] - o.x, g.x[0] - o.x, g.z[1] - o.z, g.z[0] - o.z] {
                radii.push(e.abs());
            }
            for cx in [g.x[1], g.x[0]] {
                for cz in [g.z[1], g.z[0]] {
                    radii.push((cx - o.x).hypot(cz - o.z));
                }
            }
            t.extend(radii.into_iter().map(|r| PI - (r / y).atan()));
        }
        if let Environment::Map(m) = self.env {
            // Map rows (both lookups change their row, or their row weights' slope, there).
            let rows = m.height - 1;
            t.extend((1..rows).map(|k| k as f64 * PI / rows as f64));
        }
        // Circles of constant θ meet H(n) only within π/2 of n's own polar angle: integrate
        // there only (an empty circle still costs the arc search at every node).
        let theta_n = self.n.y.clamp(-1.0, 1.0).acos();
        let (lo, hi) = ((theta_n - FRAC_PI_2).max(0.0), (theta_n + FRAC_PI_2).min(PI));
        t.push(lo);
        t.push(hi);
        t.retain(|x| (lo..=hi).contains(x));
        t.sort_by(f64::total_cmp);
        t.dedup_by(|a, b| (*a - *b).abs() <= 1e-15);
        t
    }

    /// The direction at `(θ, φ)` from `(cos θ, sin θ)`.
    #[inline]
    pub(super) fn dir(cos_t: f64, sin_t: f64, phi: f64) -> Vec3 {
        let (s, c) = phi.sin_cos();
        Vec3::new(sin_t * c, cos_t, sin_t * s)
    }

    /// The visible arcs `[φ₀, φ₁]` of the circle of constant θ (inside `H(n)`, not occluded),
    /// in increasing order within `[0, 2π]`.
    pub(super) fn arcs(&self, cos_t: f64, sin_t: f64, out: &mut Vec<(f64, f64)>) {
        out.clear();
        let mut cuts = self.scratch.borrow_mut();
        cuts.clear();
        cuts.extend([0.0, TAU]);
        let cuts = &mut *cuts;
        let o = self.p.origin;
        let n = self.n;
        push_crossings(sin_t * n.x, sin_t * n.z, -n.y * cos_t, cuts);
        if let Some(s) = &self.scene.sphere {
            let d = s.centre - o;
            let dist = d.norm();
            if dist > s.radius {
                let c = d / dist;
                let cos_beta = (1.0 - (s.radius / dist).powi(2)).sqrt();
                push_crossings(sin_t * c.x, sin_t * c.z, cos_beta - c.y * cos_t, cuts);
            }
        }
        if let Some(g) = &self.scene.ground
            && o.y > g.height
            && cos_t < 0.0
        {
            let rho = (o.y - g.height) * sin_t / -cos_t;
            for k in [1, 0] {
                push_crossings(rho, 0.0, g.x[k] - o.x, cuts);
                push_crossings(0.0, rho, g.z[k] - o.z, cuts);
            }
        }
        cuts.sort_by(f64::total_cmp);
        // Membership of each piece, decided at its midpoint by the renderer's own tests;
        // neighbouring visible pieces merged.
        for w in cuts.windows(2) {
            let (a, b) = (w[0], w[1]);
            if b <= a {
                continue;
            }
            let mid = Self::dir(cos_t, sin_t, 0.5 * (a + b));
            if mid.dot(&n) > 0.0 && !self.scene.occluded(&o, &mid) {
                match out.last_mut() {
                    Some(last) if last.1 == a => last.1 = b,
                    _ => out.push((a, b)),
                }
            }
        }
    }
}

/// Adaptive Gauss–Kronrod of a `K`-vector on `[a, b]` with the pair `rule` ([`GK21`] here, the
/// lighter [`crate::util::quadrature::GK7`] for the texel sum): on each interval the Kronrod
/// value and its embedded Gauss value come from the same integrand values; the interval is accepted when they differ by at most its share of `tol` in every one
/// of the first `checked` components (shares halve per bisection, so they add up to `tol`), else
/// bisected. Returns the sum of the accepted Kronrod values, the sum of the accepted differences
/// (the error estimate: each is an estimate of the Gauss value's error, far above the Kronrod
/// value's for smooth pieces) and whether the depth limit was reached.
pub(super) fn adaptive<const K: usize>(
    rule: &Kronrod,
    a: f64,
    b: f64,
    tol: f64,
    checked: usize,
    f: &mut impl FnMut(f64) -> [f64; K],
) -> ([f64; K], f64, bool) {
    let (x, wk, wg) = (rule.nodes, rule.kronrod, rule.gauss);
    let m = x.len() - 1;
    let mut apply = |a: f64, b: f64| -> ([f64; K], f64) {
        let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
        let mut kr = [0.0; K];
        let mut ga = [0.0; K];
        let centre = f(c);
        for k in 0..K {
            kr[k] = wk[m] * centre[k];
            // (Only when the Gauss rule has a centre node, so that K21's sums are untouched.)
            if rule.gauss_centre != 0.0 {
                ga[k] = rule.gauss_centre * centre[k];
            }
        }
        for i in 0..m {
            let (l, r) = (f(c - h * x[i]), f(c + h * x[i]));
            for k in 0..K {
                let s = l[k] + r[k];
                kr[k] += wk[i] * s;
                if i % 2 == 1 {
                    ga[k] += wg[i / 2] * s;
                }
            }
        }
        let diff = (0..checked)
            .map(|k| (h * (kr[k] - ga[k])).abs())
            .fold(0.0, f64::max);
        (kr.map(|v| v * h), diff)
    };
    let mut total = [0.0; K];
    let mut error = 0.0;
    let mut limited = false;
    let mut stack = vec![(a, b, tol, 0u32)];
    while let Some((a, b, tol, depth)) = stack.pop() {
        let (value, diff) = apply(a, b);
        let m = 0.5 * (a + b);
        let stuck = depth >= MAX_DEPTH || m <= a || m >= b;
        if diff <= tol || stuck {
            limited |= stuck && diff > tol;
            for k in 0..K {
                total[k] += value[k];
            }
            error += diff;
        } else {
            stack.push((a, m, 0.5 * tol, depth + 1));
            stack.push((m, b, 0.5 * tol, depth + 1));
        }
    }
    (total, error, limited)
}

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
            let (sv, cv) = (FRAC_PI_2 * v).sin_cos();
            let theta = c + h * sv;
            let jac = h * FRAC_PI_2 * cv;
            let (sin_t, cos_t) = theta.sin_cos();
            if jac <= 0.0 || sin_t <= 0.0 {
                return [0.0; 4];
            }
            cuts.arcs(cos_t, sin_t, &mut arcs);
            let mut s = [0.0; 4];
            let arc_tol = inner_tol / arcs.len().max(1) as f64;
            for &(a, b) in &arcs {
                let mut f = |phi: f64| -> [f64; 3] {
                    evaluations += 1;
                    let w = Cuts::dir(cos_t, sin_t, phi);
                    p.lit(env, &w, w.dot(&cuts.n))
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
        evaluations,
    }
}
