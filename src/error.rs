//! The library's error type: every fallible public function returns [`Error`] (or the narrower
//! [`InputError`] where only bad input can go wrong). The library never prints; the binary
//! reports an error once, as `Error: …` with its causes, and exits with code 2.

use std::path::Path;

/// Bad input from the user: a file, JSON field or option whose value is not accepted. The
/// message names where (file and JSON path, or the option) and what would be accepted.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct InputError(pub String);

impl InputError {
    pub fn new(message: impl Into<String>) -> Self {
        InputError(message.into())
    }
}

/// Cholesky of `Q = K + σ_n² I` failed even with the largest jitter of the ladder
/// (`bq::factor::jitter_ladder`, math.md §5).
#[derive(Debug, Clone, thiserror::Error)]
#[error(
    "Q is not positive definite even with jitter {jitter:.3e} added to its diagonal \
     (n = {n}); increase the noise σ_n² or remove duplicate points"
)]
pub struct NotPositiveDefinite {
    pub n: usize,
    pub jitter: f64,
}

/// Everything that can go wrong in the library.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad input (see [`InputError`]).
    #[error(transparent)]
    Input(#[from] InputError),
    /// Reading or writing a file failed; `what` says which file and what was being done.
    #[error("{what}")]
    Io {
        what: String,
        #[source]
        source: std::io::Error,
    },
    /// A weight set could not be computed; `what` says which.
    #[error("{what}")]
    Numerical {
        what: String,
        #[source]
        source: NotPositiveDefinite,
    },
    /// Encoding an output (CSV, SVG, PNG, EXR) failed.
    #[error("{0}")]
    Encode(String),
    /// The operating system refused a resource (threads).
    #[error("{0}")]
    System(String),
    /// An integrand given from outside (a Python callable) failed or returned bad values; the
    /// message names the integrand, the trial and N.
    #[error("{0}")]
    Integrand(String),
}

/// The library's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// An I/O error while doing `what` (e.g. "writing results/x/trials.csv").
    pub fn io(what: impl Into<String>, source: std::io::Error) -> Self {
        Error::Io {
            what: what.into(),
            source,
        }
    }

    /// An encoder's error, with the file it was meant for.
    pub fn encode(path: &Path, e: impl std::fmt::Display) -> Self {
        Error::Encode(format!("encoding {}: {e}", path.display()))
    }
}

impl From<NotPositiveDefinite> for Error {
    fn from(source: NotPositiveDefinite) -> Self {
        Error::Numerical {
            what: "computing BMC weights".into(),
            source,
        }
    }
}
