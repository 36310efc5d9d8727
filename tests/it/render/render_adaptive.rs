//! `render --target-sd T --max-spp M` (docs/guide/render.md, "Adaptive sampling"): the per-pixel stopping rule on a tiny
//! image, the nested sets' stage weights against fresh ones, and bad input.

use crate::common::*;
use workbench::bq::factor::SpdWorkspace;
use workbench::bq::kernel::{Kernel, Sobolev};
use workbench::bq::kernel_mean::KernelMeanMode;
use workbench::bq::model::BmcModel;
use workbench::render::adaptive::{self, AdaptiveSampler, AdaptiveSettings};
use workbench::render::env::EnvMap;
use workbench::render::{Environment, IntegratorKind, Renderer};
use workbench::sampling::Density;
use workbench::util::report::Silent;
use workbench::util::rng::stream;

fn model() -> BmcModel {
    BmcModel::new(
        Kernel::Sobolev(Sobolev::new(1.4).unwrap()),
        0.01,
        KernelMeanMode::Exact,
    )
}

/// Every hit pixel used a stage size; where the rule stopped it, every channel's sd is within the
/// target, and where it did not, the pixel used max_spp; the background used none.
#[test]
fn pixels_stop_at_a_stage_when_every_channel_meets_the_target() {
    let renderer = Renderer::new(24, 16, Environment::Sky);
    let settings = AdaptiveSettings::new(0.03, 8, 128);
    assert_eq!(settings.stages, vec![8, 16, 32, 64, 128]);
    let (bmc, jitter) =
        AdaptiveSampler::new(IntegratorKind::BMC, &settings, 2, true, Some(&model()), 3).unwrap();
    assert_eq!(jitter, 0.0);
    for sampler in [
        AdaptiveSampler::Mc(Density::Uniform),
        AdaptiveSampler::Mc(Density::Cosine),
        bmc,
    ] {
        let r = adaptive::render(&renderer, &sampler, &settings, 5, &Silent);
        let mut stopped_early = 0;
        for k in 0..r.spp.len() {
            match r.met[k] {
                None => assert_eq!(r.spp[k], 0),
                Some(met) => {
                    assert!(settings.stages.contains(&r.spp[k]), "pixel {k}: {} spp", r.spp[k]);
                    assert_eq!(
                        met,
                        r.sd[k].iter().all(|&s| s <= 0.03),
                        "pixel {k}: {:?}",
                        r.sd[k]
                    );
                    if !met {
                        assert_eq!(r.spp[k], 128);
                    } else if r.spp[k] < 128 {
                        stopped_early += 1;
                    }
                }
            }
        }
        assert!(
            stopped_early > 0 && r.mean_spp() > 8.0,
            "{sampler:?}: the rule never acted"
        );
        // Same seed, same image.
        let again = adaptive::render(&renderer, &sampler, &settings, 5, &Silent);
        assert_eq!(again.image, r.image);
        assert_eq!(again.spp, r.spp);
    }
}

/// The guard (math.md §9) in adaptive pixels: under a black environment every sample of every
/// pixel is 0, so MC's sample sd and BMC's fitted amplitude are exactly 0 at every stage — a
/// zero-width interval that meets any target. No pixel stops on it: each doubles to `max_spp`,
/// is not met, and is counted as having seen zero evidence.
#[test]
fn no_pixel_stops_on_zero_evidence() {
    let black = Environment::Map(EnvMap::from_texels(8, 4, vec![[0.0; 3]; 32]));
    let settings = AdaptiveSettings::new(0.03, 8, 32);
    let (bmc, _) = AdaptiveSampler::new(IntegratorKind::BMC, &settings, 2, true, Some(&model()), 3).unwrap();
    for sampler in [
        AdaptiveSampler::Mc(Density::Uniform),
        AdaptiveSampler::Mc(Density::Cosine),
        bmc,
    ] {
        let r = adaptive::render(
            &Renderer::new(12, 8, black.clone()),
            &sampler,
            &settings,
            5,
            &Silent,
        );
        let hit: Vec<usize> = (0..r.spp.len()).filter(|&k| r.met[k].is_some()).collect();
        assert!(!hit.is_empty());
        for &k in &hit {
            assert_eq!(
                (r.spp[k], r.met[k], r.zero_evidence[k], r.sd[k]),
                (32, Some(false), true, [0.0; 3]),
                "{sampler:?}: pixel {k}"
            );
        }
        assert_eq!((r.share_met(), r.share_zero_evidence()), (0.0, 1.0));
        // Under the sky only pixels whose samples all hit occluders (the sphere's underside,
        // facing the ground) see nothing; the rule stops others, never on a zero sd.
        let sky = adaptive::render(
            &Renderer::new(12, 8, Environment::Sky),
            &sampler,
            &settings,
            5,
            &Silent,
        );
        assert!(sky.share_zero_evidence() < 0.1, "{sampler:?}");
        assert!(sky.share_met() > 0.0, "{sampler:?}");
        for k in 0..sky.spp.len() {
            if sky.met[k] == Some(true) {
                assert!(sky.sd[k].iter().all(|&s| s > 0.0), "{sampler:?}: pixel {k}");
            }
        }
    }
}

/// The binary says how many pixels had zero evidence (stderr) when some did.
#[test]
fn the_command_notes_zero_evidence_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let black = image::Rgb32FImage::from_pixel(8, 4, image::Rgb([0.0, 0.0, 0.0]));
    image::DynamicImage::ImageRgb32F(black)
        .save_with_format(dir.path().join("black.exr"), image::ImageFormat::OpenExr)
        .unwrap();
    let o = workbench(
        dir.path(),
        &[
            "render",
            "--integrator",
            "mc",
            "--target-sd",
            "0.05",
            "--max-spp",
            "16",
            "--spp",
            "8",
            "--env",
            "black.exr",
            "--width",
            "8",
            "--height",
            "6",
            "--out",
            "a.exr",
            "-q",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("share of pixels meeting the target = 0.0000"),
        "{}",
        stdout(&o)
    );
    assert!(
        stderr(&o).contains("note: 100.00% of the pixels had a stage with zero evidence"),
        "{}",
        stderr(&o)
    );
}

/// A nested set's stage weights and Var₁ equal a fresh factorisation of that stage's points.
#[test]
fn nested_sets_match_fresh_weights_at_every_stage() {
    let m = model();
    let settings = AdaptiveSettings::new(0.01, 16, 256);
    let (sampler, _) = AdaptiveSampler::new(IntegratorKind::BMC, &settings, 1, false, Some(&m), 11).unwrap();
    let AdaptiveSampler::Weighted { sets, .. } = sampler else {
        unreachable!()
    };
    let set = &sets[0];
    for (k, &n) in settings.stages.iter().enumerate() {
        let fresh = m
            .weights(&set.points[..n], &mut stream(0, &[]), &mut SpdWorkspace::new())
            .unwrap();
        let scale = fresh.weights.iter().map(|w| w.abs()).fold(0.0, f64::max);
        for (a, b) in set.weights[k].weights.iter().zip(&fresh.weights) {
            assert!((a - b).abs() <= 1e-9 * scale, "N = {n}: {a} vs {b}");
        }
        let v = fresh.diagnostics.posterior_variance_clamped();
        let unit_variance = set.weights[k].diagnostics.posterior_variance_clamped();
        assert!((unit_variance - v).abs() <= 1e-9 * v.max(1e-12), "N = {n}");
    }
}

/// The binary writes the image, its PNG and the spp map and prints the figures; with a
/// reference, the RMSE and the share within 1.96·target.
#[test]
fn the_command_writes_the_spp_map() {
    let dir = tempfile::tempdir().unwrap();
    let size = ["--width", "20", "--height", "14"];
    let o = workbench(
        dir.path(),
        &[
            &[
                "render",
                "--integrator",
                "mc-cos",
                "--spp",
                "64",
                "--out",
                "ref.exr",
                "-q",
            ],
            &size[..],
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    for integrator in ["bmc", "mc"] {
        let out = format!("{integrator}.exr");
        let o = workbench(
            dir.path(),
            &[
                &[
                    "render",
                    "--integrator",
                    integrator,
                    "--target-sd",
                    "0.05",
                    "--max-spp",
                    "64",
                    "--spp",
                    "8",
                    "--reference",
                    "ref.exr",
                    "--out",
                    &out,
                    "-q",
                ],
                &size[..],
            ]
            .concat(),
        );
        assert!(o.status.success(), "{integrator}: {}", stderr(&o));
        let text = stdout(&o);
        for key in [
            "mean spp = ",
            "share of pixels meeting the target = ",
            "rmse = ",
            "within 1.96·target = ",
        ] {
            assert!(text.contains(key), "{integrator}: {text}");
        }
        for f in [
            format!("{integrator}.png"),
            format!("{integrator}-spp.png"),
            format!("{integrator}-error.png"),
        ] {
            assert!(dir.path().join(&f).is_file(), "{f}");
        }
    }
}

/// An adaptive render against a reference of another size is refused before rendering, with
/// exit 2, one line naming both sizes, and nothing written (the fixed-spp path has the same
/// check in `tests/it/render/render_cli.rs`).
#[test]
fn an_adaptive_render_refuses_a_reference_of_another_size() {
    let dir = tempfile::tempdir().unwrap();
    let o = workbench(
        dir.path(),
        &[
            "render",
            "--integrator",
            "mc",
            "--spp",
            "4",
            "--width",
            "8",
            "--height",
            "6",
            "--out",
            "ref.exr",
            "-q",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = workbench(
        dir.path(),
        &[
            "render",
            "--integrator",
            "bmc",
            "--target-sd",
            "0.05",
            "--max-spp",
            "16",
            "--spp",
            "4",
            "--width",
            "20",
            "--height",
            "14",
            "--reference",
            "ref.exr",
            "--out",
            "a.exr",
            "-q",
        ],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("--reference") && err.contains("8×6") && err.contains("20×14"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    for f in ["a.exr", "a.png", "a-spp.png", "a-error.png"] {
        assert!(!dir.path().join(f).exists(), "{f} was written");
    }
}

/// Bad adaptive options: one line naming the flag, exit 2, nothing written.
#[test]
fn bad_adaptive_options_are_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&[&str], &str); 9] = [
        (&["--target-sd", "0.01"], "--target-sd: needs --max-spp"),
        (&["--max-spp", "64"], "--max-spp: applies to adaptive sampling"),
        (
            &["--target-sd", "0", "--max-spp", "64"],
            "--target-sd: must be finite and > 0, got 0",
        ),
        (
            &["--target-sd", "0.01", "--max-spp", "8", "--spp", "16"],
            "--max-spp 8: is below the first stage --spp 16",
        ),
        (
            &["--target-sd", "0.01", "--max-spp", "32"],
            "--max-spp 32: is below the first stage --spp 64 (the default pilot; give a smaller --spp)",
        ),
        (
            &[
                "--target-sd",
                "0.01",
                "--max-spp",
                "64",
                "--integrator",
                "bmc-rings",
            ],
            "not --integrator bmc-rings",
        ),
        (
            &[
                "--target-sd",
                "0.01",
                "--max-spp",
                "64",
                "--integrator",
                "mc",
                "--spp",
                "1",
            ],
            "--spp 1: the first stage of adaptive MC",
        ),
        (
            &["--target-sd", "0.01", "--max-spp", "64", "--sd-out", "sd.exr"],
            "--sd-out: does not apply to an adaptive single image",
        ),
        (
            &["--target-sd", "0.01", "--max-spp", "64", "--scale", "unit"],
            "--scale: does not apply to an adaptive single image",
        ),
    ];
    for (flags, expected) in cases {
        let args = [
            &["render", "--out", "x.exr", "--width", "8", "--height", "8", "-q"],
            flags,
        ]
        .concat();
        let o = workbench(dir.path(), &args);
        assert_eq!(o.status.code(), Some(2), "{flags:?}: {}", stderr(&o));
        let err = stderr(&o);
        assert_eq!(err.trim_end().lines().count(), 1, "{flags:?}: {err}");
        assert!(err.contains(expected), "{flags:?}: {err}");
        assert!(!dir.path().join("x.exr").exists());
    }
}
