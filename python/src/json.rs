//! A Python value (a spec dict, a kernel dict, an integrand dict) as JSON text, checked on the
//! way: the one door through which every dict argument reaches the library's JSON parser.
//!
//! `json.dumps(…, allow_nan=False)` said "Out of range float values are not JSON compliant"
//! without naming the field, turned a set into a `TypeError` message without its place, and
//! int keys into strings silently. Here every value that JSON cannot hold is refused with its
//! path, in the library's form (`integrands[0].truth: …`, `kernel.s: …`). What JSON can hold is
//! written as `json.dumps` writes it (shortest round-trip floats, ints in full, keys in the
//! dict's order), so the library parses the same spec.

use crate::arrays::describe;
use crate::value_error;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyFrozenSet, PyInt, PyList, PySet, PyString, PyTuple};

/// `value` as JSON text; errors are `ValueError`s `path: …` (`path` the argument's name, or
/// empty for a spec whose fields are named from its root).
pub fn to_json(value: &Bound<'_, PyAny>, path: &str) -> PyResult<String> {
    let mut out = String::new();
    let numpy = value.py().import("numpy")?;
    let kinds = (
        numpy.getattr("integer")?,
        numpy.getattr("floating")?,
        numpy.getattr("bool_")?,
    );
    write(value, path, &kinds, &mut out, 0)?;
    Ok(out)
}

/// How deep a spec may nest (a self-containing list would otherwise recurse without end).
const MAX_DEPTH: usize = 64;

type Kinds<'py> = (Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>);

fn at(path: &str, message: String) -> PyErr {
    if path.is_empty() {
        value_error(message)
    } else {
        value_error(format!("{path}: {message}"))
    }
}

fn child(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

fn number(path: &str, v: f64, out: &mut String) -> PyResult<()> {
    if !v.is_finite() {
        // As Python writes them.
        let shown = if v.is_nan() {
            "nan"
        } else if v > 0.0 {
            "inf"
        } else {
            "-inf"
        };
        return Err(at(
            path,
            format!("must be a finite number, got {shown} (JSON has no NaN or infinity)"),
        ));
    }
    out.push_str(&serde_json::Number::from_f64(v).expect("finite").to_string());
    Ok(())
}

fn write(
    value: &Bound<'_, PyAny>,
    path: &str,
    kinds: &Kinds<'_>,
    out: &mut String,
    depth: usize,
) -> PyResult<()> {
    if depth > MAX_DEPTH {
        return Err(at(path, format!("nested more than {MAX_DEPTH} levels deep")));
    }
    if value.is_none() {
        out.push_str("null");
    } else if let Ok(b) = value.cast::<PyBool>() {
        out.push_str(if b.is_true() { "true" } else { "false" });
    } else if value.is_instance(&kinds.2)? {
        out.push_str(if value.is_truthy()? { "true" } else { "false" });
    } else if let Ok(i) = value.cast::<PyInt>() {
        // Every int in full, as json.dumps writes it (the library's parser says what is too big).
        out.push_str(&i.str()?.to_string());
    } else if value.is_instance(&kinds.0)? {
        out.push_str(&value.call_method0("__index__")?.str()?.to_string());
    } else if let Ok(f) = value.cast::<PyFloat>() {
        number(path, f.value(), out)?;
    } else if value.is_instance(&kinds.1)? {
        number(path, value.extract()?, out)?;
    } else if let Ok(a) = value.cast::<numpy::PyUntypedArray>() {
        // A numpy array (a normal, an axis) as its nested lists.
        let _ = a;
        write(&value.call_method0("tolist")?, path, kinds, out, depth + 1)?;
    } else if let Ok(s) = value.cast::<PyString>() {
        out.push_str(&serde_json::Value::String(s.to_str()?.to_string()).to_string());
    } else if let Ok(d) = value.cast::<PyDict>() {
        out.push('{');
        for (k, (key, v)) in d.iter().enumerate() {
            let Ok(key) = key.cast::<PyString>() else {
                return Err(at(
                    path,
                    format!("keys must be str (JSON's are), got the key {}", describe(&key)),
                ));
            };
            let key = key.to_str()?;
            if k > 0 {
                out.push(',');
            }
            out.push_str(&serde_json::Value::String(key.to_string()).to_string());
            out.push(':');
            write(&v, &child(path, key), kinds, out, depth + 1)?;
        }
        out.push('}');
    } else if value.cast::<PyList>().is_ok() || value.cast::<PyTuple>().is_ok() {
        out.push('[');
        for (i, v) in value.try_iter()?.enumerate() {
            if i > 0 {
                out.push(',');
            }
            write(&v?, &format!("{path}[{i}]"), kinds, out, depth + 1)?;
        }
        out.push(']');
    } else if value.cast::<PySet>().is_ok() || value.cast::<PyFrozenSet>().is_ok() {
        return Err(at(
            path,
            format!(
                "must be a list, got {} (a set has no order; JSON has no sets)",
                describe(value)
            ),
        ));
    } else {
        return Err(at(
            path,
            format!(
                "must be a JSON value (None, bool, int, float, str, list or dict), got {}",
                describe(value)
            ),
        ));
    }
    Ok(())
}
