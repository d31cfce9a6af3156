//! The C static library of the estimator: the flight core's C ABI (`taiji_core::capi`,
//! declared in include/taiji_estimator.h) linked with the panic handler a C host needs.
//! Built with the `flight` profile (panic = "abort"), so nothing unwinds into C.
#![no_std]

pub use taiji_core::capi::*;

extern "C" {
    /// The C library's abort, always present in a C host.
    fn abort() -> !;
}

/// Panics cannot happen on any input (fuzzed); should one, a flight host gets an
/// abort, never an unwind into C. An embedding Rust firmware links the core crate
/// itself and brings its own handler.
#[cfg(not(test))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    // SAFETY: a plain C function without arguments.
    unsafe { abort() }
}

/// The precompiled `core` carries unwind tables that name this personality routine;
/// with `panic = "abort"` nothing ever unwinds, so it is never called (and aborts if
/// it were).
#[no_mangle]
pub extern "C" fn rust_eh_personality() {
    // SAFETY: as above.
    unsafe { abort() }
}
