//! A fully symmetric ring design (Karvonen & Särkkä, "Fully symmetric kernel quadrature", SIAM
//! J. Sci. Comput. 2018): `J` rings of `M` equally spaced azimuths, `N = J·M`.
//!
//! Ring `a` lies at height `z_a = (a + u_a)/J`, uniform within the `a`-th of `J` equal-area
//! strata of the hemisphere (`cos θ ∈ [a/J, (a+1)/J)`); point `m` of every ring sits at azimuth
//! `φ_m = 2π (m + u)/M` with one random rotation `u` shared by all rings. Each point is thus
//! uniform within its stratum and uniform in azimuth, so MC on the set is unbiased (as on the
//! stratified grid), while rotating the set by `2π/M` about the pole maps it onto itself: the
//! Gram matrix is block-circulant and BMC's weights are constant on each ring (see
//! [`crate::bq::factor::rings`]). Points are stored ring by ring: point `(a, m)` is index `a·M + m`.
//!
//! **Layout from N.** `J` is the largest divisor of `N` not above `√N` and `M = N/J` (the
//! grid of the stratified design, [`super::stratified::grid`]): as many rings as azimuths when
//! `N` is a square. Fewer, longer rings (e.g. `J ≈ √(N/2π)`, square cells at the equator) are
//! cheaper but leave the pole to a single ring far from the next, and on `experiments/rings.json`
//! they gave BMC several times the error. A count is accepted when `J ≥ √N / 2` (every power of
//! two is); otherwise the rings would be too few and too crowded, and [`check`] names the
//! nearest counts that work.

use crate::util::geometry::Vec3;
use rand::{Rng, RngExt};

/// `J` rings of `M` points each.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RingLayout {
    /// `J`, the number of rings.
    pub rings: usize,
    /// `M`, the number of points on each ring.
    pub per_ring: usize,
}

/// The ideal (real) ring count `√N` for `n` points.
fn ideal_rings(n: usize) -> f64 {
    (n as f64).sqrt()
}

/// The layout for `n ≥ 1` points (see the module documentation); defined for every `n`, valid
/// only when [`check`] accepts `n`.
pub fn layout(n: usize) -> RingLayout {
    let (rings, per_ring) = super::stratified::grid(n.max(1));
    RingLayout { rings, per_ring }
}

/// Whether `n` points make a usable ring layout.
pub fn is_valid(n: usize) -> bool {
    n >= 1 && layout(n).rings as f64 >= 0.5 * ideal_rings(n)
}

/// The layout for `n`, or a message saying why `n` does not split into rings and which counts
/// near it do.
pub fn check(n: usize) -> Result<RingLayout, String> {
    if is_valid(n) {
        return Ok(layout(n));
    }
    let below = (1..n).rev().find(|&k| is_valid(k));
    let above = (n + 1..).find(|&k| is_valid(k)).expect("powers of two are valid");
    let near = match below {
        Some(b) => format!("{b} or {above}"),
        None => above.to_string(),
    };
    let l = layout(n);
    Err(format!(
        "the rings design needs N = J·M with J rings near √N = {:.1}, but the best divisor \
         of {n} is J = {} (rings of {} points); use e.g. N = {near} (any power of two works)",
        ideal_rings(n),
        l.rings,
        l.per_ring
    ))
}

/// A ring set of `n` points (one rotation, then one height per ring, from `rng`).
pub fn sample_set<R: Rng + ?Sized>(n: usize, rng: &mut R) -> Vec<Vec3> {
    let RingLayout { rings, per_ring } = layout(n);
    let rotation: f64 = rng.random();
    let mut points = Vec::with_capacity(n);
    for a in 0..rings {
        let z = (a as f64 + rng.random::<f64>()) / rings as f64;
        for m in 0..per_ring {
            points.push(super::Density::Uniform.map(z, (m as f64 + rotation) / per_ring as f64));
        }
    }
    points
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::rng::stream;

    #[test]
    fn layouts_split_n_into_rings() {
        let l = |rings, per_ring| RingLayout { rings, per_ring };
        assert_eq!(layout(512), l(16, 32));
        assert_eq!(layout(65_536), l(256, 256));
        assert_eq!(layout(100), l(10, 10));
        assert_eq!(layout(98), l(7, 14));
        assert_eq!(layout(1), l(1, 1));
        for k in 0..20 {
            assert!(is_valid(1 << k), "2^{k}");
        }
        assert!(!is_valid(37));
        let e = check(37).unwrap_err();
        assert!(e.contains("N = 36 or 40"), "{e}");
    }

    /// Every point is a unit vector in its ring's stratum; a ring's points share `z` and are
    /// `2π/M` apart in azimuth.
    #[test]
    fn sets_are_rings_in_their_strata() {
        let mut rng = stream(12, &[]);
        for n in [1, 8, 64, 100, 512] {
            let RingLayout { rings, per_ring } = layout(n);
            let pts = sample_set(n, &mut rng);
            assert_eq!(pts.len(), n);
            for (i, p) in pts.iter().enumerate() {
                let a = i / per_ring;
                assert!((p.norm() - 1.0).abs() < 1e-14);
                assert!(p.z >= a as f64 / rings as f64 && p.z < (a + 1) as f64 / rings as f64);
                assert_eq!(p.z, pts[a * per_ring].z);
                if i % per_ring > 0 {
                    let q = &pts[i - 1];
                    let dphi = p.y.atan2(p.x) - q.y.atan2(q.x);
                    let steps =
                        (dphi / (std::f64::consts::TAU / per_ring as f64)).rem_euclid(per_ring as f64);
                    assert!((steps - 1.0).abs() < 1e-9, "n={n} i={i}: {steps}");
                }
            }
        }
    }
}
