//! A counting global allocator for proving the filter loop allocation-free. A binary
//! opts in with `#[global_allocator] static A: CountingAlloc = CountingAlloc;` and the
//! loop reads `thread_allocations()` before and after (its own thread's: helper
//! threads may allocate).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicBool, Ordering};

thread_local! {
    /// This thread's allocations (a const-initialised `Cell`: reading it allocates
    /// nothing and it has no destructor, so the allocator may touch it at any time).
    static MINE: Cell<u64> = const { Cell::new(0) };
}

thread_local! {
    /// This thread's loop has started and asked for a trace of each allocation
    /// (`trace_from_here`); a second flag keeps the trace's own allocations out.
    static TRACE: Cell<bool> = const { Cell::new(false) };
    static TRACING: Cell<bool> = const { Cell::new(false) };
}

fn count() {
    let _ = MINE.try_with(|c| c.set(c.get() + 1));
    if TRACE.try_with(|t| t.get()).unwrap_or(false)
        && !TRACING.try_with(|t| t.replace(true)).unwrap_or(true)
    {
        // A diagnostic run only (`TAIJI_ALLOC_TRACE`): the backtrace itself allocates.
        let trace = std::backtrace::Backtrace::force_capture();
        match std::env::var_os("TAIJI_ALLOC_TRACE").filter(|v| v != "1") {
            Some(path) => {
                use std::io::Write;
                if let Ok(mut f) = std::fs::OpenOptions::new()
                    .create(true)
                    .append(true)
                    .open(path)
                {
                    let _ = writeln!(
                        f,
                        "[ALLOC] pid {} in the filter loop:\n{trace}",
                        std::process::id()
                    );
                }
            }
            None => eprintln!("[ALLOC] in the filter loop:\n{trace}"),
        }
        let _ = TRACING.try_with(|t| t.set(false));
    }
}

/// With `TAIJI_ALLOC_TRACE` in the environment (`1`: to stderr; else a file to append
/// to), print a backtrace of every later allocation by the calling thread: where a
/// loop that must not touch the heap did. Reads the environment: call it before the loop.
pub fn trace_from_here() {
    if std::env::var_os("TAIJI_ALLOC_TRACE").is_some_and(|v| !v.is_empty()) {
        let _ = TRACE.try_with(|t| t.set(true));
    }
}

/// The loop is over: its teardown may allocate.
pub fn trace_stop() {
    let _ = TRACE.try_with(|t| t.set(false));
}
static INSTALLED: AtomicBool = AtomicBool::new(false);

/// The system allocator, counting every `alloc` and `realloc`.
pub struct CountingAlloc;

// SAFETY: forwards every call unchanged to the system allocator.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        count();
        INSTALLED.store(true, Ordering::Relaxed);
        System.alloc(l)
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        System.dealloc(p, l)
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        count();
        INSTALLED.store(true, Ordering::Relaxed);
        System.alloc_zeroed(l)
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        count();
        System.realloc(p, l, n)
    }
}

/// Allocations so far by the calling thread, or `None` when `CountingAlloc` is not
/// installed: a filter loop counts its own, not those of its helper threads (the
/// checkpoint writer, the estimate publisher).
pub fn thread_allocations() -> Option<u64> {
    if INSTALLED.load(Ordering::Relaxed) {
        MINE.try_with(|c| c.get()).ok()
    } else {
        None
    }
}
