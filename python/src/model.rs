//! The model arguments (`kernel`, `noise`, `kernel_mean`, `kernel_mean_samples`) → the library's
//! [`ModelSpec`], resolved by its own parser and defaults (the experiment files' and the CLI's),
//! built once per distinct model and kept: tabulating a kernel's exact means takes ~10 ms.

use crate::args::{self, Number, Text, Whole};
use crate::value_error;
use pyo3::prelude::*;
use pyo3::types::PyString;
use std::sync::{Arc, Mutex};
use workbench::bq::model::{BmcModel, KernelMeanName, ModelSpec, ResolvedModel};

/// The model as given to a Python function; `None` means the default.
pub struct ModelArgs<'py> {
    /// `"sobolev"`, `"se"`, `"fitted"` or a JSON-style dict (`{"type": "sobolev", "s": 2.75}`).
    pub kernel: Option<Bound<'py, PyAny>>,
    pub noise: Option<f64>,
    pub kernel_mean: Option<String>,
    pub kernel_mean_samples: Option<u64>,
}

impl<'py> ModelArgs<'py> {
    /// The model arguments as they came ([`crate::args`]), each checked for its type.
    pub fn new(
        kernel: Option<Bound<'py, PyAny>>,
        noise: Option<Number>,
        kernel_mean: Option<Text>,
        kernel_mean_samples: Option<Whole>,
    ) -> PyResult<Self> {
        Ok(ModelArgs {
            kernel,
            noise: args::number_opt(noise.as_ref(), "noise")?,
            kernel_mean: args::text_opt(kernel_mean.as_ref(), "kernel_mean")?.map(String::from),
            kernel_mean_samples: args::whole_opt(kernel_mean_samples.as_ref(), "kernel_mean_samples")?,
        })
    }

    /// The model spec: the kernel parsed as an experiment file's `"kernel"` (so the same
    /// messages: `kernel.s: invalid type: …`), the rest as given.
    pub fn spec(&self, _py: Python<'_>) -> PyResult<ModelSpec> {
        let kernel = match &self.kernel {
            None => None,
            Some(k) => {
                let json = if let Ok(name) = k.cast::<PyString>() {
                    serde_json::json!({ "type": name.to_str()? }).to_string()
                } else {
                    crate::json::to_json(k, "kernel")?
                };
                let spec: ModelSpec =
                    workbench::files::spec_json::parse(&format!("{{\"kernel\": {json}}}"), "the model")
                        .map_err(|m| {
                            if m.starts_with("kernel") {
                                value_error(m)
                            } else {
                                value_error(format!("kernel: {m}"))
                            }
                        })?;
                spec.kernel
            }
        };
        let kernel_mean = match self.kernel_mean.as_deref() {
            None => None,
            Some("exact") => Some(KernelMeanName::Exact),
            Some("mc") => Some(KernelMeanName::Mc),
            Some("mc-shared") => Some(KernelMeanName::McShared),
            Some(other) => {
                return Err(value_error(format!(
                    "kernel_mean: unknown kernel mean {other:?}; expected \"exact\", \"mc\" or \"mc-shared\""
                )));
            }
        };
        Ok(ModelSpec {
            kernel,
            noise: self.noise,
            kernel_mean,
            kernel_mean_samples: self.kernel_mean_samples,
        })
    }

    /// The validated model, with its defaults filled in.
    pub fn resolve(&self, py: Python<'_>) -> PyResult<ResolvedModel> {
        self.spec(py)?
            .resolve()
            .map_err(|e| value_error(format!("{}: {}", e.field.json(), e.message)))
    }
}

/// Models built so far, most recent last; a few dozen at most.
static MODELS: Mutex<Vec<(ResolvedModel, Arc<BmcModel>)>> = Mutex::new(Vec::new());
const KEPT_MODELS: usize = 32;

/// The built model of `resolved` (its kernel-mean table tabulated once per process), with the
/// table's accuracy warning as a Python `RuntimeWarning` the first time.
pub fn build(py: Python<'_>, resolved: &ResolvedModel) -> PyResult<Arc<BmcModel>> {
    let lock = || MODELS.lock().unwrap_or_else(|p| p.into_inner());
    if let Some((_, m)) = lock().iter().find(|(r, _)| r == resolved) {
        return Ok(m.clone());
    }
    // Built without the lock or the GIL held (another thread may build the same model meanwhile;
    // both give the same one).
    let model = Arc::new(py.detach(|| resolved.build()));
    if let Some(w) = model.accuracy_warning() {
        warn(py, &w)?;
    }
    let mut models = lock();
    if models.len() == KEPT_MODELS {
        models.remove(0);
    }
    models.push((resolved.clone(), model.clone()));
    Ok(model)
}

/// A Python `RuntimeWarning` (what the CLI prints as `warning: …`).
pub fn warn(py: Python<'_>, message: &str) -> PyResult<()> {
    let category = py.get_type::<pyo3::exceptions::PyRuntimeWarning>();
    let message = std::ffi::CString::new(message.replace('\0', " ")).expect("no NUL left");
    PyErr::warn(py, category.as_any(), &message, 2)
}
