//! Progress bars for the library's long stages (indicatif), drawn on stderr only when it
//! is a terminal and `--quiet` was not given.

use indicatif::{ProgressBar, ProgressStyle};
use murk::render::Progress;
use std::io::IsTerminal;
use std::sync::Mutex;

/// A bar per stage, replaced when the next stage starts.
pub struct Bars {
    shown: bool,
    bar: Mutex<ProgressBar>,
}

impl Bars {
    pub fn new(quiet: bool) -> Self {
        Bars {
            shown: !quiet && std::io::stderr().is_terminal(),
            bar: Mutex::new(ProgressBar::hidden()),
        }
    }

    fn bar(&self) -> ProgressBar {
        self.bar
            .lock()
            .map(|b| b.clone())
            .unwrap_or_else(|_| ProgressBar::hidden())
    }
}

impl Bars {
    /// Prints a line on stderr above the bar.
    pub fn println(&self, line: &str) {
        let bar = self.bar();
        if bar.is_hidden() {
            eprintln!("{line}");
        } else {
            bar.suspend(|| eprintln!("{line}"));
        }
    }
}

impl Progress for Bars {
    fn start(&self, what: &str, total: u64, unit: &str) {
        if !self.shown {
            return;
        }
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template(&format!(
                "{{spinner}} {what} [{{bar:40}}] {{pos}}/{{len}} {unit} {{elapsed}} (eta {{eta}}) {{msg}}"
            ))
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        if let Ok(mut b) = self.bar.lock() {
            *b = bar;
        }
    }
    fn note(&self, what: &str) {
        self.bar().set_message(what.to_string());
    }
    fn advance(&self, n: u64) {
        self.bar().inc(n);
    }
    fn finish(&self) {
        self.bar().finish_and_clear();
    }
}
