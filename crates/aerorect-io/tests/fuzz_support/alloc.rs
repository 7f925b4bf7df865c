//! A counting allocator for the fuzz binary: each thread's live bytes, its peak since the last
//! [`reset`] and its largest single request, so a reader that allocates far beyond its limit is
//! seen. A single request over [`HARD_CAP`] is refused (the process aborts; the worker's
//! progress file names the input), so a memory bomb cannot take the machine down.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// Larger than any request a reader may make (its 4 GiB decode limit plus headroom).
pub const HARD_CAP: usize = 6 << 30;

pub struct Tracking;

thread_local! {
    static LIVE: Cell<usize> = const { Cell::new(0) };
    static PEAK: Cell<usize> = const { Cell::new(0) };
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

fn grew(delta: usize, request: usize) {
    let _ = LIVE.try_with(|l| {
        let v = l.get().saturating_add(delta);
        l.set(v);
        let _ = PEAK.try_with(|p| p.set(p.get().max(v)));
    });
    let _ = LARGEST.try_with(|m| m.set(m.get().max(request)));
}

fn shrank(delta: usize) {
    let _ = LIVE.try_with(|l| l.set(l.get().saturating_sub(delta)));
}

// SAFETY: every call forwards to `System` with the caller's layout; the bookkeeping touches
// only const-initialised thread-locals without destructors (no allocation, no unwinding).
unsafe impl GlobalAlloc for Tracking {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if layout.size() > HARD_CAP {
            return std::ptr::null_mut();
        }
        grew(layout.size(), layout.size());
        // SAFETY: the caller's contract is System's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if layout.size() > HARD_CAP {
            return std::ptr::null_mut();
        }
        grew(layout.size(), layout.size());
        // SAFETY: as above; zeroed pages stay untouched (calloc), so a large lazy buffer is cheap.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        shrank(layout.size());
        // SAFETY: as above.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > HARD_CAP {
            return std::ptr::null_mut();
        }
        if new_size >= layout.size() {
            grew(new_size - layout.size(), new_size);
        } else {
            shrank(layout.size() - new_size);
        }
        // SAFETY: as above.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Starts a measurement on this thread: the peak restarts from what is live now.
pub fn reset() -> usize {
    let live = LIVE.with(Cell::get);
    PEAK.with(|p| p.set(live));
    LARGEST.with(|m| m.set(0));
    live
}

/// (peak bytes above `baseline`, largest single request) since [`reset`].
pub fn measured(baseline: usize) -> (usize, usize) {
    (
        PEAK.with(Cell::get).saturating_sub(baseline),
        LARGEST.with(Cell::get),
    )
}
