//! Where the binary's words go: results on stdout, status lines and warnings on stderr.

use std::io::Write;

/// A status line on standard error (progress notes, warnings). Unlike `eprintln!` it never
/// panics: if standard error is closed there is nowhere left to report to.
macro_rules! status {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}
pub(crate) use status;

/// The status line after a run's units: `wrote OUT (S s on T threads)`, for a shard with where
/// it went and how to merge it.
pub fn wrote(shard: Option<&dyn std::fmt::Display>, out: &std::path::Path, seconds: f64, threads: usize) {
    let on = format!(
        "{seconds:.2} s on {threads} thread{}",
        if threads == 1 { "" } else { "s" }
    );
    match shard {
        Some(shard) => status!(
            "wrote shard {shard} to {} ({on}); merge the shards with `workbench merge OUT DIR…`",
            out.display()
        ),
        None => status!("wrote {} ({on})", out.display()),
    }
}

/// What a resume found, if it found anything.
pub fn resumed(resumed: usize, units: usize) {
    if resumed > 0 {
        status!("resumed: {resumed} of {units} units were done already");
    }
}

/// Writes `s` to standard output. A reader that has gone away (`| head`) gives an
/// `io::ErrorKind::BrokenPipe` error, which `main` turns into a quiet exit; any other failure
/// (a full disk behind a redirection) says "stdout".
pub fn stdout(s: &str) -> anyhow::Result<()> {
    use anyhow::Context;
    let mut out = std::io::stdout().lock();
    out.write_all(s.as_bytes())
        .and_then(|()| out.flush())
        .context("writing to stdout")
}

/// Whether an error was caused by writing to a closed pipe.
pub fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// The flags of the jobs' settings, for the library's messages (`--out DIR: …`, `--resume: …`).
pub const JOB_FLAGS: workbench::job::SettingNames = workbench::job::SettingNames {
    out: "--out",
    trials: "--trials",
    shard: "--shard",
    resume: "--resume",
    results_dir: "--results-dir",
};
