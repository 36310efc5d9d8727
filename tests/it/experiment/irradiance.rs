//! Probulator's irradiance protocol through `workbench run` (issue 28 item 2), on synthetic maps:
//! the exact irradiance of a constant map, cosine MC exact on it, byte-identical CSVs whatever the
//! thread count, `validate`, and bad input (one line, exit 2, nothing written).

use crate::common::*;
use image::{ImageFormat, Rgb, Rgb32FImage};
use std::path::Path;

fn write_map(path: &Path, w: u32, h: u32, f: impl Fn(u32, u32) -> [f32; 3]) {
    image::DynamicImage::ImageRgb32F(Rgb32FImage::from_fn(w, h, |x, y| Rgb(f(x, y))))
        .save_with_format(path, ImageFormat::OpenExr)
        .unwrap();
}

fn spec(env: &str, grid: &str, extra: &str) -> String {
    format!(
        r#"{{ "kind": "irradiance", "name": "irr", "env": "{env}", "grid": {grid}, "n": [4, 16], "seed": 3,
  "estimators": ["mc", "mc-cos", "bmc", "bmc-sobol", "bmc-fitted"]{extra} }}"#
    )
}

/// A constant map `L`: the exact irradiance is `L` at every normal (`exact.exr`), cosine MC is
/// exact (its density is the integrand's shape), the others are not; the published numbers given
/// in the file are in the table.
#[test]
fn constant_map_gives_exact_irradiance_and_exact_cosine_mc() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_map(&d.join("c.exr"), 16, 8, |_, _| [0.5, 1.0, 2.0]);
    std::fs::write(
        d.join("irr.json"),
        spec(
            "c.exr",
            "[8, 4]",
            r#", "published": { "sh_l2": 0.01, "sh_l4": 0.001 }"#,
        ),
    )
    .unwrap();
    let o = workbench(d, &["run", "irr.json", "-q", "--out", "out"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let exact = workbench::render::image::Image::read(&d.join("out/exact.exr"), "exact").unwrap();
    assert_eq!((exact.width, exact.height), (8, 4));
    for p in &exact.data {
        for (c, l) in [0.5, 1.0, 2.0].into_iter().enumerate() {
            assert!((p[c] - l).abs() < 1e-6, "{p:?}");
        }
    }
    let (header, rows) = read_csv(&d.join("out/irradiance.csv"));
    assert_eq!(header, ["estimator", "n", "rms", "rms_r", "rms_g", "rms_b"]);
    assert_eq!(rows.len(), 10);
    for r in &rows {
        let rms: f64 = r[2].parse().unwrap();
        if r[0] == "mc-cos" {
            assert!(rms < 1e-6, "{r:?}");
        } else if r[0] == "mc" {
            assert!(rms > 1e-3, "{r:?}");
        }
    }
    let table = std::fs::read_to_string(d.join("out/table.md")).unwrap();
    assert!(table.contains("| SH L2 (9 coefficients) | 0.01 |"), "{table}");
    assert!(table.contains("| mc-cos | 4 | 4 |"), "{table}");
    assert!(table.contains("| estimator | SH L2 | SH L4 |"), "{table}");
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("out/manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["irradiance"]["smallest_n_matching_sh_l2"]["mc-cos"], 4);
    assert!(d.join("out/rms_vs_n.svg").exists());
    let v = workbench(d, &["validate", "irr.json"]);
    assert_eq!(v.status.code(), Some(0), "{}", stderr(&v));
    assert!(
        stdout(&v).contains("irradiance protocol under c.exr on a 8×4 grid"),
        "{}",
        stdout(&v)
    );
}

/// Same file and seed: byte-identical CSV on 1 and 2 threads.
#[test]
fn csv_is_byte_identical_whatever_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_map(&d.join("v.exr"), 16, 8, |x, y| {
        [1.0 + (x * 7 % 5) as f32, 0.5 + y as f32, ((x + y) % 3) as f32]
    });
    std::fs::write(d.join("irr.json"), spec("v.exr", "[12, 6]", "")).unwrap();
    let mut csvs = Vec::new();
    for threads in ["1", "2"] {
        let out = format!("out{threads}");
        let o = workbench(d, &["run", "irr.json", "-q", "--threads", threads, "--out", &out]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        csvs.push(std::fs::read(d.join(&out).join("irradiance.csv")).unwrap());
    }
    assert_eq!(csvs[0], csvs[1]);
}

/// A grid side of 0, an unknown estimator, a missing map, `--trials`: exit 2, one line, nothing
/// written.
#[test]
fn bad_irradiance_files_are_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_map(&d.join("c.exr"), 16, 8, |_, _| [1.0; 3]);
    for (text, args, needle) in [
        (
            spec("c.exr", "[0, 128]", ""),
            vec![],
            "irr.json: grid: [0, 128]: each side must be from 1 to 4096",
        ),
        (
            spec("c.exr", "[8, 4]", "").replace("\"mc\",", "\"bmcp\","),
            vec![],
            "estimators[0]: unknown estimator \"bmcp\"",
        ),
        (
            spec("none.exr", "[8, 4]", ""),
            vec![],
            "env: none.exr: cannot read",
        ),
        (
            spec("c.exr", "[8, 4]", ""),
            vec!["--trials", "3"],
            "--trials: does not apply to an irradiance protocol file",
        ),
    ] {
        std::fs::write(d.join("irr.json"), &text).unwrap();
        let before = std::fs::read_dir(d).unwrap().count();
        let mut all = vec!["run", "irr.json", "-q", "--out", "out"];
        all.extend(args);
        let o = workbench(d, &all);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{text}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "not one line: {err}");
        assert!(err.contains(needle), "`{needle}` not in: {err}");
        assert_eq!(
            std::fs::read_dir(d).unwrap().count(),
            before,
            "wrote files: {err}"
        );
    }
}

/// The protocol's exact irradiance (`exact.exr`, 32-bit floats) against an independent
/// quadrature: 4×4 Gauss–Legendre on 16 × 16 pieces of every cell of the map's `mitsuba` grid (θ
/// rows `jπ/(H − 1)`, ψ knots at the texel centres) with the lookup itself, at the grid's
/// texel-centre normals `ψ = 2π(i + ½)/W`, `θ = π(j + ½)/H`. Pieces the horizon crosses carry a
/// kink (an O(h²) error there): 2·10⁻⁵ relative allowed (the EXR's floats hold 6·10⁻⁸).
#[test]
fn exact_irradiance_matches_a_cell_by_cell_quadrature() {
    use workbench::util::geometry::Vec3;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_map(&d.join("v.exr"), 12, 7, |x, y| {
        [
            1.0 + ((x * 3 + y * 5) % 7) as f32,
            0.5 + (x % 4) as f32,
            if y < 3 { 2.0 } else { 0.0 },
        ]
    });
    std::fs::write(d.join("irr.json"), spec("v.exr", "[6, 4]", "")).unwrap();
    let o = workbench(d, &["run", "irr.json", "-q", "--out", "out"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let exact = workbench::render::image::Image::read(&d.join("out/exact.exr"), "exact").unwrap();
    let env = workbench::render::Environment::from_arg(d.join("v.exr").to_str().unwrap()).unwrap();
    let (w, h) = (12usize, 7usize);
    let gl = workbench::util::quadrature::GaussLegendre::new(4);
    let (pi, tau) = (std::f64::consts::PI, std::f64::consts::TAU);
    for (k, got) in exact.data.iter().enumerate() {
        let (i, j) = (k % 6, k / 6);
        let (psi, theta) = (tau * (i as f64 + 0.5) / 6.0, pi * (j as f64 + 0.5) / 4.0);
        let n = Vec3::new(theta.sin() * psi.sin(), theta.cos(), -theta.sin() * psi.cos());
        let mut want = [0.0; 3];
        for r in 0..h - 1 {
            for c in 0..w {
                // Each cell in 16 × 16 pieces, so that the few the horizon crosses are small.
                for (a, b) in (0..16).flat_map(|a| (0..16).map(move |b| (a, b))) {
                    let dt = pi / (h - 1) as f64 / 16.0;
                    let dp = tau / w as f64 / 16.0;
                    let (t0, p0) = (
                        r as f64 * pi / (h - 1) as f64 + a as f64 * dt,
                        tau * (c as f64 + 0.5) / w as f64 + b as f64 * dp,
                    );
                    for (x, wx) in gl.nodes().iter().zip(gl.weights()) {
                        let t = t0 + 0.5 * dt * (1.0 + x);
                        for (y, wy) in gl.nodes().iter().zip(gl.weights()) {
                            let p = p0 + 0.5 * dp * (1.0 + y);
                            let dir = Vec3::new(t.sin() * p.sin(), t.cos(), -t.sin() * p.cos());
                            let cos = dir.dot(&n);
                            if cos > 0.0 {
                                let l = env.radiance(&dir);
                                let f = 0.25 * dt * dp * wx * wy * cos * t.sin() / pi;
                                for ch in 0..3 {
                                    want[ch] += f * l[ch];
                                }
                            }
                        }
                    }
                }
            }
        }
        for ch in 0..3 {
            assert!(
                (got[ch] - want[ch]).abs() <= 2e-5 * want[ch].abs().max(1.0),
                "normal ({i}, {j}) channel {ch}: exact.exr {} vs cells {}",
                got[ch],
                want[ch]
            );
        }
    }
}
