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
#[cfg(all(not(test), not(feature = "panic-proof")))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    // SAFETY: a plain C function without arguments.
    unsafe { abort() }
}

/// The link-time proof that no panic is reachable (`tools/panic-proof`): this handler
/// calls a function that exists nowhere, so a C program linking the library with
/// `--gc-sections` fails to link if any exported function can reach a panic.
#[cfg(all(not(test), feature = "panic-proof"))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    extern "C" {
        fn taiji_a_panic_is_reachable() -> !;
    }
    // SAFETY: never called: the link fails first if this is reachable at all.
    unsafe { taiji_a_panic_is_reachable() }
}

/// The precompiled `core` carries unwind tables that name this personality routine;
/// with `panic = "abort"` nothing ever unwinds, so it is never called (and aborts if
/// it were).
#[no_mangle]
pub extern "C" fn rust_eh_personality() {
    // SAFETY: as above.
    unsafe { abort() }
}

/// The panic proof's negative test (`tools/panic-proof --probe`): an index the
/// compiler cannot check, so a panic path is reachable and the proof's link must fail.
#[cfg(feature = "panic-probe")]
#[no_mangle]
pub extern "C" fn taiji_panic_probe(index: usize) -> u8 {
    const TABLE: [u8; 3] = [1, 2, 3];
    TABLE[index]
}
