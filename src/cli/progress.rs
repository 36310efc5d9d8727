//! The one progress bar: the library's [`Reporter`] drawn with indicatif on stderr, hidden with
//! `--quiet` or when stderr is not a terminal. Notes (status lines, warnings) are printed either
//! way, above the bar.

use super::output::status;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::sync::Mutex;
use workbench::util::report::Reporter;

pub struct Bar {
    visible: bool,
    /// The current phase's bar (a finished indicatif bar is not restarted, so each phase gets
    /// a new one).
    bar: Mutex<ProgressBar>,
}

impl Bar {
    pub fn new(quiet: bool) -> Self {
        Bar {
            visible: !quiet && std::io::stderr().is_terminal(),
            bar: Mutex::new(ProgressBar::hidden()),
        }
    }

    fn current(&self) -> ProgressBar {
        self.bar.lock().expect("the bar's lock is never poisoned").clone()
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
    }

    fn advance(&self, n: u64) {
        self.current().inc(n);
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
