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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::env::{EnvMap, Lookup};
    use crate::render::integrator::{Integrator, IntegratorKind};
    use crate::render::renderer::Renderer;
    use crate::render::scene::SceneKind;
    use crate::util::rng::stream;

    /// A 32×16 map with a small bright "sun" (50× the rest), a blue-to-white gradient and a
    /// black band (zero luminance, so zero light density) near the nadir.
    fn test_map(lookup: Lookup) -> Environment {
        let (w, h) = (32, 16);
        let texels = (0..h)
            .flat_map(|r| (0..w).map(move |c| (r, c)))
            .map(|(r, c)| {
                if r >= 13 {
                    [0.0; 3]
                } else if (3..5).contains(&r) && (20..23).contains(&c) {
                    [50.0, 45.0, 30.0]
                } else {
                    let t = r as f32 / h as f32;
                    [0.3 + t, 0.5 + 0.5 * t, 1.0 - 0.3 * t]
                }
            })
            .collect();
        Environment::Map(EnvMap::from_texels(w, h, texels).with_lookup(lookup))
    }

    /// Each renderer baseline is unbiased at a scene pixel: over 300 pixels' worth of seeds at
    /// 16 spp, the mean of its estimates lies within 4 standard errors (the estimates' sd/√300)
    /// of the exact reference ([`crate::render::exact`]), in every channel, on both scenes,
    /// under `sky`, `white` and a map with a sun and a black band under both lookups, at pixels
    /// on the sphere, on the floor and in its shadow.
    #[test]
    fn each_baseline_is_unbiased_at_scene_pixels() {
        let reps = 300;
        let spp = 16;
        let mut envs = vec![Environment::Sky, Environment::White];
        envs.extend(Lookup::ALL.map(test_map));
        let mut checked = 0;
        for scene in SceneKind::ALL {
            for env in &envs {
                let renderer = Renderer::for_scene(scene, 16, 16, env.clone());
                let points: Vec<ShadingPoint> = [(4, 8), (8, 8), (12, 5), (13, 12), (2, 14)]
                    .iter()
                    .filter_map(|&(i, j)| renderer.shading_point(i, j))
                    .collect();
                assert!(points.len() >= 3, "{scene:?}: too few hit pixels");
                for (k, p) in points.iter().enumerate() {
                    let exact = crate::render::exact::integrate(p, &renderer.scene, env, 1e-7);
                    for kind in IntegratorKind::light_baselines() {
                        if crate::render::integrator::check_light(kind, env, "test").is_err() {
                            continue;
                        }
                        let integrator = Integrator::build(kind, spp, 0, false, None, 0).unwrap();
                        let mut sum = [0.0; 3];
                        let mut sq = [0.0; 3];
                        for rep in 0..reps {
                            let mut rng = stream(40, &[k as u64, rep]);
                            let v = integrator.estimate(p, &renderer.scene, env, &mut rng, [0.0; 3]);
                            for c in 0..3 {
                                sum[c] += v[c];
                                sq[c] += v[c] * v[c];
                            }
                        }
                        for c in 0..3 {
                            let mean = sum[c] / reps as f64;
                            let var = (sq[c] / reps as f64 - mean * mean).max(0.0) * reps as f64
                                / (reps - 1) as f64;
                            let se = (var / reps as f64).sqrt();
                            let gap = (mean - exact.value[c]).abs();
                            let allowed = 4.0 * se + exact.error + 1e-9 * exact.value[c].abs();
                            assert!(
                                gap <= allowed,
                                "{kind} {scene:?} {} pixel {k} channel {c}: mean {mean} vs exact {} \
                                 (gap {gap:.3e} > {allowed:.3e}, se {se:.3e})",
                                env.key(),
                                exact.value[c]
                            );
                        }
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > 300, "{checked}");
    }

    /// Rays are counted where they are traced: `mc-bsdf` traces one per sample under `white`
    /// (every cosine direction is above the horizon and lit), `mc-light` under `white` about half
    /// (light samples below the horizon trace none).
    #[test]
    fn rays_are_counted_where_traced() {
        let renderer = Renderer::new(16, 16, Environment::White);
        let p = renderer.shading_point(8, 8).expect("the sphere");
        let count = |name: &str| {
            let kind = IntegratorKind::from_name(name).unwrap();
            let integrator = Integrator::build(kind, 64, 0, false, None, 0).unwrap();
            for rep in 0..100 {
                integrator.estimate(
                    &p,
                    &renderer.scene,
                    &renderer.env,
                    &mut stream(1, &[rep]),
                    [0.0; 3],
                );
            }
            integrator.counter.rays_per_pixel()
        };
        assert_eq!(count("mc-bsdf"), 64.0);
        assert_eq!(count("mc"), 64.0);
        let light = count("mc-light");
        // Binomial(64, 1/2) per pixel: mean 32, sd of the mean over 100 pixels 0.4.
        assert!((light - 32.0).abs() < 4.0 * 0.4, "{light}");
    }
}
