//! The integrands of experiment files (`"cos3"`, the lobe, cap and Gaussian families, scene
//! pixels, maps seen from a surface) with their certified truths.

use crate::arrays;
use crate::value_error;
use pyo3::prelude::*;
use pyo3::types::PyString;
use workbench::experiment::spec::{FamilySpec, IntegrandSpec};

/// An integrand of experiment files with its exact integral: ``Integrand("cos3")``
/// (cos^k θ, truth 2π/(k+1)) or a family dict: ``{"type": "lobe", "axis": [...], "exponent":
/// e}``, ``"cap"`` (``half_angle`` in degrees), ``"gaussian"`` (``sharpness``), each with
/// ``"cosine": true`` for the × cos θ version and an optional ``"name"``; or a render-scene
/// ``{"type": "pixel", "pixel": [i, j], "channel": "g", ...}``.
#[pyclass(frozen, module = "workbench")]
pub struct Integrand {
    f: workbench::integrand::Integrand,
}

#[pymethods]
impl Integrand {
    /// `Integrand(spec)`: a name (`"cos3"`: cos^k θ) or a family dict as in experiment files
    /// (`{"type": "lobe", "axis": [0.5, 0, 0.866], "exponent": 8}`, `cap`, `gaussian`, `pixel`,
    /// `{"type": "envmap", "env": "pisa", "normal": [0, 1, 0]}`).
    #[new]
    fn new(py: Python<'_>, spec: &Bound<'_, PyAny>) -> PyResult<Integrand> {
        let spec = if let Ok(name) = spec.cast::<PyString>() {
            IntegrandSpec::Named(name.to_str()?.to_string())
        } else {
            let text =
                crate::json::to_json(spec, "").map_err(|e| value_error(format!("spec: {}", e.value(py))))?;
            let family: FamilySpec = workbench::files::spec_json::parse(&text, "the integrand")
                .map_err(|m| value_error(format!("spec: {m}")))?;
            IntegrandSpec::Family(family)
        };
        // A pixel's or a map's truth is a certified quadrature (up to seconds): without the GIL.
        let f = py
            .detach(|| workbench::experiment::plan::resolve_integrand(&spec))
            .map_err(|m| value_error(format!("spec: {m}")))?;
        Ok(Integrand { f })
    }

    /// The name in ``trials.csv`` (``cos3``, ``lobe8-tilt30``).
    #[getter]
    fn name(&self) -> String {
        self.f.name()
    }

    /// For people: ``cos³θ``, ``Phong lobe e = 8, tilt 30°``.
    #[getter]
    fn display_name(&self) -> String {
        self.f.display_name()
    }

    /// ``I = ∫_H f dω``: the ``truth`` column of ``trials.csv``.
    #[getter]
    fn truth(&self) -> f64 {
        self.f.integral()
    }

    /// The oracle prior ``c = I/2π`` (BMCP's ``"prior": "analytic"``).
    #[getter]
    fn constant_prior(&self) -> f64 {
        self.f.constant_prior()
    }

    /// `f(points)`: the values at directions in the local frame (normal `+z`), a float64 array of
    /// shape `(n, 3)` of unit vectors with `z ≥ 0`.
    fn __call__<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, numpy::PyArray1<f64>>> {
        let points = arrays::points(points, "points")?;
        let values = py.detach(|| points.iter().map(|w| self.f.value(w)).collect());
        Ok(arrays::vector(py, values))
    }

    fn __repr__(&self) -> String {
        format!(
            "workbench.Integrand({:?}: {}, truth {:?})",
            self.f.name(),
            self.f.display_name(),
            self.f.integral()
        )
    }
}
