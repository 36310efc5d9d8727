//! Files on disk: atomic writes and staged folders ([`atomic`]), spec JSON with exact error
//! paths ([`spec_json`]), result folders committed whole under a lock ([`result_folder`]),
//! outputs named one by one and written as a set ([`file_set`]), the lock both hold
//! ([`lock`]), and bounded, typed reads, the one way a file given to the tool is read ([`read`]).

pub mod atomic;
pub mod file_set;
pub mod lock;
pub mod read;
pub mod result_folder;
pub mod spec_json;
