//! Benchmark of `workbench render`'s targets: 500×500 at 40 spp with `bmc` (4 sets: building
//! the sets plus rendering) against `mc`, and the 3000-spp MC reference at 256×256.
//!
//! Run: `cargo bench --bench render`. Prints the best of three wall-clock times.

use std::time::Instant;
use workbench::bq::kernel::{Kernel, Sobolev};
use workbench::bq::kernel_mean::KernelMeanMode;
use workbench::bq::model::BmcModel;
use workbench::bq::weights::DEFAULT_NOISE;
use workbench::render::{Environment, Integrator, IntegratorKind, Renderer};

fn best_of_three(mut f: impl FnMut()) -> f64 {
    (0..3)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

fn main() {
    let threads = rayon::current_num_threads();
    let t = Instant::now();
    let model = BmcModel::new(
        Kernel::Sobolev(Sobolev::new(1.4).unwrap()),
        DEFAULT_NOISE,
        KernelMeanMode::Exact,
    );
    println!("kernel-mean table: {:.1} ms", t.elapsed().as_secs_f64() * 1e3);
    let r = Renderer::new(500, 500, Environment::Sky);
    let bar = workbench::util::report::Silent;
    let bmc = best_of_three(|| {
        let i = Integrator::build(IntegratorKind::BMC, 40, 4, true, Some(&model), 1).unwrap();
        r.render(&i, 1, &bar);
    });
    let mc = best_of_three(|| {
        let i = Integrator::build(IntegratorKind::MC, 40, 0, false, None, 1).unwrap();
        r.render(&i, 1, &bar);
    });
    println!(
        "500×500, 40 spp ({threads} threads): bmc (4 sets) {bmc:.3} s, mc {mc:.3} s, bmc/mc = {:.2}",
        bmc / mc
    );
    let small = Renderer::new(256, 256, Environment::Sky);
    let reference = best_of_three(|| {
        small.render(
            &Integrator::build(IntegratorKind::MC, 3000, 0, false, None, 1).unwrap(),
            1,
            &bar,
        );
    });
    println!("256×256 MC reference, 3000 spp: {reference:.2} s");
}
