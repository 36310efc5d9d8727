//! Worker threads: the tool's own cap holds whatever the environment says.

use crate::error::{Error, InputError};

/// Most worker threads (each holds its own `Q`, factored in place: up to 2 GiB at the largest N).
pub const MAX_THREADS: usize = 256;

/// The number of worker threads: `requested` (validated by the caller), else
/// `RAYON_NUM_THREADS` if it is a number, else one per core — never more than [`MAX_THREADS`].
pub fn worker_threads(requested: Option<usize>) -> usize {
    let from_env = std::env::var("RAYON_NUM_THREADS")
        .ok()
        .and_then(|v| v.trim().parse::<usize>().ok())
        .filter(|&t| t > 0);
    let default = || std::thread::available_parallelism().map_or(1, |n| n.get());
    requested
        .or(from_env)
        .unwrap_or_else(default)
        .clamp(1, MAX_THREADS)
}

/// Checks a requested number of worker threads; `what` names where it came from (the CLI's
/// `--threads`, a library caller's `threads`).
pub fn check_threads(t: usize, what: &str) -> Result<usize, InputError> {
    if (1..=MAX_THREADS).contains(&t) {
        Ok(t)
    } else {
        Err(InputError::new(format!(
            "{what}: must be in 1..={MAX_THREADS}, got {t}"
        )))
    }
}

/// A pool of [`worker_threads`] threads (its size set explicitly, so `RAYON_NUM_THREADS` cannot
/// exceed the cap); a `requested` count is checked first ([`check_threads`]).
pub fn pool(requested: Option<usize>) -> Result<rayon::ThreadPool, Error> {
    // Every job asks for its pool here: a requested count outside 1..=MAX_THREADS is refused
    // for all of them, not clamped for the ones whose door forgot to check (issue 42).
    if let Some(t) = requested {
        check_threads(t, "threads")?;
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(worker_threads(requested))
        .build()
        .map_err(|e| Error::System(format!("starting worker threads: {e}")))
}
