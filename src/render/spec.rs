//! placeholder
use crate::io::InputError;
use std::path::Path;
pub struct TablePlan;
pub fn load(path: &Path) -> Result<TablePlan, InputError> {
    Err(InputError::new(format!(
        "{}: tables not implemented yet",
        path.display()
    )))
}
