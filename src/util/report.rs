//! How long-running library work tells its caller what it is doing, without printing: the
//! binary implements [`Reporter`] with a progress bar and status lines on stderr; tests and
//! other programs use [`Silent`].

/// Progress and notes from a long computation. Called from worker threads, so `Sync`.
pub trait Reporter: Sync {
    /// A new phase of `len` steps begins (`unit` names a step: "trials×N", "rows").
    fn start(&self, _unit: &str, _len: u64) {}
    /// `n` more steps are done.
    fn advance(&self, _n: u64) {}
    /// What is being worked on now (shown beside the bar).
    fn working_on(&self, _what: &str) {}
    /// The phase is over.
    fn finish(&self) {}
    /// A status line worth showing (cache hits, timings, numerical warnings).
    fn note(&self, _line: &str) {}
}

/// Reports nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct Silent;

impl Reporter for Silent {}
