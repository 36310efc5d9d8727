//! Benchmark of light sampling (math.md §11; issue 40: "one 1024×512 map takes under 1 s"): the
//! luminance distribution of a 1024×512 map of random texels with a bright "sun", built from the
//! map under both lookups (`mitsuba`: bilinear cells; `thesis`: constant cells), each with its
//! compensated density; then 10⁶ samples and 10⁶ pdf evaluations of the built distribution.
//!
//! Run: `cargo bench --bench light`. Prints, per lookup, the best of five builds (each on a fresh
//! map, so nothing is cached) and the time per sample and per pdf, on one thread.

use rand::RngExt;
use std::time::Instant;
use workbench::render::env::{EnvMap, Lookup};

fn main() {
    let (w, h) = (1024, 512);
    let mut rng = workbench::util::rng::stream(1, &[]);
    let texels: Vec<[f32; 3]> = (0..w * h)
        .map(|k| {
            let sun = if k == 100 * w + 700 { 1e4 } else { 0.0 };
            [
                rng.random::<f32>() + sun,
                rng.random::<f32>(),
                rng.random::<f32>(),
            ]
        })
        .collect();
    for lookup in Lookup::ALL {
        let mut best = f64::INFINITY;
        for _ in 0..5 {
            let map = EnvMap::from_texels(w, h, texels.clone()).with_lookup(lookup);
            let clock = Instant::now();
            let light = map.light();
            let seconds = clock.elapsed().as_secs_f64();
            assert!(light.has_compensation());
            best = best.min(seconds);
        }
        let map = EnvMap::from_texels(w, h, texels.clone()).with_lookup(lookup);
        let light = map.light();
        let n = 1_000_000;
        let us: Vec<[f64; 2]> = (0..n).map(|_| [rng.random(), rng.random()]).collect();
        let clock = Instant::now();
        let mut dirs = Vec::with_capacity(n);
        for &u in &us {
            dirs.push(light.sample(u, false).0);
        }
        let sample = clock.elapsed().as_secs_f64() / n as f64;
        let clock = Instant::now();
        let total: f64 = dirs.iter().map(|d| light.pdf(d, false)).sum();
        let pdf = clock.elapsed().as_secs_f64() / n as f64;
        println!(
            "light distribution {w}x{h} ({}): build {:.1} ms (best of 5, plain + compensated); \
             sample {:.0} ns, pdf {:.0} ns (mean pdf {:.3e})",
            lookup.name(),
            best * 1e3,
            sample * 1e9,
            pdf * 1e9,
            total / n as f64
        );
    }
}
