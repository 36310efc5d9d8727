//! Benchmark of the exact reference (`workbench render --integrator exact`): the certified
//! quadrature of every pixel of the default scene under the sky at 64×64 (target ≤ 3 s) and
//! 256×256 (target ≤ 30 s) on this project's 2-core machine, tolerance 1e-9.
//!
//! Run: `cargo bench --bench exact`. Prints the wall-clock time of one render of each (best of
//! three at 64×64), the largest estimated error and the evaluations per hit pixel.

use std::time::Instant;
use workbench::render::exact::DEFAULT_TOLERANCE;
use workbench::render::{Environment, Renderer};

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
}
