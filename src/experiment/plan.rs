//! Validation: an [`ExperimentSpec`] becomes a [`Plan`] with every default filled in, or a
//! one-line error naming the file, the JSON path and the value.

use super::spec::*;
use crate::bq::estimator::MethodName;
use crate::bq::estimator::bq_pss::PssOptions;
use crate::bq::estimator::mis::{LightEstimator, LightMethod};
use crate::bq::kernel::primary::SobolevOrder;
use crate::bq::model::BmcModel;
use crate::bq::model::ResolvedModel;
use crate::bq::rule::MAX_POINTS;
use crate::bq::weights::Scale;
use crate::error::InputError;
use crate::integrand::{CosPower, Integrand};
use crate::sampling::{Density, Design, Structure};
use serde::Serialize;
use std::sync::Arc;

/// The largest BMCP prior constant `|c|` accepted (see the estimator's prior arm: beyond about
/// 1e146 the fitted amplitude overflows).
pub const MAX_PRIOR: f64 = 1e100;

/// The largest BMCP prior constant `|c|` a model accepts: [`MAX_PRIOR`] in units of the prior
/// sd at a point, `√(k(x,x) + σ_n²)`, where that is below 1 (the smallest over a fitted grid).
///
/// Why: the fitted amplitude's `rᵀQ⁻¹r` with `r = Y − c·1` is about `c²·1ᵀQ⁻¹1`, and
/// `1ᵀQ⁻¹1 ≤ N/λ_min(Q)`. With the kernel's scale `k(x,x)` and `σ_n²` near 1, `λ_min(Q)` is at
/// least `σ_n²` or the jitter (≳ 1e-17 relative), so `|c| ≤ 1e100` leaves `c²·1ᵀQ⁻¹1` below
/// ~1e240. A kernel of tiny scale (SE `σ_f = 1e-100` with no noise: `Q ≈ 1e-200 K̃`) makes
/// `1ᵀQ⁻¹1` larger by `1/k(x,x)`, so the constant is measured in that scale's units: beyond it
/// the amplitude overflowed to ∞ (or to NaN, and a false "every residual is 0" warning).
pub fn prior_bound(model: &crate::bq::model::ResolvedModel) -> f64 {
    let models = match &model.grid {
        Some(grid) => grid.clone(),
        None => vec![(model.kernel, model.noise)],
    };
    models
        .iter()
        .map(|(k, noise)| MAX_PRIOR * (k.diagonal() + noise).sqrt().min(1.0))
        .fold(MAX_PRIOR, f64::min)
}

/// What one worker thread holds at most while it runs a unit of the plan, in bytes, and the
/// estimator (its field and what it needs) that decides it: the one memory estimate of a run
/// ([`crate::util::memory`]; `validate` states it, [`check_memory`] guards it). Per estimator
/// with weights: a fixed-size weight set at the largest N holds [`crate::bq::rule::weight_set_bytes`]
/// (one workspace, reused by a fitted grid's models); a tolerance estimator keeps one nested
/// factor per model of its grid up to `max_n` (`8 max_n²` each) and a copy while one grows.
/// Plus the sample sets and their values ([`BYTES_PER_POINT`] per point and design, up to the
/// largest N or `max_n`).
pub fn thread_memory(plan: &Plan) -> (u64, String) {
    let max_n = plan.samples.iter().copied().max().unwrap_or(0);
    let most_points = plan
        .estimators
        .iter()
        .filter_map(|e| e.tolerance.map(|t| t.max_n))
        .fold(max_n, usize::max);
    let sets = BYTES_PER_POINT
        .saturating_mul(most_points as u64)
        .saturating_mul(plan.designs.len() as u64);
    let mut worst = (sets, format!("samples: N = {max_n}"));
    for (i, e) in plan.estimators.iter().enumerate() {
        let Some(m) = e.model else { continue };
        let model = &plan.models[m];
        let exact = matches!(model.mode, crate::bq::kernel_mean::KernelMeanMode::Exact);
        let (bytes, what) = match e.tolerance {
            Some(t) => {
                let models = model.candidates().len().max(1) as u64;
                let factor = crate::util::memory::matrix_bytes(t.max_n);
                (
                    factor.saturating_mul(models + 1),
                    format!(
                        "estimators[{i}] ({:?}): {models} nested factor{} up to tolerance.max_n = {}",
                        e.label,
                        if models == 1 { "" } else { "s" },
                        t.max_n
                    ),
                )
            }
            None => (
                crate::bq::rule::weight_set_bytes(max_n, e.design, exact),
                format!("estimators[{i}] ({:?}): a weight set of N = {max_n}", e.label),
            ),
        };
        let bytes = bytes.saturating_add(sets);
        if bytes > worst.0 {
            worst = (bytes, what);
        }
    }
    worst
}

/// The memory guard of a run on `threads` worker threads: [`thread_memory`] on each, against the
/// budget ([`crate::util::memory`]); one line naming the estimator, the bytes and the budget.
pub fn check_memory(plan: &Plan, threads: usize) -> Result<(), InputError> {
    let (per_thread, what) = thread_memory(plan);
    crate::bq::rule::check_memory(
        &format!(
            "{what} per worker thread ({}) on {threads} thread{}",
            crate::util::memory::human(per_thread),
            if threads == 1 { "" } else { "s" }
        ),
        per_thread.saturating_mul(threads as u64),
    )
}

/// Largest number of points one unit of work (one N and trial) draws across all designs in use:
/// each design draws its own set of N points, and each set and its integrand values take
/// [`BYTES_PER_POINT`] per worker thread, so this keeps a thread under 0.3 GiB. With one design
/// it is the largest N (for MC; BMC's own limit is far lower).
pub const MAX_UNIT_POINTS: u64 = 10_000_000;
/// Memory per drawn point in a unit of work: the direction (3 × f64) and one integrand value.
pub const BYTES_PER_POINT: u64 = 32;
/// Longest experiment name: it names the output folder, and file systems limit a name to 255
/// bytes.
pub const MAX_NAME: usize = 100;
/// Largest number of rows in `trials.csv`: a run holds about 450 bytes per row in memory
/// (results and the CSV text), so this keeps a run under ~5 GB.
pub const MAX_ROWS: u64 = 10_000_000;

/// A resolved, validated experiment.
#[derive(Debug, Clone)]
pub struct Plan {
    pub name: String,
    pub title: String,
    pub integrands: Vec<Integrand>,
    pub estimators: Vec<PlannedEstimator>,
    pub samples: Vec<usize>,
    pub trials: usize,
    pub seed: u64,
    pub checks: Vec<Check>,
    /// Calibration checks (`"calibrated"` entries of `checks`).
    pub calibration_checks: Vec<CalibrationCheck>,
    /// Tolerance checks (`"within_tolerance"` entries of `checks`; [`super::adaptive`]).
    pub tolerance_checks: Vec<super::tolerance::ToleranceCheck>,
    /// Distinct BMC models; estimators that share one share its weights within a trial.
    pub models: Vec<Arc<BmcModel>>,
    /// Distinct designs in use; estimators with the same design see the same sample set.
    pub designs: Vec<Design>,
    /// Smallest N of the slope fits ([`super::fit`]).
    pub fit_from_n: usize,
    /// Per estimator, whether the error plots may draw its 10–90% band (`plot.bands`,
    /// [`resolve_bands`]).
    pub bands: Vec<bool>,
    /// `plot.bands` not given: each error plot draws a band only where it overlaps no band
    /// drawn before it ([`super::plot::non_overlapping`]).
    pub auto_bands: bool,
}

/// The constant prior mean of an estimator that takes one ([`Method::uses_prior`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Prior {
    /// The oracle prior `c = I / (2π)` of the integrand (math.md §1): it is given the answer.
    Analytic,
    /// A given constant.
    Value(f64),
}

impl Prior {
    /// The constant for an integrand whose analytic prior is `analytic`.
    pub fn resolve(self, analytic: f64) -> f64 {
        match self {
            Prior::Analytic => analytic,
            Prior::Value(c) => c,
        }
    }
}

/// One estimator, resolved.
#[derive(Debug, Clone)]
pub struct PlannedEstimator {
    pub label: String,
    pub method: MethodName,
    /// The design of its points; for a light-aware estimator, the design its primary samples
    /// follow (`uniform` or `sobol`, its `sampler`), never drawn as a hemisphere set.
    pub design: Design,
    /// A light-aware estimator's options (math.md §11); None for the others.
    pub light: Option<LightEstimator>,
    /// Index into [`Plan::models`] (methods that need weights).
    pub model: Option<usize>,
    /// The prior mean (methods that use one).
    pub prior: Option<Prior>,
    /// The kernel amplitude (methods with weights; math.md §7).
    pub scale: Option<Scale>,
    /// Stop at a target uncertainty ([`crate::bq::stages`], intervals of math.md §7); the sample counts are then first stages.
    pub tolerance: Option<crate::bq::stages::Tolerance>,
    /// The resolved settings, for the manifest and `validate`.
    pub settings: ResolvedSettings,
}

/// The settings of an estimator with defaults filled in.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResolvedSettings {
    pub method: MethodName,
    pub design: Design,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sampler: Option<Sampler>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heuristic: Option<Heuristic>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub compensation: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub order: Option<u64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub weights: Option<crate::bq::estimator::bq_pss::PssWeights>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kernel: Option<serde_json::Value>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kernel_mean: Option<KernelMeanName>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kernel_mean_samples: Option<u64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub prior: Option<PriorSpec>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scale: Option<Scale>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<crate::bq::stages::Tolerance>,
}

/// A resolved check.
#[derive(Debug, Clone, Serialize)]
pub struct Check {
    pub better: String,
    pub than: String,
    pub from_n: usize,
    pub alpha: f64,
    #[serde(skip)]
    pub better_index: usize,
    #[serde(skip)]
    pub than_index: usize,
}

/// A resolved calibration check: estimator `label`'s coverage at `level` lies in the binomial
/// 99% band around `level` ([`super::summary::binomial_band`]), or for [`CheckSide::Lower`] at
/// or above its lower edge, for every integrand and N ≥ `from_n`.
#[derive(Debug, Clone, Serialize)]
pub struct CalibrationCheck {
    pub calibrated: String,
    pub level: f64,
    pub from_n: usize,
    pub side: CheckSide,
    #[serde(skip)]
    pub index: usize,
}

/// Parses the JSON text; errors say where (`path: message`).
impl Plan {
    /// Whether an estimator's model is fitted per weight set (math.md §9): `trials.csv` and
    /// `summary.csv` then have a column of the chosen models.
    pub fn has_fitted_model(&self) -> bool {
        self.estimators
            .iter()
            .any(|e| e.model.is_some_and(|m| self.models[m].is_fitted()))
    }
}

pub fn parse(text: &str) -> Result<ExperimentSpec, String> {
    if crate::files::spec_json::spec_kind(text) == Some(crate::files::spec_json::SpecKind::RenderTable) {
        return Err(
            "this is a render table spec (it has \"variants\"); run it with `workbench render FILE`".into(),
        );
    }
    if crate::files::spec_json::spec_kind(text) == Some(crate::files::spec_json::SpecKind::Irradiance) {
        return Err("this is an irradiance protocol file (\"kind\": \"irradiance\"); run it with `workbench run FILE`".into());
    }
    crate::files::spec_json::parse(text, "the experiment")
}

/// `path: message`, sub-fields continuing the path ([`crate::files::spec_json::at`]).
fn err(path: impl std::fmt::Display, message: impl std::fmt::Display) -> String {
    crate::files::spec_json::at(&path.to_string(), &message.to_string())
}

/// Checks every value and fills in defaults. An integrand of `"type": "python"` is refused: it
/// needs [`resolve_with`] and a callable.
pub fn resolve(spec: &ExperimentSpec) -> Result<Plan, String> {
    resolve_with(spec, &mut |_| {
        Err(
            "type: \"python\" names a Python callable; only Python's workbench.run(spec, integrands={name: f}) \
             can run it (docs/python.md)"
                .into(),
        )
    })
}

/// Builds the integrand of a `"type": "python"` spec (its name already checked).
pub type ExternalResolver<'a> = dyn FnMut(&ExternalSpec) -> Result<Integrand, String> + 'a;

/// [`resolve`], with `external` building the integrands given from outside.
pub fn resolve_with(spec: &ExperimentSpec, external: &mut ExternalResolver<'_>) -> Result<Plan, String> {
    check_name(&spec.name)?;
    let integrands = resolve_integrands(spec, external)?;
    check_counts(spec)?;
    let Estimators {
        estimators,
        models,
        designs,
        paths,
    } = resolve_estimators(spec)?;
    check_limits(spec, &integrands, &estimators, &designs)?;
    check_lights(&integrands, &estimators, &paths)?;
    let mut checks = Vec::new();
    let mut calibration_checks = Vec::new();
    let mut tolerance_checks = Vec::new();
    for (i, c) in spec.checks.iter().enumerate() {
        if c.within_tolerance.is_some() {
            if c.side.is_some() && c.calibrated.is_none() {
                return Err(err(
                    format!("checks[{i}].side"),
                    "is used only by a calibration check (\"calibrated\": LABEL)",
                ));
            }
            let labels: Vec<(&str, bool)> = estimators
                .iter()
                .map(|e| (e.label.as_str(), e.tolerance.is_some()))
                .collect();
            tolerance_checks.push(super::tolerance::resolve_check(spec, &labels, i, c)?);
            continue;
        }
        match resolve_check(spec, &estimators, i, c)? {
            ResolvedCheck::Comparison(c) => checks.push(c),
            ResolvedCheck::Calibration(c) => calibration_checks.push(c),
        }
    }
    let bands = resolve_bands(spec, &estimators)?;
    let auto_bands = spec.plot.as_ref().and_then(|p| p.bands.as_ref()).is_none();
    Ok(Plan {
        bands,
        auto_bands,
        fit_from_n: resolve_fit_from(spec)?,
        name: spec.name.clone(),
        title: spec.title.clone().unwrap_or_else(|| spec.name.clone()),
        integrands,
        estimators,
        samples: spec.samples.iter().map(|&n| n as usize).collect(),
        trials: spec.trials as usize,
        seed: spec.seed,
        checks,
        calibration_checks,
        tolerance_checks,
        models,
        designs,
    })
}

/// The integrands, each validated with its truth, under distinct names (and none named like
/// another's calibration plot).
fn resolve_integrands(
    spec: &ExperimentSpec,
    external: &mut ExternalResolver<'_>,
) -> Result<Vec<Integrand>, String> {
    if spec.integrands.is_empty() {
        return Err(err("integrands", "must name at least one integrand"));
    }
    let mut integrands: Vec<Integrand> = Vec::new();
    for (i, f) in spec.integrands.iter().enumerate() {
        let at = format!("integrands[{i}]");
        let f = match f {
            IntegrandSpec::External(e) => check_file_name(&e.name)
                .map_err(|m| format!("name: {m}"))
                .and_then(|()| external(e)),
            _ => resolve_integrand(f),
        }
        .map_err(|m| err(&at, m))?;
        if let Some(j) = integrands.iter().position(|g| g.name() == f.name()) {
            return Err(err(
                &at,
                format!(
                    "the name {:?} is already used by integrands[{j}] (give each integrand its own \"name\")",
                    f.name()
                ),
            ));
        }
        integrands.push(f);
    }
    // `<name>-coverage.svg` is written beside `<name>.svg`: no integrand may take that name.
    for (i, f) in integrands.iter().enumerate() {
        if let Some(j) = integrands
            .iter()
            .position(|g| format!("{}-coverage", g.name()) == f.name())
        {
            return Err(err(
                format!("integrands[{i}]"),
                format!(
                    "the name {:?} is the calibration plot of integrands[{j}] ({:?}); rename one",
                    f.name(),
                    integrands[j].name()
                ),
            ));
        }
    }
    Ok(integrands)
}

/// Sample counts distinct and at least 1, trials at least 1, at least one estimator.
fn check_counts(spec: &ExperimentSpec) -> Result<(), String> {
    crate::files::spec_json::check_counts("samples", &spec.samples)?;
    if spec.trials == 0 {
        return Err(err("trials", "must be at least 1, got 0"));
    }
    if spec.estimators.is_empty() {
        return Err(err("estimators", "must list at least one estimator"));
    }
    Ok(())
}

/// The planned estimators with the distinct models and designs they use, and the JSON path of
/// each (a swept one names its values).
struct Estimators {
    estimators: Vec<PlannedEstimator>,
    models: Vec<Arc<BmcModel>>,
    designs: Vec<Design>,
    paths: Vec<String>,
}

/// A light-aware estimator needs every integrand to expose its light ([`Integrand::lit`]), a
/// light with power to sample, and with `compensation` a light that is not constant.
fn check_lights(
    integrands: &[Integrand],
    estimators: &[PlannedEstimator],
    paths: &[String],
) -> Result<(), String> {
    for (e, path) in estimators.iter().zip(paths) {
        let Some(light) = e.light else { continue };
        for (j, f) in integrands.iter().enumerate() {
            let lit = f.lit().map_err(|m| {
                err(
                    format!("{path}.method"),
                    format!(
                        "{:?} needs an integrand that knows its light, but integrands[{j}]: {m}",
                        e.method.name()
                    ),
                )
            })?;
            let l = lit.light();
            let samples_light = light.method != LightMethod::McBsdf;
            if samples_light && l.is_black() {
                return Err(err(
                    format!("{path}.method"),
                    format!(
                        "{:?} samples the light, but the light of integrands[{j}] ({:?}) is black (no texel has luminance)",
                        e.method.name(),
                        f.name()
                    ),
                ));
            }
            if light.compensation && !l.has_compensation() {
                return Err(err(
                    format!("{path}.compensation"),
                    format!(
                        "true, but the light of integrands[{j}] ({:?}) is constant (mean luminance {}, least {}: \
                         within {}% of the mean), so compensation has nothing to remove",
                        f.name(),
                        crate::util::shown::shown(l.mean()),
                        crate::util::shown::shown(l.min()),
                        crate::sampling::light::COMPENSATION_THRESHOLD * 100.0
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Every estimator (sweeps expanded), validated; estimators with the same model and design share
/// one model index.
fn resolve_estimators(spec: &ExperimentSpec) -> Result<Estimators, String> {
    let mut estimators: Vec<PlannedEstimator> = Vec::new();
    let mut models: Vec<Arc<BmcModel>> = Vec::new();
    // Estimators with the same model and design share their weights; the key's index also
    // seeds the model's kernel-mean stream, so its order is part of the results.
    let mut model_keys: Vec<(ResolvedModel, Design)> = Vec::new();
    let mut designs: Vec<Design> = Vec::new();
    // The JSON path of each planned estimator, for messages (a swept one names its values).
    let mut paths: Vec<String> = Vec::new();
    for super::sweep::Expanded { path, spec: e } in super::sweep::expand(&spec.estimators)? {
        let e = &e;
        let at = |field: &str| format!("{path}.{field}");
        if e.label.is_empty() || e.label.contains(|c: char| c.is_control()) {
            return Err(err(at("label"), format!("{:?} is not a usable label", e.label)));
        }
        if let Some(j) = estimators.iter().position(|p| p.label == e.label) {
            return Err(err(
                at("label"),
                format!("{:?} is already the label of {}", e.label, paths[j]),
            ));
        }
        paths.push(path.clone());
        let (mut planned, model) = resolve_estimator(e, &at)?;
        planned.tolerance = match planned.method.points() {
            Some(method) => super::tolerance::resolve_tolerance(
                e,
                method,
                planned.design,
                &spec.samples,
                MAX_UNIT_POINTS,
                &at,
            )?,
            // Refused by resolve_light_estimator.
            None => None,
        };
        planned.settings.tolerance = planned.tolerance;
        if let Some(model) = model {
            let key = (model.clone(), planned.design);
            let index = match model_keys.iter().position(|k| *k == key) {
                Some(index) => index,
                None => {
                    model_keys.push(key);
                    models.push(Arc::new(model.build()));
                    models.len() - 1
                }
            };
            planned.model = Some(index);
        }
        // A light-aware estimator draws its own directions, not a design's set.
        if planned.light.is_none() && !designs.contains(&planned.design) {
            designs.push(planned.design);
        }
        estimators.push(planned);
    }
    Ok(Estimators {
        estimators,
        models,
        designs,
        paths,
    })
}

/// Memory per worker thread (BMC's matrices, the sample sets of every design), the fewest points
/// each method needs, and the number of rows.
fn check_limits(
    spec: &ExperimentSpec,
    integrands: &[Integrand],
    estimators: &[PlannedEstimator],
    designs: &[Design],
) -> Result<(), String> {
    let max_n = *spec.samples.iter().max().expect("samples is not empty");
    // Some designs take only some counts (the rings need N = J·M, sampling::rings), and `mis`
    // splits N in halves.
    for e in estimators {
        for (i, &n) in spec.samples.iter().enumerate() {
            if let Some(Err(m)) = e.light.map(|l| l.method.check_count(n as usize)) {
                return Err(err(
                    format!("samples[{i}]"),
                    format!("estimator {:?}: {m}", e.label),
                ));
            }
            if let Err(m) = e.design.check_count(n as usize) {
                return Err(err(
                    format!("samples[{i}]"),
                    format!(
                        "N = {n} for estimator {:?} (design {:?}): {m}",
                        e.label,
                        e.design.name()
                    ),
                ));
            }
        }
    }
    // BMC on rings with exact kernel means solves J × J blocks (ring_solver), not Q itself.
    let on_rings = |e: &PlannedEstimator| {
        e.design.structure() == Structure::Rings
            && e.settings.kernel_mean == Some(crate::bq::model::KernelMeanName::Exact)
    };
    let needs_weights = estimators
        .iter()
        .any(|e| e.method.needs_weights() && !on_rings(e));
    let needs_ring_weights = estimators.iter().any(|e| e.method.needs_weights() && on_rings(e));
    if needs_ring_weights && max_n > crate::bq::factor::rings::MAX_RING_POINTS as u64 {
        let i = spec
            .samples
            .iter()
            .position(|&n| n == max_n)
            .expect("max is in the list");
        return Err(err(
            format!("samples[{i}]"),
            format!(
                "N = {max_n}: BMC estimators on the rings design allow at most N = {}",
                crate::bq::factor::rings::MAX_RING_POINTS
            ),
        ));
    }
    if needs_weights && max_n > MAX_POINTS as u64 {
        let i = spec
            .samples
            .iter()
            .position(|&n| n == max_n)
            .expect("max is in the list");
        let gib = crate::bq::rule::matrix_gib(max_n as usize);
        return Err(err(
            format!("samples[{i}]"),
            format!(
                "N = {max_n} would need {gib:.1} GiB per worker thread for Q (factored in place); \
                 BMC estimators allow at most N = {MAX_POINTS} ({:.0} GiB)",
                crate::bq::rule::matrix_gib(MAX_POINTS)
            ),
        ));
    }
    // Every design in use draws its own N points in each unit (runner::run_unit), so the bound
    // is on N times the number of designs, not on N.
    let design_count = designs.len() as u64;
    if max_n.saturating_mul(design_count) > MAX_UNIT_POINTS {
        let i = spec
            .samples
            .iter()
            .position(|&n| n == max_n)
            .expect("max is in the list");
        let gib = (BYTES_PER_POINT * design_count) as f64 * max_n as f64 / (1u64 << 30) as f64;
        let designs_text = if design_count == 1 {
            "1 design".to_string()
        } else {
            format!("{design_count} designs")
        };
        return Err(err(
            format!("samples[{i}]"),
            format!(
                "N = {max_n} with {designs_text} would need {gib:.1} GiB per worker thread for the sample sets \
                 and their values ({BYTES_PER_POINT} bytes per point per design); the limit is {MAX_UNIT_POINTS} \
                 points per trial across designs, so N ≤ {} here",
                MAX_UNIT_POINTS / design_count
            ),
        ));
    }
    // Bayes–Sard fits a constant: it needs at least two points.
    if let Some((i, e)) = estimators
        .iter()
        .enumerate()
        .find(|(_, e)| spec.samples.iter().any(|&n| (n as usize) < e.method.min_points()))
    {
        let (k, n) = spec
            .samples
            .iter()
            .enumerate()
            .find(|&(_, &n)| (n as usize) < e.method.min_points())
            .expect("found above");
        return Err(err(
            format!("samples[{k}]"),
            format!(
                "N = {n} is too few for estimators[{i}] ({:?}, method {}), which needs at least {} points",
                e.label,
                e.method,
                e.method.min_points()
            ),
        ));
    }
    let cells = (integrands.len() * estimators.len() * spec.samples.len()) as u128;
    let rows = cells * spec.trials as u128;
    if rows > MAX_ROWS as u128 {
        return Err(err(
            "trials",
            format!(
                "{} trials would give {rows} rows in trials.csv; the limit is {MAX_ROWS}",
                spec.trials
            ),
        ));
    }
    Ok(())
}

/// A check: a paired comparison or a calibration check.
enum ResolvedCheck {
    Comparison(Check),
    Calibration(CalibrationCheck),
}

/// Check `i`, naming its estimators by label.
fn resolve_check(
    spec: &ExperimentSpec,
    estimators: &[PlannedEstimator],
    i: usize,
    c: &CheckSpec,
) -> Result<ResolvedCheck, String> {
    let at = |field: &str| format!("checks[{i}].{field}");
    let find = |label: &str, field: &str| {
        estimators.iter().position(|e| e.label == label).ok_or_else(|| {
            let known: Vec<_> = estimators.iter().map(|e| e.label.as_str()).collect();
            err(
                at(field),
                format!(
                    "no estimator is labelled {label:?} (labels: {})",
                    known.join(", ")
                ),
            )
        })
    };
    let from_n = c.from_n.unwrap_or(1);
    if from_n == 0 {
        return Err(err(at("from_n"), "must be at least 1, got 0"));
    }
    if !spec.samples.iter().any(|&n| n >= from_n) {
        return Err(err(
            at("from_n"),
            format!("{from_n} is above every sample count, so nothing is checked"),
        ));
    }
    if let Some(label) = &c.calibrated {
        for (field, given) in [
            ("better", c.better.is_some()),
            ("than", c.than.is_some()),
            ("alpha", c.alpha.is_some()),
        ] {
            if given {
                return Err(err(
                    at(field),
                    "is not used by a calibration check (\"calibrated\" takes \"level\" and \"from_n\")",
                ));
            }
        }
        let index = find(label, "calibrated")?;
        let e = &estimators[index];
        if let Some(&n) = spec
            .samples
            .iter()
            .find(|&&n| n >= from_n && !e.method.has_interval(n as usize))
        {
            return Err(err(
                at("calibrated"),
                format!(
                    "{label:?} (method {}) has no interval at N = {n}, so its calibration cannot be checked; \
                     raise from_n",
                    e.method
                ),
            ));
        }
        let level = c.level.unwrap_or(0.95);
        if !(level > 0.0 && level < 1.0) {
            return Err(err(
                at("level"),
                format!("must be in (0, 1), got {}", crate::util::shown::shown(level)),
            ));
        }
        return Ok(ResolvedCheck::Calibration(CalibrationCheck {
            calibrated: label.clone(),
            level,
            from_n: from_n as usize,
            side: c.side.unwrap_or(CheckSide::TwoSided),
            index,
        }));
    }
    for (field, given) in [("level", c.level.is_some()), ("side", c.side.is_some())] {
        if given {
            return Err(err(
                at(field),
                "is used only by a calibration check (\"calibrated\": LABEL)",
            ));
        }
    }
    let (Some(better), Some(than)) = (&c.better, &c.than) else {
        return Err(err(
            format!("checks[{i}]"),
            "give \"better\" and \"than\" (a comparison) or \"calibrated\" (a calibration check)",
        ));
    };
    let better_index = find(better, "better")?;
    let than_index = find(than, "than")?;
    if better_index == than_index {
        return Err(err(at("than"), format!("{than:?} is compared with itself")));
    }
    let alpha = c.alpha.unwrap_or(0.01);
    if !(alpha > 0.0 && alpha < 1.0) {
        return Err(err(
            at("alpha"),
            format!("must be in (0, 1), got {}", crate::util::shown::shown(alpha)),
        ));
    }
    if spec.trials < 2 {
        return Err(err(at("better"), "a paired test needs at least 2 trials"));
    }
    Ok(ResolvedCheck::Comparison(Check {
        better: better.clone(),
        than: than.clone(),
        from_n: from_n as usize,
        alpha,
        better_index,
        than_index,
    }))
}

/// Per estimator, whether its band may be drawn: `plot.bands` as given (`"all"`, `"none"`,
/// labels of estimators), else every one, each figure then keeping those that overlap no band
/// drawn before them ([`Plan::auto_bands`]: overlapping bands hide each other and the lines).
pub fn resolve_bands(spec: &ExperimentSpec, estimators: &[PlannedEstimator]) -> Result<Vec<bool>, String> {
    use super::spec::{BandsName, BandsSpec};
    let all = |on: bool| vec![on; estimators.len()];
    Ok(match spec.plot.as_ref().and_then(|p| p.bands.as_ref()) {
        None => all(true),
        Some(BandsSpec::Named(BandsName::All)) => all(true),
        Some(BandsSpec::Named(BandsName::None)) => all(false),
        Some(BandsSpec::Labels(labels)) => {
            if let Some(unknown) = labels.iter().find(|l| !estimators.iter().any(|e| e.label == **l)) {
                return Err(err(
                    "plot.bands",
                    format!(
                        "names \"{unknown}\", which is no estimator's label ({})",
                        estimators
                            .iter()
                            .map(|e| e.label.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                ));
            }
            estimators.iter().map(|e| labels.contains(&e.label)).collect()
        }
    })
}

/// The smallest N of the slope fits: given, or the upper half of the grid.
fn resolve_fit_from(spec: &ExperimentSpec) -> Result<usize, String> {
    Ok(match spec.fit_from_n {
        None => super::fit::fit_from(&spec.samples.iter().map(|&n| n as usize).collect::<Vec<_>>()),
        Some(n) => {
            let fittable = spec.samples.iter().filter(|&&m| m >= n).count();
            if n == 0 || fittable < 2 {
                return Err(err(
                    "fit_from_n",
                    format!("{n} leaves {fittable} sample count(s) at or above it; a slope needs at least 2"),
                ));
            }
            n as usize
        }
    })
}

/// One integrand, validated, with its truth computed (and its default name filled in).
pub fn resolve_integrand(spec: &IntegrandSpec) -> Result<Integrand, String> {
    match spec {
        IntegrandSpec::Named(name) => CosPower::parse(name).map(Integrand::Cos).ok_or_else(|| {
            format!(
                "unknown integrand {name:?} (expected cos, cos2, cos3, …: cos<k> with k a whole number \
                 from 0 to 2147483647, or an object with \"type\": {})",
                FamilySpec::types_or()
            )
        }),
        IntegrandSpec::Family(family) => {
            let f = family.resolve()?;
            if let Some(n) = family.name() {
                check_file_name(n).map_err(|m| format!("name: {m}"))?;
            }
            Ok(f)
        }
        IntegrandSpec::External(_) => Err(
            "type: \"python\" names a Python callable; give the callable to workbench.run(spec, integrands={name: f})"
                .into(),
        ),
    }
}

/// An integrand's name becomes a file name (`<name>.svg`): the experiment name's alphabet.
fn check_file_name(name: &str) -> Result<(), String> {
    let ok = !name.is_empty()
        && name.len() <= MAX_NAME
        && !name.starts_with('.')
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
    if ok {
        Ok(())
    } else {
        Err(format!(
            "{name:?} is not a usable file name (1 to {MAX_NAME} letters, digits, '-', '_', '.'; no leading '.')"
        ))
    }
}

/// The experiment name becomes a folder: keep it to a safe alphabet and length.
fn check_name(name: &str) -> Result<(), String> {
    let ok = !name.is_empty()
        && !name.starts_with('.')
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
    if !ok {
        return Err(err(
            "name",
            format!(
                "{name:?} is not a safe folder name (use letters, digits, '-', '_', '.'; no '/', no leading '.')"
            ),
        ));
    }
    // After the alphabet check, so bytes are characters.
    if name.len() > MAX_NAME {
        // The first characters identify the name; all of a long one would swamp the line.
        return Err(err(
            "name",
            format!(
                "\"{}…\" is {} characters long; names are limited to {MAX_NAME} characters",
                &name[..20],
                name.len()
            ),
        ));
    }
    Ok(())
}

/// One estimator's options, checked against what its method takes: options a method does not
/// use are errors, never silently ignored.
fn resolve_estimator(
    e: &EstimatorSpec,
    at: &dyn Fn(&str) -> String,
) -> Result<(PlannedEstimator, Option<ResolvedModel>), String> {
    if let MethodName::Light(method) = e.method {
        return resolve_light_estimator(e, method, at).map(|p| (p, None));
    }
    for (field, given) in [
        ("sampler", e.sampler.map(|s| format!("{:?}", s.name()))),
        ("heuristic", e.heuristic.map(|h| format!("{:?}", h.name()))),
        ("compensation", e.compensation.map(|c| c.to_string())),
        ("order", e.order.map(|o| o.to_string())),
        ("weights", e.weights.map(|w| format!("{:?}", w.name()))),
    ] {
        if let Some(value) = given {
            return Err(err(
                at(field),
                format!(
                    "{value} is not used by method {} (only by the light-aware mc-light, mc-bsdf, mis, bq-pss)",
                    e.method
                ),
            ));
        }
    }
    let design = e.design.unwrap_or(Design::Iid(Density::Uniform));
    let unused =
        |field: &str, value: String| err(at(field), format!("{value} is not used by method {}", e.method));
    let model = if e.method.needs_weights() {
        let model = e
            .model()
            .resolve()
            .map_err(|m| err(at(m.field.json()), m.message))?;
        Some(model)
    } else {
        if let Some((field, value)) = e.model().given_fields().into_iter().next() {
            return Err(unused(field.json(), value));
        }
        None
    };
    let prior = if e.method.uses_prior() {
        Some(match e.prior.unwrap_or(PriorSpec::Named(PriorName::Analytic)) {
            PriorSpec::Named(PriorName::Analytic) => Prior::Analytic,
            PriorSpec::Value(c) => {
                let bound = prior_bound(model.as_ref().expect("a prior's method has weights"));
                if !c.is_finite() || c.abs() > bound {
                    return Err(err(
                        at("prior"),
                        format!(
                            "must be finite with |c| ≤ {MAX_PRIOR:e} · min(1, √(k(x,x) + σ_n²)) = {bound:e} for \
                             this model (larger constants overflow the fitted amplitude's rᵀQ⁻¹r), got {c:e}"
                        ),
                    ));
                }
                Prior::Value(c)
            }
        })
    } else {
        if let Some(p) = &e.prior {
            return Err(unused(
                "prior",
                serde_json::to_string(p).expect("spec values serialize"),
            ));
        }
        None
    };
    let scale = if e.method.needs_weights() {
        Some(e.scale.unwrap_or(Scale::DEFAULT))
    } else {
        if let Some(sc) = e.scale {
            return Err(unused("scale", format!("{:?}", sc.name())));
        }
        None
    };
    let settings = ResolvedSettings {
        scale,
        method: e.method,
        design,
        sampler: None,
        heuristic: None,
        compensation: None,
        order: None,
        weights: None,
        kernel: model.as_ref().map(|m| m.to_json()["kernel"].clone()),
        noise: model.as_ref().filter(|m| !m.is_fitted()).map(|m| m.noise),
        kernel_mean: model.as_ref().map(|m| m.kernel_mean),
        kernel_mean_samples: model.as_ref().and_then(|m| m.samples()),
        prior: prior.map(|p| match p {
            Prior::Analytic => PriorSpec::Named(PriorName::Analytic),
            Prior::Value(c) => PriorSpec::Value(c),
        }),
        tolerance: None,
    };
    Ok((
        PlannedEstimator {
            label: e.label.clone(),
            method: e.method,
            design,
            light: None,
            model: None,
            prior,
            scale,
            tolerance: None,
            settings,
        },
        model,
    ))
}

/// A light-aware estimator's options (math.md §11): `sampler` for every one, `heuristic` and
/// `compensation` for `mis` alone (the compensated density misses the light below the mean, so
/// light sampling alone on it would be biased); the options of point-set methods are errors.
fn resolve_light_estimator(
    e: &EstimatorSpec,
    method: LightMethod,
    at: &dyn Fn(&str) -> String,
) -> Result<PlannedEstimator, String> {
    let unused = |field: &str, value: String, why: &str| {
        err(
            at(field),
            format!("{value} is not used by method {}{why}", e.method),
        )
    };
    if let Some(d) = e.design {
        return Err(unused(
            "design",
            format!("{:?}", d.name()),
            " (it draws from the integrand's light and BSDF; its primary samples are chosen by \"sampler\")",
        ));
    }
    if let Some((field, value)) = e.model().given_fields().into_iter().next() {
        return Err(unused(field.json(), value, ""));
    }
    if let Some(p) = &e.prior {
        return Err(unused(
            "prior",
            serde_json::to_string(p).expect("spec values serialize"),
            "",
        ));
    }
    if let Some(sc) = e.scale {
        return Err(unused("scale", format!("{:?}", sc.name()), ""));
    }
    if let Some(t) = &e.tolerance {
        return Err(unused(
            "tolerance",
            serde_json::to_string(t).expect("spec values serialize"),
            "",
        ));
    }
    if method != LightMethod::Mis {
        if let Some(h) = e.heuristic {
            return Err(unused("heuristic", format!("{:?}", h.name()), " (only by mis)"));
        }
        if let Some(c) = e.compensation {
            return Err(unused(
                "compensation",
                c.to_string(),
                " (only by mis: the compensated density misses the light below the mean, which only the BSDF technique covers)",
            ));
        }
    }
    let is_pss = method == LightMethod::BqPss;
    if !is_pss {
        if let Some(o) = e.order {
            return Err(unused("order", o.to_string(), " (only by bq-pss)"));
        }
        if let Some(w) = e.weights {
            return Err(unused("weights", format!("{:?}", w.name()), " (only by bq-pss)"));
        }
    }
    let order = match e.order {
        None => SobolevOrder::One,
        Some(o) => SobolevOrder::from_number(o).ok_or_else(|| {
            err(
                at("order"),
                format!("{o} is not an order of bq-pss's product Sobolev kernel (1 or 2)"),
            )
        })?,
    };
    let pss = PssOptions {
        order,
        weights: e.weights.unwrap_or_default(),
    };
    // bq-pss's points are a scrambled Sobol set unless told otherwise (math.md §11 (a)).
    let sampler = e
        .sampler
        .unwrap_or(if is_pss { Sampler::Sobol } else { Sampler::Uniform });
    let heuristic = e.heuristic.unwrap_or_default();
    let compensation = e.compensation.unwrap_or(false);
    let design = match sampler {
        Sampler::Uniform => Design::Iid(Density::Uniform),
        Sampler::Sobol => Design::Sobol,
    };
    let is_mis = method == LightMethod::Mis;
    Ok(PlannedEstimator {
        label: e.label.clone(),
        method: e.method,
        design,
        light: Some(LightEstimator {
            method,
            heuristic,
            compensation,
            sampler,
            pss,
        }),
        model: None,
        prior: None,
        scale: None,
        tolerance: None,
        settings: ResolvedSettings {
            method: e.method,
            design,
            sampler: Some(sampler),
            heuristic: is_mis.then_some(heuristic),
            compensation: is_mis.then_some(compensation),
            order: is_pss.then_some(order.number() as u64),
            weights: is_pss.then_some(pss.weights),
            kernel: None,
            noise: None,
            kernel_mean: None,
            kernel_mean_samples: None,
            prior: None,
            scale: None,
            tolerance: None,
        },
    })
}
