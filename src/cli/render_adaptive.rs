//! `workbench render --target-sd T --max-spp M --out x.exr`: one adaptively sampled image
//! ([`workbench::render::adaptive`]), its PNG, the spp map `x-spp.png` and, with `--reference`,
//! the RMSE, the share of pixel channels within `1.96 T` and the error image.

use super::model_args::ModelArgs;
use super::output::{sibling_png, status, stdout};
use super::progress::Bar;
use std::path::PathBuf;
use std::time::Instant;
use workbench::error::InputError;
use workbench::files::file_set::FileSet;
use workbench::render::adaptive::{self, AdaptiveSampler, AdaptiveSettings, DEFAULT_FIRST_SPP};
use workbench::render::image::{ColourMap, ErrorScale};
use workbench::render::integrator::{DEFAULT_GPS, IntegratorKind, check_gps, check_spp};
use workbench::render::{Environment, Renderer, check_size};
use workbench::util::report::Reporter;

/// The options of `render` that an adaptive single image reads (built by `render`'s `single`).
pub struct AdaptiveArgs<'a> {
    pub target_sd: Option<f64>,
    pub max_spp: Option<usize>,
    /// The estimator, or the name of what was asked for instead (`exact`).
    pub integrator: Result<IntegratorKind, String>,
    pub spp: Option<usize>,
    pub gps: Option<usize>,
    pub no_rotate: bool,
    pub width: usize,
    pub height: usize,
    pub env: &'a str,
    pub env_lookup: Option<workbench::render::env::Lookup>,
    pub scene: workbench::render::SceneKind,
    pub seed: Option<u64>,
    pub out: &'a PathBuf,
    pub reference: Option<&'a PathBuf>,
    pub error_max: Option<f64>,
    pub grey: bool,
    /// A flag given that adaptive images do not take (`--tolerance`, `--results-dir`).
    pub unused: Option<&'static str>,
    pub model: &'a ModelArgs,
    pub quiet: bool,
}

/// Validates every option, then renders and writes the image set.
pub fn single(args: &AdaptiveArgs<'_>) -> anyhow::Result<()> {
    let (target_sd, max_spp) = match (args.target_sd, args.max_spp) {
        (Some(t), Some(m)) => (t, m),
        (Some(_), None) => {
            return Err(InputError::new(
                "--target-sd: needs --max-spp (the most samples a pixel may take), e.g. --max-spp 1024",
            )
            .into());
        }
        (None, _) => {
            return Err(
                InputError::new("--max-spp: applies to adaptive sampling; give --target-sd too").into(),
            );
        }
    };
    if !(target_sd.is_finite() && target_sd > 0.0) {
        return Err(InputError::new(format!(
            "--target-sd: must be finite and > 0, got {}",
            workbench::util::shown::shown(target_sd)
        ))
        .into());
    }
    let kind = match &args.integrator {
        Ok(k) if k.adaptive() => *k,
        other => {
            let name = match other {
                Ok(k) => k.name(),
                Err(name) => name.to_string(),
            };
            return Err(InputError::new(format!(
                "--target-sd: adaptive sampling needs an estimator with a per-pixel sd it can extend by stages \
                 ({}), not --integrator {name}",
                IntegratorKind::adaptive_names()
            ))
            .into());
        }
    };
    let first = args.spp.unwrap_or(DEFAULT_FIRST_SPP);
    check_spp(kind, first, "--spp")?;
    check_spp(kind, max_spp, "--max-spp")?;
    if !kind.method.has_interval(first) {
        return Err(InputError::new(format!(
            "--spp {first}: the first stage of adaptive {} needs at least {} samples to state an interval",
            kind.method.name().to_uppercase(),
            kind.method.min_interval_points()
        ))
        .into());
    }
    if max_spp < first {
        return Err(InputError::new(format!(
            "--max-spp {max_spp}: is below the first stage --spp {first}{}",
            if args.spp.is_none() {
                " (the default pilot; give a smaller --spp)"
            } else {
                ""
            }
        ))
        .into());
    }
    if !kind.uses_sets()
        && let Some(flag) = super::image_files::weight_option_given(args.gps, args.no_rotate, args.model)
    {
        return Err(InputError::new(format!("{flag}: applies to --integrator bmc, not {kind}")).into());
    }
    if let Some(flag) = args.unused {
        return Err(InputError::new(format!("{flag}: does not apply to an adaptive single image")).into());
    }
    let gps = args.gps.unwrap_or(DEFAULT_GPS);
    check_gps(gps, "--gps")?;
    let out = args.out;
    super::image_files::check_exr_out(out)?;
    check_size(args.width, args.height, "--width/--height")?;
    let png = sibling_png(out, "");
    let spp_png = sibling_png(out, "-spp");
    let error_png = sibling_png(out, "-error");
    let outputs: Vec<(&str, &std::path::Path)> = vec![
        ("--out", out),
        ("--out (its PNG)", &png),
        ("--out (its spp map)", &spp_png),
        ("--out (its error image)", &error_png),
    ];
    super::image_files::check_outputs_apart(&outputs, args.reference.map(PathBuf::as_path), args.env)?;
    let error_max = super::image_files::check_error_max(args.error_max)?;
    let env = match args.env_lookup {
        Some(lookup) => Environment::from_arg(args.env)?.with_lookup(lookup, "--env-lookup")?,
        None => Environment::from_arg(args.env)?,
    };
    super::image_files::check_out_dir_writable(out)?;
    let reference = super::image_files::read_optional_reference(
        args.reference.map(PathBuf::as_path),
        args.width,
        args.height,
    )?;
    let renderer = Renderer::for_scene(args.scene, args.width, args.height, env);
    let model = if kind.uses_sets() {
        Some(args.model.build()?)
    } else {
        None
    };
    workbench::render::integrator::check_memory(
        &format!("--max-spp {max_spp}"),
        kind,
        max_spp,
        gps,
        model.as_ref(),
        true,
        args.width * args.height,
    )?;
    let mut files = FileSet::lock(&outputs, "use another --out")?;

    let seed = args.seed.unwrap_or(0);
    let settings = AdaptiveSettings::new(target_sd, first, max_spp);
    let start = Instant::now();
    let (sampler, jitter) =
        AdaptiveSampler::new(kind, &settings, gps, !args.no_rotate, model.as_ref(), seed)?;
    if jitter > 0.0 {
        status!(
            "warning: a nested sample set's Cholesky needed jitter {jitter:.3e} on the diagonal (every \
             stage of that set uses it); increase the noise σ_n²"
        );
    }
    let pool = workbench::util::threads::pool(None)?;
    let bar = Bar::new(args.quiet);
    bar.start("rows", (sampler.passes() * args.height) as u64);
    let result = pool.install(|| adaptive::render(&renderer, &sampler, &settings, seed, &bar));
    bar.finish();
    let seconds = start.elapsed().as_secs_f64();

    let (map, black) = result.spp_as_norms();
    let spp_image = workbench::render::image::scalar_png(
        &map.error_norms(&black),
        map.width,
        map.height,
        ErrorScale::Absolute,
        settings.max_spp() as f64,
        ColourMap::Viridis,
        workbench::render::image::SPP_TITLE,
    )?;
    files.stage(out, &result.image.to_exr()?)?;
    files.stage(&png, &result.image.to_png()?)?;
    files.stage(&spp_png, &spp_image.png)?;
    match &reference {
        Some(r) => {
            let e = result.image.error_png(
                r,
                ErrorScale::Absolute,
                error_max,
                if args.grey {
                    ColourMap::Grey
                } else {
                    ColourMap::Viridis
                },
            )?;
            files.stage(&error_png, &e.png)?;
        }
        None => files.remove_stale(&error_png),
    }
    super::image_files::commit_and_report_removed(files)?;
    status!(
        "render: {kind} adaptive, target sd {target_sd:e}, stages {}…{} spp, {}×{}: {seconds:.3} s (sample sets + \
         render) → {}, {}, {}",
        first,
        settings.max_spp(),
        args.width,
        args.height,
        out.display(),
        png.display(),
        spp_png.display()
    );
    if result.zero_evidence.contains(&true) {
        status!(
            "note: {:.2}% of the pixels had a stage with zero evidence (a channel's samples all alike, e.g. all 0: \
             MC sample sd or fitted amplitude exactly 0); such a stage never stops a pixel, so they doubled on",
            100.0 * result.share_zero_evidence()
        );
    }
    stdout(&format!(
        "mean spp = {:.2}\nshare of pixels meeting the target = {:.4}\nseconds = {seconds:.3}\n",
        result.mean_spp(),
        result.share_met()
    ))?;
    if let Some(r) = &reference {
        stdout(&format!(
            "rmse = {:.6e}\nshare of pixel channels within 1.96·target = {:.4}\n",
            result.image.rmse(r),
            result.within(r)
        ))?;
    }
    Ok(())
}
