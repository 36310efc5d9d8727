//! The renderer's baselines at a scene pixel (math.md §11; issue 40): `mc-light`, `mc-bsdf` and
//! `mis` ([`crate::bq::estimator::mis`], the experiments' own estimator code) on the pixel's
//! integrand `f(ω) = L_i(ω) · (albedo/π) · (ω·n)` per colour channel.
//!
//! The pixel knows its light: the environment's luminance distribution
//! ([`Environment::light`], built once per map and lookup per run and shared by every pixel:
//! the map's cells, the sky tabulated on a 512×256 lat-long grid, the uniform density for
//! `white`); its BSDF sampler is the Lambertian cosine one; its visibility is the scene's shadow
//! ray. One direction serves the three channels (one ray), and a direction traces a ray only
//! where it can contribute: above the horizon (`ω·n > 0`) and where `env(ω) ≠ 0` — so light
//! samples below the surface's horizon trace none, and [`PixelLight::rays`] counts what is
//! traced.

use super::ShadingPoint;
use crate::bq::estimator::mis::{LightEstimator, Techniques};
use crate::integrand::lit::Technique;
use crate::render::env::Environment;
use crate::render::scene::{Rgb, Scene};
use crate::sampling::bsdf::BsdfSampler;
use crate::util::geometry::Vec3;
use std::cell::Cell;

/// A scene pixel's integrand with its two techniques (see the module docs).
pub struct PixelLight<'a> {
    pub point: &'a ShadingPoint,
    pub scene: &'a Scene,
    pub env: &'a Environment,
    /// Shadow rays traced so far.
    pub rays: Cell<u64>,
}

impl Techniques<3> for PixelLight<'_> {
    #[inline]
    fn sample(&self, t: Technique, u: [f64; 2]) -> (Vec3, f64) {
        match t {
            Technique::Light { compensated } => {
                let (d, p) = self.env.light().sample(u, compensated);
                let f = &self.point.frame;
                (Vec3::new(d.dot(&f.t), d.dot(&f.b), d.dot(&f.n)), p)
            }
            Technique::Bsdf => BsdfSampler::Cosine.sample(u),
        }
    }

    #[inline]
    fn pdf(&self, t: Technique, w: &Vec3) -> f64 {
        match t {
            Technique::Light { compensated } => {
                self.env.light().pdf(&self.point.frame.to_world(w), compensated)
            }
            Technique::Bsdf => BsdfSampler::Cosine.pdf(w),
        }
    }

    #[inline]
    fn value(&self, w: &Vec3) -> Rgb {
        if w.z <= 0.0 {
            return [0.0; 3];
        }
        let world = self.point.frame.to_world(w);
        let li = self.env.radiance(&world);
        if li == [0.0; 3] {
            return [0.0; 3];
        }
        self.rays.set(self.rays.get() + 1);
        if self.scene.occluded(&self.point.origin, &world) {
            [0.0; 3]
        } else {
            self.point.shade(li, w.z)
        }
    }
}

/// The estimate of `L_o` at `p` by `estimator` with `spp` samples (split as
/// [`crate::bq::estimator::mis::LightMethod::counts`]), each technique's primary samples drawn
/// from the pixel's own stream `rng` by the estimator's sampler (Sobol: a fresh Owen scramble per
/// pixel and technique); with the standard error per channel and the shadow rays traced.
pub fn estimate(
    estimator: &LightEstimator,
    spp: usize,
    p: &ShadingPoint,
    scene: &Scene,
    env: &Environment,
    rng: &mut crate::util::rng::WorkbenchRng,
) -> (Rgb, Option<[crate::bq::estimator::Uncertainty; 3]>, u64) {
    let (n_light, n_bsdf) = estimator.method.counts(spp);
    let light_u = estimator.sampler.points(n_light, rng);
    let bsdf_u = estimator.sampler.points(n_bsdf, rng);
    let pixel = PixelLight {
        point: p,
        scene,
        env,
        rays: Cell::new(0),
    };
    let (value, sd) = estimator.estimate_channels(&pixel, &light_u, &bsdf_u);
    (value, sd, pixel.rays.get())
}
