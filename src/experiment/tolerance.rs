//! Validation of tolerance estimators and `within_tolerance` checks ([`crate::bq::stages`];
//! docs/guide/run.md, "Stopping at a tolerance"): what the plan asks before anything runs.

use super::spec::{CheckSpec, EstimatorSpec, ExperimentSpec, KernelMeanName};
use crate::bq::estimator::Method;
use crate::bq::stages::{self, Tolerance};
use crate::sampling::Design;
use serde::Serialize;

/// The estimator's tolerance, validated against its method, design, model and the sample counts
/// (its first stages); `unit_points` is the most points a unit may draw without weights. None
/// without one.
pub fn resolve_tolerance(
    e: &EstimatorSpec,
    method: Method,
    design: Design,
    samples: &[u64],
    unit_points: u64,
    at: &dyn Fn(&str) -> String,
) -> Result<Option<Tolerance>, String> {
    let Some(t) = e.tolerance else {
        return Ok(None);
    };
    if !(t.abs.is_finite() && t.abs > 0.0) {
        return Err(format!(
            "{}: must be a positive finite number, got {}",
            at("tolerance.abs"),
            crate::util::shown::shown(t.abs)
        ));
    }
    let level = t.level.unwrap_or(stages::DEFAULT_LEVEL);
    if !(level > 0.0 && level < 1.0) {
        return Err(format!(
            "{}: must be in (0, 1), got {}",
            at("tolerance.level"),
            crate::util::shown::shown(level)
        ));
    }
    let inflate = t.inflate.unwrap_or(stages::DEFAULT_INFLATE);
    if !(inflate.is_finite() && inflate >= 1.0) {
        return Err(format!(
            "{}: must be a finite number ≥ 1 (it widens the half-width), got {}",
            at("tolerance.inflate"),
            crate::util::shown::shown(inflate)
        ));
    }
    if let Some((i, &n)) = samples
        .iter()
        .enumerate()
        .max_by_key(|&(_, &n)| n)
        .filter(|&(_, &n)| n > t.max_n)
    {
        return Err(format!(
            "{}: {} is below the first stage N = {n} (samples[{i}]); a tolerance estimator starts at each \
             sample count and doubles up to max_n, so max_n must be at least the largest sample count",
            at("tolerance.max_n"),
            t.max_n
        ));
    }
    let min_n = t.min_n.unwrap_or(stages::DEFAULT_MIN_N as u64);
    if min_n == 0 {
        return Err(format!("{}: must be at least 1, got 0", at("tolerance.min_n")));
    }
    if min_n > t.max_n {
        return Err(format!(
            "{}: {min_n}{} is above max_n = {}; no stage may have fewer than min_n points, so give a \
             smaller min_n or a larger max_n",
            at("tolerance.min_n"),
            if t.min_n.is_none() {
                " (the default pilot)"
            } else {
                ""
            },
            t.max_n
        ));
    }
    let limit = if method.needs_weights() {
        crate::bq::rule::MAX_POINTS as u64
    } else {
        unit_points
    };
    if t.max_n > limit {
        return Err(format!(
            "{}: {} is above the limit of {limit} points for method {}",
            at("tolerance.max_n"),
            t.max_n,
            method
        ));
    }
    if !design.is_nested() {
        return Err(format!(
            "{}: {:?} is not nested (its first N points change with N), so a tolerance cannot extend it; \
             use uniform, cosine or sobol",
            at("design"),
            design.name()
        ));
    }
    if let Some(m) = e.kernel_mean.filter(|&m| m != KernelMeanName::Exact) {
        return Err(format!(
            "{}: {:?} draws each weight set's kernel means afresh, so a tolerance cannot extend the set; \
             use \"exact\"",
            at("kernel_mean"),
            serde_json::to_value(m).expect("names serialize")
        ));
    }
    if let Some((i, &n)) = samples
        .iter()
        .enumerate()
        .find(|&(_, &n)| !method.has_interval(n.max(min_n) as usize))
    {
        return Err(format!(
            "{}: method {} has no interval at the first stage N = {} (samples[{i}], min_n {min_n}), so it \
             cannot stop on its interval; start from N ≥ 2 or give min_n ≥ 2",
            at("tolerance"),
            method,
            n.max(min_n)
        ));
    }
    Ok(Some(Tolerance {
        abs: t.abs,
        max_n: t.max_n as usize,
        min_n: min_n as usize,
        level,
        inflate,
    }))
}

/// A resolved `{"within_tolerance": A, "level": 0.95, "from_n": n0}` check, judged in every
/// (integrand, N₀ ≥ `from_n`) cell of A ([`super::adaptive::evaluate_check`]) on two counts, each
/// against the lower end of the binomial 99% band around `level`
/// ([`super::summary::binomial_band`]), i.e. within binomial noise of the level or above: among
/// the trials the rule stopped (`met`), the share whose actual error is within A's tolerance
/// (`within_given_met`); and the share of trials the rule stopped at all (`met`), which fails on
/// its own.
#[derive(Debug, Clone, Serialize)]
pub struct ToleranceCheck {
    pub within_tolerance: String,
    pub level: f64,
    pub from_n: usize,
    #[serde(skip)]
    pub index: usize,
}

/// Check `i`, which has `within_tolerance`.
/// `estimators` are the planned estimators' labels, each with whether it has a tolerance.
pub fn resolve_check(
    spec: &ExperimentSpec,
    estimators: &[(&str, bool)],
    i: usize,
    c: &CheckSpec,
) -> Result<ToleranceCheck, String> {
    let at = |field: &str| format!("checks[{i}].{field}");
    for (field, given) in [
        ("better", c.better.is_some()),
        ("than", c.than.is_some()),
        ("alpha", c.alpha.is_some()),
        ("calibrated", c.calibrated.is_some()),
    ] {
        if given {
            return Err(format!(
                "{}: is not used by a tolerance check (\"within_tolerance\" takes \"level\" and \"from_n\")",
                at(field)
            ));
        }
    }
    let label = c.within_tolerance.as_ref().expect("a tolerance check");
    let Some(index) = estimators.iter().position(|e| e.0 == label) else {
        let known: Vec<_> = estimators.iter().map(|e| e.0).collect();
        return Err(format!(
            "{}: no estimator is labelled {label:?} (labels: {})",
            at("within_tolerance"),
            known.join(", ")
        ));
    };
    if !estimators[index].1 {
        return Err(format!(
            "{}: {label:?} has no \"tolerance\", so nothing says what within tolerance means",
            at("within_tolerance")
        ));
    }
    let from_n = c.from_n.unwrap_or(1);
    if !spec.samples.iter().any(|&n| n >= from_n) {
        return Err(format!(
            "{}: {from_n} is above every sample count, so nothing is checked",
            at("from_n")
        ));
    }
    let level = c.level.unwrap_or(0.95);
    if !(level > 0.0 && level < 1.0) {
        return Err(format!(
            "{}: must be in (0, 1), got {}",
            at("level"),
            crate::util::shown::shown(level)
        ));
    }
    Ok(ToleranceCheck {
        within_tolerance: label.clone(),
        level,
        from_n: from_n as usize,
        index,
    })
}
