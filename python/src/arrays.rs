//! numpy arrays in and out: points `(n, 3)` and values `(n,)` of float64, checked with messages
//! that name the argument and the bad value.

use crate::value_error;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::prelude::*;
use workbench::util::geometry::Vec3;

/// What `obj` is, for a message: `an int64 array of shape (4, 3)`, `a list`.
pub fn describe(obj: &Bound<'_, PyAny>) -> String {
    match obj.cast::<PyUntypedArray>() {
        Ok(a) => {
            let shape: Vec<String> = a.shape().iter().map(|d| d.to_string()).collect();
            let shape = if shape.len() == 1 {
                format!("({},)", shape[0])
            } else {
                format!("({})", shape.join(", "))
            };
            format!("a {} array of shape {shape}", a.dtype())
        }
        Err(_) => format!(
            "{} (a Python {})",
            obj.repr().map_or("?".into(), |r| truncate(&r.to_string())),
            obj.get_type().name().map_or("?".into(), |n| n.to_string())
        ),
    }
}

fn truncate(s: &str) -> String {
    if s.chars().count() > 60 {
        format!("{}…", s.chars().take(60).collect::<String>())
    } else {
        s.to_string()
    }
}

/// Points in the local frame (normal `+z`): a float64 array of shape `(n, 3)`, `n ≥ 1`, every
/// row a unit vector (`|‖p‖ − 1| ≤ 1e-9`) with `z ≥ 0`, as `workbench rule --points` requires.
pub fn points(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<Vec3>> {
    let bad = || {
        value_error(format!(
            "{name}: must be a float64 numpy array of shape (n, 3) (unit directions, one per row), got {}",
            describe(obj)
        ))
    };
    let array = obj.cast::<PyArray2<f64>>().map_err(|_| bad())?;
    let view = array.readonly();
    let view = view.as_array();
    if view.ncols() != 3 || view.nrows() == 0 {
        return Err(bad());
    }
    let mut out = Vec::with_capacity(view.nrows());
    for (i, row) in view.rows().into_iter().enumerate() {
        let p = Vec3::new(row[0], row[1], row[2]);
        workbench::bq::rule::check_point(p).map_err(|m| value_error(format!("{name}[{i}]: {m}")))?;
        out.push(p);
    }
    Ok(out)
}

/// Values of an integrand at `n` points: a float64 array of shape `(n,)` of finite numbers.
pub fn values(obj: &Bound<'_, PyAny>, name: &str, n: usize) -> PyResult<Vec<f64>> {
    let bad = || {
        value_error(format!(
            "{name}: must be a float64 numpy array of shape ({n},) (one value per point), got {}",
            describe(obj)
        ))
    };
    let array = obj.cast::<PyArray1<f64>>().map_err(|_| bad())?;
    let view = array.readonly();
    let view = view.as_array();
    if view.len() != n {
        return Err(bad());
    }
    let mut out = Vec::with_capacity(n);
    for (i, &v) in view.iter().enumerate() {
        if !v.is_finite() {
            return Err(value_error(format!("{name}[{i}]: {v} is not a finite number")));
        }
        out.push(v);
    }
    Ok(out)
}

/// Points as a float64 array of shape `(n, 3)`.
pub fn points_array<'py>(py: Python<'py>, points: &[Vec3]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = points.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    Array2::from_shape_vec((points.len(), 3), flat)
        .expect("three coordinates per point")
        .into_pyarray(py)
}

/// A vector as a float64 array.
pub fn vector<'py>(py: Python<'py>, v: Vec<f64>) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_vec(py, v)
}
