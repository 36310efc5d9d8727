//! A map against a normalised Phong lobe (math.md §10, "Cells"; the `envmap` integrand family's
//! glossy truth):
//!
//! `I = ∫_{S²} L(d) · ((e + 1)/(2π)) max(0, a·d)^e · max(0, n·d) dω`
//!
//! per channel, with `n` the unit normal and `a` the unit lobe axis (world directions). The
//! weight is not linear in `d`, so the prefix sums of [`super::integrate`] do not apply; the
//! structure is the same otherwise. The outer integral over the map's polar angle `θ` is the
//! adaptive Gauss–Kronrod rule of [`super::integrate`] (K21/G10, pieces split at the map's rows and
//! where the circle of constant `θ` touches the great circles `n·d = 0` and `a·d = 0`, each piece
//! mapped by `θ = c + h sin(πv/2)`). At each node the circle's arcs inside both hemispheres are
//! cut in closed form ([`crate::render::cuts::push_crossings`]) and split at the map's cell
//! boundaries; on each piece the integrand is a polynomial of degree ≤ 1 in `ψ` times a smooth
//! weight, integrated by adaptive K7/G3 ([`crate::render::cuts::adaptive`]) to a share of
//! `ε = tol/(2π)` per node. **Bound stated**: the reported error is the outer rule's accepted
//! `Σ|K21 − G10|` (at most `tol/2` unless the depth limit is hit) plus `π · max_θ sin θ · e(θ)`,
//! `e(θ)` the inner rule's accepted `Σ|K7 − G3|` at the node (the inner errors integrate over
//! `θ ∈ [0, π]` with the weight `sin θ ≤ 1`); both are estimates, as in [`super::integrate`],
//! checked by the tests against closed forms (a constant map gives the lobe family's truth) and
//! against brute force.

use super::super::cuts::{PixelIntegral, adaptive, push_crossings, push_tangencies};
use super::super::env::EnvMap;
use crate::util::geometry::Vec3;
use crate::util::quadrature::{GK7, GK21};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// `I` of the module docs to the absolute tolerance `tol`, for `exponent > 0` and unit `n`, `a`.
pub fn phong(n: Vec3, a: Vec3, exponent: f64, m: &EnvMap, tol: f64) -> PixelIntegral {
    let table = m.cells();
    let norm = (exponent + 1.0) / TAU;
    let mut breaks = vec![0.0, FRAC_PI_2, PI];
    push_tangencies(&n, 0.0, &mut breaks);
    push_tangencies(&a, 0.0, &mut breaks);
    let rows = m.height - 1;
    breaks.extend((1..rows).map(|k| k as f64 * PI / rows as f64));
    // A hemisphere meets the circles of constant θ only within π/2 of its pole's polar angle.
    let band = |v: &Vec3| {
        let t = v.y.clamp(-1.0, 1.0).acos();
        ((t - FRAC_PI_2).max(0.0), (t + FRAC_PI_2).min(PI))
    };
    let ((lo_n, hi_n), (lo_a, hi_a)) = (band(&n), band(&a));
    let (lo, hi) = (lo_n.max(lo_a), hi_n.min(hi_a));
    let mut out = PixelIntegral {
        value: [0.0; 3],
        error: 0.0,
        depth_limited: false,
        evaluations: 0,
    };
    if hi <= lo {
        return out;
    }
    breaks.extend([lo, hi]);
    breaks.retain(|x| (lo..=hi).contains(x));
    breaks.sort_by(f64::total_cmp);
    breaks.dedup_by(|x, y| (*x - *y).abs() <= 1e-15);

    let inner_tol = 0.5 * tol / PI;
    let start = table.start();
    let end = start + TAU;
    let mut worst_inner = 0.0f64;
    let mut evaluations = 0u64;
    let mut cuts: Vec<f64> = Vec::with_capacity(8);
    let mut pieces: Vec<(f64, f64)> = Vec::with_capacity(64);
    for w in breaks.windows(2) {
        let (t0, t1) = (w[0], w[1]);
        if t1 <= t0 {
            continue;
        }
        let (c, h) = (0.5 * (t0 + t1), 0.5 * (t1 - t0));
        let piece_tol = 0.5 * tol * (t1 - t0) / PI;
        let mut outer = |v: f64| -> [f64; 3] {
            let (sv, cv) = (FRAC_PI_2 * v).sin_cos();
            let theta = c + h * sv;
            let jac = h * FRAC_PI_2 * cv;
            let (sin_t, cos_t) = theta.sin_cos();
            if jac <= 0.0 || sin_t <= 0.0 {
                return [0.0; 3];
            }
            // The arcs of the circle inside both hemispheres, in the azimuth φ of
            // d = (sin θ cos φ, cos θ, sin θ sin φ), then in the map's ψ = φ + π/2.
            cuts.clear();
            cuts.extend([0.0, TAU]);
            push_crossings(sin_t * n.x, sin_t * n.z, -n.y * cos_t, &mut cuts);
            push_crossings(sin_t * a.x, sin_t * a.z, -a.y * cos_t, &mut cuts);
            cuts.sort_by(f64::total_cmp);
            pieces.clear();
            for w in cuts.windows(2) {
                let (p0, p1) = (w[0], w[1]);
                if p1 <= p0 {
                    continue;
                }
                let mid = 0.5 * (p0 + p1);
                let d = Vec3::new(sin_t * mid.cos(), cos_t, sin_t * mid.sin());
                if d.dot(&n) <= 0.0 || d.dot(&a) <= 0.0 {
                    continue;
                }
                let lo = start + (p0 + FRAC_PI_2 - start).rem_euclid(TAU);
                let hi = lo + (p1 - p0);
                let mut push = |x: f64, y: f64| {
                    let mut prev = x;
                    for k in table.knots_between(x, y) {
                        pieces.push((prev, k));
                        prev = k;
                    }
                    pieces.push((prev, y));
                };
                if hi <= end {
                    push(lo, hi);
                } else {
                    push(lo, end);
                    push(start, hi - TAU);
                }
            }
            let rows = table.rows_at(theta);
            let share = inner_tol / pieces.len().max(1) as f64;
            let mut s = [0.0; 3];
            let mut inner_error = 0.0;
            for &(x, y) in pieces.iter() {
                if y <= x {
                    continue;
                }
                let mut f = |psi: f64| -> [f64; 3] {
                    let (sp, cp) = psi.sin_cos();
                    let d = Vec3::new(sin_t * sp, cos_t, -sin_t * cp);
                    let (ca, cn) = (d.dot(&a), d.dot(&n));
                    evaluations += 1;
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
                let (r, e, limited) = adaptive(&GK7, x, y, share, 3, &mut f);
                out.depth_limited |= limited;
                inner_error += e;
                for ch in 0..3 {
                    s[ch] += r[ch];
                }
            }
            worst_inner = worst_inner.max(sin_t * inner_error);
            let f = sin_t * jac;
            s.map(|x| x * f)
        };
        let (r, e, l) = adaptive(&GK21, -1.0, 1.0, piece_tol, 3, &mut outer);
        out.depth_limited |= l;
        for (v, r) in out.value.iter_mut().zip(r) {
            *v += r;
        }
        out.error += e;
    }
    out.error += PI * worst_inner;
    out.evaluations = evaluations;
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrand::family::{AxisIntegrand, Profile};

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
