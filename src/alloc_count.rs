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

fn count() {
    let _ = MINE.try_with(|c| c.set(c.get() + 1));
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
