//! Exact pixel integrals under texel maps (math.md §10, "Cells" and "Making it fast").
//!
//! Under either lookup a lat-long map is a simple function of the map's angles: with
//! `d = (sin θ sin ψ, cos θ, −sin θ cos ψ)` (`θ` from `+y`, `ψ = atan2(d.x, −d.z)`) it is
//! constant (`thesis`) or bilinear (`mitsuba`) on a grid of cells ([`crate::render::env::cells::CellTable`]). For a
//! Lambertian pixel
//!
//! `I = (albedo/π) ∫₀^π sin θ Σ_arcs ∫_arc L(θ, ψ) (A sin ψ + B + C cos ψ) dψ dθ`,
//!
//! `A = n_x sin θ`, `B = n_y cos θ`, `C = −n_z sin θ` (so the bracket is `n·d`), the arcs being the
//! visible part of the circle of constant `θ` inside `H(n)` — the same closed-form cuts as the
//! sky's quadrature ([`super::cuts`]). The inner integral is exact: two partial cells and a
//! difference of prefix sums per arc. The outer one is adaptive Gauss–Kronrod (21 points, the
//! embedded 10-point Gauss rule as the error estimate, tolerances shared as in
//! [`super::exact`]) on pieces split at the map's rows and at every change of the arc
//! structure, each mapped by `θ = c + h sin(πv/2)` against square-root end points. Inside a
//! piece the integrand is smooth except where an arc's end crosses a cell boundary (a kink
//! where an occluder's outline crosses one; a jump in a higher derivative where the horizon
//! does, since the integrand vanishes there); the adaptive rule bisects around those. (Splitting
//! the pieces at every crossing, or using the 7-point pair, was measured to cost more
//! evaluations, not fewer.) The reported error is the sum of the accepted `|K21 − G10|`, an
//! estimate far above K21's own error on smooth pieces; the tests check it
//! against closed forms and brute force.

pub mod lobe;

use super::cuts::{Cuts, MAX_PAIRS, PixelIntegral, adaptive_above_rounding, adaptive_worst_first, sine_map};
use super::env::cells::Azimuth;
use super::env::{EnvMap, Environment};
use super::integrator::ShadingPoint;
use super::scene::Scene;
use crate::util::geometry::{Frame, Vec3};
use crate::util::quadrature::GK21;
use std::cell::RefCell;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Version of the texel sum, part of the exact reference's cache key under a map.
pub const VERSION: &str = "texel-sum v1";

/// Most integrand nodes of the outer rule for one integral ([`MAX_PAIRS`] Kronrod pairs).
pub const MAX_NODES: u64 = MAX_PAIRS * 21;

/// Default absolute tolerance per pixel and channel under a map (`render --integrator exact`,
/// a table's exact reference): well below the 1e-5 the thesis images need, and reached in
/// minutes for a 500×500 image under a 1024×512 map.
pub const DEFAULT_TOLERANCE: f64 = 1e-6;

/// Relative rounding of the Lambertian sum at a node, per unit of `(|A| + |B| + |C|) Λ` summed
/// over its intervals and rows (`Λ` the interval's
/// [`crate::render::env::cells::CellTable::rounding_scale`]): each moment is a difference of
/// prefix sums and partial cells' antiderivatives, off by a few ulps of those, not of itself —
/// with one texel of 3·10¹¹ among ones, 10⁻⁵ absolute against a tolerance of 10⁻⁶, which
/// bisection can never reach (issue 42.1: the exact render never ended). Eight ulps: the three
/// moments, with room. (The prefix sums' own accumulated rounding, a fixed offset per cell, is
/// not counted; where it matters the work limit, [`MAX_PAIRS`], ends the bisection.)
const SUM_ROUNDING: f64 = 8.0 * f64::EPSILON;

/// `L_o` at `p` under the map `m` (which `env` holds) to the absolute tolerance `tol`. The
/// stated error carries the sum's rounding floor ([`SUM_ROUNDING`], the map's magnitude times
/// the albedo's `1/π`), which can exceed `tol` under a map with very bright texels.
pub fn integrate(p: &ShadingPoint, scene: &Scene, env: &Environment, m: &EnvMap, tol: f64) -> PixelIntegral {
    let table = m.cells();
    let arcs = VisibleAzimuths {
        cuts: Cuts::new(p, scene, env),
        start: table.start(),
        arcs: RefCell::new(Vec::with_capacity(8)),
    };
    let n = p.frame.n;
    let scale = p.albedo.map(|a| a / PI);
    let mut intervals = Vec::with_capacity(8);
    let breaks = arcs.cuts.theta_breaks();
    let (value, error, limited, evaluations) =
        polar(&breaks, tol, scale, Strategy::Local, |theta, sin_t, cos_t| {
            arcs.at(cos_t, sin_t, &mut intervals);
            let (a, b, cc) = (n.x * sin_t, n.y * cos_t, -n.z * sin_t);
            let rows = table.rows_at(theta);
            let mut s = [0.0; 3];
            let mut magnitude = 0.0;
            for &(lo, hi) in &intervals {
                let (lo, hi) = (Azimuth::new(lo), Azimuth::new(hi));
                for (row, weight) in rows {
                    if weight == 0.0 {
                        continue;
                    }
                    let m = table.integral(row, &lo, &hi);
                    for ch in 0..3 {
                        s[ch] += weight * (a * m[1][ch] + b * m[0][ch] + cc * m[2][ch]);
                    }
                    magnitude += weight * table.rounding_scale(row, &lo, &hi);
                }
            }
            AzimuthIntegral {
                value: s,
                error: 0.0,
                rounding: SUM_ROUNDING * (a.abs() + b.abs() + cc.abs()) * magnitude,
            }
        });
    PixelIntegral {
        value,
        error,
        depth_limited: limited.any(),
        work_limited: limited.work,
        evaluations,
    }
}

/// What the outer rule needs at a node `θ`: the azimuth integral `s(θ)` per channel, an estimate
/// of its error and a bound `r ≥ 0` on its rounding error (the Lambertian sum's inner integral
/// is exact: its error is 0, its rounding that of the prefix sums, [`SUM_ROUNDING`]).
pub(super) struct AzimuthIntegral {
    pub value: [f64; 3],
    pub error: f64,
    pub rounding: f64,
}

impl AzimuthIntegral {
    /// An exact inner integral, free of rounding (an empty circle).
    fn exact(value: [f64; 3]) -> Self {
        AzimuthIntegral {
            value,
            error: 0.0,
            rounding: 0.0,
        }
    }
}

/// How [`polar`] shares its tolerance between its intervals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Strategy<'a> {
    /// Each piece to its share `tol (t₁ − t₀)/π`, halved at each bisection
    /// ([`adaptive_above_rounding`]): the Lambertian sums, whose integrands kink only where a
    /// circle's arc ends cross cell boundaries.
    Local,
    /// One tolerance for all pieces, the worst interval bisected first
    /// ([`adaptive_worst_first`]): a Phong lobe, whose edge crosses every cell boundary it
    /// sweeps over (module docs of [`lobe`]). `kinks` (sorted polar angles) are where the
    /// integrand is known to kink inside the pieces: an interval is split at the one nearest its
    /// middle ([`split_at_kink`]) rather than at its midpoint.
    WorstFirst { kinks: &'a [f64] },
}

/// The outer rule both texel sums share: `∫ sin θ · s(θ) dθ · scale` per channel over the pieces
/// between consecutive `breaks` (sorted polar angles), `s` the azimuth integral `inner(θ, sin θ,
/// cos θ)`. Adaptive Gauss–Kronrod K21/G10 on each piece `[t₀, t₁]` mapped by
/// `θ = c + h sin(πv/2)` (`c`, `h` its centre and half-width: the square-root end points of a
/// circle's arcs at a tangency become smooth), to the tolerance `tol` shared by `strategy`; an
/// interval is also accepted when `|K21 − G10|` is within what the nodes' rounding `r` can make.
/// Returns the value, the error estimate (the sum of the accepted `|K21 − G10|` plus the same
/// rule's `∫ sin θ (e + r) dθ · max scale` of the nodes' errors `e` and rounding `r`), which
/// limits were hit and the number of nodes where `inner` ran. The work is bounded:
/// [`MAX_PAIRS`] Kronrod pairs in all, past which every interval left is accepted as it is
/// ([`Limits::work`]).
pub(super) fn polar(
    breaks: &[f64],
    tol: f64,
    scale: [f64; 3],
    strategy: Strategy,
    mut inner: impl FnMut(f64, f64, f64) -> AzimuthIntegral,
) -> ([f64; 3], f64, Limits, u64) {
    let largest_scale = scale.iter().fold(0.0f64, |m, s| m.max(s.abs()));
    let pieces: Vec<(f64, f64)> = breaks.windows(2).map(|w| (w[0], w[1])).collect();
    let mut evaluations = 0u64;
    // The integrand in v ∈ [−1, 1] on piece `i`: the three channels, then r and e.
    let mut outer = |i: usize, v: f64| -> [f64; 5] {
        let (t0, t1) = pieces[i];
        let (c, h) = (0.5 * (t0 + t1), 0.5 * (t1 - t0));
        let Some((theta, jac, sin_t, cos_t)) = sine_map(c, h, v) else {
            return [0.0; 5];
        };
        evaluations += 1;
        let node = inner(theta, sin_t, cos_t);
        let (s, f) = (node.value, sin_t * jac);
        [
            s[0] * f * scale[0],
            s[1] * f * scale[1],
            s[2] * f * scale[2],
            node.rounding * f * largest_scale,
            node.error * f * largest_scale,
        ]
    };
    let mut value = [0.0; 3];
    let mut error = 0.0;
    let mut limited = false;
    let mut budget = MAX_PAIRS;
    match strategy {
        Strategy::Local => {
            for (i, &(t0, t1)) in pieces.iter().enumerate() {
                if t1 <= t0 {
                    continue;
                }
                let piece_tol = tol * (t1 - t0) / PI;
                let (r, e, l) =
                    adaptive_above_rounding(&GK21, -1.0, 1.0, piece_tol, 3, Some(3), &mut budget, &mut |v| {
                        outer(i, v)
                    });
                limited |= l;
                for k in 0..3 {
                    value[k] += r[k];
                }
                // (`r[4]` is 0 for the Lambertian sum's exact inner integral; `r[3]` its
                // rounding floor.)
                error += e + r[3] + r[4];
            }
        }
        Strategy::WorstFirst { kinks } => {
            let spans: Vec<(f64, f64)> = pieces
                .iter()
                .map(|&(t0, t1)| if t1 > t0 { (-1.0, 1.0) } else { (0.0, 0.0) })
                .collect();
            let split = |i: usize, a: f64, b: f64| split_at_kink(pieces[i], kinks, a, b);
            let (r, e, l) = adaptive_worst_first(&GK21, &spans, tol, 3, 3, &mut budget, split, &mut outer);
            value = [r[0], r[1], r[2]];
            error = e + r[3] + r[4];
            limited = l;
        }
    }
    let limits = Limits {
        depth: limited && budget > 0,
        work: budget == 0,
    };
    (value, error, limits, evaluations)
}

/// Which limits [`polar`] hit.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Limits {
    /// Some interval reached the depth limit (or, worst-first, the cap on open intervals)
    /// before its tolerance.
    pub depth: bool,
    /// The work limit, [`MAX_PAIRS`]: the intervals left were accepted unresolved.
    pub work: bool,
}

impl Limits {
    pub fn any(&self) -> bool {
        self.depth || self.work
    }
}

/// Where [`Strategy::WorstFirst`] splits the interval `[a, b]` (in `v`) of the piece
/// `[t₀, t₁]` mapped by `θ = c + h sin(πv/2)`: at the kink of `kinks` (sorted) nearest the
/// interval's middle `m`, if one lies in its middle half (`θ` between those of `(a + m)/2` and
/// `(m + b)/2`), else at `m`. A kink split off becomes an end of both halves: each half has one
/// kink fewer inside, where bisection would need a level per kink until they are apart. Under
/// Pisa (the lobe's edge crossing the cell boundaries, `thesis` lookup) that cut the worst of 16
/// normals from 37 600 nodes to 21 400 at `e = 0.01` and from 28 900 to 19 300 at `e = 0.1`;
/// under the `mitsuba` lookup, whose kinks are an order weaker, by 2%.
fn split_at_kink((t0, t1): (f64, f64), kinks: &[f64], a: f64, b: f64) -> f64 {
    let m = 0.5 * (a + b);
    let (c, h) = (0.5 * (t0 + t1), 0.5 * (t1 - t0));
    let theta = |v: f64| c + h * (FRAC_PI_2 * v).sin();
    let (lo, hi, middle) = (theta(0.5 * (a + m)), theta(0.5 * (m + b)), theta(m));
    let first = kinks.partition_point(|&k| k <= lo);
    let nearest = kinks[first..]
        .iter()
        .take_while(|&&k| k < hi)
        .min_by(|x, y| (*x - middle).abs().total_cmp(&(*y - middle).abs()));
    match nearest {
        // θ's inverse, kept inside the interval against rounding.
        Some(&k) => ((((k - c) / h).clamp(-1.0, 1.0).asin()) / FRAC_PI_2).clamp(a, b),
        None => m,
    }
}

/// `E(n) = (1/π) ∫_{H(n)} L(d) max(0, n·d) dω` per channel to the absolute tolerance `tol`: a
/// white Lambertian surface (`f_r = 1/π`) with unit normal `n` and nothing around it, under the
/// map `m` (which `env` holds). This is [`integrate`] with an empty scene (no occluder, so the only
/// cut of each circle is the horizon of `n`); math.md §10's irradiance.
pub fn irradiance(n: Vec3, env: &Environment, m: &EnvMap, tol: f64) -> PixelIntegral {
    let p = ShadingPoint {
        origin: Vec3::zeros(),
        frame: Frame::from_normal(n),
        albedo: [1.0; 3],
    };
    integrate(&p, &unoccluded(), env, m, tol)
}

/// A scene with no objects: nothing is ever occluded.
pub fn unoccluded() -> Scene {
    Scene {
        sphere: None,
        ground: None,
        ..Scene::default_scene()
    }
}

/// The visible arcs of a circle of constant `θ` as intervals of the map's azimuth `ψ` inside the
/// table's span `[start, start + 2π]`.
struct VisibleAzimuths<'a> {
    cuts: Cuts<'a>,
    start: f64,
    /// The arcs in the exact quadrature's azimuth, kept between calls.
    arcs: RefCell<Vec<(f64, f64)>>,
}

impl VisibleAzimuths<'_> {
    /// The intervals at `(cos θ, sin θ)`, in order, into `out`.
    fn at(&self, cos_t: f64, sin_t: f64, out: &mut Vec<(f64, f64)>) {
        let mut arcs = self.arcs.borrow_mut();
        self.cuts.arcs(cos_t, sin_t, &mut arcs);
        out.clear();
        for &(phi0, phi1) in arcs.iter() {
            push_in_span(phi0, phi1, self.start, out);
        }
    }
}

/// Pushes the arc `[φ₀, φ₁]` of the exact quadrature's azimuth (`ω = (sin θ cos φ, cos θ,
/// sin θ sin φ)`) as the map's azimuth `ψ = φ + π/2`, moved into the table's span
/// `[start, start + 2π]`: one interval, or two where it wraps past the span's end.
fn push_in_span(phi0: f64, phi1: f64, start: f64, out: &mut Vec<(f64, f64)>) {
    let end = start + TAU;
    let lo = start + (phi0 + FRAC_PI_2 - start).rem_euclid(TAU);
    let hi = lo + (phi1 - phi0);
    if hi <= end {
        out.push((lo, hi));
    } else {
        out.push((lo, end));
        out.push((start, hi - TAU));
    }
}
