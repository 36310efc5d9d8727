//! Benchmark of the fitted model (math.md §9) against one fixed-kernel weight set: one
//! experiment unit (one uniform point set, cos³θ, BMC with the `ml` amplitude) with a fixed
//! Sobolev s = 1.4 kernel and with the default 8-model grid, at N = 256, 512 and 1024. Both run
//! the experiment runner's own code (`experiment::runner::run_unit`): the fixed one assembles,
//! factors and solves once; the fitted one does so per grid model and chooses.
//!
//! Run: `cargo bench --bench fitted`. Prints the median of repeated runs and the ratio.

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
    }
}
