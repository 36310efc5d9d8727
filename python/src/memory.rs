//! `check_memory(what, bytes)`: the library's memory guard (`workbench::util::memory::check`) for
//! callers that hold many rules at once (the Mitsuba integrator's K rules of N points), so that
//! their plan is refused against the same budget (`WORKBENCH_MEMORY`) with the same one line.

use pyo3::prelude::*;

use crate::value_error;

/// The library's memory guard: ``ValueError`` with one line naming ``what``, the bytes and the
/// budget (``WORKBENCH_MEMORY``, else 3/4 of the machine's memory) when ``bytes`` is more than
/// the budget or cannot be allocated now. For callers that plan many rules at once (the Mitsuba
/// integrator's ``rules × n²`` factors).
#[pyfunction]
pub fn check_memory(what: &str, bytes: u64) -> PyResult<()> {
    workbench::util::memory::check(what, bytes).map_err(value_error)
}
