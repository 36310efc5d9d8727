//! Benchmark of the numerical core: assembling Q, factoring it (faer, and nalgebra for
//! comparison), and solving for the weights, at N = 64 … 1024.
//!
//! Run: `cargo bench --bench core`. Prints the median of repeated runs; the factorisation's
//! rate counts N³/3 flops.

use std::hint::black_box;
use std::time::Instant;
use workbench::geometry::Vec3;
use workbench::kernel::{Kernel, Sobolev};
use workbench::kernel_mean::KernelMeanTable;
use workbench::linalg::SpdWorkspace;
use workbench::rng::stream;
use workbench::sampling::Design;

fn median_seconds(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..reps)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[reps / 2]
}

fn main() {
    let kernel = Kernel::Sobolev(Sobolev::new(1.4).unwrap());
    let start = Instant::now();
    let table = KernelMeanTable::new(&kernel);
    println!(
        "kernel-mean table (Sobolev s = 1.4): built in {:.1} ms",
        start.elapsed().as_secs_f64() * 1e3
    );
    let mut sink = 0.0;
    let lookups = 1_000_000;
    let t = median_seconds(5, || {
        for i in 0..lookups {
            sink += table.z(black_box(i as f64 / lookups as f64));
        }
    });
    println!("z(μ) lookup: {:.1} ns", t / lookups as f64 * 1e9);
    println!();
    println!(
        "{:>5} {:>12} {:>12} {:>10} {:>12} {:>10} {:>12} {:>10}",
        "N", "assemble ms", "factor ms", "GFLOP/s", "solve ms", "total ms", "nalgebra ms", "GFLOP/s"
    );
    for n in [64usize, 256, 512, 1024] {
        let reps = if n <= 256 { 41 } else { 11 };
        let pts: Vec<Vec3> = Design::Uniform.sample_set(n, &mut stream(1, &[n as u64]));
        let z: Vec<f64> = pts.iter().map(|p| table.z(p.z)).collect();
        let mut ws = SpdWorkspace::new();
        let diag = kernel.diagonal() + 0.01;
        let soa = workbench::kernel::PointsSoa::new(&pts);
        let fill = |j: usize, col: &mut [f64]| {
            kernel.fill_column(&soa, j, j, col);
            col[0] = diag;
        };
        let t_assemble = median_seconds(reps, || ws.assemble_lower_by_columns(n, fill));
        // Q is assembled into the factor's own buffer, so the factorisation is timed as
        // assembly + factorisation, less the assembly alone.
        let t_assemble_factor = median_seconds(reps, || {
            ws.factor_with(n, fill).unwrap();
        });
        let t_factor = (t_assemble_factor - t_assemble).max(f64::MIN_POSITIVE);
        let mut w = z.clone();
        let t_solve = median_seconds(reps, || {
            w.copy_from_slice(&z);
            ws.solve_in_place(&mut w);
        });
        sink += w[0];
        let t_total = median_seconds(reps, || {
            ws.factor_with(n, fill).unwrap();
            w.copy_from_slice(&z);
            ws.solve_in_place(&mut w);
        });
        let q = nalgebra::DMatrix::from_fn(n, n, |i, j| {
            if i == j {
                diag
            } else {
                kernel.eval(&pts[i], &pts[j])
            }
        });
        let t_nalgebra = median_seconds(reps, || {
            sink += nalgebra::Cholesky::new(q.clone()).unwrap().l_dirty()[(0, 0)];
        });
        let flops = (n as f64).powi(3) / 3.0;
        println!(
            "{n:>5} {:>12.3} {:>12.3} {:>10.1} {:>12.3} {:>10.3} {:>12.3} {:>10.1}",
            t_assemble * 1e3,
            t_factor * 1e3,
            flops / t_factor / 1e9,
            t_solve * 1e3,
            t_total * 1e3,
            t_nalgebra * 1e3,
            flops / t_nalgebra / 1e9,
        );
    }
    black_box(sink);
}
