//! The locking and the commit that the fixed-spp and adaptive single-image renders share.

use super::output::status;
use std::path::Path;
use workbench::files::file_set::FileSet;

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
