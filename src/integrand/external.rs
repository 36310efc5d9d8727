//! Integrands defined outside the library: a function of batches of directions (in Python,
//! `workbench.run(spec, integrands={"name": f})`), with a truth given by its author or computed by
//! the adaptive cubature of [`crate::util::cubature`] to a stated error estimate.
//!
//! The function is called once per point set (a trial's N points of one design, a tolerance
//! estimator's nested set, a cubature round), never per point. It must be a pure function of its
//! directions: the trials run on worker threads in no fixed order, and the byte-identical outputs
//! whatever the thread count rest on every call giving the same values for the same points.

use crate::util::cubature;
use crate::util::geometry::Vec3;
use std::sync::Arc;

/// A batch of unit directions (local frame, `z ≥ 0`) to as many values, or a one-line message.
pub type BatchFn = dyn Fn(&[Vec3]) -> Result<Vec<f64>, String> + Send + Sync;

/// `"type": "python"` of an experiment's `integrands`: where the values come from is the
/// caller's (the Python bindings map `name` to a callable).
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ExternalSpec {
    /// Always `"python"`.
    #[serde(rename = "type")]
    pub kind: ExternalKind,
    /// The integrand's name in outputs (a file name), and the key of its callable.
    pub name: String,
    /// What it is, for titles and legends; default the name.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub display_name: Option<String>,
    /// `∫_H f dω` when known; otherwise computed by adaptive cubature.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth: Option<f64>,
    /// The cubature's target error estimate (absolute, > 0); default `1e-10 · ∫_H |f| dω`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<f64>,
}

/// The one external kind so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum ExternalKind {
    Python,
}

/// Where an external integrand's truth comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Truth {
    /// Given by the integrand's author.
    Given,
    /// Computed by [`cubature::hemisphere`].
    Cubature(cubature::Cubature),
}

/// An integrand given as a batch function, with its truth.
#[derive(Clone)]
pub struct ExternalIntegrand {
    pub name: String,
    pub display_name: String,
    f: Arc<BatchFn>,
    truth: f64,
    pub truth_source: Truth,
}

impl std::fmt::Debug for ExternalIntegrand {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ExternalIntegrand")
            .field("name", &self.name)
            .field("truth", &self.truth)
            .field("truth_source", &self.truth_source)
            .finish_non_exhaustive()
    }
}

impl PartialEq for ExternalIntegrand {
    /// Equal when the same function under the same name with the same truth.
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
            && self.truth.to_bits() == other.truth.to_bits()
            && Arc::ptr_eq(&self.f, &other.f)
    }
}

impl ExternalIntegrand {
    /// The integrand of `spec` with values from `f`: the given truth (finite), or the cubature's
    /// to `spec.tolerance`. Errors name the JSON field (the caller checks the name).
    pub fn new(spec: &ExternalSpec, f: Arc<BatchFn>) -> Result<Self, String> {
        if let Some(t) = spec.tolerance {
            if spec.truth.is_some() {
                return Err("tolerance: is the computed truth's; with \"truth\" given there is none".into());
            }
            if !(t > 0.0 && t.is_finite()) {
                return Err(format!(
                    "tolerance: must be a positive number, got {}",
                    crate::util::shown::shown(t)
                ));
            }
        }
        let (truth, truth_source) = match spec.truth {
            Some(t) if !t.is_finite() => return Err(format!("truth: must be a finite number, got {t}")),
            Some(t) => (t, Truth::Given),
            None => {
                let mut batch = |p: &[Vec3]| checked(&*f, p);
                let c = cubature::hemisphere(&mut batch, spec.tolerance).map_err(|e| match e {
                    // Not the integrand's fault: the tolerance is out of the cubature's reach.
                    cubature::Failure::NotReached { error, .. } => format!(
                        "tolerance: {e}; the integrand's values were fine, the tolerance is beyond \
                         what the cubature reaches for it: give \"truth\" (∫ f dω, if known) or a \
                         \"tolerance\" of at least {}",
                        reachable(error)
                    ),
                    _ => format!("truth: computing ∫ f dω: {e}"),
                })?;
                (c.value, Truth::Cubature(c))
            }
        };
        Ok(ExternalIntegrand {
            name: spec.name.clone(),
            display_name: spec.display_name.clone().unwrap_or_else(|| spec.name.clone()),
            f,
            truth,
            truth_source,
        })
    }

    /// `I = ∫_H f dω`: given, or the cubature's value.
    pub fn integral(&self) -> f64 {
        self.truth
    }

    /// The values at `points`: as many as points, every one finite; otherwise a message saying
    /// what was wrong (the caller adds which trial and N).
    pub fn values(&self, points: &[Vec3]) -> Result<Vec<f64>, String> {
        checked(&*self.f, points)
    }
}

/// A round tolerance above the error estimate `error` that the cubature reached: the
/// smallest `d·10^k` (d = 1, 2, 5) at least twice it, as text (`2e-9`).
fn reachable(error: f64) -> String {
    let target = 2.0 * error;
    let k = target.log10().floor() as i32;
    for d in [1.0, 2.0, 5.0] {
        if d * 10f64.powi(k) >= target {
            return format!("{d}e{k}");
        }
    }
    format!("1e{}", k + 1)
}

/// `f(points)`, checked: one value per point, all finite.
fn checked(f: &BatchFn, points: &[Vec3]) -> Result<Vec<f64>, String> {
    let values = f(points)?;
    if values.len() != points.len() {
        return Err(format!(
            "returned {} values for {} directions (expected one per direction)",
            values.len(),
            points.len()
        ));
    }
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        let w = points[i];
        return Err(format!(
            "value {} at direction [{}, {}, {}] (row {i}) is not finite",
            values[i], w.x, w.y, w.z
        ));
    }
    Ok(values)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(truth: Option<f64>, tolerance: Option<f64>) -> ExternalSpec {
        ExternalSpec {
            kind: ExternalKind::Python,
            name: "f".into(),
            display_name: None,
            truth,
            tolerance,
        }
    }

    /// A tilted sharp lobe against the lobe family's closed form (math.md §1): the cubature's
    /// truth lies within its error estimate, which meets the tolerance.
    #[test]
    fn computed_truth_matches_a_family() {
        let family: crate::integrand::family::FamilySpec = serde_json::from_str(
            r#"{"type": "lobe", "axis": [0.5, 0, 0.866], "exponent": 200, "cosine": true}"#,
        )
        .unwrap();
        let g = family.resolve().unwrap();
        let h = g.clone();
        let f: Arc<BatchFn> = Arc::new(move |p: &[Vec3]| Ok(p.iter().map(|w| h.value(w)).collect()));
        let e = ExternalIntegrand::new(&spec(None, Some(1e-9)), f).unwrap();
        let Truth::Cubature(c) = e.truth_source else {
            panic!("computed")
        };
        assert!(c.error <= 1e-9, "{c:?}");
        assert!(
            (e.integral() - g.integral()).abs() <= c.error,
            "{c:?} vs {}",
            g.integral()
        );
    }

    /// Wrong lengths, non-finite values and bad fields are errors naming what was wrong.
    #[test]
    fn refuses_bad_values_and_fields() {
        let short: Arc<BatchFn> = Arc::new(|p: &[Vec3]| Ok(vec![1.0; p.len() - 1]));
        let e = ExternalIntegrand::new(&spec(Some(1.0), None), short).unwrap();
        let p = [Vec3::new(0.0, 0.0, 1.0); 3];
        assert!(
            e.values(&p)
                .unwrap_err()
                .contains("returned 2 values for 3 directions")
        );
        let nan: Arc<BatchFn> = Arc::new(|p: &[Vec3]| Ok(vec![f64::NAN; p.len()]));
        let e = ExternalIntegrand::new(&spec(Some(1.0), None), nan.clone()).unwrap();
        assert!(e.values(&p).unwrap_err().contains("is not finite"));
        assert!(
            ExternalIntegrand::new(&spec(None, None), nan.clone())
                .unwrap_err()
                .starts_with("truth: ")
        );
        assert!(ExternalIntegrand::new(&spec(Some(f64::INFINITY), None), nan.clone()).is_err());
        // A tolerance out of the cubature's reach (a step along a curve) is the tolerance's
        // fault, named as such with the remedy, not the integrand's.
        let step: Arc<BatchFn> =
            Arc::new(|p: &[Vec3]| Ok(p.iter().map(|w| f64::from(u8::from(w.x > 0.3))).collect()));
        let e = ExternalIntegrand::new(&spec(None, None), step).unwrap_err();
        assert!(
            e.starts_with("tolerance: the cubature did not reach the default tolerance"),
            "{e}"
        );
        assert!(
            e.contains("the integrand's values were fine") && e.contains("give \"truth\""),
            "{e}"
        );
        assert!(ExternalIntegrand::new(&spec(None, Some(-1.0)), nan.clone()).is_err());
        assert!(ExternalIntegrand::new(&spec(Some(1.0), Some(1e-3)), nan).is_err());
    }
}
