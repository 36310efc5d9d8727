//! `workbench render`: one image (`--out x.exr`) or a table (`workbench render SPEC.json`).

use super::image_files;
use super::model_args::ModelArgs;
use super::output::{sibling_png, status, stdout};
use super::progress::Bar;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;
use workbench::bq::weights::Scale;
use workbench::error::InputError;
use workbench::files::file_set::FileSet;
use workbench::render::env::Lookup;
use workbench::render::exact;
use workbench::render::image::{ColourMap, ErrorScale, Image, short_number};
use workbench::render::integrator::{DEFAULT_GPS, IntegratorKind, check_gps, check_spp};
use workbench::render::uncertainty::{PixelSds, coverage, coverage_map_png};
use workbench::render::{Environment, Integrator, Renderer, SceneKind, check_size};

/// `--spp` when none is given.
const DEFAULT_SPP: usize = 40;
use workbench::util::report::Reporter;
use workbench::util::shown::shown;

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
    pub integrator: RenderIntegrator,
    /// Samples per pixel (hemisphere directions per estimate) [default: 40]; not with `exact`.
    /// With --target-sd: the first stage, the pilot [default: 64].
    #[arg(long)]
    pub spp: Option<usize>,
    /// `--integrator exact` only: absolute tolerance per pixel and channel of the certified
    /// quadrature [default: 1e-9 under `sky` and `white`, 1e-6 under a map (the texel sum)].
    #[arg(long)]
    pub tolerance: Option<f64>,
    /// Number of BMC sample sets ("GPs"); one is picked at random per pixel [default: 4].
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

impl RenderArgs {
    /// `--width`, or the scene's default.
    pub fn width(&self) -> usize {
        self.width.unwrap_or(self.scene.default_size().0)
    }

    /// `--height`, or the scene's default.
    pub fn height(&self) -> usize {
        self.height.unwrap_or(self.scene.default_size().1)
    }

    /// The environment of `--env` under `--env-lookup`.
    pub fn environment(&self) -> Result<Environment, InputError> {
        let env = Environment::from_arg(&self.env)?;
        match self.env_lookup {
            Some(lookup) => env.with_lookup(lookup, "--env-lookup"),
            None => Ok(env),
        }
    }
}

fn parse_scene(name: &str) -> Result<SceneKind, String> {
    SceneKind::from_name(name, "--scene").map_err(|e| e.0.trim_start_matches("--scene: ").to_string())
}

fn parse_lookup(name: &str) -> Result<Lookup, String> {
    Lookup::from_name(name, "--env-lookup").map_err(|e| e.0.trim_start_matches("--env-lookup: ").to_string())
}

/// What computes each pixel: an estimator of the family ([`IntegratorKind`]) or the certified
/// quadrature (`exact`), which is not an estimator (no samples, no seed) and so not a `Method`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RenderIntegrator {
    Estimator(IntegratorKind),
    Exact,
}

impl std::fmt::Display for RenderIntegrator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RenderIntegrator::Estimator(k) => write!(f, "{k}"),
            RenderIntegrator::Exact => f.write_str("exact"),
        }
    }
}

fn integrator_help() -> String {
    format!(
        "The estimator of each pixel's illumination integral: {}; or `exact`, every pixel by the \
         certified quadrature (all three channels, to --tolerance)",
        IntegratorKind::names()
    )
}

fn parse_integrator(name: &str) -> Result<RenderIntegrator, String> {
    if name == "exact" {
        return Ok(RenderIntegrator::Exact);
    }
    IntegratorKind::from_name(name)
        .map(RenderIntegrator::Estimator)
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
    let report =
        pool.install(|| workbench::table::run(&plan, &results, args.resume, &Bar::new(args.quiet)))?;
    stdout(&report.table_md)?;
    stdout(&format!("\n{}", report.times_md))?;
    status!("render: table → {}", report.out_dir.display());
    Ok(())
}

fn single(args: &RenderArgs) -> anyhow::Result<()> {
    if args.target_sd.is_some() || args.max_spp.is_some() {
        // The stage walker keeps one nested factor per pixel; a fitted model would need one
        // per grid model and a choice per stage.
        if args.model.resolve()?.is_fitted() {
            anyhow::bail!(workbench::error::InputError::new(
                "--kernel fitted: cannot be used with --target-sd or --max-spp yet; give a fixed kernel"
            ));
        }
        return super::render_adaptive::single(&super::render_adaptive::AdaptiveArgs {
            target_sd: args.target_sd,
            max_spp: args.max_spp,
            integrator: match args.integrator {
                RenderIntegrator::Estimator(k) => Ok(k),
                other => Err(other.to_string()),
            },
            spp: args.spp,
            gps: args.gps,
            no_rotate: args.no_rotate,
            width: args.width(),
            height: args.height(),
            env: &args.env,
            env_lookup: args.env_lookup,
            scene: args.scene,
            seed: args.seed,
            out: args.out.as_ref().expect("clap requires --out without a spec"),
            reference: args.reference.as_ref(),
            error_max: args.error_max,
            grey: args.error_colours.as_deref() == Some("grey"),
            unused: (args.tolerance.map(|_| "--tolerance"))
                .or(args.results_dir.as_ref().map(|_| "--results-dir"))
                .or(args.sd_out.as_ref().map(|_| "--sd-out"))
                .or(args.scale.as_ref().map(|_| "--scale"))
                .or(args
                    .error_scale
                    .as_ref()
                    .filter(|v| v.as_str() != "absolute")
                    .map(|_| "--error-scale")),
            model: &args.model,
            quiet: args.quiet,
        });
    }
    // Validate everything before any work.
    let out = args.out.as_ref().expect("clap requires --out without a spec");
    image_files::check_exr_out(out)?;
    check_size(args.width(), args.height(), "--width/--height")?;
    let (kind, spp, seed, gps) = check_sampling_options(args)?;
    if args.results_dir.is_some() {
        return Err(InputError::new(
            "--results-dir: applies to tables (render SPEC.json), not single images",
        )
        .into());
    }
    let error_image_options = args
        .error_scale
        .as_ref()
        .map(|_| "--error-scale")
        .or(args.error_max.map(|_| "--error-max"))
        .or(args.error_colours.as_ref().map(|_| "--error-colours"));
    if let Some(flag) = error_image_options
        && args.reference.is_none()
        && args.sd_out.is_none()
    {
        return Err(InputError::new(format!(
            "{flag}: applies to the error image (--reference) or the sd image (--sd-out); give one of them"
        ))
        .into());
    }
    let error_scale = match args.error_scale.as_deref() {
        Some("normalised") => ErrorScale::Normalised,
        _ => ErrorScale::Absolute,
    };
    if args.error_max.is_some() && error_scale != ErrorScale::Absolute {
        return Err(InputError::new("--error-max: applies to --error-scale absolute").into());
    }
    let error_colours = match args.error_colours.as_deref() {
        Some("grey") => ColourMap::Grey,
        _ => ColourMap::Viridis,
    };
    let error_max = image_files::check_error_max(args.error_max)?;
    let scale = check_sd_options(args, kind)?;
    // Never write over an input (the reference, an environment map) or one output over another.
    let png = sibling_png(out, "");
    let error_png = sibling_png(out, "-error");
    let sd_pngs = args
        .sd_out
        .as_ref()
        .map(|sd| (sibling_png(sd, ""), sibling_png(sd, "-coverage")));
    // The error image is written with --reference and removed without it (an earlier one would
    // describe another image), so it is an output either way; so is the coverage map.
    let mut outputs: Vec<(&str, &std::path::Path)> = vec![
        ("--out", out),
        ("--out (its PNG)", &png),
        ("--out (its error image)", &error_png),
    ];
    if let (Some(sd), Some((sd_png, coverage_png))) = (&args.sd_out, &sd_pngs) {
        outputs.push(("--sd-out", sd));
        outputs.push(("--sd-out (its PNG)", sd_png));
        outputs.push(("--sd-out (its coverage map)", coverage_png));
    }
    image_files::check_outputs_apart(&outputs, args.reference.as_deref(), &args.env)?;
    let env = args.environment()?;
    if let Some(k) = kind {
        workbench::render::integrator::check_light(k, &env, "--integrator")?;
    }
    image_files::check_out_dir_writable(out)?;
    let model_start = Instant::now();
    let model = if kind.is_some_and(|k| k.uses_sets()) {
        Some(args.model.build()?)
    } else {
        None
    };
    if let Some(k) = kind {
        workbench::render::integrator::check_memory(
            &format!("--spp {spp}"),
            k,
            spp,
            gps,
            model.as_ref(),
            args.sd_out.is_some(),
            args.width() * args.height(),
        )?;
    }
    let reference =
        image_files::read_optional_reference(args.reference.as_deref(), args.width(), args.height())?;
    let renderer = Renderer::for_scene(args.scene, args.width(), args.height(), env);
    // The image and its PNGs are one set: no other command may write them meanwhile.
    let mut files = FileSet::lock(&outputs, "use another --out")?;

    let model_seconds = model_start.elapsed().as_secs_f64();
    let start = Instant::now();
    let (image, sds, what) = render_image(args, &renderer, kind, spp, gps, seed, model.as_ref(), scale)?;
    let seconds = start.elapsed().as_secs_f64();

    // Every file is written in full before any replaces its predecessor, so a failure (a full
    // disk) leaves the earlier image and PNGs together, as they were.
    files.stage(out, &image.to_exr()?)?;
    files.stage(&png, &image.to_png()?)?;
    let error_image = match &reference {
        Some(r) => Some(image.error_png(r, error_scale, error_max, error_colours)?),
        None => None,
    };
    match &error_image {
        Some(e) => files.stage(&error_png, &e.png)?,
        // An error image of an earlier render would describe another image.
        None => files.remove_stale(&error_png),
    }
    let mut sd_image = None;
    if let (Some(sds), Some(sd_out), Some((sd_png, coverage_png))) = (&sds, &args.sd_out, &sd_pngs) {
        files.stage(sd_out, &sds.sd.to_exr()?)?;
        let e = workbench::render::image::scalar_png(
            &sds.norms(),
            args.width(),
            args.height(),
            error_scale,
            error_max,
            error_colours,
            workbench::render::image::SD_TITLE,
        )?;
        files.stage(sd_png, &e.png)?;
        sd_image = Some(e);
        match &reference {
            Some(r) => files.stage(coverage_png, &coverage_map_png(&image, r, sds, 0.95)?)?,
            None => files.remove_stale(coverage_png),
        }
    }
    image_files::commit_and_report_removed(files)?;
    status!(
        "render: {what}, {}×{}: {} {seconds:.3} s (after {model_seconds:.3} s of set-up: \
         environment, kernel-mean table) → {}, {}",
        args.width(),
        args.height(),
        if kind.is_some() {
            "sample sets + render"
        } else {
            "quadrature"
        },
        out.display(),
        png.display()
    );
    if let Some(r) = &reference {
        stdout(&format!("rmse = {:.6e}\n", image.rmse(r)))?;
    }
    if let Some(e) = &error_image {
        status!(
            "render: error image → {} ({})",
            error_png.display(),
            error_summary(e, error_scale, args.width() * args.height())
        );
    }
    if let (Some(sds), Some(e), Some(sd_out), Some((sd_png, coverage_png))) =
        (&sds, &sd_image, &args.sd_out, &sd_pngs)
    {
        status!(
            "render: posterior sd ({} amplitude, {} interval) → {}, {} ({})",
            scale.name(),
            match sds.dof {
                Some(d) => format!("Student-t {d} dof"),
                None => "normal".to_string(),
            },
            sd_out.display(),
            sd_png.display(),
            error_summary(e, error_scale, args.width() * args.height()).replace("error", "sd norm")
        );
        if sds.zero_amplitude > 0 {
            status!(
                "warning: {} pixel-channel(s): {}",
                sds.zero_amplitude,
                workbench::bq::weights::NumericalWarning::ZeroAmplitude.message()
            );
        }
        if let Some(r) = &reference {
            let c = coverage(&image, r, sds, None);
            stdout(&format!(
                "coverage50 = {:.4}, coverage80 = {:.4}, coverage95 = {:.4} ({} pixel-channels), \
                 median |error|/sd = {:.3}\n",
                c.coverage50, c.coverage80, c.coverage95, c.pixel_channels, c.median_error_over_sd
            ))?;
            status!("render: coverage map → {}", coverage_png.display());
        }
    }
    Ok(())
}

/// `--sd-out` and `--scale`: the sd image needs an estimator with a posterior (an integrator
/// with weights) and an `.exr` name; `--scale` applies only to it. Returns the amplitude scale.
fn check_sd_options(args: &RenderArgs, kind: Option<IntegratorKind>) -> anyhow::Result<Scale> {
    let scale = args
        .scale
        .as_deref()
        .map(|s| Scale::from_name(s).expect("clap checks the names"))
        .unwrap_or(Scale::DEFAULT);
    let Some(sd) = &args.sd_out else {
        if let Some(s) = &args.scale {
            return Err(InputError::new(format!(
                "--scale {s}: applies to the posterior sd image; give --sd-out"
            ))
            .into());
        }
        return Ok(scale);
    };
    match kind {
        Some(k) if k.has_posterior() => {}
        _ => {
            let with_posterior = IntegratorKind::names_where(|k| k.has_posterior());
            let (last, rest) = with_posterior
                .split_last()
                .expect("some integrator has a posterior");
            return Err(InputError::new(format!(
                "--sd-out {}: needs an integrator with a posterior ({} or {last}), not {}",
                sd.display(),
                rest.join(", "),
                args.integrator
            ))
            .into());
        }
    }
    if sd.extension().and_then(|e| e.to_str()) != Some("exr") {
        return Err(InputError::new(format!(
            "--sd-out {}: the sd image is OpenEXR; use a name ending in .exr",
            sd.display()
        ))
        .into());
    }
    Ok(scale)
}

/// The sampling options, checked against the integrator: `exact` takes none of them (only
/// `--tolerance`), MC takes no set or model options. Returns the estimator (`None` for
/// `exact`), spp, seed and number of sets.
fn check_sampling_options(args: &RenderArgs) -> anyhow::Result<(Option<IntegratorKind>, usize, u64, usize)> {
    let kind = match args.integrator {
        RenderIntegrator::Estimator(kind) => {
            if let Some(t) = args.tolerance {
                return Err(InputError::new(format!(
                    "--tolerance {}: applies to --integrator exact, not {kind}",
                    shown(t)
                ))
                .into());
            }
            Some(kind)
        }
        RenderIntegrator::Exact => {
            // Sampling options are errors with the quadrature, not silently ignored.
            let given = args
                .spp
                .map(|_| "--spp")
                .or(args.seed.map(|_| "--seed"))
                .or(args.gps.map(|_| "--gps"))
                .or(args.no_rotate.then_some("--no-rotate"))
                .or(args.model.given());
            if let Some(flag) = given {
                return Err(InputError::new(format!(
                    "{flag}: does not apply to --integrator exact (the certified quadrature draws no samples)"
                ))
                .into());
            }
            let t = args.tolerance.unwrap_or(exact::DEFAULT_TOLERANCE);
            if !(exact::MIN_TOLERANCE..=1e-2).contains(&t) {
                return Err(InputError::new(format!(
                    "--tolerance: must be in [{:e}, 1e-2] (absolute, per pixel and channel), got {}",
                    exact::MIN_TOLERANCE,
                    shown(t)
                ))
                .into());
            }
            None
        }
    };
    let spp = args.spp.unwrap_or(DEFAULT_SPP);
    let seed = args.seed.unwrap_or(0);
    if let Some(kind) = kind {
        check_spp(kind, spp, "--spp")?;
    }
    if kind.is_some_and(|k| !k.uses_sets()) {
        // Options of the BMC integrators are errors with MC, not silently ignored.
        if let Some(flag) = image_files::weight_option_given(args.gps, args.no_rotate, &args.model) {
            return Err(InputError::new(format!(
                "{flag}: applies to the integrators with weights ({}), not {}",
                IntegratorKind::names_where(|k| k.uses_sets()).join(", "),
                args.integrator
            ))
            .into());
        }
    }
    let gps = args.gps.unwrap_or(DEFAULT_GPS);
    check_gps(gps, "--gps")?;
    Ok((kind, spp, seed, gps))
}

/// Renders with the estimator `kind` (its sample sets built first) or, for `None`, by the
/// certified quadrature; returns the image, its per-pixel sds when `--sd-out` asks for them
/// (amplitude `scale`), and what made it, for the status line.
#[allow(clippy::too_many_arguments)]
fn render_image(
    args: &RenderArgs,
    renderer: &Renderer,
    kind: Option<IntegratorKind>,
    spp: usize,
    gps: usize,
    seed: u64,
    model: Option<&workbench::bq::model::BmcModel>,
    scale: Scale,
) -> anyhow::Result<(Image, Option<PixelSds>, String)> {
    let pool = workbench::util::threads::pool(None)?;
    let bar = Bar::new(args.quiet);
    let (image, sds, what) = match kind {
        Some(kind) => {
            let mut integrator = Integrator::build(kind, spp, gps, !args.no_rotate, model, seed)?;
            for line in workbench::table::runner::numerical_warnings(&integrator) {
                status!("warning: {line}");
            }
            if args.sd_out.is_some() {
                integrator = integrator.with_uncertainty(scale, model)?;
            }
            bar.start("rows", (renderer.passes(&integrator) * args.height()) as u64);
            let (image, sds) = if args.sd_out.is_some() {
                let (image, sds) = pool.install(|| renderer.render_with_sd(&integrator, seed, &bar));
                (image, Some(sds))
            } else {
                (pool.install(|| renderer.render(&integrator, seed, &bar)), None)
            };
            bar.finish();
            (image, sds, format!("{kind} {spp} spp"))
        }
        None => {
            let tol = args.tolerance.unwrap_or(exact::default_tolerance(&renderer.env));
            bar.start("rows", args.height() as u64);
            let (image, stats) = pool.install(|| renderer.render_exact(tol, &bar));
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
