//! The estimator's flight host (`lib.rs`) on a SPARC V8 LEON3 under QEMU's
//! leon3_generic (tools/flight-qemu), the class of the BM3803. Built as a staticlib for
//! sparc-unknown-none-elf and linked with the start-up code of `leon3/start.S` (trap
//! table, register-window traps, FPU, stack, BSS), which calls [`taiji_flight_main`].
//!
//! SPARC QEMU has no semihosting: the export's two files are preloaded into RAM at
//! fixed addresses (`-device loader`, [`CONFIG_AT`], [`SAMPLES_AT`]), the result goes
//! out on the APBUART, GPTIMER 0 counts the instructions (40 MHz under `-icount
//! shift=0`: one tick per 25 instructions), and the program stops with `ta 0` with
//! traps disabled, which QEMU's LEON3 takes as a shutdown.

use crate::{Board, Input};
use core::fmt::Write;

/// Where tools/flight-qemu loads `estimator_config.bin` (64 KB for it).
pub const CONFIG_AT: usize = 0x4100_0000;
/// Where tools/flight-qemu loads `sensor_samples.bin`, up to the end of RAM.
pub const SAMPLES_AT: usize = 0x4101_0000;
/// The end of RAM (`-m 256M` at 0x40000000).
pub const RAM_END: usize = 0x5000_0000;

/// APBUART: data, status (bit 2: transmitter FIFO empty), control.
const UART_DATA: usize = 0x8000_0100;
const UART_STATUS: usize = 0x8000_0104;
const UART_CONTROL: usize = 0x8000_0108;
const UART_TRANSMIT_EMPTY: u32 = 1 << 2;
/// GPTIMER: the prescaler's value and reload, timer 0's counter, reload and control.
const TIMER_SCALER: usize = 0x8000_0300;
const TIMER_SCALER_RELOAD: usize = 0x8000_0304;
const TIMER0_COUNTER: usize = 0x8000_0310;
const TIMER0_RELOAD: usize = 0x8000_0314;
const TIMER0_CONTROL: usize = 0x8000_0318;
/// Timer control: enable, restart at zero, load the reload value now.
const TIMER_ENABLE_RESTART_LOAD: u32 = 0b111;

extern "C" {
    /// The caller's stack pointer (leon3/start.S).
    fn taiji_leon3_sp() -> usize;
    /// `n` rounds of `subcc; bne; nop` (leon3/start.S).
    fn taiji_leon3_spin(n: u32);
    /// Disables traps and traps (leon3/start.S): QEMU shuts down.
    fn taiji_leon3_exit() -> !;
}

fn read_reg(addr: usize) -> u32 {
    // SAFETY: a register of leon3_generic's APB bus.
    unsafe { core::ptr::read_volatile(addr as *const u32) }
}

fn write_reg(addr: usize, value: u32) {
    // SAFETY: a register of leon3_generic's APB bus.
    unsafe { core::ptr::write_volatile(addr as *mut u32, value) }
}

/// The APBUART's transmitter.
pub struct Uart;

impl Write for Uart {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        for b in s.bytes() {
            while read_reg(UART_STATUS) & UART_TRANSMIT_EMPTY == 0 {}
            write_reg(UART_DATA, b as u32);
        }
        Ok(())
    }
}

/// An export file preloaded in RAM: the bytes from `at` to `end`.
pub struct Preloaded {
    at: usize,
    end: usize,
}

impl Input for Preloaded {
    fn read_exact(&mut self, buf: &mut [u8]) -> bool {
        if self.end - self.at < buf.len() {
            return false;
        }
        // SAFETY: RAM the program does not otherwise use (above its image and stack).
        let src = unsafe { core::slice::from_raw_parts(self.at as *const u8, buf.len()) };
        buf.copy_from_slice(src);
        self.at += buf.len();
        true
    }
}

/// leon3_generic's LEON3: the APBUART, GPTIMER 0, the input in RAM.
pub struct Leon3;

impl Leon3 {
    /// Turns the UART's transmitter on and runs GPTIMER 0 at the full system clock
    /// (prescaler 1), free over its 32 bits.
    fn new() -> Leon3 {
        write_reg(UART_CONTROL, 0b11);
        write_reg(TIMER_SCALER_RELOAD, 0);
        write_reg(TIMER_SCALER, 0);
        write_reg(TIMER0_RELOAD, u32::MAX);
        write_reg(TIMER0_CONTROL, TIMER_ENABLE_RESTART_LOAD);
        Leon3
    }
}

impl Board for Leon3 {
    const CPU: &'static str = "leon3";
    const NAME: &'static str = "taiji-flight-leon3";
    const SPIN_INSTRUCTIONS: u32 = 3;
    const TIMER: &'static str = "GPTIMER 0";
    type Out = Uart;
    type Input = Preloaded;

    fn open(&mut self, name: &str) -> Option<Preloaded> {
        match name {
            "estimator_config.bin" => Some(Preloaded {
                at: CONFIG_AT,
                end: SAMPLES_AT,
            }),
            "sensor_samples.bin" => Some(Preloaded {
                at: SAMPLES_AT,
                end: RAM_END,
            }),
            _ => None,
        }
    }

    fn out(&mut self) -> Uart {
        Uart
    }

    fn clock(&self) -> u32 {
        read_reg(TIMER0_COUNTER)
    }

    /// The timer counts down.
    fn ticks_since(&self, t0: u32) -> u32 {
        t0.wrapping_sub(read_reg(TIMER0_COUNTER))
    }

    fn spin(&self, n: u32) {
        // SAFETY: a counted loop on registers.
        unsafe { taiji_leon3_spin(n) }
    }

    #[inline(always)]
    fn stack_pointer(&self) -> usize {
        // SAFETY: reads a register.
        unsafe { taiji_leon3_sp() }
    }

    /// Success and failure end the same way; a failure has said so on the UART
    /// (`taiji-flight-leon3: …`), which tools/flight-qemu looks for.
    fn halt(&mut self, _ok: bool) -> ! {
        // SAFETY: ends the program.
        unsafe { taiji_leon3_exit() }
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    let _ = writeln!(Uart, "taiji-flight-leon3: panic: {info}");
    // SAFETY: ends the program.
    unsafe { taiji_leon3_exit() }
}

/// An unexpected trap (leon3/start.S, on a fresh stack with traps enabled again).
#[no_mangle]
pub extern "C" fn taiji_leon3_trap(tt: u32, pc: u32) -> ! {
    let _ = writeln!(
        Uart,
        "taiji-flight-leon3: unexpected trap 0x{tt:02x} at pc 0x{pc:08x}"
    );
    // SAFETY: ends the program.
    unsafe { taiji_leon3_exit() }
}

/// The program, called by leon3/start.S once the CPU is set up.
#[no_mangle]
pub extern "C" fn taiji_flight_main() -> ! {
    // SAFETY: called once by the start-up code, on its 2 MB stack.
    unsafe { crate::run(&mut Leon3::new()) }
}
