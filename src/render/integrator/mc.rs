//! Monte Carlo (math.md §3) with fresh samples per pixel.

use super::ShadingPoint;
use crate::render::env::Environment;
use crate::render::scene::{Rgb, Scene};
use crate::rng::WorkbenchRng;
use crate::sampling::Design;
use std::f64::consts::PI;

/// `Î = (1/N) Σ f(ω_i)/p(ω_i)` with `f = L_i (albedo/π) cos θ`:
///
/// - uniform, `p = 1/(2π)`: `Î = (2 albedo / N) Σ L_i(ω_i) cos θ_i`;
/// - cosine, `p = cos θ/π`: `Î = (albedo / N) Σ L_i(ω_i)` (the cosine cancels exactly, which
///   also avoids `0/0` at grazing samples).
pub fn estimate(
    design: Design,
    spp: usize,
    p: &ShadingPoint,
    scene: &Scene,
    env: &Environment,
    rng: &mut WorkbenchRng,
) -> Rgb {
    let mut sum = [0.0; 3];
    for _ in 0..spp {
        let v = design.sample(rng);
        let li = p.incident(scene, env, &v);
        let g = match design {
            Design::Uniform => v.z / design.pdf(&v) / PI,
            Design::Cosine => 1.0,
        };
        for c in 0..3 {
            sum[c] += li[c] * g;
        }
    }
    [0, 1, 2].map(|c| p.albedo[c] * sum[c] / spp as f64)
}
