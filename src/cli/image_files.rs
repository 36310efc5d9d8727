//! The flags of a single image's settings, and the locking and the commit that the fixed-spp and adaptive single-image renders share.

use super::output::status;
use std::path::Path;
use workbench::files::file_set::FileSet;
use workbench::render::plan::Field;

/// Locks the image's files (`--out` and its siblings, as [`ImageOutputs::labelled`] names
/// them): no other command may write them meanwhile.
///
/// [`ImageOutputs::labelled`]: workbench::render::plan::ImageOutputs::labelled
pub fn lock(labelled: &[(String, &Path)]) -> anyhow::Result<FileSet> {
    let outputs: Vec<(&str, &Path)> = labelled.iter().map(|(l, p)| (l.as_str(), *p)).collect();
    Ok(FileSet::lock(&outputs, "use another --out")?)
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

/// The flag of each setting of a single image, in the library's messages.
pub fn flag(field: Field) -> &'static str {
    match field {
        Field::Integrator => "--integrator",
        Field::Spp => "--spp",
        Field::Tolerance => "--tolerance",
        Field::Gps => "--gps",
        Field::NoRotate => "--no-rotate",
        Field::Size => "--width/--height",
        Field::Env => "--env",
        Field::EnvLookup => "--env-lookup",
        Field::Seed => "--seed",
        Field::Out => "--out",
        Field::Reference => "--reference",
        Field::ErrorScale => "--error-scale",
        Field::ErrorMax => "--error-max",
        Field::ErrorColours => "--error-colours",
        Field::SdOut => "--sd-out",
        Field::Scale => "--scale",
        Field::TargetSd => "--target-sd",
        Field::MaxSpp => "--max-spp",
        Field::ResultsDir => "--results-dir",
        Field::Kernel => "--kernel",
    }
}
