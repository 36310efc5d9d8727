//! Benchmark of the fitted model (math.md §9) against one fixed-kernel weight set: one
//! experiment unit (one uniform point set, cos³θ, BMC with the `ml` amplitude) with a fixed
//! Sobolev s = 1.4 kernel and with the default 8-model grid, at N = 256, 512 and 1024. Both run
//! the experiment runner's own code (`experiment::runner::run_unit`): the fixed one assembles,
//! factors and solves once; the fitted one does so per grid model and chooses.
//!
//! Run: `cargo bench --bench fitted`. Prints the median of repeated runs and the ratio, and the
//! floor of that ratio: the grid's 8 factorisations alone (no assembly, no solve) against the
//! fixed unit.

mod common;
use common::median_seconds;
use workbench::bq::factor::SpdWorkspace;
use workbench::experiment::plan::{parse, resolve};
use workbench::experiment::runner::run_unit;

fn plan(kernel: &str, design: &str, n: usize) -> workbench::experiment::plan::Plan {
    let spec = format!(
        r#"{{"name":"b","integrands":["cos3"],
            "estimators":[{{"label":"BMC","method":"bmc","design":"{design}","kernel":{kernel}}}],
            "samples":[{n}],"trials":1,"seed":1}}"#
    );
    resolve(&parse(&spec).unwrap()).unwrap()
}

fn main() {
    println!(
        "{:>8} {:>5} {:>14} {:>14} {:>7}",
        "design", "N", "fixed ms", "fitted (8) ms", "ratio"
    );
    let mut floors = Vec::new();
    for (design, n) in [
        ("uniform", 256usize),
        ("uniform", 512),
        ("uniform", 1024),
        ("rings", 512),
        ("rings", 1024),
    ] {
        let reps = if n <= 512 { 21 } else { 7 };
        let mut ws = SpdWorkspace::new();
        let fixed = plan(r#"{"type":"sobolev","s":1.4}"#, design, n);
        let fitted = plan(r#"{"type":"fitted"}"#, design, n);
        let t_fixed = median_seconds(reps, || {
            run_unit(&fixed, 0, 0, &mut ws).unwrap();
        });
        let t_fitted = median_seconds(reps, || {
            run_unit(&fitted, 0, 0, &mut ws).unwrap();
        });
        println!(
            "{design:>8} {n:>5} {:>14.3} {:>14.3} {:>7.2}",
            t_fixed * 1e3,
            t_fitted * 1e3,
            t_fitted / t_fixed
        );
        if design == "uniform" {
            floors.push((n, factorisations_alone(n, reps) / t_fixed));
        }
    }
    for (n, floor) in floors {
        println!("N = {n}: the 8 factorisations alone are {floor:.2}× the fixed unit");
    }
}

/// Seconds of the default grid's 8 factorisations alone at `n` uniform points: each model's
/// assembly + factorisation less its assembly alone (as in `benches/core.rs`).
fn factorisations_alone(n: usize, reps: usize) -> f64 {
    use workbench::bq::kernel::{Kernel, PointsSoa, Sobolev};
    let points =
        workbench::sampling::Density::Uniform.sample_set(n, &mut workbench::util::rng::stream(1, &[]));
    let soa = PointsSoa::new(&points);
    let mut ws = SpdWorkspace::new();
    let mut total = 0.0;
    for s in workbench::bq::model::DEFAULT_GRID_S {
        let kernel = Kernel::Sobolev(Sobolev::new(s).unwrap());
        for noise in workbench::bq::model::DEFAULT_GRID_NOISE {
            let fill = |j: usize, col: &mut [f64]| {
                kernel.fill_column(&soa, j, j, col);
                col[0] = kernel.diagonal() + noise;
            };
            let both = median_seconds(reps, || {
                ws.factor_with(n, fill).unwrap();
            });
            let assemble = median_seconds(reps, || ws.assemble_lower_by_columns(n, fill));
            total += (both - assemble).max(0.0);
        }
    }
    total
}
