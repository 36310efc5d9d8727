//! The renderer's baselines (issue 40 part 1, math.md §11): `mc-light`, `mc-bsdf` and `mis`
//! (power and balance heuristics, compensation, Sobol primary samples) on `envmap` integrands.
//! Each is unbiased: its mean over many trials lies within 4 standard errors of the certified
//! (texel-exact) truth, on a synthetic map with a small bright "sun", under a Lambertian and a
//! tilted Phong BRDF, both lookups. Same seed ⇒ byte-identical CSV on 1 and 2 threads. Bad input
//! is one line naming the field and value, exit 2, nothing written.

use crate::common::*;
use crate::light_baselines::{baselines, check_unbiased, check_unbiased_with, pss_variants};
use std::path::Path;
use workbench::bq::estimator::mis::{BSDF_TECHNIQUE, LIGHT_TECHNIQUE, LightEstimator};
use workbench::experiment::plan::resolve_integrand;
use workbench::experiment::runner::primary_samples;
use workbench::experiment::spec::IntegrandSpec;
use workbench::integrand::Integrand;

/// A `w × h` OpenEXR map (row 0 at the zenith) of radiance `texel(row, col)`.
pub fn map(path: &Path, w: u32, h: u32, texel: impl Fn(u32, u32) -> [f32; 3]) {
    let img = image::Rgb32FImage::from_fn(w, h, |c, r| image::Rgb(texel(r, c)));
    image::DynamicImage::ImageRgb32F(img)
        .save_with_format(path, image::ImageFormat::OpenExr)
        .unwrap();
}

/// 32×16 texels: a sky gradient, a dark ground with black texels, and a 2×2 "sun" of `sun`
/// (about 0.1 sr, towards `(0.62, 0.67, −0.41)`).
fn sunny_map_with(path: &Path, sun: f32) {
    map(path, 32, 16, |r, c| {
        if (3..5).contains(&r) && (20..22).contains(&c) {
            [sun, 0.96 * sun, 0.8 * sun]
        } else if r < 8 {
            let t = r as f32 / 8.0;
            [0.3 + 0.5 * t, 0.5 + 0.3 * t, 0.9 - 0.2 * t + 0.01 * c as f32]
        } else if (r + c) % 5 == 0 {
            [0.0; 3]
        } else {
            [0.2, 0.15, 0.1]
        }
    });
}

/// The map with a sun of 500.
fn sunny_map(path: &Path) {
    sunny_map_with(path, 500.0);
}

fn integrand(spec: serde_json::Value) -> Integrand {
    resolve_integrand(&serde_json::from_value::<IntegrandSpec>(spec).unwrap()).unwrap()
}

/// A sun of 50 inside the Lambertian hemisphere and near the Phong lobe's axis, so that every
/// technique (BSDF sampling too) hits it often enough for the trials' spread to measure the
/// error: a sun in a lobe's far tail is a rare event, whose sample SE misses it.
#[test]
fn every_baseline_is_unbiased_on_a_synthetic_map() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sunny.exr");
    sunny_map_with(&path, 50.0);
    let env = path.display().to_string();
    for lookup in ["mitsuba", "thesis"] {
        let lambert = integrand(serde_json::json!({
            "type": "envmap", "env": env, "normal": [0.2, 0.9, -0.3], "lookup": lookup
        }));
        let phong = integrand(serde_json::json!({
            "type": "envmap", "env": env, "normal": [0.5, 0.8, -0.3], "lookup": lookup,
            "channel": "r", "brdf": {"phong": 6, "axis": [0.2, -0.1, 0.975]}
        }));
        for f in [&lambert, &phong] {
            check_unbiased(f, 16, 1500, 40);
            check_unbiased_with(&pss_variants(), f, 128, 400, 40);
        }
    }
}

/// On a map with a sun, light sampling and MIS beat BSDF sampling by far, and the stated
/// standard error of one trial matches the spread of the trials (within 25%, 400 trials).
#[test]
fn light_sampling_finds_the_sun_and_states_its_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sunny.exr");
    sunny_map(&path);
    let f = integrand(serde_json::json!({
        "type": "envmap", "env": path.display().to_string(), "normal": [0.0, 1.0, 0.0]
    }));
    let lit = f.lit().unwrap();
    let n = 32;
    let rmse_and_sd = |e: LightEstimator| {
        let (nl, nb) = e.method.counts(n);
        let mut se = 0.0;
        let mut sd2 = 0.0;
        let trials = 400;
        for t in 0..trials {
            let light = primary_samples(7, e.sampler, LIGHT_TECHNIQUE, nl, n, t);
            let bsdf = primary_samples(7, e.sampler, BSDF_TECHNIQUE, nb, n, t);
            let (v, u) = e.estimate(lit, &light, &bsdf);
            se += (v - f.integral()).powi(2);
            sd2 += u.unwrap().sd.powi(2);
        }
        ((se / trials as f64).sqrt(), (sd2 / trials as f64).sqrt())
    };
    let all = baselines();
    let by = |name: &str| all.iter().find(|(n, _)| *n == name).unwrap().1;
    let (light, light_sd) = rmse_and_sd(by("mc-light"));
    let (bsdf, _) = rmse_and_sd(by("mc-bsdf"));
    let (mis, mis_sd) = rmse_and_sd(by("mis"));
    assert!(
        light < 0.2 * bsdf && mis < 0.5 * bsdf,
        "light {light}, mis {mis}, bsdf {bsdf}"
    );
    for (rmse, sd) in [(light, light_sd), (mis, mis_sd)] {
        assert!((sd / rmse - 1.0).abs() < 0.25, "stated sd {sd} vs RMSE {rmse}");
    }
}

fn spec(integrands: &str, estimators: &str, samples: &str) -> String {
    format!(
        r#"{{"name": "light", "integrands": [{integrands}], "estimators": [{estimators}],
            "samples": {samples}, "trials": 6, "seed": 3}}"#
    )
}

const ESTIMATORS: &str = r#"
    {"label": "MC", "method": "mc", "design": "cosine"},
    {"label": "light", "method": "mc-light"},
    {"label": "bsdf", "method": "mc-bsdf", "sampler": "sobol"},
    {"label": "MIS", "method": "mis"},
    {"label": "MIS balance", "method": "mis", "heuristic": "balance"},
    {"label": "MIS comp", "method": "mis", "compensation": true},
    {"label": "MIS sobol", "method": "mis", "sampler": "sobol"},
    {"label": "BMC", "method": "bmc"}"#;

/// Same seed ⇒ byte-identical `trials.csv` and `summary.csv` on 1 and 2 threads, with the new
/// estimators beside MC and BMC; their rows name their method and sampler.
#[test]
fn light_estimators_are_deterministic_across_thread_counts() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    sunny_map(&d.join("sunny.exr"));
    let integrands = r#"{"name": "up", "type": "envmap", "env": "sunny.exr", "normal": [0, 1, 0]},
        {"name": "glossy", "type": "envmap", "env": "sunny.exr", "normal": [0.3, 0.9, 0.1],
         "brdf": {"phong": 30, "axis": [0, 0.5, 0.866]}}"#;
    std::fs::write(d.join("e.json"), spec(integrands, ESTIMATORS, "[4, 16]")).unwrap();
    for threads in ["1", "2"] {
        let o = workbench(
            d,
            &["run", "e.json", "-q", "--threads", threads, "--out", threads],
        );
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    for file in ["trials.csv", "summary.csv"] {
        let a = std::fs::read(d.join("1").join(file)).unwrap();
        let b = std::fs::read(d.join("2").join(file)).unwrap();
        assert!(a == b, "{file} differs between 1 and 2 threads");
    }
    let (header, rows) = read_csv(&d.join("1/trials.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let row = rows.iter().find(|r| r[col("estimator")] == "MIS sobol").unwrap();
    assert_eq!(
        (row[col("method")].as_str(), row[col("design")].as_str()),
        ("mis", "sobol")
    );
    assert!(
        rows.iter()
            .all(|r| r[col("estimate")].parse::<f64>().unwrap().is_finite())
    );
}

/// Bad input: exit 2, one line naming the field and value, nothing written.
#[test]
fn bad_light_estimator_input_is_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    sunny_map(&d.join("sunny.exr"));
    map(&d.join("flat.exr"), 8, 4, |_, _| [0.5, 0.5, 0.5]);
    let up = r#"{"name": "up", "type": "envmap", "env": "sunny.exr", "normal": [0, 1, 0]}"#;
    let flat = r#"{"name": "flat", "type": "envmap", "env": "flat.exr", "normal": [0, 1, 0]}"#;
    let cases = [
        (
            spec(r#""cos3""#, r#"{"label": "MIS", "method": "mis"}"#, "[4]"),
            vec!["estimators[0].method", "\"mis\"", "\"cos3\"", "no light"],
        ),
        (
            spec(
                r#"{"type": "lobe", "exponent": 4, "axis": [0, 0, 1]}"#,
                r#"{"label": "L", "method": "mc-light"}"#,
                "[4]",
            ),
            vec!["estimators[0].method", "\"mc-light\"", "no light"],
        ),
        (
            spec(
                flat,
                r#"{"label": "MIS", "method": "mis", "compensation": true}"#,
                "[4]",
            ),
            vec!["estimators[0].compensation", "\"flat\"", "constant"],
        ),
        (
            spec(
                up,
                r#"{"label": "MIS", "method": "mis", "sampler": "halton"}"#,
                "[4]",
            ),
            vec!["estimators[0].sampler", "halton", "sobol"],
        ),
        (
            spec(
                up,
                r#"{"label": "L", "method": "mc-light", "compensation": true}"#,
                "[4]",
            ),
            vec!["estimators[0].compensation", "mc-light", "only by mis"],
        ),
        (
            spec(
                up,
                r#"{"label": "L", "method": "mc-light", "heuristic": "balance"}"#,
                "[4]",
            ),
            vec!["estimators[0].heuristic", "balance"],
        ),
        (
            spec(
                up,
                r#"{"label": "MIS", "method": "mis", "design": "sobol"}"#,
                "[4]",
            ),
            vec!["estimators[0].design", "sampler"],
        ),
        (
            spec(up, r#"{"label": "MIS", "method": "mis", "noise": 0.1}"#, "[4]"),
            vec!["estimators[0].noise", "mis"],
        ),
        (
            spec(up, r#"{"label": "MIS", "method": "mis"}"#, "[4, 7]"),
            vec!["samples[1]", "N = 7", "even"],
        ),
        (
            spec(
                up,
                r#"{"label": "MC", "method": "mc", "sampler": "sobol"}"#,
                "[4]",
            ),
            vec!["estimators[0].sampler", "\"sobol\"", "method mc"],
        ),
        (
            spec(up, r#"{"label": "P", "method": "bq-pss", "order": 3}"#, "[4]"),
            vec!["estimators[0].order", "3", "1 or 2"],
        ),
        (
            spec(up, r#"{"label": "MIS", "method": "mis", "order": 2}"#, "[4]"),
            vec!["estimators[0].order", "only by bq-pss"],
        ),
        (
            spec(up, r#"{"label": "B", "method": "bmc", "weights": "cv"}"#, "[4]"),
            vec!["estimators[0].weights", "\"cv\"", "method bmc"],
        ),
        (
            spec(up, r#"{"label": "P", "method": "bq-pss"}"#, "[4, 5]"),
            vec!["samples[1]", "N = 5", "bq-pss", "even"],
        ),
        (
            spec(r#""cos3""#, r#"{"label": "P", "method": "bq-pss"}"#, "[4]"),
            vec!["estimators[0].method", "\"bq-pss\"", "no light"],
        ),
        (
            spec(up, r#"{"label": "X", "method": "mis-light"}"#, "[4]"),
            vec![
                "estimators[0].method",
                "mis-light",
                "`mc-light`, `mc-bsdf`, `mis`",
            ],
        ),
    ];
    for (i, (text, wants)) in cases.iter().enumerate() {
        let file = format!("bad{i}.json");
        std::fs::write(d.join(&file), text).unwrap();
        let out = format!("out{i}");
        let o = workbench(d, &["run", &file, "-q", "--out", &out]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "case {i}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "case {i}: {err}");
        assert!(err.contains(&file), "case {i} names the file: {err}");
        for w in wants {
            assert!(err.contains(w), "case {i}: {w:?} missing from {err}");
        }
        assert!(!d.join(&out).exists(), "case {i} wrote its folder");
    }
}

/// Every light's distribution — a map under both lookups, the procedural sky, white — integrates
/// to 1 over the sphere to 1e-9 (a midpoint rule in `(cos θ, ψ)` refining its own cells 2×2, exact
/// for a piecewise-constant density), with the compensated density where there is one, and is
/// positive wherever the light's radiance is (so light sampling misses no light).
#[test]
fn every_light_distribution_integrates_to_one_and_covers_its_light() {
    use rand::RngExt;
    use std::f64::consts::{PI, TAU};
    use workbench::render::Environment;
    use workbench::render::env::Lookup;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sunny.exr");
    sunny_map(&path);
    let map = || Environment::from_arg(&path.display().to_string()).unwrap();
    let lights = [
        ("mitsuba", map()),
        ("thesis", map().with_lookup(Lookup::Thesis, "lookup").unwrap()),
        ("sky", Environment::Sky),
        ("white", Environment::White),
    ];
    let mut rng = workbench::util::rng::stream(8, &[]);
    for (name, env) in &lights {
        let light = env.light();
        let g = light.grid();
        let dpsi = TAU / g.cols as f64;
        for compensated in [false, true] {
            if compensated && !light.has_compensation() {
                assert_eq!(*name, "white", "only white is constant");
                continue;
            }
            let mut sum = 0.0;
            for r in 0..g.rows {
                let (a, b) = (
                    (r as f64 * PI / g.rows as f64).cos(),
                    ((r + 1) as f64 * PI / g.rows as f64).cos(),
                );
                for c in 0..g.cols {
                    for (i, j) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                        let mu = a + (b - a) * (0.25 + 0.5 * i as f64);
                        let psi = g.psi_start + (c as f64 + 0.25 + 0.5 * j as f64) * dpsi;
                        let d = workbench::sampling::light::direction(mu, psi);
                        sum += light.pdf(&d, compensated) * (a - b) * dpsi / 4.0;
                    }
                }
            }
            assert!(
                (sum - 1.0).abs() < 1e-9,
                "{name} compensated {compensated}: {sum}"
            );
        }
        for _ in 0..20_000 {
            let mu: f64 = 2.0 * rng.random::<f64>() - 1.0;
            let d = workbench::sampling::light::direction(mu, TAU * rng.random::<f64>());
            let y = workbench::sampling::light::luminance(env.radiance(&d));
            assert!(
                y <= 0.0 || light.pdf(&d, false) > 0.0,
                "{name}: light without density at {d:?}"
            );
        }
    }
}
