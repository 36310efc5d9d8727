//! The one progress bar: the library's [`Reporter`] drawn with indicatif on stderr when it is a
//! terminal; when it is not (a log file, a pipe, a cluster job), a plain line at most every
//! [`DEFAULT_INTERVAL`] seconds — `rows: 42% (210/500), 1 min 3 s elapsed, about 1 min 27 s
//! left` —, so that a long command run with `2> log` says how far it is (issue 43.1). Both are
//! hidden with `--quiet`. Notes (status lines, warnings) are printed either way, above the bar.

use super::output::status;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::{Duration, Instant};
use workbench::util::report::Reporter;

/// Seconds between plain progress lines when stderr is not a terminal.
pub const DEFAULT_INTERVAL: f64 = 10.0;

/// Overrides [`DEFAULT_INTERVAL`] (seconds, > 0): for tests, which cannot wait 10 s per line.
pub const INTERVAL_VARIABLE: &str = "WORKBENCH_PROGRESS_INTERVAL";

pub struct Bar {
    visible: bool,
    /// The current phase's bar (a finished indicatif bar is not restarted, so each phase gets
    /// a new one).
    bar: Mutex<ProgressBar>,
    /// Plain lines instead of the bar (stderr is not a terminal, not `--quiet`).
    plain: Option<Mutex<Plain>>,
}

/// The state of the plain progress lines of one phase.
struct Plain {
    interval: Duration,
    unit: String,
    len: u64,
    pos: u64,
    started: Instant,
    last: Instant,
}

impl Plain {
    /// The line for the position now, or `None` if the last one is under an interval old.
    fn line(&mut self, now: Instant) -> Option<String> {
        if now.duration_since(self.last) < self.interval || self.len == 0 {
            return None;
        }
        self.last = now;
        let elapsed = now.duration_since(self.started).as_secs_f64();
        let done = (self.pos as f64 / self.len as f64).min(1.0);
        let left = if self.pos > 0 {
            format!(", about {} left", duration(elapsed * (1.0 - done) / done))
        } else {
            String::new()
        };
        Some(format!(
            "{}: {:.0}% ({}/{}), {} elapsed{left}",
            self.unit,
            100.0 * done,
            self.pos,
            self.len,
            duration(elapsed)
        ))
    }
}

/// `42 s`, `3 min 5 s`, `1 h 2 min`.
fn duration(seconds: f64) -> String {
    let s = seconds.max(0.0).round() as u64;
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {} s", s / 60, s % 60),
        _ => format!("{} h {} min", s / 3600, (s % 3600) / 60),
    }
}

/// The interval between plain lines: [`INTERVAL_VARIABLE`] if it holds a positive number of
/// seconds, else [`DEFAULT_INTERVAL`].
fn interval() -> Duration {
    let seconds = std::env::var(INTERVAL_VARIABLE)
        .ok()
        .and_then(|v| v.trim().parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s > 0.0)
        .unwrap_or(DEFAULT_INTERVAL);
    Duration::from_secs_f64(seconds)
}

impl Bar {
    pub fn new(quiet: bool) -> Self {
        let terminal = std::io::stderr().is_terminal();
        let now = Instant::now();
        Bar {
            visible: !quiet && terminal,
            bar: Mutex::new(ProgressBar::hidden()),
            plain: (!quiet && !terminal).then(|| {
                Mutex::new(Plain {
                    interval: interval(),
                    unit: String::new(),
                    len: 0,
                    pos: 0,
                    started: now,
                    last: now,
                })
            }),
        }
    }

    fn current(&self) -> ProgressBar {
        self.bar.lock().expect("the bar's lock is never poisoned").clone()
    }

    fn plain(&self) -> Option<std::sync::MutexGuard<'_, Plain>> {
        self.plain
            .as_ref()
            .map(|p| p.lock().expect("the plain lines' lock is never poisoned"))
    }
}

impl Reporter for Bar {
    fn start(&self, unit: &str, len: u64) {
        let bar = if self.visible {
            let style = ProgressStyle::with_template(&format!(
                "{{bar:32}} {{pos}}/{{len}} {unit} [{{elapsed}}, ETA {{eta}}] {{wide_msg}}"
            ))
            .expect("valid template");
            ProgressBar::new(len).with_style(style)
        } else {
            ProgressBar::hidden()
        };
        *self.bar.lock().expect("the bar's lock is never poisoned") = bar;
        if let Some(mut p) = self.plain() {
            let now = Instant::now();
            (p.unit, p.len, p.pos, p.started, p.last) = (unit.to_string(), len, 0, now, now);
        }
    }

    fn advance(&self, n: u64) {
        self.current().inc(n);
        if let Some(mut p) = self.plain() {
            p.pos += n;
            if let Some(line) = p.line(Instant::now()) {
                status!("{line}");
            }
        }
    }

    fn working_on(&self, what: &str) {
        self.current().set_message(what.to_string());
    }

    fn finish(&self) {
        self.current().finish_and_clear();
    }

    fn note(&self, line: &str) {
        self.current().suspend(|| status!("{line}"));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A line only once an interval has passed, with the share, the counts and both times.
    #[test]
    fn plain_lines_come_at_most_once_an_interval() {
        let t0 = Instant::now();
        let mut p = Plain {
            interval: Duration::from_secs(10),
            unit: "rows".into(),
            len: 500,
            pos: 125,
            started: t0,
            last: t0,
        };
        assert_eq!(p.line(t0 + Duration::from_secs(9)), None);
        assert_eq!(
            p.line(t0 + Duration::from_secs(60)).as_deref(),
            Some("rows: 25% (125/500), 1 min 0 s elapsed, about 3 min 0 s left")
        );
        assert_eq!(p.line(t0 + Duration::from_secs(65)), None);
    }
}
