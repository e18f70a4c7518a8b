//! The `drape` command line's parts: its flags, its progress bar, its report.

pub(crate) mod args;
pub(crate) mod colliders;
pub(crate) mod pictures;
pub(crate) mod progress;
pub(crate) mod report;
pub(crate) mod scene_file;

use std::sync::atomic::{AtomicBool, Ordering};

/// `--quiet`: nothing on stdout (errors and warnings still go to stderr).
static QUIET: AtomicBool = AtomicBool::new(false);

pub(crate) fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

pub(crate) fn quiet() -> bool {
    QUIET.load(Ordering::Relaxed)
}

/// `println!` unless `--quiet`.
macro_rules! say {
    ($($arg:tt)*) => {
        if !$crate::cli::quiet() {
            println!($($arg)*);
        }
    };
}
pub(crate) use say;
