//! The filter loop allocates nothing: a counting global allocator around ≥ 10⁵ estimator
//! steps (solves included) must count zero.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use taiji::analysis::campaign::Stages;
use taiji::sim::estimate::Method;
use taiji::sim::scenario::Scenario;

struct Counting;
static COUNTING: AtomicBool = AtomicBool::new(false);
static ALLOCS: AtomicU64 = AtomicU64::new(0);

// SAFETY: every call is forwarded unchanged to the system allocator.
unsafe impl GlobalAlloc for Counting {
    // SAFETY: forwarded unchanged to the system allocator, under the same contract.
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        if COUNTING.load(Ordering::Relaxed) {
            ALLOCS.fetch_add(1, Ordering::Relaxed);
        }
        System.alloc(l)
    }
    // SAFETY: forwarded unchanged to the system allocator, under the same contract.
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        System.dealloc(p, l)
    }
    // SAFETY: forwarded unchanged to the system allocator, under the same contract.
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        if COUNTING.load(Ordering::Relaxed) {
            ALLOCS.fetch_add(1, Ordering::Relaxed);
        }
        System.realloc(p, l, n)
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn estimator_steps_allocate_nothing() {
    let s = Scenario::default();
    let mut st = Stages::new(&s, 1, Method::Joint);
    // Produce the sensor stream first (the plant and front-end may allocate as they like).
    let samples = st.sensor_samples(s.n_samples());
    assert!(samples.len() >= 100_000);
    COUNTING.store(true, Ordering::SeqCst);
    let mut checksum = 0.0;
    for smp in &samples {
        checksum += st.estimator.step(smp).beta[0][0];
    }
    let last = st.estimator.finish();
    COUNTING.store(false, Ordering::SeqCst);
    assert!(checksum.is_finite() && last.beta[0][0] > 0.0);
    assert_eq!(
        ALLOCS.load(Ordering::SeqCst),
        0,
        "allocations in the filter loop"
    );
}
