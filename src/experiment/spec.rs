//! The experiment file, exactly as written in JSON (`deny_unknown_fields`).
//!
//! Nothing here is validated beyond types; [`super::plan`] turns a spec into a plan.

use crate::bq::estimator::MethodName;
pub use crate::bq::estimator::mis::Heuristic;
pub use crate::bq::model::{KernelMeanName, KernelSpec, ModelSpec};
pub use crate::integrand::external::ExternalSpec;
pub use crate::integrand::family::FamilySpec;
use crate::sampling::Design;
pub use crate::sampling::primary::Sampler;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// An experiment file. See docs/guide/run.md ("Experiment files") for every field.
#[derive(Debug, Clone, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ExperimentSpec {
    /// The JSON Schema this file follows (`workbench schema experiment`), for editors; ignored
    /// by the tool and never written back.
    #[serde(rename = "$schema", default, skip_serializing)]
    pub schema: Option<String>,
    /// Folder name under `results/`: letters, digits, `-`, `_`, `.`; not starting with `.`.
    #[schemars(regex(pattern = r"^[A-Za-z0-9_-][A-Za-z0-9._-]*$"), length(max = 100))]
    pub name: String,
    /// Plot title; defaults to the name.
    #[serde(default)]
    pub title: Option<String>,
    /// Integrands: names `cos`, `cos2`, `cos3`, … (`cos<k>` for any k ≥ 0) or family objects.
    #[schemars(length(min = 1))]
    pub integrands: Vec<IntegrandSpec>,
    /// The estimators compared, each with a unique `label`.
    #[schemars(length(min = 1))]
    pub estimators: Vec<EstimatorSpec>,
    /// Sample counts N, each at least 1 and listed once.
    #[schemars(length(min = 1), inner(range(min = 1)))]
    pub samples: Vec<u64>,
    /// Independent trials per N.
    #[schemars(range(min = 1))]
    pub trials: u64,
    /// Master seed: every random stream derives from it.
    pub seed: u64,
    #[serde(default)]
    pub checks: Vec<CheckSpec>,
    /// Smallest N of the log–log slope fits (`fits.csv`, the plot legends); default the upper
    /// half of the grid (the N at or above the median).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit_from_n: Option<u64>,
    /// How the figures are drawn: `{"bands": …}` ([`PlotSpec`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plot: Option<PlotSpec>,
}

/// `"plot": {"bands": "all"}`: how an experiment's figures are drawn.
#[derive(Debug, Clone, Default, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PlotSpec {
    /// Which estimators get their 10–90% quantile band in the error plots: `"all"`, `"none"`,
    /// or a list of estimator labels. Default: in each figure, every band that overlaps no band
    /// drawn before it (overlapping bands hide each other and the lines).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bands: Option<BandsSpec>,
}

/// `"all"`, `"none"`, or a list of estimator labels.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[serde(untagged)]
pub enum BandsSpec {
    Named(BandsName),
    Labels(Vec<String>),
}

/// `"all"` or `"none"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum BandsName {
    /// Every estimator has its band.
    All,
    /// No estimator has one.
    None,
}

impl<'de> Deserialize<'de> for BandsSpec {
    /// By hand rather than `untagged`, whose error ("did not match any variant") hides what is
    /// accepted.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let expected = "\"all\", \"none\" or a list of estimator labels";
        match serde_json::Value::deserialize(d)? {
            serde_json::Value::String(s) => match s.as_str() {
                "all" => Ok(BandsSpec::Named(BandsName::All)),
                "none" => Ok(BandsSpec::Named(BandsName::None)),
                _ => Err(D::Error::custom(format!("expected {expected}, got \"{s}\""))),
            },
            v @ serde_json::Value::Array(_) => serde_json::from_value(v)
                .map(BandsSpec::Labels)
                .map_err(|e| D::Error::custom(format!("expected {expected}: {e}"))),
            other => Err(D::Error::custom(format!("expected {expected}, got {other}"))),
        }
    }
}

/// One estimator of the comparison.
#[derive(Debug, Clone, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct EstimatorSpec {
    /// Unique name in outputs and checks.
    pub label: String,
    /// The estimator's method by name: `mc`, `bmc`, `bmcp`, `bsq` (values on a design's points)
    /// or the light-aware `mc-light`, `mc-bsdf`, `mis`, `bq-pss` (math.md §11; envmap integrands only).
    pub method: MethodName,
    /// Sampling design by name; default `uniform` (not for the light-aware methods: `sampler`).
    #[serde(default)]
    pub design: Option<Design>,
    /// Light-aware methods: how every technique's primary samples are drawn, `uniform`
    /// (independent, default) or `sobol` (Owen-scrambled afresh per trial).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sampler: Option<Sampler>,
    /// `mis` only: the MIS heuristic, `power` (default) or `balance`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heuristic: Option<Heuristic>,
    /// `mis` only: light samples from the compensated density `∝ max(0, Y − Ȳ)` (Karlík et al.
    /// 2019); default false. Refused on a map that is constant.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub compensation: Option<bool>,
    /// `bq-pss` only: the order of its product Sobolev kernel on primary samples, 1 (default) or 2.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub order: Option<u64>,
    /// `bq-pss` only: its weights, `bmc` (default), `bsq` (Bayes–Sard), or the ablations `equal`
    /// (RQMC on the same points) and `cv` (a least-squares polynomial control variate).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weights: Option<crate::bq::estimator::bq_pss::PssWeights>,
    /// BMC/BMCP only; default Sobolev with s = 1.4.
    #[serde(default)]
    pub kernel: Option<KernelSpec>,
    /// BMC/BMCP only: σ_n²; default 0.01.
    #[serde(default)]
    pub noise: Option<f64>,
    /// BMC/BMCP only: `exact` (default) or `mc` (the thesis's per-point MC estimate).
    #[serde(default)]
    pub kernel_mean: Option<KernelMeanName>,
    /// With `kernel_mean: "mc"`: uniform samples per kernel mean; default 10 000.
    #[serde(default)]
    pub kernel_mean_samples: Option<u64>,
    /// BMCP only: `"analytic"` (default) or a number.
    #[serde(default)]
    pub prior: Option<PriorSpec>,
    /// Values to sweep: `{"noise": [1e-2, 1e-4], "kernel.s": [1.2, 1.8]}` makes one estimator per
    /// combination, labelled by the `label` template (`"BMC s={kernel.s}"`); see
    /// [`super::sweep`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sweep: Option<std::collections::BTreeMap<String, Vec<serde_json::Value>>>,
    /// Methods with weights (BMC, BMCP, BSQ): the kernel amplitude, `unit`, `ml` or `loo`
    /// (math.md §7); default [`crate::bq::weights::Scale::DEFAULT`].
    #[serde(default)]
    pub scale: Option<crate::bq::weights::Scale>,
    /// Stop at a target uncertainty ([`crate::bq::stages`]; intervals of math.md §7):
    /// `{"abs": A, "max_n": M}`, optionally `min_n`, `level`, `inflate`. The experiment's
    /// sample counts are then this estimator's first stages; see [`super::adaptive`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<ToleranceSpec>,
}

/// `"tolerance": {"abs": 1e-3, "max_n": 1024}`: double N (keeping the earlier points) from the
/// larger of the sample count and `min_n` until `inflate ×` the half-width of the interval at
/// `level` is at most `abs`, or `max_n` is reached. A stage with zero evidence (a fitted
/// amplitude or MC sample sd of exactly 0, or a fitted amplitude on samples all equal) never
/// stops the rule.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ToleranceSpec {
    /// The absolute tolerance on the half-width (> 0).
    pub abs: f64,
    /// The most points a trial may use (≥ every sample count and ≥ `min_n`).
    pub max_n: u64,
    /// The pilot: no stage has fewer points (1 ≤ `min_n` ≤ `max_n`); default 64.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_n: Option<u64>,
    /// The level of the interval whose half-width is compared with `abs`, in (0, 1); default 0.95.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub level: Option<f64>,
    /// The factor on that half-width (≥ 1, as QMCPy's `inflate`); default 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inflate: Option<f64>,
}

/// `"analytic"` or a number.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, JsonSchema)]
#[serde(untagged)]
pub enum PriorSpec {
    Named(PriorName),
    Value(f64),
}

impl<'de> Deserialize<'de> for PriorSpec {
    /// By hand rather than `untagged`, whose error ("did not match any variant") hides what is
    /// accepted.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl serde::de::Visitor<'_> for Visitor {
            type Value = PriorSpec;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("\"analytic\" or a number")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<PriorSpec, E> {
                match v {
                    "analytic" => Ok(PriorSpec::Named(PriorName::Analytic)),
                    _ => Err(E::invalid_value(serde::de::Unexpected::Str(v), &self)),
                }
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<PriorSpec, E> {
                Ok(PriorSpec::Value(v))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<PriorSpec, E> {
                Ok(PriorSpec::Value(v as f64))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<PriorSpec, E> {
                Ok(PriorSpec::Value(v as f64))
            }
        }
        d.deserialize_any(Visitor)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum PriorName {
    Analytic,
}

impl EstimatorSpec {
    /// The model fields (kernel, noise, kernel mean), parsed by [`ModelSpec::resolve`].
    pub fn model(&self) -> ModelSpec {
        ModelSpec {
            kernel: self.kernel.clone(),
            noise: self.noise,
            kernel_mean: self.kernel_mean,
            kernel_mean_samples: self.kernel_mean_samples,
        }
    }
}

/// A check: a comparison (`better`, `than`, `from_n`, `alpha`: `better` has lower error than
/// `than` for every integrand and every N ≥ `from_n`) or a calibration check (`calibrated`,
/// `level`, `from_n`, `side`: the estimator's coverage at `level` lies in the binomial 99% band
/// around `level`, or with `"side": "lower"` at or above its lower edge, in every cell with N ≥
/// `from_n`).
#[derive(Debug, Clone, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CheckSpec {
    #[serde(default)]
    pub better: Option<String>,
    #[serde(default)]
    pub than: Option<String>,
    #[serde(default)]
    pub from_n: Option<u64>,
    /// Level of the one-sided paired t-test; default 0.01.
    #[serde(default)]
    pub alpha: Option<f64>,
    /// The label of the estimator whose calibration is checked.
    #[serde(default)]
    pub calibrated: Option<String>,
    /// The interval level of a calibration check; default 0.95.
    #[serde(default)]
    pub level: Option<f64>,
    /// Which coverage a calibration check accepts: `"two-sided"` (default) within the binomial
    /// 99% band around `level`, `"lower"` at or above its lower edge (no worse than the level:
    /// conservative intervals pass).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub side: Option<CheckSide>,
    /// The label of a tolerance estimator whose share of trials within its tolerance is
    /// checked against `level` ([`super::adaptive`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub within_tolerance: Option<String>,
}

/// Which coverage a calibration check accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
pub enum CheckSide {
    /// Within the binomial 99% band around the level: intervals neither too narrow nor too wide.
    #[serde(rename = "two-sided")]
    TwoSided,
    /// At or above the band's lower edge: no worse than the level (too wide intervals pass).
    #[serde(rename = "lower")]
    Lower,
}

/// An integrand: a name (`"cos3"`), a family object (`{"type": "lobe", …}`) or, from Python
/// only, a callable's (`{"type": "python", "name": …}`).
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[serde(untagged)]
pub enum IntegrandSpec {
    Named(String),
    Family(FamilySpec),
    External(ExternalSpec),
}

impl<'de> Deserialize<'de> for IntegrandSpec {
    /// By hand rather than `untagged`, whose error ("did not match any variant") hides what is
    /// accepted and what was wrong inside the object.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        match serde_json::Value::deserialize(d)? {
            serde_json::Value::String(name) => Ok(IntegrandSpec::Named(name)),
            // With the path inside (`normal[0]`), which `serde_json::from_value` would drop.
            v @ serde_json::Value::Object(_) if v.get("type").and_then(|t| t.as_str()) == Some("python") => {
                crate::files::spec_json::from_value(v)
                    .map(IntegrandSpec::External)
                    .map_err(D::Error::custom)
            }
            v @ serde_json::Value::Object(_) => crate::files::spec_json::from_value(v)
                .map(IntegrandSpec::Family)
                .map_err(D::Error::custom),
            other => Err(D::Error::custom(format!(
                "expected a name such as \"cos3\" or an object with a \"type\" ({}), got {other}",
                FamilySpec::TYPES.join(", ")
            ))),
        }
    }
}
