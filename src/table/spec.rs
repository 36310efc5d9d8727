//! The render-table file, exactly as written in JSON (`deny_unknown_fields`). Nothing here is
//! validated beyond types; [`super::plan`] turns a spec into a plan.
//!
//! ```json
//! { "name": "render-table", "seed": 0, "width": 256, "height": 256, "env": "sky",
//!   "spp": [20, 40, 60, 80], "repetitions": 10,
//!   "reference": { "method": "exact" },
//!   "model": { "kernel": { "type": "sobolev", "s": 1.4 }, "noise": 0.01, "kernel_mean": "exact" },
//!   "variants": [ { "label": "MC", "integrator": "mc" },
//!                 { "label": "BMC 4 GP", "integrator": "bmc", "gps": 4, "rotate": true } ] }
//! ```

use crate::bq::model::ModelSpec;
use crate::render::integrator::IntegratorKind;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// A render table. See docs/guide/render.md ("Tables") for every field.
#[derive(Debug, Clone, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TableSpec {
    /// The JSON Schema this file follows (`workbench schema render-table`), for editors;
    /// ignored by the tool and never written back.
    #[serde(rename = "$schema", default, skip_serializing)]
    pub schema: Option<String>,
    /// Output folder name under the results folder: A–Z, a–z, 0–9, `-`, `_`.
    pub name: String,
    /// The RMSE plot's title; defaults to the name.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub title: Option<String>,
    /// Master seed; default 0.
    #[serde(default)]
    pub seed: Option<u64>,
    /// Image width in pixels; default the scene's (256 for `workbench`, 500 for `thesis`).
    #[serde(default)]
    pub width: Option<u64>,
    /// Image height in pixels; default the scene's (256 for `workbench`, 500 for `thesis`).
    #[serde(default)]
    pub height: Option<u64>,
    /// The scene: `workbench` (docs/render-scene.md) or `thesis` (the thesis code's); default
    /// `workbench`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene: Option<String>,
    /// `sky`, `white`, a catalogue map by name (`pisa`; from the data folder) or an environment
    /// map file; default `sky`.
    #[serde(default)]
    pub env: Option<String>,
    /// How the map is looked up (math.md §10): `mitsuba` (bilinear) or `thesis` (nearest
    /// texel); default `mitsuba`. Maps only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lookup: Option<String>,
    /// Clamp every texel channel of the map to at most this value (finite, > 0) before
    /// anything, reference included: what a low-dynamic-range light store does to a sun (the
    /// thesis's Archi map is clamped at 1.0). Maps only; default no clamp.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clamp: Option<f64>,
    /// Samples per pixel; default `[20, 40, 60, 80]`.
    #[serde(default)]
    pub spp: Option<Vec<u64>>,
    /// Renders per spp: one number, or one per `spp` entry; default 10.
    #[serde(default)]
    pub repetitions: Option<Repetitions>,
    /// Adaptive sampling for every variant (docs/guide/render.md, "Adaptive sampling"): the table's columns
    /// are target sds instead of `spp`, which must then be absent.
    #[serde(default)]
    pub adaptive: Option<AdaptiveSpec>,
    /// The reference; default exact (certified quadrature at 1e-9).
    #[serde(default)]
    pub reference: Option<ReferenceSpec>,
    /// The BMC model of the variants with weights; the experiments' fields.
    #[serde(default)]
    pub model: Option<ModelSpec>,
    pub variants: Vec<VariantSpec>,
    /// Images made elsewhere: another renderer's reference, against which every render is also
    /// measured, and its renders, measured against both references.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub external: Option<ExternalSpec>,
}

/// `"external"`: another renderer's reference and renders, by catalogue name or path, at the
/// table's size.
#[derive(Debug, Clone, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ExternalSpec {
    /// Their reference (a Radiance .hdr or OpenEXR image).
    pub reference: String,
    /// Their renders, each measured against both references.
    #[serde(default)]
    pub images: Option<Vec<ExternalImageSpec>>,
}

/// One render made elsewhere.
#[derive(Debug, Clone, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ExternalImageSpec {
    /// Its row label.
    pub label: String,
    /// The image (a Radiance .hdr or OpenEXR image), by catalogue name or path.
    pub image: String,
}

/// One row of the table.
#[derive(Debug, Clone, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct VariantSpec {
    /// Row label; default the integrator's name.
    #[serde(default)]
    pub label: Option<String>,
    /// The per-pixel integrator by name.
    pub integrator: IntegratorKind,
    /// Sample sets (integrators with weights only); default 4.
    #[serde(default)]
    pub gps: Option<u64>,
    /// Rotate the set per pixel (integrators with weights only); default true.
    #[serde(default)]
    pub rotate: Option<bool>,
    /// Amplitude of the per-pixel posterior sd behind the coverage columns (integrators with
    /// weights only): `unit`, `ml` or `loo` (math.md §7); default `ml`.
    #[serde(default)]
    pub scale: Option<crate::bq::weights::Scale>,
    /// This row's own BMC model (integrators with weights only), replacing the table's
    /// `model`: e.g. `{"kernel": {"type": "fitted"}}` for a model fitted per pixel and channel
    /// (math.md §9).
    #[serde(default)]
    pub model: Option<ModelSpec>,
}

/// `{"target_sd": [0.08, 0.04, 0.02], "max_spp": 512, "first_spp": 16}`: each pixel doubles its
/// samples from `first_spp` until the sd it states for every channel is at most the target, or
/// `max_spp` is reached; one column of the table per target.
#[derive(Debug, Clone, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AdaptiveSpec {
    /// Target sds `T` per pixel and channel (each finite and > 0, distinct), one column each.
    pub target_sd: Vec<f64>,
    /// The most samples a pixel may take (≥ `first_spp`).
    pub max_spp: u64,
    /// The first stage (the pilot); default 64, as an experiment's `min_n` (MC needs at least 2).
    #[serde(default)]
    pub first_spp: Option<u64>,
}

/// The reference image: `{"method": "exact"}` (the default; optional `tolerance`) or
/// `{"method": "mc", "spp": 3000}` (optional `seed`). Without `method`, `spp` or `seed` mean MC
/// (the form of files written before the exact reference existed).
#[derive(Debug, Clone, Copy, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ReferenceSpec {
    #[serde(default)]
    pub method: Option<ReferenceMethod>,
    #[serde(default)]
    pub spp: Option<u64>,
    #[serde(default)]
    pub seed: Option<u64>,
    #[serde(default)]
    pub tolerance: Option<f64>,
}

/// How the reference is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum ReferenceMethod {
    /// Every pixel by the certified quadrature (`render::exact`).
    Exact,
    /// Uniform MC.
    Mc,
}

/// `10` (every spp) or `[80, 40, 26, 20]` (one per spp).
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[serde(untagged)]
pub enum Repetitions {
    All(u64),
    PerSpp(Vec<u64>),
}

impl<'de> Deserialize<'de> for Repetitions {
    /// By hand rather than `untagged`, whose error ("did not match any variant") hides what is
    /// accepted.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        match serde_json::Value::deserialize(d)? {
            serde_json::Value::Number(n) if n.as_u64().is_some() => {
                Ok(Repetitions::All(n.as_u64().expect("checked")))
            }
            serde_json::Value::Array(items) => items
                .iter()
                .map(|v| {
                    v.as_u64()
                        .ok_or_else(|| serde::de::Error::custom(format!("expected whole numbers, got {v}")))
                })
                .collect::<Result<_, _>>()
                .map(Repetitions::PerSpp),
            other => Err(serde::de::Error::custom(format!(
                "expected a whole number or a list of them (one per spp), got {other}"
            ))),
        }
    }
}

impl<'de> Deserialize<'de> for IntegratorKind {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        IntegratorKind::from_name(&name).ok_or_else(|| {
            serde::de::Error::custom(format!(
                "unknown integrator {name:?}; expected one of {}",
                IntegratorKind::names()
            ))
        })
    }
}
