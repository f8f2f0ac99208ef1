//! The library's progress bars drawn on the terminal with indicatif (stderr; hidden when stderr is
//! not a terminal, as indicatif does).

use std::sync::Arc;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

struct Terminal;

struct TerminalBar(ProgressBar);

impl sism::progress::Reporter for Terminal {
    fn bar(&self, len: u64, what: &str) -> Box<dyn sism::progress::ProgressSink> {
        let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
        bar.set_style(
            ProgressStyle::with_template("{msg:>24} [{bar:40}] {pos}/{len} ({elapsed}, eta {eta})")
                .expect("static template")
                .progress_chars("=> "),
        );
        bar.set_message(what.to_string());
        Box::new(TerminalBar(bar))
    }
}

impl sism::progress::ProgressSink for TerminalBar {
    fn set_position(&self, pos: u64) {
        self.0.set_position(pos);
    }

    fn set_message(&self, msg: &str) {
        self.0.set_message(msg.to_string());
    }

    fn suspend(&self, f: &mut dyn FnMut()) {
        self.0.suspend(f);
    }

    fn finish(&self) {
        self.0.finish_and_clear();
    }
}

/// Makes the library's bars draw on this terminal.
pub fn install() {
    sism::progress::set_reporter(Arc::new(Terminal));
}
