//! `to_world(points, normal, azimuth=0)`: a rule's local points carried to a world normal, by
//! the library's own frame (the one the `envmap` integrand evaluates its directions in).

use crate::args::Number;
use crate::arrays::{self, describe};
use crate::value_error;
use pyo3::prelude::*;
use workbench::util::geometry::{Frame, Vec3, rotate_about_z};

/// Carries directions in the local frame (normal ``+z``) to the world: each point rotated by
/// ``azimuth`` (radians, default 0) about ``+z``, then mapped by the orthonormal frame
/// ``(t, b, n)`` about the unit ``normal`` (normalised; Duff et al., JCGT 2017 — the frame of the
/// renderer and of the ``envmap`` integrand). A rule's weights are invariant under this
/// rotation (its kernels are isotropic), so ``Rule.estimate(values)`` with values taken at
/// ``to_world(rule.points, n, φ)`` estimates the integral over the hemisphere about ``n``.
///
/// >>> points, _ = rule(16, seed=1)
/// >>> world = to_world(points, [0.0, 1.0, 0.0], azimuth=0.5)
/// >>> bool(abs(world[:, 1] - points[:, 2]).max() < 1e-12)
/// True
#[pyfunction]
#[pyo3(signature = (points, normal, azimuth=None))]
pub fn to_world<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    normal: &Bound<'py, PyAny>,
    azimuth: Option<Number>,
) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
    let points = arrays::points(points, "points")?;
    let n = normal_of(normal)?;
    let azimuth = azimuth.map(|a| a.get("azimuth")).transpose()?.unwrap_or(0.0);
    if !azimuth.is_finite() {
        return Err(value_error(format!(
            "azimuth: must be a finite angle in radians, got {azimuth}"
        )));
    }
    let frame = Frame::from_normal(n);
    let world: Vec<Vec3> = points
        .iter()
        .map(|p| frame.to_world(&rotate_about_z(p, azimuth)))
        .collect();
    Ok(arrays::points_array(py, &world))
}

/// Three finite numbers, not all zero, normalised.
fn normal_of(normal: &Bound<'_, PyAny>) -> PyResult<Vec3> {
    let bad = || {
        value_error(format!(
            "normal: must be three numbers [x, y, z] (a non-zero finite vector), got {}",
            describe(normal)
        ))
    };
    if normal.is_instance_of::<pyo3::types::PyString>() {
        return Err(bad());
    }
    let v: [f64; 3] = normal.extract().map_err(|_| bad())?;
    let w = Vec3::new(v[0], v[1], v[2]);
    let norm = w.norm();
    if !(norm.is_finite() && norm > 1e-12) {
        return Err(value_error(format!(
            "normal: must be a non-zero finite vector, got [{}, {}, {}]",
            v[0], v[1], v[2]
        )));
    }
    Ok(w / norm)
}
