//! A map against a normalised Phong lobe (math.md §10, "Cells"; the `envmap` integrand family's
//! glossy truth):
//!
//! `I = ∫_{S²} L(d) · w(d) dω`, `w(d) = ((e + 1)/(2π)) max(0, a·d)^e · max(0, n·d)`,
//!
//! per channel, with `n` the unit normal and `a` the unit lobe axis (world directions). The
//! weight is not linear in `d`, so the prefix sums of [`super::integrate`] do not apply; the
//! structure is the same otherwise.
//!
//! **Outer rule** (over the map's polar angle `θ`): [`super::polar`], the adaptive K21/G10 of
//! [`super::integrate`], on pieces split at the map's rows, at the band where both hemispheres
//! meet the circles of constant `θ`, and where a circle touches the great circles `n·d = 0` and
//! `a·d = 0`, to the tolerance `tol/2` shared by QUADPACK's global strategy
//! ([`super::Strategy::WorstFirst`]). Wherever the lobe's edge `a·d = 0` crosses a cell boundary
//! the azimuth integral has a weak kink in `θ` (`~|θ − θ_c|^(1+e)` under the `thesis` lookup's
//! steps), and the edge sweeps across hundreds of boundaries; the local strategy bisected each
//! kink to an ever smaller share of the tolerance. Under Pisa (1024×512) at `e = 0.1` the global
//! one needs 29 000 nodes where the local one needed 85 000, and the worst time per normal fell
//! from 5.7 s to 1.8 s. (Breaks at every crossing cost more: 21 nodes each, about 1 000 of them.)
//!
//! **Azimuth integral** at a node: the circle's arcs inside both hemispheres are cut in closed
//! form ([`crate::render::cuts::push_crossings`]). On an arc the weight `w(ψ)` is smooth (`a·d`
//! and `n·d` are sinusoids `A sin ψ + B + C cos ψ` in the map's azimuth `ψ`) and the map is a
//! polynomial of degree ≤ 1 in `ψ` on each cell (`L = a₀ + a₁ (ψ − ψ_i)`,
//! [`super::cells::CellTable::linear`]), so each cell needs only the moments `∫w` and
//! `∫(ψ − ψ_i) w`. Each arc is cut into panels; on a panel `w` is interpolated at the 17
//! Chebyshev–Lobatto points (`p̃ = Σ_{k≤16} c_k T_k`), `p̃` and `x·p̃` are integrated in closed
//! form (Chebyshev antiderivatives) and the antiderivatives evaluated at the cell knots inside
//! the panel (Clenshaw): per node `O(17 · panels + cells)` operations instead of a quadrature
//! per cell. A panel's error estimate is
//!
//! - `τΛ` if it is resolved: `τ = 2 (|c₁₃| + |c₁₄| + |c₁₅| + |c₁₆|)` estimates `max|w − p̃|`, and
//!   `Λ = max_channel ∫_panel |L| dψ` ([`super::cells::CellTable::magnitude`]) turns it into a
//!   bound on `∫ L (w − p̃)`; resolved means that the largest sampled weight is at least 1/16 of
//!   the weight's bound on the panel, `W̄ = ((e + 1)/2π) (max a·d)^e · max n·d` (the maxima of the
//!   two sinusoids over the panel, in closed form), so that a lobe far narrower than the points'
//!   spacing cannot hide between them;
//! - `(W̄ + Σ|c_k|) Λ` if not (all that is known);
//! - `W̄Λ` for a panel skipped unsampled because `W̄Λ` is below `ε/64` per unit of its share of
//!   the circle's visible length (`ε = tol/(2π)`; its integral is taken as 0).
//!
//! Starting from the arcs, the node bisects the panel with the largest estimate until their sum
//! `e(θ)` is within `ε` (QUADPACK's global strategy: a lobe with `e < 1` has square-root end
//! points, which per-panel shares of `ε` would chase to 2⁻⁶⁰ of an arc, the sum to about 2⁻²⁰); a
//! panel is not bisected once `τ` is at rounding level or after 40 levels, and a node stops early
//! (`depth_limited`, if `e(θ) > ε` at the panel cap or the depth limit) when the panels left to
//! bisect carry under `ε/8` or there are 2¹⁴ panels.
//!
//! **Edges.** For `e < 1` the weight meets the lobe's edge `a·d = 0` (an arc's end) like
//! `(ψ − p)^e`, whose Chebyshev interpolants converge slowly: bisection chased such an end to
//! 2⁻²⁴ of an arc. A panel with `a·d ≤ 10⁻⁹` at one end (and not at the other) is graded towards
//! it: `ψ = p + h s^k` (or `q − h s^k`), `k = ⌈5/(1 + e)⌉`, and the points interpolate
//! `G = w dψ/ds ~ s^(k(1 + e) − 1)` (at least four continuous derivatives) in `x = 2s − 1`; the
//! cells' moments come from `∫G̃` and `∫s^k G̃` at each knot's `x`, and `τ` multiplies the
//! largest `|L|` on the panel ([`CellTable::peak`]) instead of `Λ`. Under Pisa that cut the weight
//! evaluations at `e = 0.3` threefold and the time per normal by a third to a half; what is left
//! there is the outer rule's, near the circles tangent to the edge.
//!
//! **Rounding.** `τ` is at rounding level when it is at most `10⁻¹⁴ Σ|c_k|` or `NOISE (e + 1)`
//! times the largest sampled weight: `(a·d)^e` turns the few ulps of `a·d` into a relative error
//! about `e` times larger, so past `e ≈ 10⁴` the weights themselves are only known to a relative
//! `~(e + 1) ε_mach`, and panels bisected below that level only chase noise (under Pisa at
//! `e = 10⁴` nodes hit the panel cap with every panel's `τ` at `0.2 (e + 1) ε_mach w_max`). The
//! same rounding is common to a whole circle where `a·d` barely varies along it (about the
//! lobe's axis), where no `τ` sees it; so each node also reports the bound
//! `r(θ) = NOISE (e + 1) Σ_panels w_max Λ` on its value's rounding error, and the outer rule
//! accepts an interval whose `|K21 − G10|` is within what `r` can make
//! ([`super::polar`]) instead of bisecting it to the depth limit.
//!
//! **Error stated**: the outer rule's accepted `Σ|K21 − G10|` plus `∫ sin θ (e(θ) + r(θ)) dθ` by
//! the outer rule's own nodes. With `ε = tol/(2π)` the inner errors add up to at most `tol/2` and the
//! outer ones to `tol/2` unless a depth limit is hit; past `e ≈ 10⁴` the rounding floor
//! `~(e + 1) ε_mach I` can exceed `tol`, and is stated rather than chased. All are estimates (`τ`
//! from the last coefficients, as `|K21 − G10|` from two rules), checked by the tests against
//! closed forms (a constant map gives the lobe family's truth), against the cell-by-cell adaptive
//! quadrature this replaced (K7/G3 on every cell at every node, about 100 times slower on a
//! 1024×512 map), against a composite Gauss–Legendre of the renderer's own lookup for lobes up
//! to `e = 10⁶` straddling four texels, and, with the data folder, against a cell-by-cell
//! Gauss–Legendre quadrature under Pisa.

use super::super::cuts::{PixelIntegral, push_crossings, push_tangencies};
use super::super::env::EnvMap;
use super::cells::{Azimuth, CellTable};
use super::{AzimuthIntegral, Strategy, polar};
use crate::util::geometry::Vec3;
use crate::util::quadrature::chebyshev_eval;
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::sync::LazyLock;

/// Degree of the weight's interpolant on a panel (`N + 1` Chebyshev–Lobatto points).
const N: usize = 16;
/// Deepest bisection of an arc (2⁻⁴⁰ of it).
const MAX_DEPTH: u32 = 40;
/// A panel counts as resolved only if its largest sampled weight is at least its bound `W̄` over
/// this.
const SPREAD: f64 = 16.0;
/// A panel whose bound `W̄Λ` is below this share of `ε` per unit of its share of the circle's
/// visible length is skipped.
const NEGLIGIBLE: f64 = 1.0 / 64.0;
/// `τ` at or below this fraction of `Σ|c_k|` is rounding: bisecting would not lower it.
const ROUNDING: f64 = 1e-14;
/// `τ` at or below this times `(e + 1)` times the largest sampled weight is the weights' own
/// rounding (module docs, "Rounding"): twenty times the `0.2 (e + 1) ε_mach` measured at
/// `e = 10⁴`. Also the relative rounding bound `r(θ)` a node reports.
const NOISE: f64 = 4.0 * f64::EPSILON;
/// Most panels per node: past it (or once the panels that may still be bisected carry less
/// than an eighth of `ε`, the rest being at rounding level or the depth limit) the node stops
/// with `depth_limited`, its error estimate still counting every panel.
const MAX_PANELS: usize = 1 << 14;

/// `I` of the module docs to the absolute tolerance `tol`, for `exponent > 0` and unit `n`, `a`.
pub fn phong(n: Vec3, a: Vec3, exponent: f64, m: &EnvMap, tol: f64) -> PixelIntegral {
    let mut out = PixelIntegral {
        value: [0.0; 3],
        error: 0.0,
        depth_limited: false,
        evaluations: 0,
    };
    let Some(breaks) = polar_breaks(&n, &a, m.height) else {
        return out;
    };
    let table = m.cells();
    let mut azimuth = Azimuthal::new(table, n, a, exponent, 0.5 * tol / PI);
    let (value, error, limited, _) = polar(
        &breaks,
        0.5 * tol,
        [1.0; 3],
        Strategy::WorstFirst,
        |theta, sin_t, cos_t| azimuth.at(theta, sin_t, cos_t),
    );
    out.value = value;
    out.error = error;
    out.depth_limited = limited || azimuth.limited;
    out.evaluations = azimuth.evaluations;
    out
}

/// The outer rule's breaks: `0`, `π/2`, `π`, the tangencies of the two great circles and the
/// map's rows, inside the band of `θ` where both hemispheres meet the circles (`None` if empty).
fn polar_breaks(n: &Vec3, a: &Vec3, height: usize) -> Option<Vec<f64>> {
    let mut breaks = vec![0.0, FRAC_PI_2, PI];
    push_tangencies(n, 0.0, &mut breaks);
    push_tangencies(a, 0.0, &mut breaks);
    let rows = height - 1;
    breaks.extend((1..rows).map(|k| k as f64 * PI / rows as f64));
    // A hemisphere meets the circles of constant θ only within π/2 of its pole's polar angle.
    let band = |v: &Vec3| {
        let t = v.y.clamp(-1.0, 1.0).acos();
        ((t - FRAC_PI_2).max(0.0), (t + FRAC_PI_2).min(PI))
    };
    let ((lo_n, hi_n), (lo_a, hi_a)) = (band(n), band(a));
    let (lo, hi) = (lo_n.max(lo_a), hi_n.min(hi_a));
    if hi <= lo {
        return None;
    }
    breaks.extend([lo, hi]);
    breaks.retain(|x| (lo..=hi).contains(x));
    breaks.sort_by(f64::total_cmp);
    breaks.dedup_by(|x, y| (*x - *y).abs() <= 1e-15);
    Some(breaks)
}

/// The visible arcs of the circle of constant `θ` inside both hemispheres, as intervals of the
/// map's azimuth `ψ` inside `[start, start + 2π]`, into `out` (`cuts` is scratch).
fn visible_arcs(
    n: &Vec3,
    a: &Vec3,
    sin_t: f64,
    cos_t: f64,
    start: f64,
    cuts: &mut Vec<f64>,
    out: &mut Vec<(f64, f64)>,
) {
    // The cuts in the azimuth φ of d = (sin θ cos φ, cos θ, sin θ sin φ), then ψ = φ + π/2.
    cuts.clear();
    cuts.extend([0.0, TAU]);
    push_crossings(sin_t * n.x, sin_t * n.z, -n.y * cos_t, cuts);
    push_crossings(sin_t * a.x, sin_t * a.z, -a.y * cos_t, cuts);
    cuts.sort_by(f64::total_cmp);
    out.clear();
    let end = start + TAU;
    for w in cuts.windows(2) {
        let (p0, p1) = (w[0], w[1]);
        if p1 <= p0 {
            continue;
        }
        let mid = 0.5 * (p0 + p1);
        let d = Vec3::new(sin_t * mid.cos(), cos_t, sin_t * mid.sin());
        if d.dot(n) <= 0.0 || d.dot(a) <= 0.0 {
            continue;
        }
        let lo = start + (p0 + FRAC_PI_2 - start).rem_euclid(TAU);
        let hi = lo + (p1 - p0);
        if hi <= end {
            out.push((lo, hi));
        } else {
            out.push((lo, end));
            out.push((start, hi - TAU));
        }
    }
}

/// `A sin ψ + B + C cos ψ` (= `v·d` on the circle of constant `θ`, `A = v_x sin θ`,
/// `B = v_y cos θ`, `C = −v_z sin θ`), with its amplitude `R` and the `ψ*` of its maximum `B + R`.
#[derive(Clone, Copy, Debug)]
struct Sinusoid {
    a: f64,
    b: f64,
    c: f64,
    r: f64,
    peak: f64,
}

impl Sinusoid {
    fn new(v: &Vec3, sin_t: f64, cos_t: f64) -> Self {
        let (a, b, c) = (v.x * sin_t, v.y * cos_t, -v.z * sin_t);
        Sinusoid {
            a,
            b,
            c,
            r: a.hypot(c),
            peak: a.atan2(c),
        }
    }

    #[inline]
    fn at(&self, x: &Azimuth) -> f64 {
        self.a * x.sin + self.b + self.c * x.cos
    }

    /// The maximum over `[p, q]` (`q − p ≤ 2π`): `B + R` if a `ψ* + 2πk` lies inside, else the
    /// larger end value (the sinusoid is monotone between its extremes).
    fn max(&self, p: &Azimuth, q: &Azimuth) -> f64 {
        let first = self.peak + ((p.psi - self.peak) / TAU).ceil() * TAU;
        if first <= q.psi {
            self.b + self.r
        } else {
            self.at(p).max(self.at(q))
        }
    }
}

/// The 17 Chebyshev–Lobatto points `x_j = cos(πj/N)` and the DCT-I that maps values there to
/// the interpolant's Chebyshev coefficients.
struct Lobatto {
    x: [f64; N + 1],
    /// `c_k = Σ_j dct[k][j] f(x_j)`.
    dct: [[f64; N + 1]; N + 1],
}

static LOBATTO: LazyLock<Lobatto> = LazyLock::new(|| {
    let nf = N as f64;
    let x = std::array::from_fn(|j| (PI * j as f64 / nf).cos());
    let half = |i: usize| if i == 0 || i == N { 0.5 } else { 1.0 };
    let dct = std::array::from_fn(|k| {
        std::array::from_fn(|j| 2.0 / nf * half(k) * half(j) * (PI * (j * k) as f64 / nf).cos())
    });
    Lobatto { x, dct }
});

/// One panel of an arc: the weight's interpolant there (`None`: skipped, its integral below
/// its error), the error estimate of `∫ L w` over it, and whether it may still be bisected.
#[derive(Clone, Copy, Debug)]
struct Panel {
    p: f64,
    q: f64,
    depth: u32,
    coefficients: Option<[f64; N + 1]>,
    /// `None`: the points are spread evenly in `ψ` and `coefficients` interpolate `w`; else the
    /// panel is graded towards that end ([`Graded`]) and they interpolate `G = w · dψ/ds`.
    graded: Option<End>,
    error: f64,
    /// The largest sampled weight times `Λ`: about `∫_panel |L| w dψ`, the scale of its rounding.
    scale: f64,
    /// Not to be bisected: skipped, at rounding level, or at the depth limit (`stuck`).
    final_: bool,
    stuck: bool,
    /// Replaced by its halves.
    split: bool,
}

/// An end of a panel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum End {
    Start,
    Finish,
}

/// The change of variables of a panel graded towards an end where `a·d = 0` (exponents
/// `e < 1`, module docs "Edges"): `ψ = p + h s^k` (towards `p`) or `ψ = q − h s^k` (towards
/// `q`), `s ∈ [0, 1]`, `h = q − p`, `x = 2s − 1` the Chebyshev variable.
#[derive(Clone, Copy, Debug)]
struct Graded {
    end: End,
    p: f64,
    q: f64,
    k: i32,
}

impl Graded {
    fn h(&self) -> f64 {
        self.q - self.p
    }

    /// `ψ` and `dψ/ds` at `s`.
    fn psi(&self, s: f64) -> (f64, f64) {
        let (h, k) = (self.h(), self.k);
        let t = h * s.powi(k);
        let slope = k as f64 * h * s.powi(k - 1);
        match self.end {
            End::Start => (self.p + t, slope),
            End::Finish => (self.q - t, slope),
        }
    }

    /// The Chebyshev variable `x = 2s − 1` of `ψ` in `[p, q]`.
    fn x(&self, psi: f64) -> f64 {
        let t = match self.end {
            End::Start => psi - self.p,
            End::Finish => self.q - psi,
        };
        let s = (t / self.h()).clamp(0.0, 1.0).powf(1.0 / self.k as f64);
        2.0 * s - 1.0
    }
}

/// Largest grading power: `k = ⌈5/(1 + e)⌉ ≤ 5` for `e > 0`.
const MAX_GRADE: usize = 5;

/// `a·d` at or below this at one end of a panel (and above it at the other) makes the panel
/// graded towards that end when `e < 1`.
const EDGE: f64 = 1e-9;

/// What the panels of one circle share: the two sinusoids, the profile rows and the skip level.
struct Circle {
    wa: Sinusoid,
    wn: Sinusoid,
    rows: [(usize, f64); 2],
    negligible: f64,
}

/// A candidate for bisection: its error estimate and index, ordered by the estimate.
#[derive(Clone, Copy, Debug)]
struct Worst(f64, usize);

impl PartialEq for Worst {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other).is_eq()
    }
}
impl Eq for Worst {}
impl PartialOrd for Worst {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Worst {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0).then(other.1.cmp(&self.1))
    }
}

/// The azimuth integrals at the outer rule's nodes, with what they have cost and how far off
/// they may be.
struct Azimuthal<'a> {
    table: &'a CellTable,
    n: Vec3,
    a: Vec3,
    exponent: f64,
    norm: f64,
    /// The grading power `k` for panels at an edge of the lobe (0: no grading, `e ≥ 1`).
    grade: i32,
    /// `ε`, the inner tolerance per node.
    tol: f64,
    limited: bool,
    evaluations: u64,
    cuts: Vec<f64>,
    arcs: Vec<(f64, f64)>,
    panels: Vec<Panel>,
    heap: std::collections::BinaryHeap<Worst>,
    /// The error estimates in `heap`, summed.
    open: f64,
}

impl<'a> Azimuthal<'a> {
    fn new(table: &'a CellTable, n: Vec3, a: Vec3, exponent: f64, tol: f64) -> Self {
        Azimuthal {
            table,
            n,
            a,
            exponent,
            norm: (exponent + 1.0) / TAU,
            // G ~ s^(k(1 + e) − 1): at least the fourth derivative continuous.
            grade: if exponent < 1.0 {
                (5.0 / (1.0 + exponent)).ceil() as i32
            } else {
                0
            },
            tol,
            limited: false,
            evaluations: 0,
            cuts: Vec::with_capacity(8),
            arcs: Vec::with_capacity(8),
            panels: Vec::with_capacity(64),
            heap: std::collections::BinaryHeap::with_capacity(64),
            open: 0.0,
        }
    }

    /// `∫ L(θ, ψ) w(θ, ψ) dψ` per channel over the circle at `θ`, with a bound on its rounding
    /// error: `(e + 1) NOISE Σ_panels w_max Λ`. That error is common to the whole circle (`a·d`
    /// is rounded at every `ψ` alike where it barely varies, as about the lobe's axis), so the
    /// panels' `τ` cannot see it; the outer rule does, as noise between nodes.
    fn at(&mut self, theta: f64, sin_t: f64, cos_t: f64) -> AzimuthIntegral {
        let table = self.table;
        visible_arcs(
            &self.n,
            &self.a,
            sin_t,
            cos_t,
            table.start(),
            &mut self.cuts,
            &mut self.arcs,
        );
        let total: f64 = self.arcs.iter().map(|(p, q)| q - p).sum();
        let mut s = [0.0; 3];
        if total <= 0.0 {
            return AzimuthIntegral::exact(s);
        }
        let circle = Circle {
            wa: Sinusoid::new(&self.a, sin_t, cos_t),
            wn: Sinusoid::new(&self.n, sin_t, cos_t),
            rows: table.rows_at(theta),
            // A skipped panel's bound is at most this share of ε per unit of its length.
            negligible: NEGLIGIBLE * self.tol / total,
        };
        self.panels.clear();
        self.heap.clear();
        self.open = 0.0;
        let mut error = 0.0;
        for k in 0..self.arcs.len() {
            let (p, q) = self.arcs[k];
            if q > p {
                let fit = self.fit(&circle, p, q, 0);
                error += self.keep(fit);
            }
        }
        // Bisect the panel with the largest error estimate until the node's total is within ε.
        while error > self.tol {
            if self.open <= 0.125 * self.tol || self.panels.len() >= MAX_PANELS {
                break;
            }
            let Some(Worst(e, k)) = self.heap.pop() else {
                break;
            };
            self.open -= e;
            let Panel { p, q, depth, .. } = self.panels[k];
            let mid = 0.5 * (p + q);
            self.panels[k].error = 0.0;
            self.panels[k].split = true;
            error -= e;
            let left = self.fit(&circle, p, mid, depth + 1);
            error += self.keep(left);
            let right = self.fit(&circle, mid, q, depth + 1);
            error += self.keep(right);
        }
        let mut error = 0.0;
        let mut scale = 0.0;
        for panel in self.panels.iter().filter(|p| !p.split) {
            error += panel.error;
            scale += panel.scale;
            match (&panel.coefficients, panel.graded) {
                (Some(c), None) => self.add(c, panel.p, panel.q, &circle.rows, &mut s),
                (Some(c), Some(end)) => {
                    let graded = Graded {
                        end,
                        p: panel.p,
                        q: panel.q,
                        k: self.grade,
                    };
                    self.add_graded(c, &graded, &circle.rows, &mut s)
                }
                (None, _) => {}
            }
        }
        // Over ε because the panels left are at rounding level is what the weights allow (and
        // stated); over it at the panel cap or the depth limit is a limit.
        self.limited |= error > self.tol
            && (self.panels.len() >= MAX_PANELS || self.panels.iter().any(|p| !p.split && p.stuck));
        AzimuthIntegral {
            value: s,
            error,
            rounding: NOISE * (self.exponent + 1.0) * scale,
        }
    }

    /// Stores a panel (in the heap of candidates for bisection unless it is final); its error.
    fn keep(&mut self, panel: Panel) -> f64 {
        let e = panel.error;
        if !panel.final_ {
            self.open += e;
            self.heap.push(Worst(e, self.panels.len()));
        }
        self.panels.push(panel);
        e
    }

    /// The weight's interpolant on `[p, q]` with its error estimate (module docs), or a skip.
    fn fit(&mut self, circle: &Circle, p: f64, q: f64, depth: u32) -> Panel {
        let table = self.table;
        let (pa, qa) = (Azimuth::new(p), Azimuth::new(q));
        let (wa, wn) = (&circle.wa, &circle.wn);
        let bound = self.norm * wa.max(&pa, &qa).max(0.0).powf(self.exponent) * wn.max(&pa, &qa).max(0.0);
        let magnitude: f64 = circle
            .rows
            .iter()
            .filter(|(_, w)| *w != 0.0)
            .map(|&(row, w)| w * table.magnitude(row, &pa, &qa))
            .sum();
        let mut panel = Panel {
            p,
            q,
            depth,
            coefficients: None,
            graded: None,
            error: bound * magnitude,
            scale: 0.0,
            final_: true,
            stuck: false,
            split: false,
        };
        if bound * magnitude <= circle.negligible * (q - p) {
            return panel;
        }
        let lobatto = &*LOBATTO;
        let (mid, h) = (0.5 * (p + q), 0.5 * (q - p));
        let weight = |psi: f64| -> f64 {
            let d = Azimuth::new(psi);
            let (ca, cn) = (wa.at(&d), wn.at(&d));
            if ca <= 0.0 || cn <= 0.0 {
                0.0
            } else {
                self.norm * ca.powf(self.exponent) * cn
            }
        };
        let graded = self.edge(wa, &pa, &qa).map(|end| Graded {
            end,
            p,
            q,
            k: self.grade,
        });
        let mut values = [0.0; N + 1];
        // The largest sampled weight, and the largest interpolated value (w or G).
        let (mut largest, mut largest_value) = (0.0f64, 0.0f64);
        for (v, &x) in values.iter_mut().zip(&lobatto.x) {
            let w = match &graded {
                None => weight(mid + h * x),
                Some(g) => {
                    let (psi, slope) = g.psi(0.5 * (1.0 + x));
                    let w = weight(psi);
                    *v = w * slope;
                    w
                }
            };
            if graded.is_none() {
                *v = w;
            }
            largest = largest.max(w);
            largest_value = largest_value.max(*v);
        }
        self.evaluations += (N + 1) as u64;
        let c: [f64; N + 1] =
            std::array::from_fn(|k| lobatto.dct[k].iter().zip(&values).map(|(t, v)| t * v).sum());
        let tail = 2.0 * c[N - 3..].iter().map(|v| v.abs()).sum::<f64>();
        let size: f64 = c.iter().map(|v| v.abs()).sum();
        let resolved = SPREAD * largest >= bound;
        panel.stuck = depth >= MAX_DEPTH || mid <= p || mid >= q;
        // What a bound on |w − p̃| (on |G − G̃| over s ∈ [0, 1]) multiplies: ∫|L| dψ (max |L|).
        let per_unit = match graded {
            None => magnitude,
            Some(_) => circle
                .rows
                .iter()
                .filter(|(_, w)| *w != 0.0)
                .map(|&(row, w)| w * table.peak(row, p, q))
                .sum(),
        };
        // An unresolved panel's integral is only known to within ∫|L| w plus what p̃ integrates to.
        panel.error = match (resolved, graded) {
            (true, _) => tail * per_unit,
            (false, None) => (bound + size) * magnitude,
            (false, Some(_)) => bound * magnitude + size * per_unit,
        };
        let rounding = (ROUNDING * size).max(NOISE * (self.exponent + 1.0) * largest_value);
        panel.final_ = panel.stuck || (resolved && tail <= rounding);
        panel.coefficients = Some(c);
        panel.graded = graded.map(|g| g.end);
        panel.scale = largest * magnitude;
        panel
    }

    /// The end of `[p, q]` on the lobe's edge (`a·d ≤ EDGE` there and not at the other end),
    /// when panels are graded (`e < 1`).
    fn edge(&self, wa: &Sinusoid, p: &Azimuth, q: &Azimuth) -> Option<End> {
        if self.grade == 0 {
            return None;
        }
        match (wa.at(p) <= EDGE, wa.at(q) <= EDGE) {
            (true, false) => Some(End::Start),
            (false, true) => Some(End::Finish),
            _ => None,
        }
    }

    /// Adds `∫_p^q L(ψ) w(ψ) dψ` to `s` for a graded panel, `G̃ = Σ_k c_k T_k(x)` interpolating
    /// `G = w dψ/ds`, `s = (1 + x)/2`, cell by cell: with `Ĝ' = G̃` and `Ŝ' = s^k G̃` in `x`, a part
    /// `[u, v]` of cell `i` has `∫w dψ = ±½ ΔĜ` and `∫(ψ − ψ_i) w dψ = (ψ_e − ψ_i) ∫w dψ ± (h/2) ΔŜ`
    /// (`ψ_e` the graded end; `+` towards `p`, where `x` grows with `ψ`, `−` towards `q`).
    fn add_graded(&self, c: &[f64; N + 1], g: &Graded, rows: &[(usize, f64); 2], s: &mut [f64; 3]) {
        const M: usize = N + 1 + MAX_GRADE;
        let table = self.table;
        let (p, q, h) = (g.p, g.q, g.h());
        let gi: [f64; N + 2] = antiderivative(c);
        let slopes = table.has_slopes();
        let si: [f64; M + 1] = if slopes {
            // s^k G̃, one factor (1 + x)/2 at a time: x T_0 = T_1, x T_j = (T_{j+1} + T_{j−1})/2.
            let mut y = [0.0; M];
            y[..=N].copy_from_slice(c);
            for _ in 0..g.k {
                let mut xy = [0.0; M];
                for j in 0..M {
                    if y[j] == 0.0 {
                        continue;
                    }
                    if j == 0 {
                        xy[1] += y[0];
                    } else {
                        xy[j - 1] += 0.5 * y[j];
                        if j + 1 < M {
                            xy[j + 1] += 0.5 * y[j];
                        }
                    }
                }
                for j in 0..M {
                    y[j] = 0.5 * (y[j] + xy[j]);
                }
            }
            antiderivative(&y)
        } else {
            [0.0; M + 1]
        };
        let (sign, anchor) = match g.end {
            End::Start => (1.0, p),
            End::Finish => (-1.0, q),
        };
        let at = |psi: f64| -> (f64, f64) {
            let x = g.x(psi);
            (
                chebyshev_eval(&gi, x),
                if slopes { chebyshev_eval(&si, x) } else { 0.0 },
            )
        };
        let at = |edge: Edge| {
            at(match edge {
                Edge::Start => p,
                Edge::Knot(k) => k,
                Edge::End => q,
            })
        };
        self.add_by_cells(p, q, rows, s, at, |i, (gu, su), (gv, sv)| {
            let zeroth = sign * 0.5 * (gv - gu);
            (zeroth, (anchor - table.knot(i)) * zeroth + 0.5 * h * (sv - su))
        });
    }

    /// Adds `∫_p^q L(ψ) p̃(ψ) dψ` to `s`, `p̃ = Σ_k c_k T_k(x)`, `ψ = m + h x`, cell by cell: with
    /// `G' = p̃` and `H' = x p̃` in `x`, a part `[u, v]` of cell `i` has `∫p̃ dψ = h ΔG` and
    /// `∫(ψ − ψ_i) p̃ dψ = h² ΔH + (m − ψ_i) h ΔG`.
    fn add(&self, c: &[f64; N + 1], p: f64, q: f64, rows: &[(usize, f64); 2], s: &mut [f64; 3]) {
        let table = self.table;
        let (m, h) = (0.5 * (p + q), 0.5 * (q - p));
        let g: [f64; N + 2] = antiderivative(c);
        let slopes = table.has_slopes();
        let h_coefficients: [f64; N + 3] = if slopes {
            // x T_0 = T_1, x T_k = (T_{k+1} + T_{k−1})/2.
            let mut xp = [0.0; N + 2];
            xp[1] += c[0];
            for k in 1..=N {
                xp[k + 1] += 0.5 * c[k];
                xp[k - 1] += 0.5 * c[k];
            }
            antiderivative(&xp)
        } else {
            [0.0; N + 3]
        };
        let at = |x: f64| -> (f64, f64) {
            let gx = chebyshev_eval(&g, x);
            (
                gx,
                if slopes {
                    chebyshev_eval(&h_coefficients, x)
                } else {
                    0.0
                },
            )
        };
        let at = |edge: Edge| match edge {
            Edge::Start => at(-1.0),
            Edge::Knot(k) => at((k - m) / h),
            Edge::End => at(1.0),
        };
        self.add_by_cells(p, q, rows, s, at, |i, (gu, hu), (gv, hv)| {
            let zeroth = h * (gv - gu);
            (zeroth, h * h * (hv - hu) + (m - table.knot(i)) * zeroth)
        });
    }

    /// Adds `∫_p^q L w dψ` to `s` cell by cell, `L = a₀ + a₁ (ψ − ψ_i)` on cell `i`: `at(edge)`
    /// gives a panel's two antiderivatives at its ends and at the knots inside it, and
    /// `moments(i, at(u), at(v))` turns them into `(∫w, ∫(ψ − ψ_i) w)` over the part `[u, v]` of
    /// cell `i`.
    fn add_by_cells(
        &self,
        p: f64,
        q: f64,
        rows: &[(usize, f64); 2],
        s: &mut [f64; 3],
        at: impl Fn(Edge) -> (f64, f64),
        moments: impl Fn(usize, (f64, f64), (f64, f64)) -> (f64, f64),
    ) {
        let table = self.table;
        let cells = table.knots().len() - 1;
        let mut i = table.cell_of(p);
        while i + 1 < cells && table.knot(i + 1) <= p {
            i += 1;
        }
        let mut u = at(Edge::Start);
        loop {
            let next = table.knot(i + 1);
            let last = i + 1 >= cells || next >= q;
            let v = at(if last { Edge::End } else { Edge::Knot(next) });
            let (zeroth, first) = moments(i, u, v);
            for &(row, w) in rows {
                if w != 0.0 {
                    let l = table.linear(row, i, zeroth, first);
                    for ch in 0..3 {
                        s[ch] += w * l[ch];
                    }
                }
            }
            if last {
                break;
            }
            u = v;
            i += 1;
        }
    }
}

/// Where [`Azimuthal::add_by_cells`] needs a panel's antiderivatives: its ends, or a knot inside.
#[derive(Clone, Copy, Debug)]
enum Edge {
    Start,
    Knot(f64),
    End,
}

/// The Chebyshev coefficients of an antiderivative of `Σ_{k<K} c_k T_k` (constant term 0):
/// `C_1 = c_0 − c_2/2`, `C_k = (c_{k−1} − c_{k+1})/(2k)` for `k ≥ 2`.
fn antiderivative<const K: usize, const L: usize>(c: &[f64; K]) -> [f64; L] {
    debug_assert_eq!(L, K + 1);
    let at = |k: usize| c.get(k).copied().unwrap_or(0.0);
    std::array::from_fn(|k| match k {
        0 => 0.0,
        1 => at(0) - 0.5 * at(2),
        _ => (at(k - 1) - at(k + 1)) / (2 * k) as f64,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrand::family::{AxisIntegrand, Profile};
    use crate::render::cuts::adaptive;
    use crate::util::quadrature::GK7;

    /// The cell-by-cell quadrature the Chebyshev panels replaced, kept as the independent check:
    /// the same outer rule and arcs, and at each node every piece of an arc between cell knots
    /// integrated by adaptive K7/G3 of `L·w` itself to a share of `ε = tol/(2π)`. Its error is
    /// the outer `Σ|K21 − G10|` plus `π · max_θ sin θ · Σ|K7 − G3|`.
    fn per_cell(n: Vec3, a: Vec3, exponent: f64, m: &EnvMap, tol: f64) -> PixelIntegral {
        let table = m.cells();
        let norm = (exponent + 1.0) / TAU;
        let breaks = polar_breaks(&n, &a, m.height).expect("the hemispheres meet");
        let inner_tol = 0.5 * tol / PI;
        let mut worst_inner = 0.0f64;
        let mut limited = false;
        let (mut cuts, mut arcs, mut pieces) = (Vec::new(), Vec::new(), Vec::new());
        let (value, error, outer_limited, _) = polar(
            &breaks,
            0.5 * tol,
            [1.0; 3],
            Strategy::Local,
            |theta, sin_t, cos_t| {
                visible_arcs(&n, &a, sin_t, cos_t, table.start(), &mut cuts, &mut arcs);
                pieces.clear();
                for &(x, y) in &arcs {
                    let mut prev = x;
                    for k in table.knots_between(x, y) {
                        pieces.push((prev, k));
                        prev = k;
                    }
                    pieces.push((prev, y));
                }
                let rows = table.rows_at(theta);
                let share = inner_tol / pieces.len().max(1) as f64;
                let mut s = [0.0; 3];
                let mut inner_error = 0.0;
                for &(x, y) in &pieces {
                    if y <= x {
                        continue;
                    }
                    let mut f = |psi: f64| -> [f64; 3] {
                        let (sp, cp) = psi.sin_cos();
                        let d = Vec3::new(sin_t * sp, cos_t, -sin_t * cp);
                        let (ca, cn) = (d.dot(&a), d.dot(&n));
                        if ca <= 0.0 || cn <= 0.0 {
                            return [0.0; 3];
                        }
                        let weight = norm * ca.powf(exponent) * cn;
                        let mut l = [0.0; 3];
                        for &(row, wr) in &rows {
                            if wr != 0.0 {
                                let v = table.value(row, psi);
                                for ch in 0..3 {
                                    l[ch] += wr * v[ch];
                                }
                            }
                        }
                        l.map(|x| x * weight)
                    };
                    let (r, e, l) = adaptive(&GK7, x, y, share, 3, &mut f);
                    limited |= l;
                    inner_error += e;
                    for ch in 0..3 {
                        s[ch] += r[ch];
                    }
                }
                worst_inner = worst_inner.max(sin_t * inner_error);
                AzimuthIntegral::exact(s)
            },
        );
        PixelIntegral {
            value,
            error: error + PI * worst_inner,
            depth_limited: limited || outer_limited,
            evaluations: 0,
        }
    }

    /// A `w × h` map of pseudo-random texels in `[0, 1)` with one bright texel of `sun`.
    fn random_map(w: usize, h: usize, sun: f32) -> EnvMap {
        let mut x = 12345u64;
        let mut next = move || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut texels: Vec<[f32; 3]> = (0..w * h).map(|_| [next(), next(), next()]).collect();
        texels[h / 3 * w + w / 2][0] += sun;
        EnvMap::from_texels(w, h, texels)
    }

    /// The Chebyshev panels agree with the cell-by-cell quadrature within the two stated
    /// errors, on a small map with a bright texel, both lookups, lobes about the normal, tilted,
    /// straddling the horizon and below it, exponents from 0.5 (a square-root edge) to 1000, and
    /// meet the tolerance without hitting a depth limit.
    #[test]
    fn panels_agree_with_the_cell_by_cell_quadrature() {
        use crate::render::env::Lookup;
        let tol = 1e-9;
        for lookup in Lookup::ALL {
            let m = random_map(24, 13, 50.0).with_lookup(lookup);
            for (n, a, e) in [
                (unit(0.0, 1.0, 0.0), unit(0.0, 1.0, 0.0), 1.0),
                (unit(0.3, 0.2, -0.9), unit(0.1, 0.6, -0.7), 0.5),
                (unit(1.0, 0.0, 0.0), unit(-0.6, 0.3, 0.74), 0.3),
                (unit(0.3, 0.2, -0.9), unit(0.1, 0.6, -0.7), 2.5),
                (unit(0.3, 0.2, -0.9), unit(0.5, 0.4, -0.3), 10.0),
                (unit(-0.7, -0.2, 0.4), unit(-0.6, 0.1, 0.6), 100.0),
                (unit(1.0, 0.0, 0.0), unit(0.02, 0.9, 0.1), 1000.0),
                (unit(0.0, 1.0, 0.0), unit(0.6, 0.05, 0.8), 1000.0),
                (unit(0.0, 1.0, 0.0), unit(0.6, -0.1, 0.8), 300.0),
            ] {
                let got = phong(n, a, e, &m, tol);
                let want = per_cell(n, a, e, &m, 0.1 * tol);
                // (The reference may hit its depth limit at the square-root ends of e < 1; its
                // error estimate still counts those intervals.)
                assert!(!got.depth_limited, "{lookup:?} e {e}: depth limit");
                assert!(
                    got.error <= tol,
                    "{lookup:?} n {n:?} a {a:?} e {e}: error estimate {}",
                    got.error
                );
                for ch in 0..3 {
                    assert!(
                        (got.value[ch] - want.value[ch]).abs() <= got.error + want.error,
                        "{lookup:?} n {n:?} a {a:?} e {e} channel {ch}: {} vs {} (errors {:.1e}, {:.1e})",
                        got.value[ch],
                        want.value[ch],
                        got.error,
                        want.error
                    );
                }
            }
        }
    }

    /// `∫ L(d) w(d) dω` by composite 10-point Gauss–Legendre in `(θ, ψ)` over the window
    /// `|θ − θ_a| ≤ β`, `|ψ − ψ_a| ≤ β / sin(θ_a − β)` around the axis `a = d(θ_a, ψ_a)`, outside
    /// which `w < e^−60 w_max` (`β = √(120/e)`), split at every kink of the map's lookup (`θ` at
    /// `kπ/(H − 1)`; `ψ` at `(2k/(W − 1) − 1)π` for `thesis`, `2π(k + ½)/W` for `mitsuba`) and
    /// into panels of at most a quarter of the lobe's width `1/√e`. `L` is the renderer's own
    /// lookup ([`EnvMap::lookup`]), not the cell table.
    fn windowed_gauss_legendre(n: Vec3, theta_a: f64, psi_a: f64, e: f64, m: &EnvMap) -> [f64; 3] {
        use crate::render::env::Lookup;
        let dir = |t: f64, p: f64| Vec3::new(t.sin() * p.sin(), t.cos(), -t.sin() * p.cos());
        let a = dir(theta_a, psi_a);
        let beta = (120.0 / e).sqrt();
        let (t0, t1) = (theta_a - beta, theta_a + beta);
        let half = beta / t0.sin();
        let (p0, p1) = (psi_a - half, psi_a + half);
        let pieces = |lo: f64, hi: f64, kinks: Vec<f64>| -> Vec<(f64, f64)> {
            let mut cuts: Vec<f64> = kinks.into_iter().filter(|k| *k > lo && *k < hi).collect();
            cuts.extend([lo, hi]);
            cuts.sort_by(f64::total_cmp);
            let width = 0.25 / e.sqrt();
            let mut out = Vec::new();
            for w in cuts.windows(2) {
                let k = ((w[1] - w[0]) / width).ceil().max(1.0) as usize;
                let h = (w[1] - w[0]) / k as f64;
                out.extend((0..k).map(|i| (w[0] + i as f64 * h, w[0] + (i + 1) as f64 * h)));
            }
            out
        };
        let rows = (0..m.height)
            .map(|k| k as f64 * PI / (m.height - 1) as f64)
            .collect();
        let columns: Vec<f64> = match m.lookup_kind() {
            Lookup::Thesis => (0..m.width)
                .map(|k| (2.0 * k as f64 / (m.width - 1) as f64 - 1.0) * PI)
                .collect(),
            Lookup::Mitsuba => (0..m.width)
                .map(|k| TAU * (k as f64 + 0.5) / m.width as f64)
                .collect(),
        };
        // Each column kink once more a turn down and up, for windows across ψ = ±π.
        let columns = columns.iter().flat_map(|c| [c - TAU, *c, c + TAU]).collect();
        let gl = crate::util::quadrature::GaussLegendre::new(10);
        let (x, wt) = (gl.nodes(), gl.weights());
        let (thetas, psis) = (pieces(t0, t1, rows), pieces(p0, p1, columns));
        let norm = (e + 1.0) / TAU;
        let mut sum = [0.0; 3];
        for &(ta, tb) in &thetas {
            let (tc, th) = (0.5 * (ta + tb), 0.5 * (tb - ta));
            for (xi, wi) in x.iter().zip(wt) {
                let t = tc + th * xi;
                for &(pa, pb) in &psis {
                    let (pc, ph) = (0.5 * (pa + pb), 0.5 * (pb - pa));
                    for (xj, wj) in x.iter().zip(wt) {
                        let d = dir(t, pc + ph * xj);
                        let (ca, cn) = (a.dot(&d), n.dot(&d));
                        if ca <= 0.0 || cn <= 0.0 {
                            continue;
                        }
                        let f = wi * wj * th * ph * t.sin() * norm * ca.powf(e) * cn;
                        let l = m.lookup(&d);
                        for ch in 0..3 {
                            sum[ch] += f * l[ch];
                        }
                    }
                }
            }
        }
        sum
    }

    /// Sharp lobes (`e` = 10⁴, 10⁵, 10⁶, far past the other tests' 1000) with their axis on a
    /// kink of the lookup (a cell corner for `thesis`, between four texel centres' lines for
    /// `mitsuba`, so that the lobe straddles four different texels), on a random map, both
    /// lookups, a normal 40° and one 80° from the axis: the panels agree with a composite
    /// Gauss–Legendre of the renderer's own lookup within the stated error, without a depth
    /// limit, and the stated error stays below `tol` plus the weights' rounding floor
    /// `(e + 1) NOISE I` times 8 (the floor the module docs derive: at these exponents `(a·d)^e`
    /// cannot be evaluated closer than that).
    #[test]
    fn sharp_lobes_agree_with_gauss_legendre_on_the_lookup() {
        use crate::render::env::Lookup;
        let tol = 1e-10;
        for lookup in Lookup::ALL {
            let m = random_map(16, 9, 0.0).with_lookup(lookup);
            let theta_a = 3.0 * PI / 8.0;
            let psi_a = match lookup {
                Lookup::Thesis => (2.0 * 5.0 / 15.0 - 1.0) * PI,
                Lookup::Mitsuba => TAU * 5.5 / 16.0,
            };
            let a = Vec3::new(
                theta_a.sin() * psi_a.sin(),
                theta_a.cos(),
                -theta_a.sin() * psi_a.cos(),
            );
            // A unit vector perpendicular to a, to tilt the normal away from it.
            let side = a.cross(&Vec3::new(0.0, 1.0, 0.0)).normalize();
            for tilt in [40f64, 80.0] {
                let t = tilt.to_radians();
                let n = (a * t.cos() + side * t.sin()).normalize();
                for e in [1e4, 1e5, 1e6] {
                    let got = phong(n, a, e, &m, tol);
                    let want = windowed_gauss_legendre(n, theta_a, psi_a, e, &m);
                    assert!(!got.depth_limited, "{lookup:?} tilt {tilt} e {e}: depth limit");
                    let largest = want.iter().fold(0.0f64, |x, v| x.max(v.abs()));
                    let floor = 8.0 * NOISE * (e + 1.0) * largest;
                    assert!(
                        got.error <= tol + floor,
                        "{lookup:?} tilt {tilt} e {e}: error estimate {:.2e} over {:.2e}",
                        got.error,
                        tol + floor
                    );
                    for (ch, (got_ch, want_ch)) in got.value.iter().zip(&want).enumerate() {
                        assert!(
                            (got_ch - want_ch).abs() <= got.error,
                            "{lookup:?} tilt {tilt} e {e} channel {ch}: {got_ch} vs {want_ch} (error estimate {:.1e})",
                            got.error
                        );
                    }
                }
            }
        }
    }

    /// The Chebyshev antiderivative differentiates back: `∫_{-1}^{x} Σ c_k T_k` against
    /// Gauss–Legendre for a polynomial of degree 16.
    #[test]
    fn antiderivative_integrates_the_series() {
        let c: [f64; N + 1] =
            std::array::from_fn(|k| 1.0 / (1.0 + k as f64) * if k % 3 == 0 { -1.0 } else { 1.0 });
        let g: [f64; N + 2] = antiderivative(&c);
        let gl = crate::util::quadrature::GaussLegendre::new(12);
        for x in [-0.7, 0.1, 0.93, 1.0] {
            let want = gl.integrate(-1.0, x, |t| chebyshev_eval(&c, t));
            let got = chebyshev_eval(&g, x) - chebyshev_eval(&g, -1.0);
            assert!((got - want).abs() < 1e-13, "x {x}: {got} vs {want}");
        }
    }

    fn unit(x: f64, y: f64, z: f64) -> Vec3 {
        Vec3::new(x, y, z).normalize()
    }

    /// Under a constant map `L` the integral is `L (e + 1)/(2π)` times the lobe family's
    /// `∫ max(0, a·d)^e max(0, n·d) dω` (an independent 1-D quadrature, 1e-14), whatever the
    /// frame: the family's frame has `n = +z` and the axis at the same angle from it.
    #[test]
    fn constant_map_gives_the_lobe_family_truth() {
        let m = EnvMap::from_texels(8, 5, vec![[0.5, 1.0, 2.0]; 40]);
        for (n, a, e) in [
            (unit(0.0, 1.0, 0.0), unit(0.0, 1.0, 0.0), 1.0),
            (unit(0.3, 0.5, -0.2), unit(0.3, 0.5, -0.2), 20.0),
            (unit(0.3, 0.5, -0.2), unit(-0.4, 0.8, 0.1), 8.0),
            (unit(1.0, -0.2, 0.4), unit(0.2, -0.9, 0.3), 2.5),
            (unit(1.0, -0.2, 0.4), unit(0.2, -0.9, 0.3), 0.3),
            (unit(0.3, 0.5, -0.2), unit(-0.4, 0.8, 0.1), 0.05),
        ] {
            let tilt = n.dot(&a).clamp(-1.0, 1.0).acos();
            let lobe = AxisIntegrand::new(Profile::Lobe { exponent: e }, [tilt.sin(), 0.0, tilt.cos()], true)
                .unwrap();
            let want = lobe.integral() * (e + 1.0) / TAU;
            let got = phong(n, a, e, &m, 1e-10);
            for (ch, l) in [0.5, 1.0, 2.0].into_iter().enumerate() {
                assert!(
                    (got.value[ch] - l * want).abs() < 1e-9,
                    "n {n:?} a {a:?} e {e} channel {ch}: {} vs {}",
                    got.value[ch],
                    l * want
                );
            }
            assert!(got.error < 1e-10, "error estimate {}", got.error);
        }
    }
}
