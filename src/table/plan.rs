//! Validation: a [`TableSpec`] becomes a [`TablePlan`] with every default filled in, or a
//! one-line error naming the file, the JSON path, the value and what is accepted — the same
//! form as experiment files.

use super::adaptive::plan::AdaptivePlan;
use super::spec::{ReferenceMethod, Repetitions, TableSpec, VariantSpec};
use crate::bq::model::BmcModel;
use crate::bq::weights::Scale;
use crate::error::InputError;
use crate::render::SceneKind;
use crate::render::env::{Environment, Lookup};
use crate::render::integrator::{DEFAULT_GPS, IntegratorKind, MAX_MC_SPP, check_gps, check_spp};
use crate::render::renderer::check_size;
use std::path::{Path, PathBuf};

/// One row of the table.
#[derive(Clone, Debug, PartialEq)]
pub struct VariantPlan {
    pub label: String,
    pub kind: IntegratorKind,
    /// Sample sets (integrators with weights only; 0 otherwise).
    pub gps: usize,
    /// Random azimuth rotation (integrators with weights only; false otherwise).
    pub rotate: bool,
    /// Amplitude of the posterior sd (integrators with weights only; MC's sd is its standard
    /// error whatever this says, and it is [`Scale::DEFAULT`] there).
    pub scale: Scale,
    /// The row's own model replacing the table's (integrators with weights only), with its
    /// resolved parameters for the manifest.
    pub model: Option<VariantModel>,
}

/// A variant's own model, built, with its resolved parameters (what it is compared by).
#[derive(Clone, Debug)]
pub struct VariantModel {
    pub model: std::sync::Arc<BmcModel>,
    pub json: serde_json::Value,
}

impl PartialEq for VariantModel {
    fn eq(&self, other: &Self) -> bool {
        self.json == other.json
    }
}

impl TablePlan {
    /// Whether the table has a renderer's baseline (`mc-light`, `mis`, …), whose shadow rays per
    /// pixel are not its spp: then `rmse.csv` states them ([`super::export::RAYS_COLUMN`]) and
    /// `table.md` has their grid and the ratios to the strongest baseline.
    pub fn counts_rays(&self) -> bool {
        self.variants.iter().any(|v| v.kind.light.is_some())
    }

    /// The model variant `v` renders with: its own, else the table's.
    pub fn model_of<'a>(&'a self, v: &'a VariantPlan) -> Option<&'a BmcModel> {
        v.model.as_ref().map(|m| m.model.as_ref()).or(self.model.as_ref())
    }
}

/// How the reference image is made.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ReferencePlan {
    /// Every pixel by the certified quadrature (`render::exact`) to an absolute tolerance.
    Exact { tolerance: f64 },
    /// Uniform MC at `spp` samples per pixel from `seed` (its noise is in every RMSE).
    Mc { spp: usize, seed: u64 },
}

impl ReferencePlan {
    /// `the exact reference (certified quadrature, tolerance 1e-9)` or `an MC reference with
    /// 3000 spp`, for tables, captions and `validate`.
    pub fn describe(&self) -> String {
        match self {
            ReferencePlan::Exact { tolerance } => {
                format!("the exact reference (certified quadrature, tolerance {tolerance:e})")
            }
            ReferencePlan::Mc { spp, .. } => format!("an MC reference with {spp} spp"),
        }
    }

    /// What determines the image under `env`, for the manifest and the cache key.
    pub fn json(&self, env: &Environment) -> serde_json::Value {
        match self {
            ReferencePlan::Exact { tolerance } => serde_json::json!({
                "integrator": "exact", "tolerance": tolerance,
                "quadrature": crate::render::exact::version(env),
            }),
            ReferencePlan::Mc { spp, seed } => {
                serde_json::json!({"integrator": "mc", "spp": spp, "seed": seed})
            }
        }
    }
}

/// A validated table: everything the run needs, defaults filled in.
#[derive(Clone, Debug)]
pub struct TablePlan {
    pub file: PathBuf,
    pub name: String,
    /// The RMSE plot's title (`title`, default the name).
    pub title: String,
    pub seed: u64,
    pub width: usize,
    pub height: usize,
    /// The scene (`scene`, default the workbench's).
    pub scene: SceneKind,
    pub env: Environment,
    pub env_arg: String,
    /// The map's clamp (`clamp`), already applied to `env`.
    pub clamp: Option<f64>,
    pub spp: Vec<usize>,
    /// Repetitions per entry of `spp` (per target of an adaptive table).
    pub repetitions: Vec<usize>,
    /// Adaptive sampling: the columns are its targets and `spp` is empty.
    pub adaptive: Option<AdaptivePlan>,
    pub reference: ReferencePlan,
    /// The BMC model, built only when a variant needs it.
    pub model: Option<BmcModel>,
    /// The model's resolved parameters, for the manifest.
    pub model_json: serde_json::Value,
    pub variants: Vec<VariantPlan>,
    /// Images made elsewhere (`"external"`), read and checked.
    pub external: Option<super::external::ExternalPlan>,
}

/// Default spp list (thesis Table 4.1, Fig. 4.1b).
pub const DEFAULT_SPP: [usize; 4] = [20, 40, 60, 80];
/// Default repetitions per spp.
pub const DEFAULT_REPETITIONS: usize = 10;
/// Most repetitions per spp (a table of more would run for days).
pub const MAX_REPETITIONS: usize = 10_000;
/// Default spp of an MC reference (thesis §3.2.7).
pub const DEFAULT_REFERENCE_SPP: usize = 3000;
/// Longest variant label: it names PNG files, which file systems limit to 255 bytes.
pub const MAX_LABEL: usize = 100;
/// The reference's default seed is `mix(seed, [REFERENCE_SEED])`.
const REFERENCE_SEED: u64 = 0x2ef;

/// Reads and validates `path`.
pub fn load(path: &Path) -> Result<TablePlan, InputError> {
    let text = crate::files::spec_json::read_spec(path)?;
    parse(&text, path)
}

/// Validates the text of a spec read from `path`.
pub fn parse(text: &str, path: &Path) -> Result<TablePlan, InputError> {
    let file = path.display().to_string();
    let in_file = |m: String| InputError::new(format!("{file}: {m}"));
    if crate::files::spec_json::spec_kind(text) == Some(crate::files::spec_json::SpecKind::Experiment) {
        return Err(in_file(
            "this is an experiment file (it has no \"variants\"); run it with `workbench run FILE`".into(),
        ));
    }
    let spec: TableSpec = crate::files::spec_json::parse(text, "the render table").map_err(in_file)?;
    resolve(&spec, path).map_err(in_file)
}

/// `path: message`, sub-fields continuing the path ([`crate::files::spec_json::at`]).
fn err(path: impl std::fmt::Display, message: impl std::fmt::Display) -> String {
    crate::files::spec_json::at(&path.to_string(), &message.to_string())
}

/// Checks every value and fills in defaults.
pub fn resolve(spec: &TableSpec, path: &Path) -> Result<TablePlan, String> {
    check_name(&spec.name)?;
    let seed = spec.seed.unwrap_or(0);
    let scene = match &spec.scene {
        Some(name) => SceneKind::from_name(name, "scene").map_err(|e| e.0)?,
        None => SceneKind::default(),
    };
    let (default_width, default_height) = scene.default_size();
    let width = spec.width.unwrap_or(default_width as u64) as usize;
    let height = spec.height.unwrap_or(default_height as u64) as usize;
    check_size(width, height, "width/height").map_err(|e| e.0)?;
    let env_arg = spec.env.clone().unwrap_or_else(|| "sky".into());
    // Not `err`: the message starts with the map's name, which is no sub-field of `env`.
    let env = Environment::from_arg(&env_arg).map_err(|e| format!("env: {}", e.0))?;
    let env = match &spec.lookup {
        Some(name) => env
            .with_lookup(Lookup::from_name(name, "lookup").map_err(|e| e.0)?, "lookup")
            .map_err(|e| e.0)?,
        None => env,
    };
    let env = match (spec.clamp, env) {
        (None, env) => env,
        (Some(c), Environment::Map(m)) if c.is_finite() && c > 0.0 && c <= f32::MAX as f64 => {
            Environment::Map(m.clamped(c as f32))
        }
        (Some(c), Environment::Map(_)) => {
            return Err(err(
                "clamp",
                format!(
                    "{} is not a radiance in (0, {:e}] (a texel's largest value)",
                    crate::util::shown::shown(c),
                    f32::MAX
                ),
            ));
        }
        (Some(_), other) => {
            return Err(err(
                "clamp",
                format!("applies to environment map files, not to `{}`", other.key()),
            ));
        }
    };
    let adaptive = spec
        .adaptive
        .as_ref()
        .map(|a| super::adaptive::plan::resolve(a, spec.spp.as_deref()))
        .transpose()?;
    let (spp, repetitions) = match &adaptive {
        Some(a) => (
            Vec::new(),
            resolve_repetitions(spec.repetitions.as_ref(), a.targets.len(), "adaptive.target_sd")?,
        ),
        None => {
            let spp = resolve_spp(spec.spp.as_deref())?;
            let repetitions = resolve_repetitions(spec.repetitions.as_ref(), spp.len(), "spp")?;
            (spp, repetitions)
        }
    };
    let reference = resolve_reference(spec, seed, &env)?;

    if spec.variants.is_empty() {
        return Err(err("variants", "must list at least one variant"));
    }
    let mut variants: Vec<VariantPlan> = Vec::new();
    for (k, v) in spec.variants.iter().enumerate() {
        let at = format!("variants[{k}]");
        let variant = resolve_variant(v, &at, &variants)?;
        crate::render::integrator::check_light(variant.kind, &env, "integrator")
            .map_err(|e| err(format!("{at}.integrator"), e.0.trim_start_matches("integrator: ")))?;
        if let Some(a) = &adaptive {
            super::adaptive::plan::check_variant(a, variant.kind, v.scale, &at)?;
        }
        for &n in &spp {
            check_spp(variant.kind, n, "spp").map_err(|e| {
                err(
                    format!("spp with variants[{k}] ({})", variant.kind),
                    e.0.trim_start_matches("spp: "),
                )
            })?;
        }
        variants.push(variant);
    }

    let model_spec = spec.model.clone().unwrap_or_default();
    let model = model_spec
        .resolve()
        .map_err(|m| err(format!("model.{}", m.field.json()), m.message))?;
    // The stage walker keeps one nested factor per pixel; a fitted model would need one per
    // grid model and a choice per stage, which adaptive tables do not do yet.
    if adaptive.is_some() {
        for (k, v) in variants.iter().enumerate() {
            let own = v.model.as_ref().map(|m| m.model.is_fitted());
            if v.kind.uses_sets() && own.unwrap_or(model.is_fitted()) {
                let at = if own.is_some() {
                    format!("variants[{k}].model.kernel")
                } else {
                    "model.kernel".into()
                };
                return Err(err(
                    at,
                    "a fitted kernel cannot be used with \"adaptive\" yet; give a fixed kernel".to_string(),
                ));
            }
        }
    }
    let external = spec
        .external
        .as_ref()
        .map(|e| super::external::resolve(e, width, height, &super::external::image_file))
        .transpose()?;
    if external.is_some() && adaptive.is_some() {
        return Err(err(
            "external",
            "applies to fixed-spp tables, not to \"adaptive\" ones",
        ));
    }
    let needed = variants.iter().any(|v| v.kind.uses_sets());
    let plan = TablePlan {
        file: path.to_path_buf(),
        name: spec.name.clone(),
        title: spec.title.clone().unwrap_or_else(|| spec.name.clone()),
        seed,
        width,
        height,
        scene,
        env,
        env_arg,
        clamp: spec.clamp,
        spp,
        repetitions,
        adaptive,
        reference,
        model: needed.then(|| model.build()),
        model_json: model.to_json(),
        variants,
        external,
    };
    check_memory(&plan)?;
    Ok(plan)
}

/// The memory guard ([`crate::render::integrator::check_memory`]) for every variant at its
/// largest spp (an adaptive table's `max_spp`): renders run one at a time, so the largest one
/// is what the table needs.
fn check_memory(plan: &TablePlan) -> Result<(), String> {
    let (spp, field) = match &plan.adaptive {
        Some(a) => (a.max_spp, "adaptive.max_spp"),
        None => (plan.spp.iter().copied().max().unwrap_or(0), "spp"),
    };
    for (k, v) in plan.variants.iter().enumerate() {
        crate::render::integrator::check_memory(
            &format!("{field} {spp} with variants[{k}]"),
            v.kind,
            spp,
            v.gps,
            plan.model_of(v),
            true,
            plan.width * plan.height,
        )
        .map_err(|e| e.0)?;
    }
    Ok(())
}

/// The table name becomes a folder: keep it to a safe alphabet.
fn check_name(name: &str) -> Result<(), String> {
    let ok = !name.is_empty()
        && name.len() <= 100
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
    if ok {
        Ok(())
    } else {
        Err(err(
            "name",
            format!("{name:?} is not a usable folder name (1 to 100 of A–Z, a–z, 0–9, - and _)"),
        ))
    }
}

fn resolve_spp(spp: Option<&[u64]>) -> Result<Vec<usize>, String> {
    let Some(items) = spp else {
        return Ok(DEFAULT_SPP.to_vec());
    };
    if items.is_empty() {
        return Err(err("spp", "must list at least one sample count"));
    }
    let mut out = Vec::new();
    for (k, &n) in items.iter().enumerate() {
        if n == 0 {
            return Err(err(format!("spp[{k}]"), "must be at least 1, got 0"));
        }
        if n > MAX_MC_SPP as u64 {
            return Err(err(
                format!("spp[{k}]"),
                format!("at most {MAX_MC_SPP} samples per pixel, got {n}"),
            ));
        }
        if out.contains(&(n as usize)) {
            return Err(err(format!("spp[{k}]"), format!("{n} is listed twice")));
        }
        out.push(n as usize);
    }
    Ok(out)
}

/// Repetitions per column: `columns` entries of the list named `per` (`spp`, or the adaptive
/// targets).
fn resolve_repetitions(reps: Option<&Repetitions>, columns: usize, per: &str) -> Result<Vec<usize>, String> {
    let n_spp = columns;
    let check = |path: String, r: u64| {
        if r == 0 {
            Err(err(path, "must be at least 1, got 0"))
        } else if r > MAX_REPETITIONS as u64 {
            Err(err(
                path,
                format!(
                    "at most {MAX_REPETITIONS} renders per {}, got {r}",
                    if per == "spp" { "spp" } else { "target" }
                ),
            ))
        } else {
            Ok(r as usize)
        }
    };
    match reps {
        None => Ok(vec![DEFAULT_REPETITIONS; n_spp]),
        Some(&Repetitions::All(r)) => Ok(vec![check("repetitions".into(), r)?; n_spp]),
        Some(Repetitions::PerSpp(list)) => {
            if list.len() != n_spp {
                return Err(err(
                    "repetitions",
                    format!(
                        "has {} entries; it needs one count per entry of {per} ({n_spp}), or one number",
                        list.len()
                    ),
                ));
            }
            list.iter()
                .enumerate()
                .map(|(k, &r)| check(format!("repetitions[{k}]"), r))
                .collect()
        }
    }
}

fn resolve_reference(spec: &TableSpec, seed: u64, env: &Environment) -> Result<ReferencePlan, String> {
    let r = spec.reference.unwrap_or(super::spec::ReferenceSpec {
        method: None,
        spp: None,
        seed: None,
        tolerance: None,
    });
    let method = r.method.unwrap_or(if r.spp.is_some() || r.seed.is_some() {
        ReferenceMethod::Mc
    } else {
        ReferenceMethod::Exact
    });
    if method == ReferenceMethod::Exact {
        if let Some((field, value)) = r
            .spp
            .map(|v| ("spp", v.to_string()))
            .or(r.seed.map(|v| ("seed", v.to_string())))
        {
            return Err(err(
                format!("reference.{field}"),
                format!("{value}: applies to \"method\": \"mc\", not \"exact\""),
            ));
        }
        let tolerance = r
            .tolerance
            .unwrap_or(crate::render::exact::default_tolerance(env));
        if !(crate::render::exact::MIN_TOLERANCE..=1e-2).contains(&tolerance) {
            return Err(err(
                "reference.tolerance",
                format!(
                    "must be in [{:e}, 1e-2] (absolute error per pixel and channel), got {}",
                    crate::render::exact::MIN_TOLERANCE,
                    crate::util::shown::shown(tolerance)
                ),
            ));
        }
        return Ok(ReferencePlan::Exact { tolerance });
    }
    if let Some(t) = r.tolerance {
        return Err(err(
            "reference.tolerance",
            format!(
                "{}: applies to \"method\": \"exact\", not \"mc\"",
                crate::util::shown::shown(t)
            ),
        ));
    }
    let spp = r.spp.unwrap_or(DEFAULT_REFERENCE_SPP as u64);
    if spp == 0 || spp > MAX_MC_SPP as u64 {
        return Err(err(
            "reference.spp",
            format!("must be in 1..={MAX_MC_SPP}, got {spp}"),
        ));
    }
    Ok(ReferencePlan::Mc {
        spp: spp as usize,
        seed: r
            .seed
            .unwrap_or_else(|| crate::util::rng::mix(seed, &[REFERENCE_SEED])),
    })
}

fn resolve_variant(v: &VariantSpec, at: &str, earlier: &[VariantPlan]) -> Result<VariantPlan, String> {
    let kind = v.integrator;
    let label = v.label.clone().unwrap_or_else(|| kind.name());
    let label_path = format!("{at}.label");
    if label.is_empty() || label.chars().count() > MAX_LABEL || label.contains(|c: char| c.is_control()) {
        return Err(err(
            label_path,
            format!("{label:?}: labels are 1 to {MAX_LABEL} printable characters"),
        ));
    }
    if let Some(j) = earlier.iter().position(|e| e.label == label) {
        return Err(err(
            label_path,
            format!("{label:?} is already the label of variants[{j}]"),
        ));
    }
    // Labels name the PNG files: two that give the same file name would overwrite each other.
    let slug = png_name(&label, 0);
    if slug == "-0spp.png" {
        return Err(err(
            label_path,
            format!("{label:?} needs an ASCII letter or digit (it names the PNG files)"),
        ));
    }
    if let Some(j) = earlier.iter().position(|e| png_name(&e.label, 0) == slug) {
        return Err(err(
            label_path,
            format!(
                "{label:?} gives the same file names as variants[{j}] ({:?}); file names keep ASCII letters and digits, lower-cased",
                earlier[j].label
            ),
        ));
    }
    if !kind.uses_sets() {
        if let Some(g) = v.gps.filter(|_| !kind.takes_gps()) {
            return Err(err(
                format!("{at}.gps"),
                format!("{g} is not used by integrator {kind}"),
            ));
        }
        if let Some(r) = v.rotate {
            return Err(err(
                format!("{at}.rotate"),
                format!("{r} is not used by integrator {kind}"),
            ));
        }
        if let Some(s) = v.scale {
            let why = if kind.uses_point_sets() {
                "its sd is its rule's: the amplitude fitted by ml for bmc and bsq, the standard error for equal and cv"
            } else {
                "its sd is the standard error of its mean"
            };
            return Err(err(
                format!("{at}.scale"),
                format!("{:?} is not used by integrator {kind} ({why})", s.name()),
            ));
        }
        if let Some((field, value)) = v.model.as_ref().and_then(|m| m.given_fields().into_iter().next()) {
            return Err(err(
                format!("{at}.model.{}", field.json()),
                format!("{value} is not used by integrator {kind}"),
            ));
        }
        // bq-pss's point sets (its only setting besides the name).
        let gps = match v.gps {
            Some(g) if kind.takes_gps() => {
                let g = usize::try_from(g).unwrap_or(usize::MAX);
                check_gps(g, "gps").map_err(|e| err(format!("{at}.gps"), e.0.trim_start_matches("gps: ")))?;
                g
            }
            _ if kind.takes_gps() => DEFAULT_GPS,
            _ => 0,
        };
        return Ok(VariantPlan {
            label,
            kind,
            gps,
            rotate: false,
            scale: Scale::DEFAULT,
            model: None,
        });
    }
    let gps = v.gps.unwrap_or(DEFAULT_GPS as u64);
    let gps = usize::try_from(gps).unwrap_or(usize::MAX);
    check_gps(gps, "gps").map_err(|e| err(format!("{at}.gps"), e.0.trim_start_matches("gps: ")))?;
    let model = match &v.model {
        Some(spec) => {
            let resolved = spec
                .resolve()
                .map_err(|m| err(format!("{at}.model.{}", m.field.json()), m.message))?;
            Some(VariantModel {
                model: std::sync::Arc::new(resolved.build()),
                json: resolved.to_json(),
            })
        }
        None => None,
    };
    Ok(VariantPlan {
        label,
        kind,
        gps,
        rotate: v.rotate.unwrap_or(true),
        scale: v.scale.unwrap_or(Scale::DEFAULT),
        model,
    })
}

/// `BMC 4 GP` at 40 spp → `bmc-4-gp-40spp-error.png`: the error image beside [`png_name`]'s.
pub fn error_png_name(label: &str, spp: usize) -> String {
    png_name(label, spp).replace("spp.png", "spp-error.png")
}

/// The sd image of a cell's first render: `…-40spp-sd.png`.
pub fn sd_png_name(label: &str, spp: usize) -> String {
    png_name(label, spp).replace("spp.png", "spp-sd.png")
}

/// The coverage map of a cell's first render: `…-40spp-coverage.png`.
pub fn coverage_png_name(label: &str, spp: usize) -> String {
    png_name(label, spp).replace("spp.png", "spp-coverage.png")
}

/// `BMC 4 GP (no rotation)` at 40 spp → `bmc-4-gp-no-rotation-40spp.png`.
pub fn png_name(label: &str, spp: usize) -> String {
    format!("{}-{spp}spp.png", slug(label))
}

/// A label as a file-name part: lower-case ASCII letters and digits, runs of anything else
/// one `-`, none at the ends.
pub fn slug(label: &str) -> String {
    let mut slug = String::new();
    for c in label.chars() {
        if c.is_ascii_alphanumeric() {
            slug.push(c.to_ascii_lowercase());
        } else if !slug.ends_with('-') && !slug.is_empty() {
            slug.push('-');
        }
    }
    slug.trim_end_matches('-').to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(text: &str) -> String {
        parse(text, Path::new("t.json")).unwrap_err().0
    }

    #[test]
    fn reference_methods_resolve_and_key_the_cache_apart() {
        let with = |reference: &str| {
            parse(
                &format!(
                    r#"{{"name": "t", "reference": {reference}, "variants": [{{"integrator": "mc"}}]}}"#
                ),
                Path::new("t.json"),
            )
            .unwrap()
        };
        let exact = with(r#"{"method": "exact"}"#);
        assert_eq!(exact.reference, ReferencePlan::Exact { tolerance: 1e-9 });
        let loose = with(r#"{"tolerance": 1e-6}"#);
        assert_eq!(loose.reference, ReferencePlan::Exact { tolerance: 1e-6 });
        // Files from before the exact reference: spp alone means MC.
        let old = with(r#"{"spp": 3000}"#);
        assert!(matches!(old.reference, ReferencePlan::Mc { spp: 3000, .. }));
        assert_eq!(with(r#"{"method": "mc", "spp": 3000}"#).reference, old.reference);
        let keys: Vec<String> = [&exact, &loose, &old]
            .iter()
            .map(|p| super::super::reference::reference_key(p).0)
            .collect();
        assert!(
            keys[0] != keys[1] && keys[0] != keys[2] && keys[1] != keys[2],
            "{keys:?}"
        );
        assert!(
            super::super::reference::reference_key(&exact)
                .1
                .contains("\"integrator\": \"exact\"")
        );
    }

    #[test]
    fn defaults_are_filled_in() {
        let p = parse(
            r#"{"name": "t", "variants": [{"integrator": "mc"}, {"integrator": "bmc"}]}"#,
            Path::new("t.json"),
        )
        .unwrap();
        assert_eq!(p.spp, DEFAULT_SPP);
        assert_eq!(p.repetitions, vec![DEFAULT_REPETITIONS; 4]);
        assert_eq!((p.width, p.height), (256, 256));
        assert_eq!(p.reference, ReferencePlan::Exact { tolerance: 1e-9 });
        assert_eq!(
            p.variants[0],
            VariantPlan {
                label: "mc".into(),
                kind: IntegratorKind::MC,
                gps: 0,
                rotate: false,
                scale: Scale::Ml,
                model: None
            }
        );
        assert_eq!(
            p.variants[1],
            VariantPlan {
                label: "bmc".into(),
                kind: IntegratorKind::BMC,
                gps: 4,
                rotate: true,
                scale: Scale::Ml,
                model: None
            }
        );
        assert!(p.model.is_some());
    }

    /// The experiment's form: `file: path: message`, with the value and what is accepted.
    #[test]
    fn errors_name_file_path_and_value() {
        let base = r#""name": "t", "variants": [{"integrator": "mc"}]"#;
        assert!(err(&format!("{{{base}, \"colour\": 1}}")).starts_with(
            "t.json: colour: unknown field `colour`, expected one of `$schema`, `name`, `title`, `seed`"
        ));
        assert_eq!(
            err(r#"{"name": "t", "variants": [{"integrator": "bmx"}]}"#),
            format!(
                "t.json: variants[0].integrator: unknown integrator \"bmx\"; expected one of {}",
                IntegratorKind::names()
            )
        );
        assert_eq!(
            err(&format!("{{{base}, \"spp\": [20, 0]}}")),
            "t.json: spp[1]: must be at least 1, got 0"
        );
        assert!(
            err(&format!("{{{base}, \"repetitions\": [1, 2]}}"))
                .starts_with("t.json: repetitions: has 2 entries; it needs one count")
        );
        assert_eq!(
            err(r#"{"name": "t", "variants": [{"integrator": "mc", "gps": 2}]}"#),
            "t.json: variants[0].gps: 2 is not used by integrator mc"
        );
        assert_eq!(
            err(&format!("{{{base}, \"model\": {{\"noise\": -1}}}}")),
            "t.json: model.noise: noise must be finite and >= 0, got -1"
        );
        assert!(
            err(&format!(
                "{{{base}, \"model\": {{\"kernel\": {{\"type\": \"sobolev\", \"s\": 3}}}}}}"
            ))
            .starts_with("t.json: model.kernel: sobolev kernel: s must be")
        );
        assert!(
            err(&format!("{{{base}, \"model\": {{\"kernel\": \"sobolev\"}}}}"))
                .starts_with("t.json: model.kernel:")
        );
        assert!(err(&format!("{{{base}, \"width\": 100000, \"height\": 100000}}")).contains("width/height"));
        assert!(
            err(&format!("{{{base}, \"env\": \"missing.hdr\"}}"))
                .starts_with("t.json: env: missing.hdr: cannot read")
        );
        assert!(
            err(&format!("{{{base}, \"reference\": {{\"spp\": 0}}}}")).starts_with("t.json: reference.spp:")
        );
        assert_eq!(
            err(&format!(
                "{{{base}, \"reference\": {{\"method\": \"exact\", \"spp\": 100}}}}"
            )),
            "t.json: reference.spp: 100: applies to \"method\": \"mc\", not \"exact\""
        );
        assert_eq!(
            err(&format!(
                "{{{base}, \"reference\": {{\"method\": \"mc\", \"tolerance\": 1e-6}}}}"
            )),
            "t.json: reference.tolerance: 1e-6: applies to \"method\": \"exact\", not \"mc\""
        );
        assert!(
            err(&format!("{{{base}, \"reference\": {{\"tolerance\": 0}}}}"))
                .starts_with("t.json: reference.tolerance: must be in [1e-13, 1e-2]")
        );
        assert!(err(r#"{"variants": []}"#).starts_with("t.json: missing field `name`"));
        assert_eq!(
            err(r#"{"name": "t", "variants": []}"#),
            "t.json: variants: must list at least one variant"
        );
        assert!(err(r#"{"name": "a/b", "variants": []}"#).starts_with("t.json: name: \"a/b\""));
        assert!(err("{").starts_with("t.json: malformed JSON"));
        assert!(
            err(r#"{"name": "t", "variants": [{"integrator": "mc"}, {"integrator": "mc"}]}"#)
                .contains("already the label of variants[0]")
        );
        assert!(err(r#"{"name": "t", "spp": [20000], "variants": [{"integrator": "bmc"}]}"#).contains("GiB"));
        let long = "x".repeat(300);
        assert!(
            err(&format!(
                r#"{{"name": "t", "variants": [{{"integrator": "mc", "label": "{long}"}}]}}"#
            ))
            .contains("labels are 1 to 100 printable characters")
        );
        assert!(
            err(r#"{"name": "t", "estimators": [], "integrands": []}"#)
                .contains("this is an experiment file")
        );
    }

    #[test]
    fn png_names_are_slugs() {
        assert_eq!(
            png_name("BMC 4 GP (no rotation)", 40),
            "bmc-4-gp-no-rotation-40spp.png"
        );
        assert_eq!(png_name("MC", 20), "mc-20spp.png");
    }
}
