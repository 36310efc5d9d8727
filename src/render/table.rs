//! placeholder
use super::spec::TablePlan;
use std::path::Path;
pub fn run(_plan: &TablePlan, _results: &Path, _quiet: bool) -> anyhow::Result<()> {
    Ok(())
}
