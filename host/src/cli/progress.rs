//! The progress bar on stderr (indicatif): drawn only on a terminal and not with `--quiet`, so a
//! redirected log gets no carriage returns; log lines are printed above it, and it is cleared
//! when the run ends, by success or error, so an error never shares its line.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::Mutex;

/// The bar being drawn, for the logger to print above.
static ACTIVE: Mutex<Option<ProgressBar>> = Mutex::new(None);

/// The frames' progress bar; clears itself when dropped.
pub(crate) struct Progress(Option<ProgressBar>);

impl Progress {
    /// A bar over `frames` frames (none when stderr is not a terminal or with `--quiet`).
    pub(crate) fn new(frames: u32) -> Self {
        if !std::io::stderr().is_terminal() || super::quiet() {
            return Progress(None);
        }
        let style = ProgressStyle::with_template("[{bar:40}] {pos}/{len} frames, {elapsed} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("#>-");
        let bar =
            ProgressBar::with_draw_target(Some(u64::from(frames)), ProgressDrawTarget::stderr()).with_style(style);
        if let Ok(mut active) = ACTIVE.lock() {
            *active = Some(bar.clone());
        }
        Progress(Some(bar))
    }

    /// `frame` frames are done.
    pub(crate) fn set(&self, frame: u32) {
        if let Some(bar) = &self.0 {
            bar.set_position(u64::from(frame));
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        if let Some(bar) = self.0.take() {
            bar.finish_and_clear();
        }
        if let Ok(mut active) = ACTIVE.lock() {
            *active = None;
        }
    }
}

/// Prints a line on stderr above the bar, if one is drawn.
pub(crate) fn eprint_line(line: &str) {
    match ACTIVE.lock().ok().and_then(|a| a.clone()) {
        Some(bar) => bar.suspend(|| eprintln!("{line}")),
        None => eprintln!("{line}"),
    }
}
