//! Parameter sweeps: `"sweep": {"noise": [1e-2, 1e-4], "kernel.s": [1.2, 1.8]}` on an estimator
//! expands it into one estimator per combination (the Cartesian product, keys in alphabetical
//! order, the last key varying fastest — like Hydra's multirun), each labelled by filling the
//! estimator's `label` template (`"BMC s={kernel.s} σ²={noise}"`) with the combination's values.
//! Duplicate labels after expansion are an error (a template without placeholders gives them).

use super::spec::EstimatorSpec;
use serde_json::Value;

/// The fields a sweep may vary: the estimator's options, and the kernel's parameters.
pub const KEYS: [&str; 12] = [
    "design",
    "noise",
    "kernel_mean",
    "kernel_mean_samples",
    "prior",
    "scale",
    "kernel.type",
    "kernel.s",
    "kernel.sigma",
    "kernel.length",
    "tolerance.abs",
    "tolerance.max_n",
];

/// One estimator after expansion, with the JSON path its messages name.
pub struct Expanded {
    pub path: String,
    pub spec: EstimatorSpec,
}

/// Expands every estimator's sweep; estimators without one pass through unchanged.
pub fn expand(estimators: &[EstimatorSpec]) -> Result<Vec<Expanded>, String> {
    let mut out = Vec::new();
    for (i, e) in estimators.iter().enumerate() {
        let path = format!("estimators[{i}]");
        let Some(sweep) = &e.sweep else {
            out.push(Expanded {
                path,
                spec: e.clone(),
            });
            continue;
        };
        if sweep.is_empty() {
            return Err(format!("{path}.sweep: must name at least one field to vary"));
        }
        for (key, values) in sweep {
            if !KEYS.contains(&key.as_str()) {
                return Err(format!(
                    "{path}.sweep: unknown key {key:?} (expected one of {})",
                    KEYS.join(", ")
                ));
            }
            if values.is_empty() {
                return Err(format!("{path}.sweep.{key}: must list at least one value"));
            }
        }
        let mut base = serde_json::to_value(e).expect("specs serialize");
        base.as_object_mut().expect("an object").remove("sweep");
        for combination in product(sweep) {
            let mut v = base.clone();
            for (key, value) in &combination {
                set(&mut v, key, value.clone());
            }
            let label = fill(&e.label, &combination);
            v["label"] = Value::String(label.clone());
            let spec: EstimatorSpec = serde_json::from_value(v)
                .map_err(|err| format!("{path}.sweep ({}): {err}", describe(&combination)))?;
            out.push(Expanded {
                path: format!("{path} (sweep {})", describe(&combination)),
                spec,
            });
        }
    }
    Ok(out)
}

/// Every combination, the last key varying fastest.
fn product(sweep: &std::collections::BTreeMap<String, Vec<Value>>) -> Vec<Vec<(String, Value)>> {
    let mut all: Vec<Vec<(String, Value)>> = vec![Vec::new()];
    for (key, values) in sweep {
        all = all
            .into_iter()
            .flat_map(|prefix| {
                values.iter().map(move |v| {
                    let mut c = prefix.clone();
                    c.push((key.clone(), v.clone()));
                    c
                })
            })
            .collect();
    }
    all
}

/// Sets `key` (`noise` or `kernel.s`) in the estimator's JSON; a kernel parameter on an
/// estimator without a kernel starts from the default kernel (Sobolev).
fn set(v: &mut Value, key: &str, value: Value) {
    match key.split_once('.') {
        None => v[key] = value,
        Some((outer, inner)) => {
            if !v[outer].is_object() {
                // A swept kernel parameter without a kernel: the default kernel's family.
                v[outer] = if outer == "kernel" {
                    serde_json::json!({ "type": "sobolev" })
                } else {
                    serde_json::json!({})
                };
            }
            v[outer][inner] = value;
        }
    }
}

/// A value as it reads in a label: numbers in shortest form, strings without quotes.
fn show(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// `noise=0.0001, kernel.s=1.8`.
fn describe(combination: &[(String, Value)]) -> String {
    combination
        .iter()
        .map(|(k, v)| format!("{k}={}", show(v)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The label template with `{key}` replaced by the combination's values.
fn fill(template: &str, combination: &[(String, Value)]) -> String {
    let mut label = template.to_string();
    for (key, value) in combination {
        label = label.replace(&format!("{{{key}}}"), &show(value));
    }
    label
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(json: &str) -> EstimatorSpec {
        serde_json::from_str(json).unwrap()
    }

    #[test]
    fn a_sweep_expands_into_labelled_estimators() {
        let e = spec(
            r#"{"label": "BMC s={kernel.s} n={noise}", "method": "bmc",
                "sweep": {"noise": [0.01, 1e-4], "kernel.s": [1.2, 1.4, 1.8]}}"#,
        );
        let out = expand(&[e]).unwrap();
        let labels: Vec<&str> = out.iter().map(|x| x.spec.label.as_str()).collect();
        assert_eq!(
            labels,
            [
                "BMC s=1.2 n=0.01",
                "BMC s=1.2 n=0.0001",
                "BMC s=1.4 n=0.01",
                "BMC s=1.4 n=0.0001",
                "BMC s=1.8 n=0.01",
                "BMC s=1.8 n=0.0001"
            ]
        );
        assert_eq!(out[3].spec.noise, Some(1e-4));
        assert!(out.iter().all(|x| x.spec.sweep.is_none()));
        assert_eq!(out[1].path, "estimators[0] (sweep kernel.s=1.2, noise=0.0001)");
    }

    #[test]
    fn bad_sweeps_name_the_key() {
        let e = spec(r#"{"label": "x", "method": "bmc", "sweep": {"kernel.q": [1]}}"#);
        assert!(
            expand(&[e])
                .err()
                .unwrap()
                .starts_with("estimators[0].sweep: unknown key \"kernel.q\"")
        );
        let e = spec(r#"{"label": "x", "method": "bmc", "sweep": {"noise": []}}"#);
        assert!(expand(&[e]).err().unwrap().contains("at least one value"));
        let e = spec(r#"{"label": "x", "method": "bmc", "sweep": {"noise": ["a"]}}"#);
        assert!(
            expand(&[e])
                .err()
                .unwrap()
                .starts_with("estimators[0].sweep (noise=a): invalid type")
        );
    }
}
