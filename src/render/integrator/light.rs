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

use super::{PssSets, ShadingPoint};
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
/// pixel and technique); with the standard error per channel and the shadow rays traced. A
/// quadrature with point sets (`bq-pss`, `sets`) instead picks one of its sets from `rng` and
/// states its posterior sd ([`super::pss`]).
pub fn estimate(
    estimator: &LightEstimator,
    sets: Option<&PssSets>,
    spp: usize,
    p: &ShadingPoint,
    scene: &Scene,
    env: &Environment,
    rng: &mut crate::util::rng::WorkbenchRng,
) -> (Rgb, Option<[crate::bq::estimator::Uncertainty; 3]>, u64) {
    let pixel = PixelLight {
        point: p,
        scene,
        env,
        rays: Cell::new(0),
    };
    if let Some(sets) = sets {
        let (value, sd) = estimator.estimate_channels_on_rule(&pixel, sets.pick(rng));
        return (value, sd, pixel.rays.get());
    }
    let (n_light, n_bsdf) = estimator.method.counts(spp);
    let light_u = estimator.sampler.points(n_light, rng);
    let bsdf_u = estimator.sampler.points(n_bsdf, rng);
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
    use crate::sampling::primary::Sampler;
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

    /// Checks that each integrator of `kinds` is unbiased at scene pixels: over `reps` pixels'
    /// worth of seeds at `spp`, the mean of its estimates lies within 4 standard errors (the
    /// estimates' sd/√reps) of the exact reference ([`crate::render::exact`]), in every channel,
    /// on both scenes, under `sky`, `white` and a map with a sun and a black band under both
    /// lookups, at pixels on the sphere, on the floor and in its shadow. `build(kind, rep)` is
    /// the integrator of repetition `rep`. Returns the number of (integrator, pixel) cases.
    fn check_unbiased_at_scene_pixels(
        kinds: &[IntegratorKind],
        spp: usize,
        reps: u64,
        build: &dyn Fn(IntegratorKind, u64) -> Integrator,
    ) -> usize {
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
                    for &kind in kinds {
                        if crate::render::integrator::check_light(kind, env, "test").is_err() {
                            continue;
                        }
                        let fixed = build(kind, 0);
                        assert_eq!(fixed.spp, spp);
                        let mut sum = [0.0; 3];
                        let mut sq = [0.0; 3];
                        for rep in 0..reps {
                            let integrator = if kind.uses_point_sets() {
                                build(kind, rep)
                            } else {
                                fixed.clone()
                            };
                            let mut rng = stream(40, &[k as u64, rep]);
                            let v = integrator.estimate(p, &renderer.scene, env, &mut rng, [0.0; 3]);
                            for c in 0..3 {
                                sum[c] += v[c];
                                sq[c] += v[c] * v[c];
                            }
                        }
                        let n = reps as f64;
                        for c in 0..3 {
                            let mean = sum[c] / n;
                            let var = (sq[c] / n - mean * mean).max(0.0) * n / (n - 1.0);
                            let se = (var / n).sqrt();
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
        checked
    }

    /// Each renderer baseline is unbiased at scene pixels
    /// ([`check_unbiased_at_scene_pixels`], 300 repetitions).
    #[test]
    fn each_baseline_is_unbiased_at_scene_pixels() {
        let kinds = IntegratorKind::light_baselines();
        let checked = check_unbiased_at_scene_pixels(&kinds, 16, 300, &|kind, _| {
            Integrator::build(kind, 16, 0, false, None, 0).unwrap()
        });
        assert!(checked > 300, "{checked}");
    }

    /// `bq-pss` on its default sampler (scrambled Sobol sets) is unbiased at scene pixels over
    /// its randomised point sets, with every weighting and both kernel orders, at 64 spp (32
    /// points; [`check_unbiased_at_scene_pixels`], 300 repetitions): repetition `rep` draws its
    /// own 4 sets from seed `rep` (as a render table's repetitions do) and the pixel picks one.
    /// So is `bq-pss-equal-uniform` (plain MC on `G`) at 16 spp.
    ///
    /// Not claimed, because measured otherwise (2026-12-02): at 16 spp (8 points) order 2
    /// with `bmc` or `bsq` weights is 4.1–4.8 SE off at a few pixels, and the kernel-weighted
    /// variants on independent points (`-uniform`) are 4–8 SE off at 16 and 64 spp: weights
    /// fitted to a set's own points are not an unbiased rule over random sets (for BMC
    /// `E[1ᵀQ⁻¹1] < 1`), least so on well-spread points.
    #[test]
    fn each_light_quadrature_is_unbiased_at_scene_pixels() {
        let sobol: Vec<IntegratorKind> = IntegratorKind::light_quadratures()
            .into_iter()
            .filter(|k| k.light.is_some_and(|l| l.sampler == Sampler::Sobol))
            .collect();
        assert_eq!(sobol.len(), 8);
        let build = |spp| move |kind, rep| Integrator::build(kind, spp, 4, false, None, 1000 + rep).unwrap();
        let checked = check_unbiased_at_scene_pixels(&sobol, 64, 300, &build(64));
        assert!(checked >= 200, "{checked}");
        let equal = [IntegratorKind::from_name("bq-pss-equal-uniform").unwrap()];
        let checked = check_unbiased_at_scene_pixels(&equal, 16, 300, &build(16));
        assert!(checked >= 25, "{checked}");
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
