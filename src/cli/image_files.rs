//! The checks and the commit that the fixed-spp and adaptive single-image renders share: the
//! image's files (`--out` and its siblings) against each other and the inputs, and the options
//! that only integrators with weights take.

use super::model_args::ModelArgs;
use super::output::status;
use std::path::{Path, PathBuf};
use workbench::error::InputError;
use workbench::files::file_set::FileSet;
use workbench::render::image::{DEFAULT_ERROR_MAX, Image};

/// The first option given that only integrators with weights use (`--gps`, `--no-rotate`, the
/// model's), if any: an error with MC rather than silently ignored.
pub fn weight_option_given(gps: Option<usize>, no_rotate: bool, model: &ModelArgs) -> Option<&'static str> {
    gps.map(|_| "--gps")
        .or(no_rotate.then_some("--no-rotate"))
        .or(model.given())
}

/// `--out` names the linear image, which is OpenEXR.
pub fn check_exr_out(out: &Path) -> Result<(), InputError> {
    if out.extension().and_then(|e| e.to_str()) == Some("exr") {
        return Ok(());
    }
    Err(InputError::new(format!(
        "--out {}: the linear image is OpenEXR; use a name ending in .exr",
        out.display()
    )))
}

/// `--error-max` (or its default): finite and positive.
pub fn check_error_max(given: Option<f64>) -> Result<f64, InputError> {
    let error_max = given.unwrap_or(DEFAULT_ERROR_MAX);
    if error_max.is_finite() && error_max > 0.0 {
        Ok(error_max)
    } else {
        Err(InputError::new(format!(
            "--error-max: must be finite and > 0, got {}",
            workbench::util::shown::shown(error_max)
        )))
    }
}

/// Never write over an input (the reference, an environment map file) or one output over
/// another, and refuse names too long for the file system, before any work.
pub fn check_outputs_apart(
    outputs: &[(&str, &Path)],
    reference: Option<&Path>,
    env: &str,
) -> anyhow::Result<()> {
    let mut inputs: Vec<(&str, &Path)> = Vec::new();
    if let Some(r) = reference {
        inputs.push(("--reference", r));
    }
    if !matches!(env, "sky" | "white") {
        inputs.push(("--env", Path::new(env)));
    }
    workbench::files::atomic::check_distinct(outputs, &inputs)?;
    for (flag, path) in outputs {
        workbench::files::atomic::check_name_length(flag, path)?;
    }
    Ok(())
}

/// Fail on an unwritable output folder now, not after the render.
pub fn check_out_dir_writable(out: &Path) -> anyhow::Result<()> {
    let dir = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    workbench::files::atomic::check_writable_dir(&dir)?;
    Ok(())
}

/// The `--reference` image, if given, read and checked to be the render's size.
pub fn read_optional_reference(
    reference: Option<&Path>,
    width: usize,
    height: usize,
) -> Result<Option<Image>, InputError> {
    reference
        .map(|path| Image::read_reference(path, "--reference", width, height))
        .transpose()
}

/// Replaces the image's files with the staged ones, and says which earlier ones it removed
/// (an error image or coverage map of an earlier render with `--reference`).
pub fn commit_and_report_removed(files: FileSet) -> anyhow::Result<()> {
    for removed in files.commit()? {
        status!(
            "render: removed {} (an earlier render's error image or coverage map; this one has no --reference)",
            removed.display()
        );
    }
    Ok(())
}
