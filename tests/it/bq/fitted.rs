//! The fitted model (math.md §9): the profiled log marginal likelihood against a direct
//! computation with an independent solver, the ring factor's `log det Q` against the dense one,
//! the choice on smooth and edged integrands, what a fitted run writes, and its bad input.

use crate::common::{read_csv, stderr, workbench};
use nalgebra::{DMatrix, DVector};
use workbench::bq::estimator::Method;
use workbench::bq::factor::SpdWorkspace;
use workbench::bq::fitted::log_marginal_likelihood;
use workbench::bq::kernel::{Kernel, Sobolev};
use workbench::bq::kernel_mean::KernelMeanMode;
use workbench::bq::model::BmcModel;
use workbench::sampling::{Density, Design};
use workbench::util::geometry::Vec3;
use workbench::util::rng::stream;

/// `ℓ` straight from §9 with nalgebra's Cholesky of an explicitly assembled `Q` (not the
/// workspace's faer factor): `r` from the method's own offset (0, `c`, or the GLS constant
/// `β̂`), `−(d/2) log(rᵀQ⁻¹r/d) − ½ log det Q`, and `−½ log 1ᵀQ⁻¹1` for Bayes–Sard.
fn direct_ell(method: Method, points: &[Vec3], y: &[f64], kernel: &Kernel, noise: f64, prior: f64) -> f64 {
    let n = points.len();
    let q = DMatrix::from_fn(n, n, |i, j| {
        kernel.eval(&points[i], &points[j]) + if i == j { noise } else { 0.0 }
    });
    let chol = q.cholesky().expect("SPD");
    let log_det = 2.0 * chol.l().diagonal().iter().map(|d| d.ln()).sum::<f64>();
    let ones = DVector::from_element(n, 1.0);
    let yv = DVector::from_column_slice(y);
    let u = chol.solve(&ones);
    let offset = match method {
        Method::Bmc => 0.0,
        Method::Bmcp => prior,
        Method::Bsq => u.dot(&yv) / u.sum(),
        Method::Mc => unreachable!(),
    };
    let r = yv - DVector::from_element(n, offset);
    let quad = r.dot(&chol.solve(&r));
    let dof = if method == Method::Bsq { n - 1 } else { n } as f64;
    let mut ell = -0.5 * dof * (quad / dof).ln() - 0.5 * log_det;
    if method == Method::Bsq {
        ell -= 0.5 * u.sum().ln();
    }
    ell
}

/// For BMC, BMCP and Bayes–Sard on s ∈ {1.2, 2.75, 3.75} × σ_n² ∈ {1e-2, 1e-8} at N = 96, the
/// workspace's `ℓ` (faer factor, `Q⁻¹Y`, `log det` from `L`) equals the direct one to 1e-9
/// relative.
#[test]
fn log_marginal_likelihood_matches_a_direct_computation() {
    let points = Density::Uniform.sample_set(96, &mut stream(5, &[1]));
    let y: Vec<f64> = points.iter().map(|p| p.z.powi(3) + 0.3 * p.x).collect();
    let mut ws = SpdWorkspace::new();
    for s in [1.2, 2.75, 3.75] {
        for noise in [1e-2, 1e-8] {
            let kernel = Kernel::Sobolev(Sobolev::new(s).unwrap());
            let model = BmcModel::new(kernel, noise, KernelMeanMode::Exact);
            let w = model.weights(&points, &mut stream(0, &[]), &mut ws).unwrap();
            assert_eq!(
                w.diagnostics.jitter, 0.0,
                "s = {s}, noise = {noise} needed jitter"
            );
            let mut solve = y.clone();
            ws.solve_in_place(&mut solve);
            let log_det = ws.log_det();
            for (method, prior) in [(Method::Bmc, 0.0), (Method::Bmcp, 0.25), (Method::Bsq, 0.0)] {
                let got = log_marginal_likelihood(method, &y, &solve, &w, prior, log_det).unwrap();
                let want = direct_ell(method, &points, &y, &kernel, noise, prior);
                assert!(
                    (got - want).abs() <= 1e-9 * want.abs().max(1.0),
                    "{method:?}, s = {s}, noise = {noise}: {got} vs {want}"
                );
            }
        }
    }
}

/// `log det Q` from the ring factor (sum over frequency blocks with multiplicities) equals the
/// dense factor's on ring sets with an odd and an even number of points per ring.
#[test]
fn ring_log_det_matches_the_dense_one() {
    let kernel = Kernel::Sobolev(Sobolev::new(2.75).unwrap());
    for n in [128, 288, 512] {
        let points = Design::Rings.sample_set(n, &mut stream(9, &[n as u64]));
        let mut ws = SpdWorkspace::new();
        let layout = workbench::sampling::rings::layout(n);
        let ring = workbench::bq::factor::rings::RingFactor::new(&points, layout, &kernel, 1e-2).unwrap();
        ws.factor_gram(&points, &kernel, 1e-2).unwrap();
        let dense = ws.log_det();
        let rel = (ring.log_det() - dense).abs() / dense.abs();
        assert!(
            rel < 1e-10,
            "N = {n} ({layout:?}): ring {} vs dense {dense}",
            ring.log_det()
        );
    }
}

fn run_fitted(dir: &std::path::Path, integrands: &str, samples: &str, trials: usize) -> std::path::PathBuf {
    let spec = format!(
        r#"{{"name":"fit","integrands":{integrands},
            "estimators":[{{"label":"BMC","method":"bmc"}},
                          {{"label":"BMC fitted","method":"bmc","kernel":{{"type":"fitted"}}}},
                          {{"label":"BSQ fitted","method":"bsq","kernel":{{"type":"fitted"}}}}],
            "samples":{samples},"trials":{trials},"seed":17}}"#
    );
    std::fs::write(dir.join("fit.json"), spec).unwrap();
    let o = workbench(dir, &["run", "fit.json", "-q", "--out", "out"]);
    assert!(o.status.success(), "{}", stderr(&o));
    dir.join("out")
}

fn column(header: &[String], name: &str) -> usize {
    header
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("no column {name}"))
}

/// cos³θ at N = 256: the fitted model picks a smooth kernel (s > 2) in every trial and its mean
/// error is below a tenth of fixed s = 1.4's, beyond both 95% intervals; a 25° cap light (an
/// edge) picks a rough one (s < 2) in most trials. `trials.csv` names the chosen model and
/// `summary.csv`'s shares add up to 1.
#[test]
fn fitted_model_chooses_smooth_kernels_for_smooth_integrands_and_rough_for_edges() {
    let dir = tempfile::tempdir().unwrap();
    let out = run_fitted(
        dir.path(),
        r#"["cos3",{"type":"cap","axis":[0.7071067811865476,0,0.7071067811865476],"half_angle":25,"cosine":true}]"#,
        "[256]",
        40,
    );
    let (h, rows) = read_csv(&out.join("trials.csv"));
    let model = column(&h, "model");
    for r in &rows {
        let fitted = r[1].contains("fitted");
        assert_eq!(r[model].is_empty(), !fitted, "{r:?}");
    }
    let smooth = |r: &Vec<String>| r[model].starts_with("s=2.75") || r[model].starts_with("s=3.75");
    let cos3: Vec<_> = rows
        .iter()
        .filter(|r| r[0] == "cos3" && r[1] == "BMC fitted")
        .collect();
    assert_eq!(cos3.len(), 40);
    assert!(cos3.iter().all(|r| smooth(r)), "cos3 chose a rough kernel");
    let cap: Vec<_> = rows
        .iter()
        .filter(|r| r[0] != "cos3" && r[1] == "BMC fitted")
        .collect();
    let rough = cap.iter().filter(|r| !smooth(r)).count();
    assert!(
        rough * 2 > cap.len(),
        "the cap chose a rough kernel in only {rough} of {}",
        cap.len()
    );

    let (h, rows) = read_csv(&out.join("summary.csv"));
    let (mean, lo, hi, shares) = (
        column(&h, "mean_abs_error"),
        column(&h, "ci95_low"),
        column(&h, "ci95_high"),
        column(&h, "chosen_models"),
    );
    let cell = |f: &str, e: &str| rows.iter().find(|r| r[0] == f && r[1] == e).unwrap();
    let (fixed, fitted) = (cell("cos3", "BMC"), cell("cos3", "BMC fitted"));
    let num = |r: &Vec<String>, c: usize| r[c].parse::<f64>().unwrap();
    assert!(
        num(fitted, hi) < num(fixed, lo) / 10.0,
        "fitted {} [{}, {}] vs fixed {} [{}, {}]",
        num(fitted, mean),
        num(fitted, lo),
        num(fitted, hi),
        num(fixed, mean),
        num(fixed, lo),
        num(fixed, hi)
    );
    for r in rows.iter().filter(|r| r[1].contains("fitted")) {
        let total: f64 = r[shares]
            .split("; ")
            .map(|part| part.rsplit(": ").next().unwrap().parse::<f64>().unwrap())
            .sum();
        assert!((total - 1.0).abs() < 1e-12, "{r:?}");
    }
    assert!(cell("cos3", "BMC")[shares].is_empty());
}

/// A fitted run split into two shards and merged, and a run resumed from its unit log, read the
/// chosen models back: the same `trials.csv` and `summary.csv` bytes as one run.
#[test]
fn fitted_choices_survive_shards_and_merge() {
    let dir = tempfile::tempdir().unwrap();
    let whole = run_fitted(dir.path(), r#"["cos3","cos2"]"#, "[8,32]", 6);
    for k in ["1/2", "2/2"] {
        let out = format!("shard{}", &k[..1]);
        let o = workbench(
            dir.path(),
            &["run", "fit.json", "-q", "--shard", k, "--out", &out],
        );
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let o = workbench(dir.path(), &["merge", "merged", "shard1", "shard2", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    for file in ["trials.csv", "summary.csv"] {
        let a = std::fs::read(whole.join(file)).unwrap();
        let b = std::fs::read(dir.path().join("merged").join(file)).unwrap();
        assert!(a == b, "{file} differs after merging shards");
    }
}

/// Fitted kernels' bad input, each a one-line error naming the field and value, exit 2.
#[test]
fn fitted_kernel_bad_input_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (r#""kernel":{"type":"fitted","grid":{"s":[]}}"#, "grid.s is empty"),
        (
            r#""kernel":{"type":"fitted","grid":{"noise":[]}}"#,
            "grid.noise is empty",
        ),
        (r#""kernel":{"type":"fitted","grid":{"s":[2]}}"#, "got 2"),
        (r#""kernel":{"type":"fitted","grid":{"s":[3]}}"#, "got 3"),
        (r#""kernel":{"type":"fitted","grid":{"s":[4.5]}}"#, "got 4.5"),
        (
            r#""kernel":{"type":"fitted","grid":{"noise":[-1e-3]}}"#,
            "got -0.001",
        ),
        (
            r#""kernel":{"type":"fitted"},"kernel_mean":"mc""#,
            "needs exact kernel means",
        ),
        (
            r#""kernel":{"type":"fitted"},"noise":0.1"#,
            "grid's \"noise\" list",
        ),
    ];
    for (fields, message) in cases {
        let spec = format!(
            r#"{{"name":"b","integrands":["cos3"],"estimators":[{{"label":"F","method":"bmc",{fields}}}],"samples":[16],"trials":2,"seed":1}}"#
        );
        std::fs::write(dir.path().join("b.json"), spec).unwrap();
        let o = workbench(dir.path(), &["run", "b.json", "-q", "--out", "never"]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{fields}: {err}");
        assert!(err.contains("b.json: estimators[0]."), "{fields}: {err}");
        assert!(err.contains(message), "{fields}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(!dir.path().join("never").exists());
    }
}

/// A fitted model at a tolerance (math.md §9, "Stopping with a guard", and issue 20's finding
/// that the fixed kernel's intervals on smooth integrands are 5–10× too wide): each stage
/// chooses among the grid by `ℓ` on its own points, so on a smooth lobe the rule stops at a
/// fraction of the fixed s = 1.4 kernel's points (§9's simulation: N 1024 → 131), every trial
/// that stops is within the tolerance, and `trials.csv` names the chosen model.
#[test]
fn a_fitted_model_stops_a_smooth_lobe_early_and_within_the_tolerance() {
    let dir = tempfile::tempdir().unwrap();
    let spec = r#"{"name": "t", "integrands": [{"name": "lobe-8", "type": "lobe",
          "axis": [0.5, 0, 0.8660254037844386], "exponent": 8, "cosine": true}],
        "estimators": [
          {"label": "fixed", "method": "bmc", "tolerance": {"abs": 0.01, "max_n": 1024}},
          {"label": "fitted", "method": "bmc", "kernel": {"type": "fitted"},
           "tolerance": {"abs": 0.01, "max_n": 1024}}],
        "samples": [64], "trials": 20, "seed": 3}"#;
    std::fs::write(dir.path().join("t.json"), spec).unwrap();
    let o = workbench(dir.path(), &["run", "t.json", "-q", "--out", "o"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (h, rows) = read_csv(&dir.path().join("o/stopping_summary.csv"));
    let col = |name: &str| h.iter().position(|c| c == name).unwrap();
    let row = |label: &str| rows.iter().find(|r| r[col("estimator")] == label).unwrap();
    let n_used = |label: &str| row(label)[col("mean_n_used")].parse::<f64>().unwrap();
    assert!(
        n_used("fitted") <= 0.25 * n_used("fixed"),
        "fitted {} against fixed {} points",
        n_used("fitted"),
        n_used("fixed")
    );
    assert_eq!(row("fitted")[col("met")], "1.0");
    assert_eq!(row("fitted")[col("within_given_met")], "1.0");
    let (h, rows) = read_csv(&dir.path().join("o/trials.csv"));
    let col = |name: &str| h.iter().position(|c| c == name).unwrap();
    for r in &rows {
        let fitted = r[col("estimator")] == "fitted";
        assert_eq!(
            r[col("model")].starts_with("s="),
            fitted,
            "only the fitted estimator names a model: {r:?}"
        );
    }
}
