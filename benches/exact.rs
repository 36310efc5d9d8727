//! Benchmark of the exact reference (`workbench render --integrator exact`): the certified
//! quadrature of every pixel of the default scene under the sky at 64×64 (target ≤ 3 s) and
//! 256×256 (target ≤ 30 s) on this project's 2-core machine, tolerance 1e-9.
//!
//! Then the texel sum (math.md §10) on the thesis scene under a 1024×512 map of random texels
//! with a bright "sun", both lookups, at tolerance 1e-6: every 10th row and column of the
//! 500×500 image (2500 pixels), whose time × 100 estimates the full reference (target ≤ 10 min
//! on 2 cores).
//!
//! Run: `cargo bench --bench exact`. Prints the wall-clock time of one render of each (best of
//! three at 64×64), the largest estimated error and the evaluations per hit pixel.

use rayon::prelude::*;
use std::time::Instant;
use workbench::render::env::{EnvMap, Lookup};
use workbench::render::exact::DEFAULT_TOLERANCE;
use workbench::render::{Environment, Renderer, SceneKind};

fn main() {
    let threads = rayon::current_num_threads();
    let bar = workbench::util::report::Silent;
    for (size, runs) in [(64, 3), (256, 1)] {
        let r = Renderer::new(size, size, Environment::Sky);
        let mut best = f64::INFINITY;
        let mut stats = None;
        for _ in 0..runs {
            let t = Instant::now();
            let (_, s) = r.render_exact(DEFAULT_TOLERANCE, &bar);
            best = best.min(t.elapsed().as_secs_f64());
            stats = Some(s);
        }
        let s = stats.unwrap();
        println!(
            "exact {size}×{size} sky ({threads} threads): {best:.2} s; max error estimate {:.2e} at {:?}; \
             {} depth-limited pixels; {:.0} evaluations per pixel",
            s.max_error,
            s.worst_pixel,
            s.depth_limited,
            s.evaluations as f64 / (size * size) as f64
        );
    }
    let mut rng = workbench::util::rng::stream(1, &[]);
    use rand::RngExt;
    let texels: Vec<[f32; 3]> = (0..1024 * 512)
        .map(|k| {
            let sun = if k == 100 * 1024 + 700 { 1e4 } else { 0.0 };
            [
                rng.random::<f32>() + sun,
                rng.random::<f32>(),
                rng.random::<f32>(),
            ]
        })
        .collect();
    for lookup in Lookup::ALL {
        let env = Environment::Map(EnvMap::from_texels(1024, 512, texels.clone()).with_lookup(lookup));
        let r = Renderer::for_scene(SceneKind::Thesis, 500, 500, env);
        let pixels: Vec<(usize, usize)> = (0..50)
            .flat_map(|j| (0..50).map(move |i| (10 * i + 5, 10 * j + 5)))
            .collect();
        let t = Instant::now();
        let out: Vec<(f64, u64)> = pixels
            .par_iter()
            .filter_map(|&(i, j)| r.exact_pixel(i, j, 1e-6))
            .map(|q| (q.error, q.evaluations))
            .collect();
        let seconds = t.elapsed().as_secs_f64();
        let max_error = out.iter().map(|o| o.0).fold(0.0, f64::max);
        let evaluations: u64 = out.iter().map(|o| o.1).sum();
        println!(
            "texel sum, thesis scene, 1024×512 map, {} lookup ({threads} threads): {seconds:.2} s for 2500 of the \
             500×500 pixels ({} hit) → about {:.0} s for the image; max error estimate {max_error:.2e}; {:.0} \
             evaluations per hit pixel",
            lookup.name(),
            out.len(),
            100.0 * seconds,
            evaluations as f64 / out.len() as f64
        );
    }
}
