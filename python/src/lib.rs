//! `workbench._workbench`: the Python bindings of the workbench library (PyO3).
//!
//! Everything numerical is the library's own code, called as the command line calls it, so the
//! numbers are the CLI's to the bit (`python/tests/` compares them with the CLI's CSVs). This
//! crate only converts arguments, checks them and turns every library error into a `ValueError`
//! carrying the library's one-line message, with the Python argument's name where the CLI would
//! name a flag. Nothing here may panic on bad input: every argument is checked before a library
//! function that asserts on it is called.

mod args;
mod arrays;
mod external;
mod frame;
mod integrand;
mod json;
mod memory;
mod model;
mod pss;
mod rule;
mod run;

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// A `ValueError` with `message`.
pub(crate) fn value_error(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}

/// A library error as a `ValueError`: its message and its causes, joined by `: ` (what the CLI
/// prints after `Error: `).
pub(crate) fn library_error(e: workbench::Error) -> PyErr {
    let mut message = e.to_string();
    let mut source = std::error::Error::source(&e);
    while let Some(s) = source {
        message.push_str(": ");
        message.push_str(&s.to_string());
        source = s.source();
    }
    value_error(message)
}

#[pymodule]
fn _workbench(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(rule::rule, m)?)?;
    m.add_function(wrap_pyfunction!(rule::weights, m)?)?;
    m.add_function(wrap_pyfunction!(rule::kernel_means, m)?)?;
    m.add_function(wrap_pyfunction!(rule::prior_variance, m)?)?;
    m.add_function(wrap_pyfunction!(rule::fit, m)?)?;
    m.add_function(wrap_pyfunction!(rule::estimate, m)?)?;
    m.add_function(wrap_pyfunction!(rule::estimate_core_seconds, m)?)?;
    m.add_class::<rule::Rule>()?;
    m.add_class::<integrand::Integrand>()?;
    m.add_function(wrap_pyfunction!(run::run, m)?)?;
    m.add_function(wrap_pyfunction!(run::trial_points, m)?)?;
    m.add_function(wrap_pyfunction!(frame::to_world, m)?)?;
    m.add_function(wrap_pyfunction!(memory::check_memory, m)?)?;
    m.add_function(wrap_pyfunction!(pss::pss_rules, m)?)?;
    m.add(
        "METHODS",
        workbench::bq::estimator::Method::ALL.map(|m| m.name()).to_vec(),
    )?;
    m.add(
        "DESIGNS",
        workbench::sampling::Design::ALL.map(|d| d.name()).to_vec(),
    )?;
    Ok(())
}
