//! Brute force shared by the test binaries (`it` and `data`, each includes this file by path):
//! the texel sum of a shading point against cosine-weighted MC over the renderer's own integrand.

use workbench::render::cuts::PixelIntegral;
use workbench::render::integrator::ShadingPoint;
use workbench::render::{Environment, Scene};
use workbench::sampling::Density;
use workbench::util::rng::WorkbenchRng;

/// Asserts that `exact` (a certified quadrature of `p`'s integral) and `samples` cosine-weighted
/// MC samples of `p`'s integrand agree per channel within 5 standard errors of the MC mean plus
/// the quadrature's stated error; `what` names the case in the message.
pub fn assert_agrees_with_cosine_mc(
    exact: &PixelIntegral,
    p: &ShadingPoint,
    scene: &Scene,
    env: &Environment,
    samples: usize,
    rng: &mut WorkbenchRng,
    what: &str,
) {
    let (mut sum, mut sq) = ([0.0; 3], [0.0; 3]);
    for _ in 0..samples {
        let v = Density::Cosine.sample(rng);
        let f = p.integrand(scene, env, &v);
        let pdf = Density::Cosine.pdf(&v);
        for c in 0..3 {
            let y = f[c] / pdf;
            sum[c] += y;
            sq[c] += y * y;
        }
    }
    for c in 0..3 {
        let mean = sum[c] / samples as f64;
        let se = ((sq[c] / samples as f64 - mean * mean) / (samples - 1) as f64).sqrt();
        assert!(
            (exact.value[c] - mean).abs() <= 5.0 * se + exact.error,
            "{what} channel {c}: texel sum {} vs MC {mean} ± {se}",
            exact.value[c]
        );
    }
}
