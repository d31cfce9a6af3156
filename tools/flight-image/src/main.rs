//! The estimator's flight host (`lib.rs`) on an ARM Cortex-M7 under QEMU's mps2-an500
//! (tools/flight-qemu): the export files are read and the result written by
//! semihosting; SysTick, driven by the core clock, counts the instructions.
#![no_std]
#![no_main]

use core::fmt::Write;
use cortex_m::peripheral::{syst::SystClkSource, SYST};
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hio, nr, syscall};
use taiji_flight_image::{Board, Input};

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    if let Ok(mut out) = hio::hstdout() {
        let _ = writeln!(out, "taiji-flight-m7: panic: {info}");
    }
    halt(debug::EXIT_FAILURE)
}

/// Ends the emulation with `status` (QEMU exits with it); waits for interrupts should
/// the debugger not take the request.
fn halt(status: debug::ExitStatus) -> ! {
    debug::exit(status);
    loop {
        cortex_m::asm::wfi();
    }
}

/// A file of the host opened read-only (semihosting).
struct File(usize);

impl Input for File {
    fn read_exact(&mut self, buf: &mut [u8]) -> bool {
        // SAFETY: SYS_READ writes at most `buf.len()` bytes into `buf`.
        let left = unsafe { syscall!(READ, self.0, buf.as_mut_ptr(), buf.len()) };
        left == 0
    }
}

impl Drop for File {
    fn drop(&mut self) {
        // SAFETY: closes a handle this program opened.
        unsafe { syscall!(CLOSE, self.0) };
    }
}

/// The mps2-an500's Cortex-M7: semihosting and SysTick.
struct M7;

impl Board for M7 {
    const CPU: &'static str = "cortex-m7";
    const NAME: &'static str = "taiji-flight-m7";
    const SPIN_INSTRUCTIONS: u32 = 2;
    const TIMER: &'static str = "SysTick";
    type Out = hio::HostStream;
    type Input = File;

    fn open(&mut self, name: &str) -> Option<File> {
        let mut path = [0u8; 128];
        if name.len() >= path.len() {
            return None;
        }
        path[..name.len()].copy_from_slice(name.as_bytes());
        // SAFETY: a NUL-terminated path and its length, as SYS_OPEN takes them.
        let fd = unsafe { syscall!(OPEN, path.as_ptr(), nr::open::R_BINARY, name.len()) } as isize;
        (fd >= 0).then_some(File(fd as usize))
    }

    fn out(&mut self) -> hio::HostStream {
        hio::hstdout().unwrap_or_else(|_| halt(debug::EXIT_FAILURE))
    }

    fn clock(&self) -> u32 {
        SYST::get_current()
    }

    /// SysTick counts down over its 24 bits.
    fn ticks_since(&self, t0: u32) -> u32 {
        t0.wrapping_sub(SYST::get_current()) & 0x00FF_FFFF
    }

    fn spin(&self, n: u32) {
        // SAFETY: a counted loop on one scratch register.
        unsafe {
            core::arch::asm!(
                "2:",
                "subs {0}, {0}, #1",
                "bne 2b",
                inout(reg) n => _,
                options(nomem, nostack),
            );
        }
    }

    #[inline(always)]
    fn stack_pointer(&self) -> usize {
        cortex_m::register::msp::read() as usize
    }

    fn halt(&mut self, ok: bool) -> ! {
        halt(if ok {
            debug::EXIT_SUCCESS
        } else {
            debug::EXIT_FAILURE
        })
    }
}

#[entry]
fn main() -> ! {
    let mut cp = cortex_m::Peripherals::take().unwrap_or_else(|| halt(debug::EXIT_FAILURE));
    // SysTick free-running over its 24 bits on the core clock.
    cp.SYST.set_clock_source(SystClkSource::Core);
    cp.SYST.set_reload(0x00FF_FFFF);
    cp.SYST.clear_current();
    cp.SYST.enable_counter();
    // SAFETY: called once; the stack is 3 MB, deeper than the painted range.
    unsafe { taiji_flight_image::run(&mut M7) }
}
