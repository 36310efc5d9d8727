//! Benchmark of the numerical core: assembling Q, factoring it (faer, and nalgebra for
//! comparison), and solving for the weights, at N = 64 … 1024.
//!
//! Run: `cargo bench --bench core`. Prints the median of repeated runs; the factorisation's
//! rate counts N³/3 flops.

mod common;
use common::median_seconds;
use std::hint::black_box;
use std::time::Instant;
use workbench::bq::factor::SpdWorkspace;
use workbench::bq::kernel::{Kernel, Sobolev};
use workbench::bq::kernel_mean::KernelMeanTable;
use workbench::sampling::Density;
use workbench::util::geometry::Vec3;
use workbench::util::rng::stream;

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
        let pts: Vec<Vec3> = Density::Uniform.sample_set(n, &mut stream(1, &[n as u64]));
        let z: Vec<f64> = pts.iter().map(|p| table.z(p.z)).collect();
        let mut ws = SpdWorkspace::new();
        let diag = kernel.diagonal() + 0.01;
        let soa = workbench::bq::kernel::PointsSoa::new(&pts);
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
    rings(&kernel, &table, &mut sink);
    black_box(sink);
}

/// BMC on ring sets (`sampling::rings`, `ring_solver`): the weights (kernel sums, transforms,
/// block factors, the `J × J` solve), then one general solve `Q⁻¹Y` as the `ml` amplitude needs,
/// and `diag(Q⁻¹)` as `loo` needs. Median seconds per weight set.
fn rings(kernel: &Kernel, table: &KernelMeanTable, sink: &mut f64) {
    use workbench::bq::weights::bmc_weights_on_rings;
    use workbench::sampling::{Design, rings};
    println!();
    println!(
        "{:>6} {:>5} {:>5} {:>12} {:>12} {:>12}",
        "N", "J", "M", "weights ms", "+Q⁻¹Y ms", "diag ms"
    );
    for n in [512usize, 2048, 4096, 16384, 65536] {
        let layout = rings::layout(n);
        let reps = if n <= 4096 { 11 } else { 5 };
        let pts = Design::Rings.sample_set(n, &mut stream(2, &[n as u64]));
        let z: Vec<f64> = pts.iter().map(|p| table.z(p.z)).collect();
        let y: Vec<f64> = pts.iter().map(|p| p.z.powi(3) + p.x).collect();
        let mut ws = SpdWorkspace::new();
        let v = table.prior_variance();
        let t_weights = median_seconds(reps, || {
            let w = bmc_weights_on_rings(&pts, layout, &z, v, kernel, 0.01, &mut ws).unwrap();
            *sink += w.weights[0];
        });
        let mut solved = y.clone();
        let t_ml = median_seconds(reps, || {
            let w = bmc_weights_on_rings(&pts, layout, &z, v, kernel, 0.01, &mut ws).unwrap();
            solved.copy_from_slice(&y);
            ws.solve_in_place(&mut solved);
            *sink += w.weights[0] + solved[0];
        });
        let t_diag = median_seconds(reps, || *sink += ws.inverse_diagonal()[0]);
        println!(
            "{n:>6} {:>5} {:>5} {:>12.3} {:>12.3} {:>12.3}",
            layout.rings,
            layout.per_ring,
            t_weights * 1e3,
            t_ml * 1e3,
            t_diag * 1e3
        );
    }
}
