//! BSDF sampling in the local frame (normal `+z`; math.md §11, "BSDF sampling"), beside the
//! hemisphere densities of [`super::Density`]:
//!
//! - Lambert: cosine-weighted, `cos θ = √u₁`, `φ = 2π u₂`, `p_B = max(0, ω_z)/π`;
//! - a normalised Phong lobe `(e + 1)/(2π) max(0, ω·a)^e` about the unit axis `a`:
//!   `cos α = u₁^{1/(e+1)}`, `φ = 2π u₂` about `a`, `p_B = (e + 1)/(2π) cos^e α` — the lobe is its
//!   own density, so `f_r/p_B = 1`. Directions below the horizon (`ω_z ≤ 0`) are drawn with their
//!   density and contribute `f = 0`.

use super::Density;
use crate::util::geometry::{Frame, Vec3};
use std::f64::consts::{PI, TAU};

/// How a BSDF technique draws directions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BsdfSampler {
    /// Cosine-weighted about the normal (Lambert).
    Cosine,
    /// The Phong lobe `(e + 1)/(2π) max(0, ω·a)^e`, `e > 0`, `a` a unit vector.
    Phong { exponent: f64, axis: Vec3 },
}

impl BsdfSampler {
    /// The local direction for the primary sample `u ∈ [0, 1)²`, with its density.
    #[inline]
    pub fn sample(&self, u: [f64; 2]) -> (Vec3, f64) {
        match *self {
            BsdfSampler::Cosine => {
                let w = Density::Cosine.map(u[0], u[1]);
                (w, Density::Cosine.pdf(&w))
            }
            BsdfSampler::Phong { exponent, axis } => {
                // 1 − u keeps cos α > 0 (u₁ = 0 would give the lobe's edge, of density 0).
                let cos_alpha = (1.0 - u[0]).powf(1.0 / (exponent + 1.0));
                let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
                let (s, c) = (TAU * u[1]).sin_cos();
                let w =
                    Frame::from_normal(axis).to_world(&Vec3::new(sin_alpha * c, sin_alpha * s, cos_alpha));
                (w, (exponent + 1.0) / TAU * cos_alpha.powf(exponent))
            }
        }
    }

    /// The density of local direction `w` (unit).
    #[inline]
    pub fn pdf(&self, w: &Vec3) -> f64 {
        match *self {
            BsdfSampler::Cosine => w.z.max(0.0) / PI,
            BsdfSampler::Phong { exponent, axis } => {
                let c = w.dot(&axis);
                if c <= 0.0 {
                    0.0
                } else {
                    (exponent + 1.0) / TAU * c.powf(exponent)
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::rng::stream;
    use rand::RngExt;

    fn samplers() -> Vec<BsdfSampler> {
        let axis = Vec3::new(0.5, -0.2, 0.8).normalize();
        vec![
            BsdfSampler::Cosine,
            BsdfSampler::Phong { exponent: 1.0, axis },
            BsdfSampler::Phong { exponent: 20.0, axis },
            BsdfSampler::Phong {
                exponent: 0.3,
                axis: Vec3::z(),
            },
        ]
    }

    /// `∫_{S²} p_B dω = 1` to 1e-9. Each density depends on `c = cos α` about its axis alone,
    /// so the integral is `2π ∫₀¹ p dc`: Gauss–Legendre on panels graded towards `c = 0`, where
    /// `e < 1` has its power singularity.
    #[test]
    fn each_density_integrates_to_one() {
        let gl = crate::util::quadrature::GaussLegendre::new(20);
        for s in samplers() {
            let axis = match s {
                BsdfSampler::Cosine => Vec3::z(),
                BsdfSampler::Phong { axis, .. } => axis,
            };
            let frame = Frame::from_normal(axis);
            // Graded panels [2^-(k+1), 2^-k] towards c = 0, where e < 1 has its power.
            let mut total = 0.0;
            for k in 0..60 {
                let (a, b) = (0.5f64.powi(k + 1), 0.5f64.powi(k));
                total += gl.integrate(a, b, |c| {
                    let sin = (1.0 - c * c).sqrt();
                    // Constant in the azimuth about the axis: one azimuth suffices, times 2π.
                    TAU * s.pdf(&frame.to_world(&Vec3::new(sin, 0.0, c)))
                });
            }
            assert!((total - 1.0).abs() < 1e-9, "{s:?}: {total}");
        }
    }

    /// The density `sample` returns is `pdf` at the direction; the mean of `cos α` about the axis
    /// is `(e + 1)/(e + 2)` (cosine: 2/3), within 5 standard errors.
    #[test]
    fn samples_follow_their_density() {
        let n = 100_000;
        let mut rng = stream(11, &[]);
        for s in samplers() {
            let (axis, e) = match s {
                BsdfSampler::Cosine => (Vec3::z(), 1.0),
                BsdfSampler::Phong { axis, exponent } => (axis, exponent),
            };
            let mut sum = 0.0;
            for _ in 0..n {
                let (w, p) = s.sample([rng.random(), rng.random()]);
                assert!((w.norm() - 1.0).abs() < 1e-12);
                assert!((p - s.pdf(&w)).abs() <= 1e-9 * p, "{s:?}: {p} vs {}", s.pdf(&w));
                sum += w.dot(&axis);
            }
            let mean = (e + 1.0) / (e + 2.0);
            // Var cos α = E[c²] − mean², E[c²] = (e + 1)/(e + 3).
            let se = (((e + 1.0) / (e + 3.0) - mean * mean) / n as f64).sqrt();
            assert!((sum / n as f64 - mean).abs() < 5.0 * se, "{s:?}");
        }
    }
}
