//! A progress bar with ETA on an interactive terminal (stderr), nothing otherwise, so
//! logs and pipes stay clean. Cheap to clone and to update from several threads.

use std::io::IsTerminal;

#[derive(Clone)]
pub struct Bar(Option<indicatif::ProgressBar>);

impl Bar {
    /// A bar of `len` steps labelled `what`; hidden unless stderr is a terminal.
    pub fn new(len: u64, what: &str) -> Self {
        if !std::io::stderr().is_terminal() {
            return Bar(None);
        }
        let b = indicatif::ProgressBar::new(len);
        let style = indicatif::ProgressStyle::with_template(
            "{msg:>12} [{bar:40}] {percent:>3}%  elapsed {elapsed}  ETA {eta}",
        )
        .map(|s| s.progress_chars("=> "));
        if let Ok(s) = style {
            b.set_style(s);
        }
        b.set_message(what.to_string());
        Bar(Some(b))
    }

    pub fn set(&self, pos: u64) {
        if let Some(b) = &self.0 {
            b.set_position(pos);
        }
    }

    pub fn inc(&self, n: u64) {
        if let Some(b) = &self.0 {
            b.inc(n);
        }
    }

    /// Remove the bar (before the result table is printed).
    pub fn finish(&self) {
        if let Some(b) = &self.0 {
            b.finish_and_clear();
            // A bar drawn once and finished within its refresh interval may not redraw:
            // clear the line explicitly.
            eprint!("\r\x1b[2K");
        }
    }
}
