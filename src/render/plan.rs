//! The resolved plan of one single image, as experiments (`experiment::plan`) and render
//! tables (`table::plan`) resolve theirs: [`ImagePlan::resolve`] checks every setting
//! of an unchecked [`ImageRequest`] — integrator, samples, size, environment and its lookup,
//! outputs, reference, error and sd images, adaptive stages — reads the inputs and builds the
//! model, all before the first pixel. What is left to the caller is to lock the outputs, render
//! and write.
//!
//! Messages name each setting by the caller's name for it ([`Names`]: the CLI's flags), so the
//! library holds no flag.

use super::adaptive::{AdaptiveSettings, DEFAULT_FIRST_SPP};
use super::env::Lookup;
use super::exact;
use super::image::{ColourMap, DEFAULT_ERROR_MAX, ErrorScale, Image};
use super::integrator::{DEFAULT_GPS, IntegratorKind, check_gps, check_memory, check_spp};
use super::{Environment, Renderer, SceneKind, check_size};
use crate::bq::model::{BmcModel, ResolvedModel};
use crate::bq::weights::Scale;
use crate::error::{InputError, Result};
use crate::util::report::Reporter;
use crate::util::shown::shown;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Samples per pixel of a fixed-spp image when none is given.
pub const DEFAULT_SPP: usize = 40;

/// What computes each pixel: an estimator of the family ([`IntegratorKind`]) or the certified
/// quadrature (`exact`), which is not an estimator (no samples, no seed) and so not a `Method`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ImageIntegrator {
    Estimator(IntegratorKind),
    Exact,
}

impl std::fmt::Display for ImageIntegrator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ImageIntegrator::Estimator(k) => write!(f, "{k}"),
            ImageIntegrator::Exact => f.write_str("exact"),
        }
    }
}

/// A setting of a single image, as messages name it through the caller's [`Names`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    Integrator,
    Spp,
    Tolerance,
    Gps,
    NoRotate,
    /// Width and height together.
    Size,
    Env,
    EnvLookup,
    Seed,
    Out,
    Reference,
    ErrorScale,
    ErrorMax,
    ErrorColours,
    SdOut,
    Scale,
    TargetSd,
    MaxSpp,
    ResultsDir,
    /// The model's kernel (its other fields are named by the caller's model resolver).
    Kernel,
}

/// The caller's name of each [`Field`] in messages (the CLI: `--spp`, `--width/--height`, …).
pub type Names = fn(Field) -> &'static str;

/// An unchecked single-image request: what was given, `None` where nothing was.
pub struct ImageRequest<'a> {
    pub integrator: ImageIntegrator,
    pub spp: Option<usize>,
    pub tolerance: Option<f64>,
    pub gps: Option<usize>,
    pub no_rotate: bool,
    /// Width and height; `None` takes the scene's.
    pub width: Option<usize>,
    pub height: Option<usize>,
    pub scene: SceneKind,
    /// `sky`, `white`, a catalogue map or a map file ([`Environment::from_arg`]).
    pub env: &'a str,
    pub env_lookup: Option<Lookup>,
    pub seed: Option<u64>,
    /// The linear image (`.exr`).
    pub out: &'a Path,
    pub reference: Option<&'a Path>,
    pub error_scale: Option<ErrorScale>,
    pub error_max: Option<f64>,
    pub error_colours: Option<ColourMap>,
    pub sd_out: Option<&'a Path>,
    pub scale: Option<Scale>,
    pub target_sd: Option<f64>,
    pub max_spp: Option<usize>,
    /// A setting of render tables was given (a results folder), named so.
    pub table_only: Option<&'a str>,
    /// The caller's name of the first model setting given, if any.
    pub model_given: Option<&'a str>,
    /// The model, resolved (validated, not yet built) by the caller, or why it could not be.
    pub model: std::result::Result<ResolvedModel, InputError>,
}

/// How the pixels are computed.
#[derive(Clone, Debug, PartialEq)]
pub enum Method {
    /// The certified quadrature to `tolerance` per pixel and channel.
    Exact { tolerance: f64 },
    /// `spp` samples per pixel of the estimator `kind`.
    Fixed { kind: IntegratorKind, spp: usize },
    /// Stages of `kind` doubling until the target sd or the last stage ([`super::adaptive`]).
    Adaptive {
        kind: IntegratorKind,
        settings: AdaptiveSettings,
    },
}

/// The sd image's files (`<sd>.exr`, its PNG, its coverage map).
#[derive(Clone, Debug, PartialEq)]
pub struct SdOutputs {
    pub exr: PathBuf,
    pub png: PathBuf,
    pub coverage: PathBuf,
}

/// Every file a single image writes (or removes, when stale).
#[derive(Clone, Debug, PartialEq)]
pub struct ImageOutputs {
    pub exr: PathBuf,
    pub png: PathBuf,
    /// Written with a reference, removed without (an earlier one would describe another image).
    pub error_png: PathBuf,
    /// Adaptive images: the samples each pixel took.
    pub spp_png: Option<PathBuf>,
    pub sd: Option<SdOutputs>,
}

impl ImageOutputs {
    /// The files of an image written to `out` (OpenEXR): its PNG and error image beside it, an
    /// adaptive image's spp map, and the sd image's three files at `sd_out`.
    pub fn new(out: &Path, adaptive: bool, sd_out: Option<&Path>) -> ImageOutputs {
        ImageOutputs {
            exr: out.to_path_buf(),
            png: sibling_png(out, ""),
            error_png: sibling_png(out, "-error"),
            spp_png: adaptive.then(|| sibling_png(out, "-spp")),
            sd: sd_out.map(|sd| SdOutputs {
                exr: sd.to_path_buf(),
                png: sibling_png(sd, ""),
                coverage: sibling_png(sd, "-coverage"),
            }),
        }
    }

    /// Each file with its name in messages (`--out (its PNG)`), for the file set's lock.
    pub fn labelled(&self, names: Names) -> Vec<(String, &Path)> {
        let out = names(Field::Out);
        let mut v = vec![
            (out.to_string(), self.exr.as_path()),
            (format!("{out} (its PNG)"), self.png.as_path()),
        ];
        if let Some(spp) = &self.spp_png {
            v.push((format!("{out} (its spp map)"), spp.as_path()));
        }
        v.push((format!("{out} (its error image)"), self.error_png.as_path()));
        if let Some(sd) = &self.sd {
            let name = names(Field::SdOut);
            v.push((name.to_string(), sd.exr.as_path()));
            v.push((format!("{name} (its PNG)"), sd.png.as_path()));
            v.push((format!("{name} (its coverage map)"), sd.coverage.as_path()));
        }
        v
    }
}

/// Every checked setting of one single image, its inputs read and its model built.
pub struct ImagePlan {
    pub method: Method,
    /// Number of BMC sample sets; one is picked at random per pixel.
    pub gps: usize,
    /// Rotate each pixel's sample set by a random azimuth.
    pub rotate: bool,
    pub seed: u64,
    pub width: usize,
    pub height: usize,
    /// The scene under its environment, at the image's size.
    pub renderer: Renderer,
    /// The built model, for the integrators with weights.
    pub model: Option<BmcModel>,
    pub reference: Option<Image>,
    pub outputs: ImageOutputs,
    pub error_scale: ErrorScale,
    pub error_max: f64,
    pub error_colours: ColourMap,
    /// The amplitude of the posterior sd image (fixed-spp images with an sd image).
    pub scale: Scale,
    /// When the set-up (environment, kernel-mean table) began, for the status line's time.
    pub setup_start: Instant,
}

/// `x.exr` → `x<suffix>.png`, keeping the stem's bytes as they are (a name need not be UTF-8).
pub fn sibling_png(out: &Path, suffix: &str) -> PathBuf {
    let mut name = out.file_stem().unwrap_or_default().to_os_string();
    name.push(suffix);
    name.push(".png");
    out.with_file_name(name)
}

impl ImagePlan {
    /// Checks every setting of `req` (named in messages by `names`), reads the environment and
    /// the reference and builds the model, in the order that puts the cheap checks first; notes
    /// (a model's accuracy warning) go to `reporter`. Nothing is written.
    pub fn resolve(req: ImageRequest<'_>, names: Names, reporter: &dyn Reporter) -> Result<ImagePlan> {
        if req.target_sd.is_some() || req.max_spp.is_some() {
            Self::resolve_adaptive(req, names, reporter)
        } else {
            Self::resolve_fixed(req, names, reporter)
        }
    }

    fn resolve_fixed(req: ImageRequest<'_>, n: Names, reporter: &dyn Reporter) -> Result<ImagePlan> {
        let (width, height) = size(&req);
        check_exr_out(req.out, n)?;
        check_size(width, height, n(Field::Size))?;
        let (kind, spp, seed, gps) = check_sampling(&req, n)?;
        if let Some(name) = req.table_only {
            return refuse(format!(
                "{name}: applies to tables (render SPEC.json), not single images"
            ));
        }
        let error_image_setting = req
            .error_scale
            .map(|_| Field::ErrorScale)
            .or(req.error_max.map(|_| Field::ErrorMax))
            .or(req.error_colours.map(|_| Field::ErrorColours));
        if let Some(field) = error_image_setting
            && req.reference.is_none()
            && req.sd_out.is_none()
        {
            return refuse(format!(
                "{}: applies to the error image ({}) or the sd image ({}); give one of them",
                n(field),
                n(Field::Reference),
                n(Field::SdOut)
            ));
        }
        let error_scale = req.error_scale.unwrap_or(ErrorScale::Absolute);
        if req.error_max.is_some() && error_scale != ErrorScale::Absolute {
            return refuse(format!(
                "{}: applies to {} absolute",
                n(Field::ErrorMax),
                n(Field::ErrorScale)
            ));
        }
        let error_colours = req.error_colours.unwrap_or(ColourMap::Viridis);
        let error_max = check_error_max(req.error_max, n)?;
        let scale = check_sd(&req, kind, n)?;
        // Never write over an input (the reference, an environment map) or one output over another.
        let outputs = ImageOutputs::new(req.out, false, req.sd_out);
        check_outputs_apart(&outputs, &req, n)?;
        let env = environment(&req, n)?;
        if let Some(k) = kind {
            super::integrator::check_light(k, &env, n(Field::Integrator))?;
        }
        check_out_dir_writable(req.out)?;
        let setup_start = Instant::now();
        let model = match kind {
            Some(k) if k.uses_sets() => Some(build(req.model, reporter)?),
            _ => None,
        };
        if let Some(k) = kind {
            check_memory(
                &format!("{} {spp}", n(Field::Spp)),
                k,
                spp,
                gps,
                model.as_ref(),
                req.sd_out.is_some(),
                width * height,
            )?;
        }
        let reference = read_reference(req.reference, width, height, n)?;
        let renderer = Renderer::for_scene(req.scene, width, height, env);
        let method = match kind {
            Some(kind) => Method::Fixed { kind, spp },
            None => Method::Exact {
                tolerance: req.tolerance.unwrap_or(exact::default_tolerance(&renderer.env)),
            },
        };
        Ok(ImagePlan {
            method,
            gps,
            rotate: !req.no_rotate,
            seed,
            width,
            height,
            renderer,
            model,
            reference,
            outputs,
            error_scale,
            error_max,
            error_colours,
            scale,
            setup_start,
        })
    }

    fn resolve_adaptive(req: ImageRequest<'_>, n: Names, reporter: &dyn Reporter) -> Result<ImagePlan> {
        // The stage walker keeps one nested factor per pixel; a fitted model would need one per
        // grid model and a choice per stage.
        let resolved = match &req.model {
            Ok(m) => m.clone(),
            Err(e) => return refuse(e.0.clone()),
        };
        if resolved.is_fitted() {
            return refuse(format!(
                "{} fitted: cannot be used with {} or {} yet; give a fixed kernel",
                n(Field::Kernel),
                n(Field::TargetSd),
                n(Field::MaxSpp)
            ));
        }
        let (target_sd, max_spp) = match (req.target_sd, req.max_spp) {
            (Some(t), Some(m)) => (t, m),
            (Some(_), None) => {
                return refuse(format!(
                    "{}: needs {} (the most samples a pixel may take), e.g. {} 1024",
                    n(Field::TargetSd),
                    n(Field::MaxSpp),
                    n(Field::MaxSpp)
                ));
            }
            (None, _) => {
                return refuse(format!(
                    "{}: applies to adaptive sampling; give {} too",
                    n(Field::MaxSpp),
                    n(Field::TargetSd)
                ));
            }
        };
        if !(target_sd.is_finite() && target_sd > 0.0) {
            return refuse(format!(
                "{}: must be finite and > 0, got {}",
                n(Field::TargetSd),
                shown(target_sd)
            ));
        }
        let kind = match req.integrator {
            ImageIntegrator::Estimator(k) if k.adaptive() => k,
            other => {
                return refuse(format!(
                    "{}: adaptive sampling needs an estimator with a per-pixel sd it can extend by stages \
                     ({}), not {} {other}",
                    n(Field::TargetSd),
                    IntegratorKind::adaptive_names(),
                    n(Field::Integrator)
                ));
            }
        };
        let first = req.spp.unwrap_or(DEFAULT_FIRST_SPP);
        check_spp(kind, first, n(Field::Spp))?;
        check_spp(kind, max_spp, n(Field::MaxSpp))?;
        if !kind.method.has_interval(first) {
            return refuse(format!(
                "{} {first}: the first stage of adaptive {} needs at least {} samples to state an interval",
                n(Field::Spp),
                kind.method.name().to_uppercase(),
                kind.method.min_interval_points()
            ));
        }
        if max_spp < first {
            return refuse(format!(
                "{} {max_spp}: is below the first stage {} {first}{}",
                n(Field::MaxSpp),
                n(Field::Spp),
                if req.spp.is_none() {
                    format!(" (the default pilot; give a smaller {})", n(Field::Spp))
                } else {
                    String::new()
                }
            ));
        }
        if !kind.uses_sets()
            && let Some(name) = weight_setting_given(&req, n, None)
        {
            return refuse(format!(
                "{name}: applies to {} bmc, not {kind}",
                n(Field::Integrator)
            ));
        }
        // Settings of fixed-spp images that adaptive ones do not take (an absolute error
        // scale is the only one there is).
        let unused = (req.tolerance.map(|_| n(Field::Tolerance)))
            .or(req.table_only)
            .or(req.sd_out.map(|_| n(Field::SdOut)))
            .or(req.scale.map(|_| n(Field::Scale)))
            .or(req
                .error_scale
                .filter(|s| *s != ErrorScale::Absolute)
                .map(|_| n(Field::ErrorScale)));
        if let Some(name) = unused {
            return refuse(format!("{name}: does not apply to an adaptive single image"));
        }
        let gps = req.gps.unwrap_or(DEFAULT_GPS);
        check_gps(gps, n(Field::Gps))?;
        let (width, height) = size(&req);
        check_exr_out(req.out, n)?;
        check_size(width, height, n(Field::Size))?;
        let outputs = ImageOutputs::new(req.out, true, None);
        check_outputs_apart(&outputs, &req, n)?;
        let error_max = check_error_max(req.error_max, n)?;
        let env = environment(&req, n)?;
        super::integrator::check_light(kind, &env, n(Field::Integrator))?;
        check_out_dir_writable(req.out)?;
        let reference = read_reference(req.reference, width, height, n)?;
        let setup_start = Instant::now();
        let renderer = Renderer::for_scene(req.scene, width, height, env);
        let model = if kind.uses_sets() {
            Some(build(Ok(resolved), reporter)?)
        } else {
            None
        };
        check_memory(
            &format!("{} {max_spp}", n(Field::MaxSpp)),
            kind,
            max_spp,
            gps,
            model.as_ref(),
            true,
            width * height,
        )?;
        Ok(ImagePlan {
            method: Method::Adaptive {
                kind,
                settings: AdaptiveSettings::new(target_sd, first, max_spp),
            },
            gps,
            rotate: !req.no_rotate,
            seed: req.seed.unwrap_or(0),
            width,
            height,
            renderer,
            model,
            reference,
            outputs,
            error_scale: ErrorScale::Absolute,
            error_max,
            error_colours: req.error_colours.unwrap_or(ColourMap::Viridis),
            scale: Scale::DEFAULT,
            setup_start,
        })
    }
}

/// Refuses the request: `message` names the setting and what is wrong (an [`InputError`],
/// exit 2 at the CLI), before any work.
fn refuse<T>(message: String) -> Result<T> {
    Err(InputError::new(message).into())
}

/// The image's size: the request's, or the scene's.
fn size(req: &ImageRequest<'_>) -> (usize, usize) {
    let (w, h) = req.scene.default_size();
    (req.width.unwrap_or(w), req.height.unwrap_or(h))
}

/// The model built (its kernel-mean table tabulated), its accuracy warning noted.
fn build(model: std::result::Result<ResolvedModel, InputError>, reporter: &dyn Reporter) -> Result<BmcModel> {
    let model = model?.build();
    if let Some(w) = model.accuracy_warning() {
        reporter.note(&format!("warning: {w}"));
    }
    Ok(model)
}

/// The first setting given that only integrators with weights use (sets, rotation, the
/// model's), if any: an error with MC rather than silently ignored. `kind` takes the number of
/// sets when it is `bq-pss` (its point sets); the adaptive image asks with none.
fn weight_setting_given<'a>(
    req: &ImageRequest<'a>,
    n: Names,
    kind: Option<IntegratorKind>,
) -> Option<&'a str> {
    req.gps
        .filter(|_| !kind.is_some_and(|k| k.takes_gps()))
        .map(|_| n(Field::Gps))
        .or(req.no_rotate.then(|| n(Field::NoRotate)))
        .or(req.model_given)
}

/// The sampling settings, checked against the integrator: `exact` takes none of them (only
/// the tolerance), MC takes no set or model settings. Returns the estimator (`None` for
/// `exact`), spp, seed and number of sets.
fn check_sampling(req: &ImageRequest<'_>, n: Names) -> Result<(Option<IntegratorKind>, usize, u64, usize)> {
    let kind = match req.integrator {
        ImageIntegrator::Estimator(kind) => {
            if let Some(t) = req.tolerance {
                return refuse(format!(
                    "{} {}: applies to {} exact, not {kind}",
                    n(Field::Tolerance),
                    shown(t),
                    n(Field::Integrator)
                ));
            }
            Some(kind)
        }
        ImageIntegrator::Exact => {
            // Sampling settings are errors with the quadrature, not silently ignored.
            let given = req
                .spp
                .map(|_| n(Field::Spp))
                .or(req.seed.map(|_| n(Field::Seed)))
                .or(req.gps.map(|_| n(Field::Gps)))
                .or(req.no_rotate.then(|| n(Field::NoRotate)))
                .or(req.model_given);
            if let Some(name) = given {
                return refuse(format!(
                    "{name}: does not apply to {} exact (the certified quadrature draws no samples)",
                    n(Field::Integrator)
                ));
            }
            let t = req.tolerance.unwrap_or(exact::DEFAULT_TOLERANCE);
            if !(exact::MIN_TOLERANCE..=1e-2).contains(&t) {
                return refuse(format!(
                    "{}: must be in [{:e}, 1e-2] (absolute, per pixel and channel), got {}",
                    n(Field::Tolerance),
                    exact::MIN_TOLERANCE,
                    shown(t)
                ));
            }
            None
        }
    };
    let spp = req.spp.unwrap_or(DEFAULT_SPP);
    let seed = req.seed.unwrap_or(0);
    if let Some(kind) = kind {
        check_spp(kind, spp, n(Field::Spp))?;
    }
    if kind.is_some_and(|k| !k.uses_sets())
        && let Some(name) = weight_setting_given(req, n, kind)
    {
        // Settings of the BMC integrators are errors with MC, not silently ignored.
        return refuse(format!(
            "{name}: applies to the integrators with weights ({}), not {}",
            IntegratorKind::names_where(|k| k.uses_sets()).join(", "),
            req.integrator
        ));
    }
    let gps = req.gps.unwrap_or(DEFAULT_GPS);
    check_gps(gps, n(Field::Gps))?;
    Ok((kind, spp, seed, gps))
}

/// The sd image and its amplitude: the sd image needs an estimator with a posterior (an
/// integrator with weights) and an `.exr` name; the scale applies only to it.
fn check_sd(req: &ImageRequest<'_>, kind: Option<IntegratorKind>, n: Names) -> Result<Scale> {
    let scale = req.scale.unwrap_or(Scale::DEFAULT);
    let Some(sd) = req.sd_out else {
        if let Some(s) = req.scale {
            return refuse(format!(
                "{} {}: applies to the posterior sd image; give {}",
                n(Field::Scale),
                s.name(),
                n(Field::SdOut)
            ));
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
            return refuse(format!(
                "{} {}: needs an integrator with a posterior ({} or {last}), not {}",
                n(Field::SdOut),
                sd.display(),
                rest.join(", "),
                req.integrator
            ));
        }
    }
    if let (Some(k), Some(s)) = (kind, req.scale)
        && k.uses_point_sets()
    {
        return Err(InputError::new(format!(
            "{} {}: not used by {k}, whose amplitude is its rule's (fitted by ml)",
            n(Field::Scale),
            s.name()
        ))
        .into());
    }
    if sd.extension().and_then(|e| e.to_str()) != Some("exr") {
        return refuse(format!(
            "{} {}: the sd image is OpenEXR; use a name ending in .exr",
            n(Field::SdOut),
            sd.display()
        ));
    }
    Ok(scale)
}

/// The linear image is OpenEXR.
fn check_exr_out(out: &Path, n: Names) -> Result<()> {
    if out.extension().and_then(|e| e.to_str()) == Some("exr") {
        return Ok(());
    }
    refuse(format!(
        "{} {}: the linear image is OpenEXR; use a name ending in .exr",
        n(Field::Out),
        out.display()
    ))
}

/// The top of the absolute error scale (or its default): finite and positive.
fn check_error_max(given: Option<f64>, n: Names) -> Result<f64> {
    let error_max = given.unwrap_or(DEFAULT_ERROR_MAX);
    if error_max.is_finite() && error_max > 0.0 {
        Ok(error_max)
    } else {
        refuse(format!(
            "{}: must be finite and > 0, got {}",
            n(Field::ErrorMax),
            shown(error_max)
        ))
    }
}

/// Never write over an input (the reference, an environment map file) or one output over
/// another, and refuse names too long for the file system, before any work.
fn check_outputs_apart(outputs: &ImageOutputs, req: &ImageRequest<'_>, n: Names) -> Result<()> {
    let labelled = outputs.labelled(n);
    let outputs: Vec<(&str, &Path)> = labelled.iter().map(|(l, p)| (l.as_str(), *p)).collect();
    let mut inputs: Vec<(&str, &Path)> = Vec::new();
    if let Some(r) = req.reference {
        inputs.push((n(Field::Reference), r));
    }
    if !matches!(req.env, "sky" | "white") {
        inputs.push((n(Field::Env), Path::new(req.env)));
    }
    crate::files::atomic::check_distinct(&outputs, &inputs)?;
    for (name, path) in &outputs {
        crate::files::atomic::check_name_length(name, path)?;
    }
    Ok(())
}

/// The environment under its lookup.
fn environment(req: &ImageRequest<'_>, n: Names) -> Result<Environment> {
    let env =
        Environment::from_arg(req.env).map_err(|e| InputError::new(format!("{} {}", n(Field::Env), e.0)))?;
    Ok(match req.env_lookup {
        Some(lookup) => env.with_lookup(lookup, n(Field::EnvLookup))?,
        None => env,
    })
}

/// Fail on an unwritable output folder now, not after the render.
fn check_out_dir_writable(out: &Path) -> Result<()> {
    let dir = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    crate::files::atomic::check_writable_dir(&dir)
}

/// The reference image, if given, read and checked to be the render's size.
fn read_reference(reference: Option<&Path>, width: usize, height: usize, n: Names) -> Result<Option<Image>> {
    Ok(reference
        .map(|path| Image::read_reference(path, n(Field::Reference), width, height))
        .transpose()?)
}
