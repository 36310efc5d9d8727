//! Benchmark of the exact reference (`workbench render --integrator exact`): the certified
//! quadrature of every pixel of the default scene under the sky at 64×64 (target ≤ 3 s) and
//! 256×256 (target ≤ 30 s) on this project's 2-core machine, tolerance 1e-9.
//!
//! Then the texel sum (math.md §10) on the thesis scene under a 1024×512 map of random texels
//! with a bright "sun", both lookups, at tolerance 1e-6: every 10th row and column of the
//! 500×500 image (2500 pixels), whose time × 100 estimates the full reference (target ≤ 10 min
//! on 2 cores).
//!
//! Then an `envmap` integrand's Phong truth ([`workbench::render::texel::lobe::phong`], issue 28:
//! target < 1 s per normal after the map is loaded) on the same 1024×512 map and, when the data
//! folder is set (`WORKBENCH_DATA`), on Pisa 1024×512: exponents 1, 10, …, 10⁶ tilted 30°,
//! 100 and 10⁶ about the normal, and 0.5, 0.1, 0.01 tilted 30° from a normal straight up (the
//! slowest of 16 orientations for them), at the integrand's tolerance (`TRUTH_TOLERANCE` × the map's mean
//! texel), one thread, map loaded and its cell table built before the clock starts.
//!
//! Run: `cargo bench --bench exact` (everything), `cargo bench --bench exact -- phong` (the Phong
//! truths only, about 10 s). Prints the wall-clock time of one render of each (best of
//! three at 64×64), the largest estimated error and the evaluations per hit pixel; per Phong truth
//! its time, value, error estimate and weight evaluations.

use rayon::prelude::*;
use std::time::Instant;
use workbench::integrand::envmap::{Brdf, EnvmapIntegrand, TRUTH_TOLERANCE};
use workbench::render::env::{EnvMap, Lookup};
use workbench::render::exact::DEFAULT_TOLERANCE;
use workbench::render::{Environment, Renderer, SceneKind};

fn main() {
    let threads = rayon::current_num_threads();
    let phong_only = std::env::args().any(|a| a == "phong");
    let texels = random_map_with_sun();
    if !phong_only {
        renders(threads, &texels);
    }
    phong(&texels);
}

/// 1024×512 random texels in [0, 1) with one "sun" texel of 10⁴ in red.
fn random_map_with_sun() -> Vec<[f32; 3]> {
    let mut rng = workbench::util::rng::stream(1, &[]);
    use rand::RngExt;
    (0..1024 * 512)
        .map(|k| {
            let sun = if k == 100 * 1024 + 700 { 1e4 } else { 0.0 };
            [
                rng.random::<f32>() + sun,
                rng.random::<f32>(),
                rng.random::<f32>(),
            ]
        })
        .collect()
}

/// The Phong cases: (world normal, lobe axis in the local frame, exponent).
fn phong_cases() -> Vec<([f64; 3], [f64; 3], f64)> {
    let mut cases = Vec::new();
    for e in [1.0, 10.0, 100.0, 1000.0, 1e4, 1e5, 1e6] {
        cases.push(([0.3, 0.2, -0.9], [0.5, 0.0, 0.866_025_403_784_438_6], e));
    }
    cases.push(([0.0, 1.0, 0.0], [0.0, 0.0, 1.0], 100.0));
    cases.push(([0.0, 1.0, 0.0], [0.0, 0.0, 1.0], 1e6));
    // Lobes broader than a cosine, about the orientation slowest for them (the lobe's edge
    // sweeping across every cell boundary of the upper hemisphere).
    for e in [0.5, 0.1, 0.01] {
        cases.push(([0.0, 1.0, 0.0], [0.5, 0.0, 0.866_025_403_784_438_6], e));
    }
    cases
}

fn phong(texels: &[[f32; 3]]) {
    use workbench::render::texel::lobe;
    use workbench::util::geometry::{Frame, Vec3};
    let mean = texels
        .iter()
        .flat_map(|t| t.iter())
        .map(|&v| v as f64)
        .sum::<f64>()
        / (3 * texels.len()) as f64;
    for lookup in Lookup::ALL {
        let m = EnvMap::from_texels(1024, 512, texels.to_vec()).with_lookup(lookup);
        let _ = m.cells();
        let mut total = 0.0;
        let cases = phong_cases();
        for &(normal, axis, e) in &cases {
            let n = Vec3::from(normal).normalize();
            let a = Frame::from_normal(n).to_world(&Vec3::from(axis).normalize());
            let t = Instant::now();
            let q = lobe::phong(n, a, e, &m, TRUTH_TOLERANCE * mean);
            let seconds = t.elapsed().as_secs_f64();
            total += seconds;
            println!(
                "phong, random 1024×512 map, {} lookup, n {normal:?}, axis {axis:?}, e {e}: {seconds:.3} s; \
                 value {:?}; error estimate {:.2e}{}; {} weight evaluations",
                lookup.name(),
                q.value,
                q.error,
                if q.depth_limited { " (depth-limited)" } else { "" },
                q.evaluations
            );
        }
        println!(
            "phong, random 1024×512 map, {} lookup: mean {:.3} s per normal",
            lookup.name(),
            total / cases.len() as f64
        );
    }
    for lookup in ["mitsuba", "thesis"] {
        let brdf = |axis: [f64; 3], e: f64| Brdf::Phong {
            exponent: e,
            axis: Vec3::from(axis),
        };
        // Loads the map and builds its cell table (cached per process and lookup).
        if let Err(e) = EnvmapIntegrand::new("pisa", [0.0, 1.0, 0.0], brdf([0.0, 0.0, 1.0], 1.0), lookup, "r")
        {
            println!("phong under pisa: skipped ({e}; set WORKBENCH_DATA)");
            return;
        }
        let mut total = 0.0;
        let cases = phong_cases();
        for &(normal, axis, e) in &cases {
            let t = Instant::now();
            let f = EnvmapIntegrand::new("pisa", normal, brdf(axis, e), lookup, "luminance").expect("pisa");
            let seconds = t.elapsed().as_secs_f64();
            total += seconds;
            println!(
                "phong, pisa 1024×512, {lookup} lookup, n {normal:?}, axis {axis:?}, e {e}: {seconds:.3} s; \
                 luminance {:.12e} ± {:.2e}",
                f.integral(),
                f.integral_error()
            );
        }
        println!(
            "phong, pisa 1024×512, {lookup} lookup: mean {:.3} s per normal",
            total / cases.len() as f64
        );
    }
}

fn renders(threads: usize, texels: &[[f32; 3]]) {
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
    for lookup in Lookup::ALL {
        let env = Environment::Map(EnvMap::from_texels(1024, 512, texels.to_vec()).with_lookup(lookup));
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
