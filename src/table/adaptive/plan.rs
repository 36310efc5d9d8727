//! Validation of a table's `"adaptive"` object and of the variants it runs (docs/guide/render.md, "Adaptive
//! sampling"): targets, stages, and which integrators can stop at a target.

use crate::bq::weights::Scale;
use crate::render::integrator::{IntegratorKind, check_spp};
use crate::table::spec::AdaptiveSpec;

/// The first stage when `first_spp` is not given (as `render --target-sd`'s default `--spp`).
pub use crate::render::adaptive::DEFAULT_FIRST_SPP;

/// A validated `"adaptive"` object: the table's columns are `targets`.
#[derive(Clone, Debug, PartialEq)]
pub struct AdaptivePlan {
    /// Target sds `T`, in the order of the spec.
    pub targets: Vec<f64>,
    pub first_spp: usize,
    pub max_spp: usize,
}

impl AdaptivePlan {
    /// The stopping rule of target `T` ([`crate::render::adaptive::AdaptiveSettings`]).
    pub fn settings(&self, target: f64) -> crate::render::adaptive::AdaptiveSettings {
        crate::render::adaptive::AdaptiveSettings::new(target, self.first_spp, self.max_spp)
    }

    /// For the manifest.
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "target_sd": self.targets,
            "first_spp": self.first_spp,
            "max_spp": self.max_spp,
            "stages": self.settings(1.0).stages,
            "rule": "each pixel doubles its samples from first_spp until the sd it states for every channel is ≤ target_sd, never on a stage with zero evidence (a channel's MC sample sd or fitted amplitude exactly 0), or max_spp",
        })
    }
}

/// `path: message`, sub-fields continuing the path ([`crate::files::spec_json::at`]).
fn err(path: impl std::fmt::Display, message: impl std::fmt::Display) -> String {
    crate::files::spec_json::at(&path.to_string(), &message.to_string())
}

/// Checks the targets and stages. `spp_given`: the table also lists `spp`, which an adaptive
/// table does not use (its samples per pixel are the stages), so it is refused as ambiguous.
pub fn resolve(a: &AdaptiveSpec, spp_given: Option<&[u64]>) -> Result<AdaptivePlan, String> {
    if let Some(spp) = spp_given {
        return Err(err(
            "spp",
            format!(
                "{spp:?}: a table with \"adaptive\" takes its samples per pixel from adaptive.first_spp doubling up \
                 to adaptive.max_spp; remove spp (or put fixed-spp variants in a table of their own)"
            ),
        ));
    }
    if a.target_sd.is_empty() {
        return Err(err("adaptive.target_sd", "must list at least one target sd"));
    }
    let mut targets: Vec<f64> = Vec::new();
    for (k, &t) in a.target_sd.iter().enumerate() {
        if !(t.is_finite() && t > 0.0) {
            return Err(err(
                format!("adaptive.target_sd[{k}]"),
                format!("must be finite and > 0, got {}", crate::util::shown::shown(t)),
            ));
        }
        if targets.contains(&t) {
            return Err(err(
                format!("adaptive.target_sd[{k}]"),
                format!("{t} is listed twice"),
            ));
        }
        targets.push(t);
    }
    let first_spp = a
        .first_spp
        .map_or(DEFAULT_FIRST_SPP, |f| usize::try_from(f).unwrap_or(usize::MAX));
    if first_spp == 0 {
        return Err(err("adaptive.first_spp", "must be at least 1, got 0"));
    }
    let max_spp = usize::try_from(a.max_spp).unwrap_or(usize::MAX);
    if max_spp < first_spp {
        return Err(err(
            "adaptive.max_spp",
            format!(
                "{max_spp} is below the first stage adaptive.first_spp = {first_spp}{}",
                if a.first_spp.is_none() {
                    " (the default pilot; give a smaller first_spp)"
                } else {
                    ""
                }
            ),
        ));
    }
    Ok(AdaptivePlan {
        targets,
        first_spp,
        max_spp,
    })
}

/// Checks that variant `at` (integrator `kind`, `scale` as written) can run adaptively.
pub fn check_variant(
    plan: &AdaptivePlan,
    kind: IntegratorKind,
    scale: Option<Scale>,
    at: &str,
) -> Result<(), String> {
    if !kind.adaptive() {
        return Err(err(
            format!("{at}.integrator"),
            format!(
                "{kind} cannot sample adaptively: a table with \"adaptive\" needs an estimator with a per-pixel sd \
                 it can extend by stages ({})",
                IntegratorKind::adaptive_names()
            ),
        ));
    }
    if let Some(s) = scale.filter(|&s| s != Scale::Ml) {
        return Err(err(
            format!("{at}.scale"),
            format!(
                "{:?}: adaptive BMC states the ml amplitude's sd (the rule extends ‖L⁻¹Y‖² stage by stage); use \"ml\" or leave it out",
                s.name()
            ),
        ));
    }
    if !kind.method.has_interval(plan.first_spp) {
        return Err(err(
            "adaptive.first_spp",
            format!(
                "{} with {at} ({kind}): the first stage of adaptive {} needs at least {} samples to state an interval",
                plan.first_spp,
                kind.method.name().to_uppercase(),
                kind.method.min_interval_points()
            ),
        ));
    }
    for (n, field) in [(plan.first_spp, "first_spp"), (plan.max_spp, "max_spp")] {
        check_spp(kind, n, field).map_err(|e| {
            err(
                format!("adaptive.{field} with {at} ({kind})"),
                e.0.trim_start_matches(&format!("{field}: ")),
            )
        })?;
    }
    Ok(())
}
