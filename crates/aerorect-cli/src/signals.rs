//! On SIGINT, SIGTERM or SIGHUP (Ctrl-C on Windows): remove the outputs still being written
//! (their temporary files) and exit 128 + the signal's number, as a shell reports a process
//! killed by it: 130 for SIGINT, 143 for SIGTERM, 129 for SIGHUP. Outputs already in place stay
//! whole.

use std::io::Write;

/// Removes the temporary files and exits with `code`, the register held so that no further
/// output can land.
fn abandon_outputs_and_exit(code: i32) -> ! {
    let abandoned = aerorect::io::remove_pending();
    let _ = writeln!(
        std::io::stderr(),
        "interrupted: {} unfinished output file(s) removed; finished outputs are kept",
        abandoned.removed
    );
    std::process::exit(code);
}

fn warn_unhandled(e: impl std::fmt::Display) {
    let _ = writeln!(
        std::io::stderr(),
        "warning: no signal handler ({e}): an interrupted run may leave .aerorect-*.tmp files"
    );
}

#[cfg(unix)]
pub(crate) fn remove_partial_outputs_on_signal() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let mut signals = match signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) {
        Ok(s) => s,
        Err(e) => return warn_unhandled(e),
    };
    let watcher = std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            if let Some(signal) = signals.forever().next() {
                abandon_outputs_and_exit(128 + signal);
            }
        });
    if let Err(e) = watcher {
        warn_unhandled(e);
    }
}

#[cfg(not(unix))]
pub(crate) fn remove_partial_outputs_on_signal() {
    if let Err(e) = ctrlc::set_handler(|| abandon_outputs_and_exit(130)) {
        warn_unhandled(e);
    }
}
