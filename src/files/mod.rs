//! Files on disk: atomic writes and staged folders ([`atomic`]), spec JSON with exact error
//! paths ([`spec_json`]), and result folders committed whole under a lock ([`result_folder`]).

pub mod atomic;
pub mod result_folder;
pub mod spec_json;
