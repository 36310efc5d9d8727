//! `workbench render SPEC.json` through the binary: the output layout, the reference cache,
//! reproducible numbers, and spec errors rejected before any work.

use crate::common::*;

const SPEC: &str = r#"{
  "name": "tiny", "seed": 7, "width": 32, "height": 24, "spp": [4, 8], "repetitions": [3, 2],
  "reference": {"spp": 64},
  "variants": [
    {"label": "MC", "integrator": "mc"},
    {"label": "BMC 2 GP", "integrator": "bmc", "gps": 2},
    {"label": "BMCP", "integrator": "bmcp", "gps": 1, "rotate": false}
  ]
}"#;

#[test]
fn table_writes_its_outputs_and_reuses_the_reference() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("tiny.json"), SPEC).unwrap();
    let o = workbench(d, &["render", "tiny.json", "--results-dir", "out"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("reference (mc, 64 spp)"), "{err}");

    let out = d.join("out/tiny");
    let rmse = std::fs::read_to_string(out.join("rmse.csv")).unwrap();
    let lines: Vec<&str> = rmse.lines().collect();
    assert_eq!(
        lines[0],
        "variant,integrator,gps,rotate,spp,repetition,seed,rmse,rmse_edges,coverage95,coverage95_edges"
    );
    // Every render, MC included (its Student-t standard error), states its coverage: a share.
    for line in &lines[1..] {
        let f: Vec<&str> = line.split(',').collect();
        let rmse: f64 = f[7].parse().unwrap();
        let edges: f64 = f[8].parse().unwrap();
        assert!(rmse > 0.0 && edges > 0.0, "{line}");
        for share in [f[9], f[10]] {
            let v: f64 = share.parse().unwrap_or_else(|_| panic!("{line}"));
            assert!((0.0..=1.0).contains(&v), "{line}");
        }
    }
    // Wall-clock times stay out of the stable outputs, in files that are not committed.
    assert!(
        !std::fs::read_to_string(out.join("table.csv"))
            .unwrap()
            .contains("seconds")
    );
    assert!(
        std::fs::read_to_string(out.join("timings.csv"))
            .unwrap()
            .starts_with("variant,spp,repetition,seconds\n")
    );
    assert_eq!(lines.len(), 1 + 3 * (3 + 2));
    assert!(lines[1].starts_with("MC,mc,,,4,0,"), "{}", lines[1]);
    assert!(lines[3].starts_with("BMCP,bmcp,1,false,4,0,"), "{}", lines[3]);

    let table = std::fs::read_to_string(out.join("table.csv")).unwrap();
    assert_eq!(table.lines().count(), 1 + 3 * 2);
    assert_eq!(
        table.lines().next().unwrap(),
        "variant,integrator,gps,rotate,spp,repetitions,rmse_mean,rmse_sd,rmse_ci95_low,rmse_ci95_high,\
         rmse_edges_mean,rmse_edges_ci95_low,rmse_edges_ci95_high,coverage95,coverage95_edges"
    );
    // The cell's coverage95 is the mean of its renders' (MC at 4 spp: rows 1, 4, 7 of rmse.csv).
    let mc4: Vec<f64> = [1, 4, 7]
        .iter()
        .map(|&k| lines[k].split(',').nth(9).unwrap().parse().unwrap())
        .collect();
    let cell: f64 = table
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .nth(13)
        .unwrap()
        .parse()
        .unwrap();
    assert!(
        (cell - mc4.iter().sum::<f64>() / 3.0).abs() < 1e-15,
        "{cell} vs {mc4:?}"
    );
    assert!(table.lines().nth(1).unwrap().starts_with("MC,mc,,,4,3,"));
    let md = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(
        md.contains("| Method | 4 spp | 8 spp |") && md.contains("| BMC 2 GP |"),
        "{md}"
    );
    assert!(
        md.contains("Mean RMSE at edges") && md.contains("Coverage95, whole image / edges"),
        "{md}"
    );
    let svg = std::fs::read_to_string(out.join("rmse_vs_spp.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    assert!(svg.contains("samples per pixel (spp)") && svg.contains("BMC 2 GP"));
    for png in [
        "mc-4spp.png",
        "bmc-2-gp-8spp.png",
        "bmcp-4spp.png",
        "bmcp-4spp-error.png",
        "mc-8spp-error.png",
        "mc-4spp-sd.png",
        "bmc-2-gp-8spp-sd.png",
        "bmcp-4spp-coverage.png",
        "reference.png",
    ] {
        assert!(out.join(png).exists(), "{png}");
    }
    // The equal-time comparison (machine-dependent, so in the uncommitted timings.md): MC
    // against itself is 1 in every column, which only an interpolation through its own
    // measured points gives.
    let times = std::fs::read_to_string(out.join("timings.md")).unwrap();
    assert!(times.contains("RMSE at equal time, relative to MC"), "{times}");
    assert!(times.contains("| MC | 1.000 | 1.000 |"), "{times}");
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["seed"], 7);
    assert_provenance(&out);

    // A second table (another name, same reference inputs) reads the cached reference and
    // reproduces every number.
    std::fs::write(d.join("again.json"), SPEC.replace("\"tiny\"", "\"again\"")).unwrap();
    let o = workbench(d, &["render", "again.json", "--results-dir", "out", "--quiet"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("reference from cache"), "{err}");
    let again = std::fs::read_to_string(d.join("out/again/rmse.csv")).unwrap();
    assert_eq!(rmse, again);
    assert_eq!(
        std::fs::read_dir(d.join("out/cache")).unwrap().count(),
        2,
        "one .exr and its .json"
    );
}

#[test]
fn spec_errors_are_exit_2_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases = [
        (
            SPEC.replace("\"seed\": 7", "\"sede\": 7"),
            "bad.json: sede: unknown field `sede`, expected one of",
        ),
        (
            SPEC.replace("\"gps\": 2", "\"gps\": 0"),
            "bad.json: variants[1].gps: must be in 1..=1024, got 0",
        ),
        (
            SPEC.replace("[4, 8]", "[4, 0]"),
            "bad.json: spp[1]: must be at least 1, got 0",
        ),
        (
            SPEC.replace("\"mc\"}", "\"mcc\"}"),
            "bad.json: variants[0].integrator: unknown integrator \"mcc\"; expected one of mc, mc-cos, bmc, bmcp, bmcp-edge, bsq",
        ),
        (
            SPEC.replace("\"width\": 32", "\"width\": \"wide\""),
            "bad.json: width: invalid type: string \"wide\", expected u64",
        ),
        (
            SPEC.replace("\"seed\": 7", "\"env\": \"nowhere.hdr\""),
            "bad.json: env: nowhere.hdr: cannot read",
        ),
        ("{\"name\": ".into(), "bad.json: malformed JSON"),
        (
            SPEC.replace("\"seed\": 7", "\"clamp\": 1.0"),
            "bad.json: clamp: applies to environment map files, not to `sky`",
        ),
        (
            SPEC.replace("\"mc\"}", "\"mc\", \"scale\": \"ml\"}"),
            "bad.json: variants[0].scale: \"ml\" is not used by integrator mc",
        ),
        (
            SPEC.replace("\"label\": \"BMCP\"", "\"label\": \"bmc-2-gp\""),
            "bad.json: variants[2].label: \"bmc-2-gp\" gives the same file names as variants[1] (\"BMC 2 GP\")",
        ),
        (
            SPEC.replace("\"mc\"}", "\"bsq-rings\"}")
                .replace("[4, 8]", "[4, 38]"),
            "bad.json: spp with variants[0] (bsq-rings): got 38 for bsq-rings; the rings design needs N = J·M",
        ),
        (
            SPEC.replace("[3, 2]", "[3, 4611686018427387904]"),
            "bad.json: repetitions[1]: at most 10000 renders per spp, got 4611686018427387904",
        ),
        (
            SPEC.replace("\"spp\": 64", "\"spp\": 5000000"),
            "bad.json: reference.spp: must be in 1..=1000000, got 5000000",
        ),
        (
            SPEC.replace(
                "\"seed\": 7",
                "\"seed\": 7, \"model\": {\"kernel_mean\": \"mc\", \"kernel_mean_samples\": 100000000000}",
            ),
            "bad.json: model.kernel_mean_samples: must be in 1..=10000000",
        ),
    ];
    for (text, want) in cases {
        std::fs::write(d.join("bad.json"), &text).unwrap();
        let o = workbench(d, &["render", "bad.json", "--results-dir", "out"]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{want}: {err}");
        assert!(err.contains(want), "expected `{want}` in: {err}");
        assert_eq!(err.lines().count(), 1, "one line: {err}");
        assert!(!d.join("out").exists(), "{want}: wrote output");
    }
    let o = workbench(d, &["render", "missing.json"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("missing.json: cannot read"));
}

/// The default reference is exact: the table renders it by the certified quadrature, says so in
/// its manifest and table, caches it under a key of its own, and the cached image equals
/// `render --integrator exact` of the same size.
#[test]
fn the_default_reference_is_exact_and_matches_render_exact() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let spec = r#"{"name": "ex", "width": 16, "height": 12, "spp": [4], "repetitions": 1,
                   "variants": [{"label": "MC", "integrator": "mc"}]}"#;
    std::fs::write(d.join("ex.json"), spec).unwrap();
    let o = workbench(d, &["render", "ex.json", "--results-dir", "out", "-q"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("reference (exact, tolerance 1e-9"), "{err}");
    let manifest = std::fs::read_to_string(d.join("out/ex/manifest.json")).unwrap();
    assert!(manifest.contains("\"integrator\": \"exact\""), "{manifest}");
    let md = std::fs::read_to_string(d.join("out/ex/table.md")).unwrap();
    assert!(md.contains("the exact reference"), "{md}");
    let cached: Vec<_> = std::fs::read_dir(d.join("out/cache"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "exr"))
        .collect();
    assert_eq!(cached.len(), 1);
    let o = workbench(
        d,
        &[
            "render",
            "--integrator",
            "exact",
            "--width",
            "16",
            "--height",
            "12",
            "--out",
            "ref.exr",
            "-q",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let a = workbench::render::Image::read(&cached[0], "cache").unwrap();
    let b = workbench::render::Image::read(&d.join("ref.exr"), "ref").unwrap();
    assert_eq!(a.data, b.data);
    // Run again: the reference comes from the cache.
    let o = workbench(d, &["render", "ex.json", "--results-dir", "out"]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("reference from cache"));
}

/// `clamp` caps the map's texels before anything: a map whose only texel above 1 is a "sun"
/// of 10⁴, clamped at 1, is the constant map of 1 — the same reference cache entry and the
/// same numbers as a table under that constant map — and the manifest says so; unclamped, the
/// sun makes another reference. A clamp that is not a finite radiance > 0 is refused.
#[test]
fn a_clamped_map_is_the_map_with_its_texels_capped() {
    use image::{ImageFormat, Rgb, Rgb32FImage};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let ones = Rgb32FImage::from_pixel(16, 8, Rgb([1.0, 1.0, 1.0]));
    let mut sun = ones.clone();
    sun.get_pixel_mut(3, 2).0 = [1e4, 2e4, 1e4];
    for (name, map) in [("ones.exr", ones), ("sun.exr", sun)] {
        image::DynamicImage::ImageRgb32F(map)
            .save_with_format(d.join(name), ImageFormat::OpenExr)
            .unwrap();
    }
    let table = |name: &str, env: &str, clamp: &str| {
        format!(
            r#"{{"name": "{name}", "width": 12, "height": 8, "spp": [4], "repetitions": 2,
                 "env": "{env}"{clamp}, "reference": {{"spp": 8}},
                 "variants": [{{"label": "MC", "integrator": "mc"}},
                              {{"label": "BMC", "integrator": "bmc", "gps": 1}}]}}"#
        )
    };
    for (name, env, clamp) in [
        ("clamped", "sun.exr", r#", "clamp": 1.0"#),
        ("ones", "ones.exr", ""),
        ("sun", "sun.exr", ""),
    ] {
        std::fs::write(d.join(format!("{name}.json")), table(name, env, clamp)).unwrap();
        let o = workbench(
            d,
            &["render", &format!("{name}.json"), "--results-dir", "out", "-q"],
        );
        assert!(o.status.success(), "{name}: {}", stderr(&o));
    }
    let read = |name: &str, file: &str| std::fs::read_to_string(d.join("out").join(name).join(file)).unwrap();
    assert_eq!(read("clamped", "rmse.csv"), read("ones", "rmse.csv"));
    assert_ne!(read("sun", "rmse.csv"), read("ones", "rmse.csv"));
    let manifest: serde_json::Value = serde_json::from_str(&read("clamped", "manifest.json")).unwrap();
    assert_eq!(manifest["clamp"], 1.0);
    assert!(
        serde_json::from_str::<serde_json::Value>(&read("ones", "manifest.json")).unwrap()["clamp"].is_null()
    );
    // Two references in the cache (each an .exr and its .json): the clamped map's is the ones'.
    assert_eq!(std::fs::read_dir(d.join("out/cache")).unwrap().count(), 4);
    for (bad, want) in [
        ("0.0", "bad.json: clamp: 0 is not a radiance in (0, 3.4028235e38]"),
        ("-1", "bad.json: clamp: -1 is not a radiance in (0, 3.4028235e38]"),
        (
            "1e300",
            "bad.json: clamp: 1e300 is not a radiance in (0, 3.4028235e38]",
        ),
    ] {
        std::fs::write(
            d.join("bad.json"),
            table("bad", "sun.exr", &format!(r#", "clamp": {bad}"#)),
        )
        .unwrap();
        let o = workbench(d, &["render", "bad.json", "--results-dir", "out"]);
        assert_eq!(o.status.code(), Some(2), "{bad}: {}", stderr(&o));
        assert!(stderr(&o).contains(want), "{want}: {}", stderr(&o));
        assert!(!d.join("out/bad").exists());
    }
}

/// A table's variant has the face of the same estimator in an experiment: cosine MC its
/// cosine marker (not uniform MC's), BMC on Sobol sets BMC's colour with Sobol's marker.
#[test]
fn variants_wear_the_faces_of_the_same_estimators_in_an_experiment() {
    let table = workbench::table::plan::parse(
        r#"{"name": "t", "variants": [{"integrator": "mc"}, {"integrator": "mc-cos"},
            {"integrator": "bmc"}, {"integrator": "bmc-sobol"}]}"#,
        std::path::Path::new("t.json"),
    )
    .unwrap();
    let experiment = workbench::experiment::plan::resolve(
        &workbench::experiment::plan::parse(
            r#"{"name": "x", "integrands": ["cos3"], "samples": [4], "trials": 2, "seed": 1,
                "estimators": [{"label": "MC", "method": "mc"},
                {"label": "MC cosine", "method": "mc", "design": "cosine"},
                {"label": "BMC", "method": "bmc"},
                {"label": "BMC Sobol", "method": "bmc", "design": "sobol"}]}"#,
        )
        .unwrap(),
    )
    .unwrap();
    let (ours, theirs) = (
        workbench::table::plot::variant_faces(&table),
        workbench::experiment::plot::faces(&experiment.estimators),
    );
    assert_eq!(ours, theirs);
    assert_ne!(ours[0].marker, ours[1].marker);
}
