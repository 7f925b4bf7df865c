//! Where a flight's time goes, for benchmarks: with `AERORECT_FLIGHT_TIMING` set, each stage
//! adds its seconds here (summed over threads for the per-frame and per-pair stages, so those
//! are CPU seconds) and [`super::adjust_flight`] prints the totals to stderr at the end.

use std::sync::Mutex;

static STAGES: Mutex<Vec<(&'static str, f64, usize)>> = Mutex::new(Vec::new());

/// Whether stages are timed (`AERORECT_FLIGHT_TIMING` set).
pub(crate) fn enabled() -> bool {
    static ON: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *ON.get_or_init(|| std::env::var_os("AERORECT_FLIGHT_TIMING").is_some())
}

/// Adds `seconds` (one call) to stage `name`.
pub(crate) fn add(name: &'static str, seconds: f64) {
    if !enabled() {
        return;
    }
    let Ok(mut s) = STAGES.lock() else { return };
    match s.iter_mut().find(|e| e.0 == name) {
        Some(e) => {
            e.1 += seconds;
            e.2 += 1;
        }
        None => s.push((name, seconds, 1)),
    }
}

/// Runs `f`, adding its seconds to stage `name`.
pub(crate) fn time<T>(name: &'static str, f: impl FnOnce() -> T) -> T {
    if !enabled() {
        return f();
    }
    let t = std::time::Instant::now();
    let out = f();
    add(name, t.elapsed().as_secs_f64());
    out
}

/// Prints every stage's total seconds and calls to stderr, and clears them.
pub(crate) fn print() {
    if !enabled() {
        return;
    }
    let Ok(mut s) = STAGES.lock() else { return };
    for (name, secs, calls) in s.drain(..) {
        eprintln!("flight timing: {name:<28} {secs:9.3} s  {calls:6} calls");
    }
}
