//! The progress bar on stderr: only on a terminal, and never sharing a line with an error.

use std::io::Write;

/// Whether a progress bar is on stderr's current line (so what comes next starts a new one).
pub(crate) static PROGRESS_ON_LINE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// The progress bar, redrawn in place: only on a terminal (a redirected log gets no carriage
/// returns).
pub(crate) fn progress(frame: u32, total: u32) {
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() || super::quiet() {
        return;
    }
    let width = 40;
    let done = (frame as usize * width) / total.max(1) as usize;
    eprint!("\r[{}{}] {frame}/{total} frames", "#".repeat(done), " ".repeat(width - done));
    let _ = std::io::stderr().flush();
    PROGRESS_ON_LINE.store(true, std::sync::atomic::Ordering::Relaxed);
}

/// Ends the progress bar's line, if one is drawn.
pub(crate) fn end_progress_line() {
    if PROGRESS_ON_LINE.swap(false, std::sync::atomic::Ordering::Relaxed) {
        eprintln!();
    }
}
