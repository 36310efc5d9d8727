//! Where the CPU of `workbench run experiments/cos3.json` goes, against its floor (issue 12).
//!
//! Run: `cargo bench --bench phases` (one thread). It replays cos3's BMC work in the run's order
//! (300 trials × N = 4 … 512, one reused workspace, Sobolev s = 1.4, σ_n² = 0.01, exact kernel
//! means) and times each phase: building the kernel-mean table, drawing the points, the kernel
//! means, assembling Q, factoring it, and the three solves per weight set (`w = Q⁻¹z`,
//! `u = Q⁻¹1`, the `ml` amplitude's `Q⁻¹Y`). The floor is the factorisation alone at the rate
//! faer reaches on each N factored repeatedly in isolation (median of repeated runs, as in
//! `cargo bench --bench core`), times 300. What the run does besides (MC, estimates, statistics,
//! CSV, plots) is the whole run's CPU less this sum.

mod common;
use common::median_seconds;
use std::hint::black_box;
use std::time::Instant;
use workbench::bq::factor::SpdWorkspace;
use workbench::bq::kernel::{Kernel, PointsSoa, Sobolev};
use workbench::bq::kernel_mean::KernelMeanTable;
use workbench::sampling::Density;
use workbench::util::geometry::Vec3;
use workbench::util::rng::stream;

const SAMPLES: [usize; 8] = [4, 8, 16, 32, 64, 128, 256, 512];
const TRIALS: u64 = 300;
const NOISE: f64 = 0.01;

/// Wall-clock seconds spent per phase, summed over the replay.
#[derive(Default)]
struct Phases {
    sampling: f64,
    kernel_means: f64,
    assembly: f64,
    factorisation: f64,
    solves: f64,
}

/// The points of trial `trial` at `n`: the run draws from its own streams, so these are other
/// points of the same design, which costs the same.
fn points(n: usize, trial: u64) -> Vec<Vec3> {
    Density::Uniform.sample_set(n, &mut stream(2023, &[n as u64, trial]))
}

/// The floor: `TRIALS ×` the factorisation of each N alone (assembly timed and subtracted, as
/// in the core bench, since Q is assembled into the factor's buffer).
fn floor_seconds(kernel: &Kernel) -> f64 {
    SAMPLES
        .iter()
        .map(|&n| {
            let pts = points(n, 0);
            let soa = PointsSoa::new(&pts);
            let diag = kernel.diagonal() + NOISE;
            let fill = |j: usize, col: &mut [f64]| {
                kernel.fill_column(&soa, j, j, col);
                col[0] = diag;
            };
            let mut ws = SpdWorkspace::new();
            let reps = if n <= 256 { 401 } else { 101 };
            let assemble = median_seconds(reps, || ws.assemble_lower_by_columns(n, fill));
            let both = median_seconds(reps, || {
                ws.factor_with(n, fill).unwrap();
            });
            (both - assemble).max(0.0) * TRIALS as f64
        })
        .sum()
}

fn replay(kernel: &Kernel, table: &KernelMeanTable) -> Phases {
    let mut p = Phases::default();
    let mut ws = SpdWorkspace::new();
    let mut sink = 0.0;
    let diag = kernel.diagonal() + NOISE;
    for trial in 0..TRIALS {
        for n in SAMPLES {
            let clock = Instant::now();
            let pts = points(n, trial);
            p.sampling += clock.elapsed().as_secs_f64();
            let clock = Instant::now();
            let z: Vec<f64> = pts.iter().map(|x| table.z(x.z)).collect();
            p.kernel_means += clock.elapsed().as_secs_f64();
            let soa = PointsSoa::new(&pts);
            let fill = |j: usize, col: &mut [f64]| {
                kernel.fill_column(&soa, j, j, col);
                col[0] = diag;
            };
            // Assembly alone, then assembly + factorisation as the run does it.
            let clock = Instant::now();
            ws.assemble_lower_by_columns(n, fill);
            let assembly = clock.elapsed().as_secs_f64();
            p.assembly += assembly;
            let clock = Instant::now();
            ws.factor_with(n, fill).unwrap();
            p.factorisation += (clock.elapsed().as_secs_f64() - assembly).max(0.0);
            let clock = Instant::now();
            let mut w = z.clone();
            ws.solve_in_place(&mut w);
            let mut u = vec![1.0; n];
            ws.solve_in_place(&mut u);
            let mut y: Vec<f64> = pts.iter().map(|x| x.z.powi(3)).collect();
            ws.solve_in_place(&mut y);
            p.solves += clock.elapsed().as_secs_f64();
            sink += w[0] + u[0] + y[0];
        }
    }
    black_box(sink);
    p
}

fn main() {
    let kernel = Kernel::Sobolev(Sobolev::new(1.4).unwrap());
    let clock = Instant::now();
    let table = KernelMeanTable::new(&kernel);
    let table_seconds = clock.elapsed().as_secs_f64();
    let floor = floor_seconds(&kernel);
    let p = replay(&kernel, &table);
    let rows = [
        ("kernel-mean table (once)", table_seconds),
        ("sampling", p.sampling),
        ("kernel means z", p.kernel_means),
        ("assembling Q", p.assembly),
        ("factorisation (in the run's order)", p.factorisation),
        ("three solves per weight set", p.solves),
    ];
    let total: f64 = rows.iter().map(|r| r.1).sum();
    println!("cos3's BMC work, {TRIALS} trials × N = 4 … 512, one thread:");
    println!("{:<38} {:>9} {:>10}", "phase", "seconds", "× floor");
    for (name, s) in rows {
        println!("{name:<38} {s:>9.4} {:>10.3}", s / floor);
    }
    println!("{:<38} {total:>9.4} {:>10.3}", "sum", total / floor);
    println!("{:<38} {floor:>9.4} {:>10.3}", "floor (factorisation alone)", 1.0);
    println!(
        "1.3 × floor = {:.4} s leaves {:.4} s for everything besides the factorisation in the run's order",
        1.3 * floor,
        1.3 * floor - p.factorisation
    );
}
