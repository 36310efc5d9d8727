//! Integrands that know their factors (math.md §11, "The integral and its cost";
//! docs/architecture.md §3): `f(ω) = L(ω) f_r(ω) max(0, n·ω) V(ω)` with the light `L`, the BRDF
//! `f_r` and the visibility `V` exposed apart, and the two techniques a renderer samples it by —
//! the light's luminance distribution ([`crate::sampling::light`]) and the BSDF's own sampler
//! ([`crate::sampling::bsdf`]) — each a warp of a primary sample `u ∈ [0, 1)²` with its exact
//! density at any direction. Light-aware estimators ([`crate::bq::estimator::mis`]) see an
//! integrand only through this trait; an integrand without it (`cos^k`, the analytic families)
//! makes them a one-line error ([`super::Integrand::lit`]).
//!
//! Directions are local (normal `+z`), as every estimator's; the light's distribution is over
//! world directions, and the trait's frame carries one to the other.

use crate::sampling::bsdf::BsdfSampler;
use crate::sampling::light::LightDistribution;
use crate::util::geometry::{Frame, Vec3};

/// A technique of a light-aware estimator (math.md §11).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Technique {
    /// Light sampling, from the plain (`compensated: false`) or the compensated density.
    Light { compensated: bool },
    /// BSDF sampling.
    Bsdf,
}

/// An integrand with its factors and techniques (see the module docs).
pub trait Lit {
    /// `L(ω)` in the integrand's channel, arriving from local direction `w` (unit).
    fn radiance(&self, w: &Vec3) -> f64;
    /// `f_r(ω)` at local direction `w` (per steradian).
    fn brdf(&self, w: &Vec3) -> f64;
    /// `V(ω)`: 1 when the ray towards `w` escapes, 0 when it is blocked.
    fn visibility(&self, w: &Vec3) -> f64;
    /// The light's luminance distribution over world directions.
    fn light(&self) -> &LightDistribution;
    /// The frame whose `n` is the normal (local `+z`).
    fn frame(&self) -> &Frame;
    /// How the BSDF technique draws directions.
    fn bsdf_sampler(&self) -> BsdfSampler;

    /// `f(ω) = L f_r max(0, ω_z) V`, 0 below the horizon (without a ray).
    #[inline]
    fn integrand(&self, w: &Vec3) -> f64 {
        if w.z <= 0.0 {
            return 0.0;
        }
        let fr = self.brdf(w);
        if fr == 0.0 {
            return 0.0;
        }
        self.radiance(w) * fr * w.z * self.visibility(w)
    }

    /// The local direction technique `t` draws for the primary sample `u`, with its density.
    #[inline]
    fn sample(&self, t: Technique, u: [f64; 2]) -> (Vec3, f64) {
        match t {
            Technique::Light { compensated } => {
                let (d, p) = self.light().sample(u, compensated);
                let f = self.frame();
                (Vec3::new(d.dot(&f.t), d.dot(&f.b), d.dot(&f.n)), p)
            }
            Technique::Bsdf => self.bsdf_sampler().sample(u),
        }
    }

    /// The density with which technique `t` draws local direction `w` (unit).
    #[inline]
    fn pdf(&self, t: Technique, w: &Vec3) -> f64 {
        match t {
            Technique::Light { compensated } => self.light().pdf(&self.frame().to_world(w), compensated),
            Technique::Bsdf => self.bsdf_sampler().pdf(w),
        }
    }
}
