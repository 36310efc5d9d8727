//! Python callables as integrands: `run(spec, integrands={"name": f})` with `{"type": "python",
//! "name": "name"}` in the spec's `integrands`. `f` maps a float64 array of shape `(n, 3)` of
//! directions to `n` values; it is called once per point set, from the run's worker threads,
//! each call taking the GIL (so one at a time), the rest of the run without it.

use crate::arrays;
use crate::value_error;
use numpy::PyArrayMethods;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use std::collections::BTreeMap;
use std::sync::Arc;
use workbench::experiment::spec::{ExperimentSpec, IntegrandSpec};
use workbench::integrand::external::BatchFn;
use workbench::util::geometry::Vec3;

/// The callables of `integrands` (a dict of str to callable) by name, each named by exactly
/// one `"type": "python"` integrand of `spec`, and every such integrand with one.
pub fn callables(
    py: Python<'_>,
    integrands: Option<&Bound<'_, PyAny>>,
    spec: &ExperimentSpec,
) -> PyResult<BTreeMap<String, Arc<BatchFn>>> {
    let named: Vec<(usize, &str)> = spec
        .integrands
        .iter()
        .enumerate()
        .filter_map(|(i, f)| match f {
            IntegrandSpec::External(e) => Some((i, e.name.as_str())),
            _ => None,
        })
        .collect();
    let mut out = BTreeMap::new();
    if let Some(d) = integrands.filter(|d| !d.is_none()) {
        let d = d.cast::<PyDict>().map_err(|_| {
            value_error(format!(
                "integrands: must be a dict of names to callables ({{\"ggx\": f}}), got {}",
                arrays::describe(d)
            ))
        })?;
        for (k, v) in d.iter() {
            let name: String = k
                .cast::<PyString>()
                .map_err(|_| {
                    value_error(format!(
                        "integrands: keys must be str, got {}",
                        arrays::describe(&k)
                    ))
                })?
                .to_str()?
                .to_string();
            if !v.is_callable() {
                return Err(value_error(format!(
                    "integrands[{name:?}]: must be callable (points of shape (n, 3) → values of shape (n,)), got {}",
                    arrays::describe(&v)
                )));
            }
            if !named.iter().any(|(_, n)| *n == name) {
                return Err(value_error(format!(
                    "integrands[{name:?}]: no integrand of the spec is {{\"type\": \"python\", \"name\": {name:?}}}"
                )));
            }
            out.insert(name.clone(), batch_fn(v.unbind()));
        }
    }
    if let Some((i, name)) = named.iter().find(|(_, n)| !out.contains_key(*n)) {
        return Err(value_error(format!(
            "integrands[{i}]: {{\"type\": \"python\", \"name\": {name:?}}} has no callable; pass \
             run(spec, integrands={{{name:?}: f}})"
        )));
    }
    let _ = py;
    Ok(out)
}

/// `f` as a batch function: the points as a float64 array of shape `(n, 3)`, the result through
/// `numpy.asarray(…, dtype=float64)`, which must have shape `(n,)`.
fn batch_fn(f: Py<PyAny>) -> Arc<BatchFn> {
    Arc::new(move |points: &[Vec3]| -> Result<Vec<f64>, String> {
        Python::attach(|py| {
            let array = arrays::points_array(py, points);
            let raised = |e: PyErr| {
                let kind = e.get_type(py).name().map_or("?".into(), |n| n.to_string());
                format!("the callable raised {kind}: {}", e.value(py))
            };
            let result = f.call1(py, (array,)).map_err(raised)?;
            let result = result.bind(py);
            let numpy = py.import("numpy").map_err(raised)?;
            // The values' own kind first: `asarray(…, dtype=float64)` would cut complex values to
            // their real part (with only a ComplexWarning) and parse strings as numbers.
            if let Ok(kind) = numpy
                .getattr("asarray")
                .and_then(|a| a.call1((result,)))
                .and_then(|a| a.getattr("dtype"))
                .and_then(|d| d.getattr("kind"))
                .and_then(|k| k.extract::<String>())
            {
                let what = match kind.as_str() {
                    "b" | "i" | "u" | "f" => None,
                    "c" => Some(
                        "complex values (an integral of real values is what is estimated: return the real part, or the modulus, yourself)",
                    ),
                    "U" | "S" => Some("strings"),
                    "O" => Some("Python objects that are not all real numbers"),
                    _ => Some("values that are not real numbers"),
                };
                if let Some(what) = what {
                    return Err(format!(
                        "returned {what}: {}, not an array of {} float64 values",
                        arrays::describe(result),
                        points.len()
                    ));
                }
            }
            let kwargs = PyDict::new(py);
            kwargs
                .set_item("dtype", numpy.getattr("float64").map_err(raised)?)
                .map_err(raised)?;
            let converted = numpy
                .getattr("asarray")
                .and_then(|a| a.call((result,), Some(&kwargs)))
                .map_err(|_| {
                    format!(
                        "returned {}, not an array of {} float64 values",
                        arrays::describe(result),
                        points.len()
                    )
                })?;
            let values = converted.cast::<numpy::PyArray1<f64>>().map_err(|_| {
                format!(
                    "returned {}; expected shape ({},), one value per direction",
                    arrays::describe(result),
                    points.len()
                )
            })?;
            let values = values.readonly();
            let v = values
                .as_slice()
                .map(|s| s.to_vec())
                .unwrap_or_else(|_| values.as_array().to_vec());
            if v.len() != points.len() {
                return Err(format!(
                    "returned {}; expected shape ({},), one value per direction",
                    arrays::describe(result),
                    points.len()
                ));
            }
            Ok(v)
        })
    })
}
