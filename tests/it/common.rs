//! Helpers for tests that drive the binary.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// Runs `workbench` with `args` in `dir`.
pub fn workbench(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_workbench"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("binary runs")
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Parses a CSV into its header and rows of fields.
pub fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let mut r = csv::Reader::from_path(path).expect("csv opens");
    let header = r.headers().unwrap().iter().map(String::from).collect();
    let rows = r
        .records()
        .map(|rec| rec.unwrap().iter().map(String::from).collect())
        .collect();
    (header, rows)
}

use std::f64::consts::{PI, TAU};
use workbench::bq::kernel::Kernel;

/// The Funk–Hecke eigenvalues `λ_l = 2π ∫_{−1}^{1} κ(t) P_l(t) dt` of degrees 0 and 1, in closed
/// form: `k(x, y) = Σ_l λ_l Σ_m Y_lm(x) Y_lm(y)`, so the RKHS norms are
/// `‖1‖² = 4π/λ_0` (1 = √(4π) Y_00) and `‖cos θ‖² = (4π/3)/λ_1` (cos θ = √(4π/3) Y_10).
pub fn funk_hecke_0_1(kernel: &Kernel) -> (f64, f64) {
    match kernel {
        Kernel::Sobolev(k) => {
            // κ = c − (2 − 2t)^p; ∫(2−2t)^p dt = 4^(p+1)/(2(p+1)); ∫t(2−2t)^p dt = −4^(p+1) p/(2(p+1)(p+2)).
            let (s, p) = (k.s(), k.s() - 1.0);
            let c = 2f64.powf(2.0 * s - 1.0) / s;
            let l0 = TAU * (2.0 * c - 4f64.powf(p + 1.0) / (2.0 * (p + 1.0)));
            let l1 = TAU * 4f64.powf(p + 1.0) * p / (2.0 * (p + 1.0) * (p + 2.0));
            (l0, l1)
        }
        Kernel::SquaredExponential(k) => {
            // κ = σ² exp((t − 1)/l²); ∫t e^((t−1)/l²) dt = l² e^((t−1)/l²) (t − l²).
            let (v, l2) = (k.sigma() * k.sigma(), k.length() * k.length());
            let e = (-2.0 / l2).exp();
            (
                TAU * v * l2 * (1.0 - e),
                TAU * v * l2 * ((1.0 - l2) + e * (1.0 + l2)),
            )
        }
    }
}

/// `(‖1‖_H, ‖cos θ‖_H)` in the kernel's RKHS on the sphere.
pub fn rkhs_norms_of_one_and_cos(kernel: &Kernel) -> (f64, f64) {
    let (l0, l1) = funk_hecke_0_1(kernel);
    ((4.0 * PI / l0).sqrt(), (4.0 * PI / 3.0 / l1).sqrt())
}

/// Issue 30 item 8 (issue 21 item 4 before it): a result folder records which build wrote it —
/// the committed `manifest.json` the package version only (a commit there would change with every
/// commit and dirty a clean checkout that reruns it), the git-ignored `timings.json` the whole
/// build ([`assert_build_recorded`]).
pub fn assert_provenance(folder: &Path) {
    let read = |name: &str| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(folder.join(name)).unwrap()).unwrap()
    };
    let manifest = read("manifest.json");
    assert_eq!(manifest["workbench_version"], env!("CARGO_PKG_VERSION"));
    for k in ["workbench_commit", "workbench_dirty", "workbench_changes"] {
        assert!(manifest.get(k).is_none(), "{k} in the manifest: {manifest}");
    }
    assert_build_recorded(&read("timings.json"));
}

/// Issue 21 item 4: manifests recorded no commit of the tool. The record (a folder's
/// `timings.json`, a shard's `shard.json`) records the package
/// version and, built from a git checkout (as the tests are, unless from a tarball), the commit
/// and whether the sources (`src/`, `build.rs`, `Cargo.toml`, `Cargo.lock`) had uncommitted
/// changes — as git sees them now.
pub fn assert_build_recorded(manifest: &serde_json::Value) {
    assert_eq!(manifest["workbench_version"], env!("CARGO_PKG_VERSION"));
    let root = env!("CARGO_MANIFEST_DIR");
    let git = |args: &[&str]| {
        Command::new("git")
            .args(args)
            .current_dir(root)
            .env("GIT_OPTIONAL_LOCKS", "0")
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8(o.stdout).unwrap())
    };
    if git(&["ls-files", "--error-unmatch", "Cargo.toml"]).is_none() {
        assert!(
            manifest.get("workbench_commit").is_none(),
            "not built from git: {manifest}"
        );
        return;
    }
    let head = git(&["rev-parse", "HEAD"]).unwrap();
    assert_eq!(manifest["workbench_commit"], head.trim(), "the commit built");
    let status = git(&[
        "status",
        "--porcelain",
        "--untracked-files=all",
        "--",
        "src",
        "build.rs",
        "Cargo.toml",
        "Cargo.lock",
    ])
    .unwrap();
    let dirty = !status.trim().is_empty();
    assert_eq!(manifest["workbench_dirty"], dirty, "{status}");
    assert_eq!(manifest.get("workbench_changes").is_some(), dirty);
}
