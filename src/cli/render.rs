//! `workbench render`: one image (`--out x.exr`) or a table (`workbench render SPEC.json`).

use super::image_files;
use super::model_args::ModelArgs;
use super::output::{status, stdout};
use super::progress::Bar;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;
use workbench::bq::weights::Scale;
use workbench::error::InputError;
use workbench::render::env::Lookup;
use workbench::render::image::{ColourMap, ErrorScale, Image, short_number};
use workbench::render::integrator::IntegratorKind;
use workbench::render::plan::{Field, ImageIntegrator, ImagePlan, ImageRequest, Method};
use workbench::render::uncertainty::{PixelSds, coverage, coverage_map_png};
use workbench::render::{Integrator, SceneKind};
use workbench::util::report::Reporter;

/// Options of `workbench render`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:\n  \
    workbench render --integrator exact --out ref.exr\n  \
    workbench render --integrator mc --spp 3000 --out ref-mc.exr\n  \
    workbench render --integrator bmc --spp 40 --reference ref.exr --out bmc.exr\n  \
    workbench render --integrator bmc --spp 40 --reference ref.exr --out bmc.exr --sd-out bmc-sd.exr\n  \
    workbench render experiments/render-table.json\n  \
    workbench render experiments/render-table.json --resume             (after an interrupted table)\n\n\
    Render-table fields are documented in docs/guide/render.md (\"Tables\"); the scene in docs/render-scene.md.\n\n\
    Exit codes: 0 success; 2 any error (bad input, I/O).")]
pub struct RenderArgs {
    /// Render-table file (JSON): renders every variant × spp × repetition against a cached
    /// reference and writes results/<name>/. Without it, one image is rendered to --out.
    #[arg(
        value_name = "SPEC.json",
        conflicts_with_all = ["integrator", "spp", "tolerance", "gps", "no_rotate", "width", "height",
                              "env", "env_lookup", "scene", "seed", "reference", "sd_out", "scale", "target_sd",
                              "max_spp"]
    )]
    pub spec: Option<PathBuf>,
    #[arg(long, default_value = "bmc", value_parser = parse_integrator, help = integrator_help())]
    pub integrator: ImageIntegrator,
    /// Samples per pixel (hemisphere directions per estimate) [default: 40]; not with `exact`.
    /// With --target-sd: the first stage, the pilot [default: 64].
    #[arg(long)]
    pub spp: Option<usize>,
    /// `--integrator exact` only: absolute tolerance per pixel and channel of the certified
    /// quadrature [default: 1e-9 under `sky` and `white`, 1e-6 under a map (the texel sum)].
    #[arg(long)]
    pub tolerance: Option<f64>,
    /// Number of BMC sample sets ("GPs"), or of `bq-pss`'s point sets; one is picked at random
    /// per pixel [default: 4].
    #[arg(long)]
    pub gps: Option<usize>,
    /// Do not rotate the BMC sample set by a random azimuth per pixel.
    #[arg(long)]
    pub no_rotate: bool,
    /// Image width in pixels [default: the scene's, 256 (workbench) or 500 (thesis)].
    #[arg(long)]
    pub width: Option<usize>,
    /// Image height in pixels [default: the scene's, 256 (workbench) or 500 (thesis)].
    #[arg(long)]
    pub height: Option<usize>,
    /// The scene: `workbench` (docs/render-scene.md) or `thesis` (the thesis code's sphere on a
    /// green parallelogram, camera at the origin; docs/guide/thesis-images.md).
    #[arg(long, default_value = "workbench", value_parser = parse_scene)]
    pub scene: SceneKind,
    /// Lighting: `sky`, `white`, a catalogue map by name (`pisa`, `archi`, …; read from the data
    /// folder, --data or WORKBENCH_DATA; `workbench data` lists them), or an equirectangular
    /// Radiance .hdr / OpenEXR file (a path: anything with a `/`, or an existing file).
    #[arg(long, default_value = "sky")]
    pub env: String,
    /// How a map is looked up (math.md §10): `mitsuba`, bilinear between texel centres, or
    /// `thesis`, the thesis code's nearest texel [default: mitsuba]; maps only.
    #[arg(long, value_parser = parse_lookup)]
    pub env_lookup: Option<Lookup>,
    /// Master seed: sample sets and per-pixel streams derive from it [default: 0]; not with
    /// `exact`, which draws nothing.
    #[arg(long)]
    pub seed: Option<u64>,
    /// The linear image (OpenEXR, .exr); a tone-mapped PNG is written beside it. With a table
    /// and --shard: the shard folder [default: <results-dir>/<name>-shard-<i>-of-<n>/].
    #[arg(long, required_unless_present = "spec")]
    pub out: Option<PathBuf>,
    /// Reference image (OpenEXR): print the RMSE and write the error image <out>-error.png.
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Error image scale (also of the --sd-out PNG): `absolute` maps the per-pixel error norm
    /// 0…--error-max onto the colours (larger errors clamped), the same in every image, so that
    /// images can be compared; `normalised` maps 0…the image's own largest value. Either way the
    /// PNG carries a colour bar labelled with the scale, and the image's largest value is printed.
    #[arg(long, value_parser = ["absolute", "normalised"])]
    pub error_scale: Option<String>,
    /// Error norm ‖render − reference‖₂ (linear RGB) at the top of the absolute scale; only with
    /// `--error-scale absolute` [default: 0.25, which clamps about 5–10% of a 40-spp render's pixels].
    #[arg(long)]
    pub error_max: Option<f64>,
    /// Error (and sd) image colours: viridis (perceptually uniform) or grey (black = 0)
    /// [default: viridis].
    #[arg(long, value_parser = ["viridis", "grey"])]
    pub error_colours: Option<String>,
    /// Also write the posterior sd each pixel's estimator states, per channel (linear OpenEXR;
    /// integrators with a posterior), its norm ‖sd‖₂ as <sd>.png on the error image's scale and,
    /// with --reference, the coverage map <sd>-coverage.png and the image's coverage on stdout.
    #[arg(long, value_name = "SD.exr")]
    pub sd_out: Option<PathBuf>,
    /// Amplitude of the --sd-out posterior: `ml` (λ̂ = rᵀQ⁻¹r/N fitted per pixel and channel,
    /// Student-t interval), `loo` or `unit` (the thesis's λ = 1), as in experiments (math.md §7)
    /// [default: ml].
    #[arg(long, value_parser = ["unit", "ml", "loo"])]
    pub scale: Option<String>,
    /// Adaptive sampling: each pixel doubles its samples from --spp (the first stage) until every
    /// channel's stated standard deviation is at most this — never on a stage with zero evidence
    /// (a channel's MC sample sd or fitted amplitude exactly 0, or its samples all equal) — or
    /// --max-spp is reached; `mc`,
    /// `mc-cos` and the integrators with weights on uniform sets. Writes <out>-spp.png (the
    /// samples each pixel took).
    #[arg(long)]
    pub target_sd: Option<f64>,
    /// With --target-sd: the most samples a pixel may take (stages spp, 2 spp, … ≤ this).
    #[arg(long)]
    pub max_spp: Option<usize>,
    #[command(flatten)]
    pub model: ModelArgs,
    /// Tables only: folder of the outputs (<dir>/<name>/) and of the reference cache
    /// (<dir>/cache/) [default: results].
    #[arg(long)]
    pub results_dir: Option<PathBuf>,
    /// Tables only: render only shard i of n (1 <= i <= n) of the table's rounds (every variant
    /// at one spp or target and repetition), into a shard folder for `workbench merge`.
    #[arg(long, value_name = "i/n", requires = "spec", allow_hyphen_values = true)]
    pub shard: Option<String>,
    /// Tables only: continue an interrupted table (or, with --shard, shard) from the rounds its
    /// folder's rounds.partial.csv holds; the same files as an uninterrupted run.
    #[arg(long, requires = "spec")]
    pub resume: bool,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

fn parse_scene(name: &str) -> Result<SceneKind, String> {
    SceneKind::from_name(name, "--scene").map_err(|e| e.0.trim_start_matches("--scene: ").to_string())
}

fn parse_lookup(name: &str) -> Result<Lookup, String> {
    Lookup::from_name(name, "--env-lookup").map_err(|e| e.0.trim_start_matches("--env-lookup: ").to_string())
}

fn integrator_help() -> String {
    format!(
        "The estimator of each pixel's illumination integral: {}; or `exact`, every pixel by the \
         certified quadrature (all three channels, to --tolerance)",
        IntegratorKind::names()
    )
}

fn parse_integrator(name: &str) -> Result<ImageIntegrator, String> {
    if name == "exact" {
        return Ok(ImageIntegrator::Exact);
    }
    IntegratorKind::from_name(name)
        .map(ImageIntegrator::Estimator)
        .ok_or_else(|| {
            format!(
                "unknown integrator {name:?}; expected one of {}, exact",
                IntegratorKind::names()
            )
        })
}

/// Runs `workbench render`.
pub fn render(args: RenderArgs) -> anyhow::Result<ExitCode> {
    match &args.spec {
        Some(_) if args.model.given().is_some() => {
            let flag = args.model.given().unwrap_or_default();
            return Err(InputError::new(format!(
                "{flag}: applies to single images; a table takes its model from the spec's \"model\""
            ))
            .into());
        }
        Some(_) if args.error_scale.is_some() || args.error_max.is_some() || args.error_colours.is_some() => {
            return Err(InputError::new(
                "--error-scale/--error-max/--error-colours: apply to single images; a table writes its error \
                 images on the default scale",
            )
            .into());
        }
        Some(spec) => table(spec, &args)?,
        None => single(&args)?,
    }
    Ok(ExitCode::SUCCESS)
}

fn table(spec: &Path, args: &RenderArgs) -> anyhow::Result<()> {
    let shard = args
        .shard
        .as_deref()
        .map(|s| workbench::job::Shard::parse(s).map_err(|m| InputError::new(format!("--shard: {m}"))))
        .transpose()?;
    if shard.is_none()
        && let Some(out) = &args.out
    {
        return Err(InputError::new(format!(
            "--out {}: a table writes <results-dir>/<name>/; --out names a shard's folder (with --shard i/n)",
            out.display()
        ))
        .into());
    }
    let plan = workbench::table::load(spec)?;
    if let Some(w) = plan.model.as_ref().and_then(|m| m.accuracy_warning()) {
        status!("warning: {w}");
    }
    let results = args
        .results_dir
        .clone()
        .unwrap_or_else(|| PathBuf::from("results"));
    let pool = workbench::util::threads::pool(None)?;
    if let Some(shard) = shard {
        let out = args
            .out
            .clone()
            .unwrap_or_else(|| workbench::table::shard::default_out(&results, &plan, shard));
        let report = pool.install(|| {
            workbench::table::shard::run_shard(
                &plan,
                &results,
                shard,
                &out,
                args.resume,
                &super::output::JOB_FLAGS,
                &Bar::new(args.quiet),
            )
        })?;
        status!(
            "wrote shard {shard} ({} renders) to {} ({:.2} s); merge the shards with `workbench merge OUT DIR…`",
            report.renders,
            report.out_dir.display(),
            report.wall_seconds
        );
        return Ok(());
    }
    let report = pool.install(|| {
        workbench::table::run(
            &plan,
            &results,
            args.resume,
            &super::output::JOB_FLAGS,
            &Bar::new(args.quiet),
        )
    })?;
    stdout(&report.table_md)?;
    stdout(&format!("\n{}", report.times_md))?;
    status!("render: table → {}", report.out_dir.display());
    Ok(())
}

/// The flags of a single image as an unchecked request.
fn request(args: &RenderArgs) -> ImageRequest<'_> {
    ImageRequest {
        integrator: args.integrator,
        spp: args.spp,
        tolerance: args.tolerance,
        gps: args.gps,
        no_rotate: args.no_rotate,
        width: args.width,
        height: args.height,
        scene: args.scene,
        env: &args.env,
        env_lookup: args.env_lookup,
        seed: args.seed,
        out: args.out.as_deref().expect("clap requires --out without a spec"),
        reference: args.reference.as_deref(),
        error_scale: args.error_scale.as_deref().map(|s| match s {
            "normalised" => ErrorScale::Normalised,
            _ => ErrorScale::Absolute,
        }),
        error_max: args.error_max,
        error_colours: args.error_colours.as_deref().map(|c| match c {
            "grey" => ColourMap::Grey,
            _ => ColourMap::Viridis,
        }),
        sd_out: args.sd_out.as_deref(),
        scale: args
            .scale
            .as_deref()
            .map(|s| Scale::from_name(s).expect("clap checks the names")),
        target_sd: args.target_sd,
        max_spp: args.max_spp,
        table_only: args
            .results_dir
            .as_ref()
            .map(|_| image_files::flag(Field::ResultsDir)),
        model_given: args.model.given(),
        model: args.model.resolve().map_err(|e| {
            e.downcast::<InputError>()
                .unwrap_or_else(|e| InputError::new(e.to_string()))
        }),
    }
}

/// One image: the flags resolved into a plan (every check before the first pixel), then
/// rendered and written.
fn single(args: &RenderArgs) -> anyhow::Result<()> {
    let bar = Bar::new(args.quiet);
    let plan = ImagePlan::resolve(request(args), image_files::flag, &bar)?;
    if let Method::Adaptive { .. } = plan.method {
        return super::render_adaptive::single(&plan, &bar);
    }
    // The image and its PNGs are one set: no other command may write them meanwhile.
    let labelled = plan.outputs.labelled(image_files::flag);
    let mut files = image_files::lock(&labelled)?;
    let model_seconds = plan.setup_start.elapsed().as_secs_f64();
    let start = Instant::now();
    let (image, sds, what) = render_image(&plan, &bar)?;
    let seconds = start.elapsed().as_secs_f64();

    let outputs = &plan.outputs;
    let (out, png, error_png) = (&outputs.exr, &outputs.png, &outputs.error_png);
    let (error_scale, error_max, error_colours) = (plan.error_scale, plan.error_max, plan.error_colours);
    let pixels = plan.width * plan.height;
    // Every file is written in full before any replaces its predecessor, so a failure (a full
    // disk) leaves the earlier image and PNGs together, as they were.
    files.stage(out, &image.to_exr()?)?;
    files.stage(png, &image.to_png()?)?;
    let error_image = match &plan.reference {
        Some(r) => Some(image.error_png(r, error_scale, error_max, error_colours)?),
        None => None,
    };
    match &error_image {
        Some(e) => files.stage(error_png, &e.png)?,
        // An error image of an earlier render would describe another image.
        None => files.remove_stale(error_png),
    }
    let mut sd_image = None;
    if let (Some(sds), Some(sd)) = (&sds, &outputs.sd) {
        files.stage(&sd.exr, &sds.sd.to_exr()?)?;
        let e = workbench::render::image::scalar_png(
            &sds.norms(),
            plan.width,
            plan.height,
            error_scale,
            error_max,
            error_colours,
            workbench::render::image::SD_TITLE,
        )?;
        files.stage(&sd.png, &e.png)?;
        sd_image = Some(e);
        match &plan.reference {
            Some(r) => files.stage(&sd.coverage, &coverage_map_png(&image, r, sds, 0.95)?)?,
            None => files.remove_stale(&sd.coverage),
        }
    }
    image_files::commit_and_report_removed(files)?;
    status!(
        "render: {what}, {}×{}: {} {seconds:.3} s (after {model_seconds:.3} s of set-up: \
         environment, kernel-mean table) → {}, {}",
        plan.width,
        plan.height,
        if matches!(plan.method, Method::Exact { .. }) {
            "quadrature"
        } else {
            "sample sets + render"
        },
        out.display(),
        png.display()
    );
    if let Some(r) = &plan.reference {
        stdout(&format!("rmse = {:.6e}\n", image.rmse(r)))?;
    }
    if let Some(e) = &error_image {
        status!(
            "render: error image → {} ({})",
            error_png.display(),
            error_summary(e, error_scale, pixels)
        );
    }
    if let (Some(sds), Some(e), Some(sd)) = (&sds, &sd_image, &outputs.sd) {
        status!(
            "render: posterior sd ({} amplitude, {} interval) → {}, {} ({})",
            plan.scale.name(),
            match sds.dof {
                Some(d) => format!("Student-t {d} dof"),
                None => "normal".to_string(),
            },
            sd.exr.display(),
            sd.png.display(),
            error_summary(e, error_scale, pixels).replace("error", "sd norm")
        );
        if sds.zero_amplitude > 0 {
            status!(
                "warning: {} pixel-channel(s): {}",
                sds.zero_amplitude,
                workbench::bq::weights::NumericalWarning::ZeroAmplitude.message()
            );
        }
        if let Some(r) = &plan.reference {
            let c = coverage(&image, r, sds, None);
            stdout(&format!(
                "coverage50 = {:.4}, coverage80 = {:.4}, coverage95 = {:.4} ({} pixel-channels), \
                 median |error|/sd = {:.3}\n",
                c.coverage50, c.coverage80, c.coverage95, c.pixel_channels, c.median_error_over_sd
            ))?;
            status!("render: coverage map → {}", sd.coverage.display());
        }
    }
    Ok(())
}

/// Renders the plan's fixed-spp estimator (its sample sets built first) or its certified
/// quadrature; returns the image, its per-pixel sds when the plan has an sd image, and what
/// made it, for the status line.
fn render_image(plan: &ImagePlan, bar: &Bar) -> anyhow::Result<(Image, Option<PixelSds>, String)> {
    let pool = workbench::util::threads::pool(None)?;
    let renderer = &plan.renderer;
    let with_sd = plan.outputs.sd.is_some();
    let (image, sds, what) = match plan.method {
        Method::Fixed { kind, spp } => {
            let model = plan.model.as_ref();
            let mut integrator = Integrator::build(kind, spp, plan.gps, plan.rotate, model, plan.seed)?;
            for line in workbench::table::runner::numerical_warnings(&integrator) {
                status!("warning: {line}");
            }
            if with_sd {
                integrator = integrator.with_uncertainty(plan.scale, model)?;
            }
            bar.start("rows", (renderer.passes(&integrator) * plan.height) as u64);
            let (image, sds) = if with_sd {
                let (image, sds) = pool.install(|| renderer.render_with_sd(&integrator, plan.seed, bar));
                (image, Some(sds))
            } else {
                (
                    pool.install(|| renderer.render(&integrator, plan.seed, bar)),
                    None,
                )
            };
            bar.finish();
            (image, sds, format!("{kind} {spp} spp"))
        }
        Method::Exact { tolerance: tol } => {
            bar.start("rows", plan.height as u64);
            let (image, stats) = pool.install(|| renderer.render_exact(tol, bar));
            bar.finish();
            if stats.work_limited > 0 {
                status!(
                    "warning: {} pixel(s) stopped at the exact quadrature's work limit ({} nodes) before \
                     their tolerance; their error estimates count what is left (largest {:.1e})",
                    stats.work_limited,
                    workbench::render::texel::MAX_NODES,
                    stats.max_error
                );
            }
            let limited = if stats.depth_limited > 0 {
                format!(
                    "; {} pixel(s) reached the bisection depth limit (their error estimate counts it)",
                    stats.depth_limited
                )
            } else {
                String::new()
            };
            (
                image,
                None,
                format!(
                    "exact (tolerance {tol:e}; largest error estimate {:.1e} at pixel ({}, {}){limited}; {:.3e} \
                     integrand evaluations)",
                    stats.max_error, stats.worst_pixel.0, stats.worst_pixel.1, stats.evaluations as f64
                ),
            )
        }
        Method::Adaptive { .. } => unreachable!("adaptive images render in render_adaptive"),
    };
    Ok((image, sds, what))
}

/// `max error 0.579 at pixel (237, 169); scale 0–0.25, 3516 pixel(s) (5.4%) above it clamped`.
fn error_summary(e: &workbench::render::image::ErrorImage, scale: ErrorScale, pixels: usize) -> String {
    let scale = match scale {
        ErrorScale::Absolute if e.clamped > 0 => format!(
            "scale 0–{}, {} pixel(s) ({:.1}%) above it clamped",
            short_number(e.scale_max),
            e.clamped,
            100.0 * e.clamped as f64 / pixels as f64
        ),
        ErrorScale::Absolute => format!("scale 0–{}", short_number(e.scale_max)),
        ErrorScale::Normalised => format!("scale 0–{}, the image's own maximum", short_number(e.scale_max)),
    };
    format!(
        "max error {} at pixel ({}, {}); {scale}",
        short_number(e.max_error),
        e.max_at.0,
        e.max_at.1
    )
}
