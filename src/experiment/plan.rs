//! Validation: an [`ExperimentSpec`] becomes a [`Plan`] with every default filled in, or a
//! one-line error naming the file, the JSON path and the value.

use super::spec::*;
use crate::bmc::{BmcModel, DEFAULT_NOISE};
use crate::estimator::{Method, Prior};
use crate::integrand::CosPower;
use crate::kernel::{Kernel, Sobolev, SquaredExponential};
use crate::kernel_mean::KernelMeanMode;
use crate::rule::MAX_POINTS;
use crate::sampling::{Design, SetDesign};
use serde::Serialize;
use std::sync::Arc;

/// Largest N for estimators without weights (MC): the sample set and values of one trial
/// take 32 bytes per point and per worker thread.
pub const MAX_MC_POINTS: u64 = 10_000_000;
/// Largest number of rows in `trials.csv`: a run holds about 450 bytes per row in memory
/// (results and the CSV text), so this keeps a run under ~5 GB.
pub const MAX_ROWS: u64 = 10_000_000;

/// A resolved, validated experiment.
#[derive(Debug, Clone)]
pub struct Plan {
    pub name: String,
    pub title: String,
    pub integrands: Vec<CosPower>,
    pub estimators: Vec<PlannedEstimator>,
    pub samples: Vec<usize>,
    pub trials: usize,
    pub seed: u64,
    pub checks: Vec<Check>,
    /// Distinct BMC models; estimators that share one share its weights within a trial.
    pub models: Vec<Arc<BmcModel>>,
    /// Distinct designs in use; estimators with the same design see the same sample set.
    pub designs: Vec<SetDesign>,
}

/// One estimator, resolved.
#[derive(Debug, Clone)]
pub struct PlannedEstimator {
    pub label: String,
    pub method: Method,
    pub design: SetDesign,
    /// Index into [`Plan::models`] (BMC-type methods).
    pub model: Option<usize>,
    /// The resolved settings, for the manifest and `validate`.
    pub settings: ResolvedSettings,
}

/// The settings of an estimator with defaults filled in.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResolvedSettings {
    pub method: MethodName,
    pub design: DesignName,
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

/// Parses the JSON text; errors say where (`path: message`).
pub fn parse(text: &str) -> Result<ExperimentSpec, String> {
    let value: serde_json::Value = serde_json::from_str(text).map_err(|e| format!("malformed JSON: {e}"))?;
    if value.get("variants").is_some() && value.get("estimators").is_none() {
        return Err(
            "this is a render table spec (it has \"variants\"); run it with `workbench render FILE`".into(),
        );
    }
    if !value.is_object() {
        return Err(format!(
            "the file must hold one JSON object (the experiment), got {}",
            match value {
                serde_json::Value::Array(_) => "an array",
                serde_json::Value::String(_) => "a string",
                serde_json::Value::Number(_) => "a number",
                serde_json::Value::Bool(_) => "a boolean",
                _ => "null",
            }
        ));
    }
    serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        if path == "." {
            inner.to_string()
        } else {
            format!("{path}: {inner}")
        }
    })
}

fn err(path: impl std::fmt::Display, message: impl std::fmt::Display) -> String {
    format!("{path}: {message}")
}

/// Checks every value and fills in defaults.
pub fn resolve(spec: &ExperimentSpec) -> Result<Plan, String> {
    check_name(&spec.name)?;
    if spec.integrands.is_empty() {
        return Err(err("integrands", "must name at least one integrand"));
    }
    let mut integrands = Vec::new();
    for (i, name) in spec.integrands.iter().enumerate() {
        let f = CosPower::parse(name).ok_or_else(|| {
            err(
                format!("integrands[{i}]"),
                format!("unknown integrand {name:?} (expected cos, cos2, cos3, …: cos<k> with k a whole number from 0 to 2147483647)"),
            )
        })?;
        if integrands.contains(&f) {
            return Err(err(
                format!("integrands[{i}]"),
                format!("{name:?} is listed twice"),
            ));
        }
        integrands.push(f);
    }
    if spec.samples.is_empty() {
        return Err(err("samples", "must list at least one sample count"));
    }
    for (i, &n) in spec.samples.iter().enumerate() {
        if n == 0 {
            return Err(err(format!("samples[{i}]"), "N must be at least 1, got 0"));
        }
        if spec.samples[..i].contains(&n) {
            return Err(err(format!("samples[{i}]"), format!("N = {n} is listed twice")));
        }
    }
    if spec.trials == 0 {
        return Err(err("trials", "must be at least 1, got 0"));
    }
    if spec.estimators.is_empty() {
        return Err(err("estimators", "must list at least one estimator"));
    }

    let mut estimators: Vec<PlannedEstimator> = Vec::new();
    let mut models: Vec<Arc<BmcModel>> = Vec::new();
    let mut model_keys: Vec<ResolvedSettings> = Vec::new();
    let mut designs: Vec<SetDesign> = Vec::new();
    for (i, e) in spec.estimators.iter().enumerate() {
        let at = |field: &str| format!("estimators[{i}].{field}");
        if e.label.is_empty() || e.label.contains(|c: char| c.is_control()) {
            return Err(err(at("label"), format!("{:?} is not a usable label", e.label)));
        }
        if let Some(j) = estimators.iter().position(|p| p.label == e.label) {
            return Err(err(
                at("label"),
                format!("{:?} is already the label of estimators[{j}]", e.label),
            ));
        }
        let (planned, model) = resolve_estimator(e, &at)?;
        let mut planned = planned;
        if let Some(model) = model {
            // The key is everything that determines the weights: method and prior aside.
            let key = ResolvedSettings {
                method: MethodName::Bmc,
                prior: None,
                ..planned.settings.clone()
            };
            let index = match model_keys.iter().position(|k| *k == key) {
                Some(index) => index,
                None => {
                    model_keys.push(key);
                    models.push(Arc::new(model()));
                    models.len() - 1
                }
            };
            planned.model = Some(index);
        }
        if !designs.contains(&planned.design) {
            designs.push(planned.design);
        }
        estimators.push(planned);
    }

    let max_n = *spec.samples.iter().max().expect("samples is not empty");
    let needs_weights = estimators.iter().any(|e| e.method.needs_weights());
    if needs_weights && max_n > MAX_POINTS as u64 {
        let i = spec
            .samples
            .iter()
            .position(|&n| n == max_n)
            .expect("max is in the list");
        let gib = 16.0 * (max_n as f64).powi(2) / (1u64 << 30) as f64;
        return Err(err(
            format!("samples[{i}]"),
            format!(
                "N = {max_n} would need {gib:.1} GiB per worker thread for Q and its Cholesky factor; \
                 BMC estimators allow at most N = {MAX_POINTS} (4 GiB)"
            ),
        ));
    }
    if max_n > MAX_MC_POINTS {
        let i = spec
            .samples
            .iter()
            .position(|&n| n == max_n)
            .expect("max is in the list");
        return Err(err(
            format!("samples[{i}]"),
            format!(
                "N = {max_n} would need {:.1} GiB per worker thread for the sample set; the limit is {MAX_MC_POINTS}",
                32.0 * max_n as f64 / (1u64 << 30) as f64
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

    let mut checks = Vec::new();
    for (i, c) in spec.checks.iter().enumerate() {
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
        let better_index = find(&c.better, "better")?;
        let than_index = find(&c.than, "than")?;
        if better_index == than_index {
            return Err(err(at("than"), format!("{:?} is compared with itself", c.than)));
        }
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
        let alpha = c.alpha.unwrap_or(0.01);
        if !(alpha > 0.0 && alpha < 1.0) {
            return Err(err(at("alpha"), format!("must be in (0, 1), got {alpha}")));
        }
        if spec.trials < 2 {
            return Err(err(at("better"), "a paired test needs at least 2 trials"));
        }
        checks.push(Check {
            better: c.better.clone(),
            than: c.than.clone(),
            from_n: from_n as usize,
            alpha,
            better_index,
            than_index,
        });
    }

    Ok(Plan {
        name: spec.name.clone(),
        title: spec.title.clone().unwrap_or_else(|| spec.name.clone()),
        integrands,
        estimators,
        samples: spec.samples.iter().map(|&n| n as usize).collect(),
        trials: spec.trials as usize,
        seed: spec.seed,
        checks,
        models,
        designs,
    })
}

/// The experiment name becomes a folder: keep it to a safe alphabet.
fn check_name(name: &str) -> Result<(), String> {
    let ok = !name.is_empty()
        && name.len() <= 100
        && !name.starts_with('.')
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
    if ok {
        Ok(())
    } else {
        Err(err(
            "name",
            format!(
                "{name:?} is not a safe folder name (use letters, digits, '-', '_', '.'; no '/', no leading '.')"
            ),
        ))
    }
}

type ModelBuilder = Box<dyn FnOnce() -> BmcModel>;

fn resolve_estimator(
    e: &EstimatorSpec,
    at: &dyn Fn(&str) -> String,
) -> Result<(PlannedEstimator, Option<ModelBuilder>), String> {
    let design_name = e.design.unwrap_or(DesignName::Uniform);
    let design = match design_name {
        DesignName::Uniform => SetDesign::Iid(Design::Uniform),
        DesignName::Cosine => SetDesign::Iid(Design::Cosine),
        DesignName::Fibonacci => SetDesign::Fibonacci,
    };
    let unused = |field: &str, value: String| {
        err(
            at(field),
            format!(
                "{value} is not used by method {}",
                format!("{:?}", e.method).to_lowercase()
            ),
        )
    };
    // The value as it stood in the file, for the message.
    fn json<T: Serialize>(v: &Option<T>) -> Option<String> {
        v.as_ref()
            .map(|v| serde_json::to_string(v).expect("spec values serialize"))
    }
    if e.method == MethodName::Mc {
        for (field, given) in [
            ("kernel", json(&e.kernel)),
            ("noise", json(&e.noise)),
            ("kernel_mean", json(&e.kernel_mean)),
            ("kernel_mean_samples", json(&e.kernel_mean_samples)),
            ("prior", json(&e.prior)),
        ] {
            if let Some(value) = given {
                return Err(unused(field, value));
            }
        }
        let settings = ResolvedSettings {
            method: MethodName::Mc,
            design: design_name,
            kernel: None,
            noise: None,
            kernel_mean: None,
            kernel_mean_samples: None,
            prior: None,
        };
        return Ok((
            PlannedEstimator {
                label: e.label.clone(),
                method: Method::Mc,
                design,
                model: None,
                settings,
            },
            None,
        ));
    }
    if let (MethodName::Bmc, Some(value)) = (e.method, json(&e.prior)) {
        return Err(unused("prior", value));
    }

    let kernel = match e.kernel.unwrap_or(KernelSpec::Sobolev { s: None }) {
        KernelSpec::Sobolev { s } => Sobolev::new(s.unwrap_or(Sobolev::DEFAULT_S)).map(Kernel::Sobolev),
        KernelSpec::SquaredExponential { sigma, length } => {
            SquaredExponential::new(sigma.unwrap_or(1.0), length.unwrap_or(0.5))
                .map(Kernel::SquaredExponential)
        }
    }
    .map_err(|k| err(at("kernel"), k))?;
    let noise = e.noise.unwrap_or(DEFAULT_NOISE);
    crate::bmc::validate_noise(noise).map_err(|m| err(at("noise"), m))?;
    let mean_name = e.kernel_mean.unwrap_or(KernelMeanName::Exact);
    let (mode, samples) = match mean_name {
        KernelMeanName::Exact => {
            if e.kernel_mean_samples.is_some() {
                return Err(err(
                    at("kernel_mean_samples"),
                    "is only used with \"kernel_mean\": \"mc\"",
                ));
            }
            (KernelMeanMode::Exact, None)
        }
        KernelMeanName::Mc => {
            let m = e
                .kernel_mean_samples
                .unwrap_or(KernelMeanMode::THESIS_SAMPLES as u64);
            let mode = KernelMeanMode::monte_carlo(m).map_err(|msg| err(at("kernel_mean_samples"), msg))?;
            (mode, Some(m))
        }
    };
    let (method, prior) = match e.method {
        MethodName::Bmc => (Method::Bmc, None),
        _ => match e.prior.unwrap_or(PriorSpec::Named(PriorName::Analytic)) {
            PriorSpec::Named(PriorName::Analytic) => (
                Method::Bmcp(Prior::Analytic),
                Some(PriorSpec::Named(PriorName::Analytic)),
            ),
            PriorSpec::Value(c) if c.is_finite() => {
                (Method::Bmcp(Prior::Value(c)), Some(PriorSpec::Value(c)))
            }
            PriorSpec::Value(c) => return Err(err(at("prior"), format!("must be finite, got {c}"))),
        },
    };
    let settings = ResolvedSettings {
        method: e.method,
        design: design_name,
        kernel: Some(kernel.to_json()),
        noise: Some(noise),
        kernel_mean: Some(mean_name),
        kernel_mean_samples: samples,
        prior,
    };
    let builder: ModelBuilder = Box::new(move || BmcModel::new(kernel, noise, mode));
    Ok((
        PlannedEstimator {
            label: e.label.clone(),
            method,
            design,
            model: None,
            settings,
        },
        Some(builder),
    ))
}
