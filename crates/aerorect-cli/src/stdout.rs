//! The one stdout of the program: every report line goes through [`outln!`], never `println!`,
//! so that a closed or failing stdout never panics.
//!
//! The rule (CONVENTIONS.md, "stdout"): when the reader has gone (EPIPE: `| head -1`), printing
//! stops quietly, the command finishes its work and commits its outputs, and the program exits
//! 141 (128 + SIGPIPE, as a shell reports a tool killed by SIGPIPE) so that a pipeline can tell
//! its report was cut. Any other write error (ENOSPC on `> /dev/full`, EIO) stops printing too,
//! and the program ends with an error naming stdout and exit 1; the output files, which do not go
//! through stdout, are still written. A streaming command (`track`) asks [`closed`] and stops
//! reading frames once nobody reads its lines.

use std::fmt;
use std::io::{self, Write};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, PoisonError};

/// Set once a write to stdout failed: nothing more is printed.
static CLOSED: AtomicBool = AtomicBool::new(false);
/// The first failure that was not a broken pipe.
static FAILURE: Mutex<Option<io::Error>> = Mutex::new(None);

/// Prints one line of a report on stdout (a broken pipe or a full disk ends printing, not the
/// program: see the module's rule).
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::stdout::line(format_args!($($arg)*))
    };
}

/// Writes `args` and a newline, flushed, unless stdout already failed.
pub(crate) fn line(args: fmt::Arguments<'_>) {
    if closed() {
        return;
    }
    let mut out = io::stdout().lock();
    let written = out
        .write_fmt(args)
        .and_then(|()| out.write_all(b"\n"))
        .and_then(|()| out.flush());
    if let Err(e) = written {
        record(e);
    }
}

/// Whether stdout has failed (its reader has gone, or it cannot be written): nothing more will
/// be printed.
pub(crate) fn closed() -> bool {
    CLOSED.load(Ordering::Relaxed)
}

fn record(e: io::Error) {
    CLOSED.store(true, Ordering::Relaxed);
    if e.kind() != io::ErrorKind::BrokenPipe {
        let mut first = FAILURE.lock().unwrap_or_else(PoisonError::into_inner);
        first.get_or_insert(e);
    }
}

/// The exit code once the command succeeded (`done`) or failed: 1 after a stdout write error
/// (with the message) or a failure, else 141 after a broken pipe, else 0.
pub(crate) fn finish(done: bool) -> ExitCode {
    if !closed()
        && let Err(e) = io::stdout().lock().flush()
    {
        record(e);
    }
    let failure = FAILURE
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .take();
    if let Some(e) = failure {
        let _ = writeln!(
            io::stderr(),
            "error: writing the report to stdout: {e}; the report is incomplete (output files are not affected)"
        );
        return ExitCode::FAILURE;
    }
    match (done, closed()) {
        (false, _) => ExitCode::FAILURE,
        (true, true) => ExitCode::from(141),
        (true, false) => ExitCode::SUCCESS,
    }
}
