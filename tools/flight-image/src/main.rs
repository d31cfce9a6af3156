//! A flight host of the estimator on bare metal: the same cycle as the C host
//! (examples/c/host.c) — the table in, one `update` per sensor sample, the solve
//! whenever `update` flags it due, a checkpoint round trip, `finish` — on an ARM
//! Cortex-M7 under QEMU (tools/flight-qemu). The export files are read and the result
//! written by semihosting; the estimator's state is static memory.
//!
//! Per call it measures the work in instructions (QEMU's `-icount shift=0` makes
//! virtual time one nanosecond per instruction; SysTick counts that time, calibrated
//! against a loop of known length) and the stack depth, by painting.
#![no_std]
#![no_main]

use core::fmt::Write;
use cortex_m::peripheral::{syst::SystClkSource, SYST};
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hio, nr, syscall};
use taiji_core::capi::*;
use taiji_core::estimate::EstimatorConfig;
use taiji_core::math::Real;
use taiji_core::msg::{EstimateMsg, SensorSample};

/// The state's memory (static, as a flight host has it), with margin over its size.
const STATE_WORDS: usize = 96 * 1024 / 8;
static mut STATE: [u64; STATE_WORDS] = [0; STATE_WORDS];
const CKPT_BYTES: usize = 96 * 1024;
static mut CKPT: [u8; CKPT_BYTES] = [0; CKPT_BYTES];
/// Samples are streamed from the export in chunks of this many.
const CHUNK: usize = 256;
static mut SAMPLES: [SensorSample; CHUNK] = [SensorSample {
    header: taiji_core::msg::Header {
        seq: 0,
        tick: 0,
        sim_time_ns: 0,
        publish_ns: 0,
        origin_ns: 0,
        due_ns: 0,
        epoch: 0,
    },
    star: taiji_core::msg::StarSample {
        q_bn: [0.0; 4],
        valid: 0,
        _pad: [0; 7],
    },
    is: [taiji_core::msg::IsSample {
        volts: [[0.0; 2]; 3],
        flags: 0,
        _pad: [0; 7],
    }; 2],
}; CHUNK];
/// Instruction counts of every update (the p50/p99 need them all).
const MAX_UPDATES: usize = 200_000;
static mut UPDATE_COST: [u32; MAX_UPDATES] = [0; MAX_UPDATES];

/// Stack painting: this many bytes below the caller's frame.
const PAINT_BYTES: usize = 256 * 1024;
const PAINT: u8 = 0xA5;

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

/// Ends the program with a message on stdout and exit status 2.
fn fail(msg: core::fmt::Arguments) -> ! {
    if let Ok(mut out) = hio::hstdout() {
        let _ = writeln!(out, "taiji-flight-m7: {msg}");
    }
    halt(debug::EXIT_FAILURE)
}

/// A file of the host opened read-only (semihosting).
struct File(usize);

impl File {
    fn open(name: &str) -> File {
        let mut path = [0u8; 128];
        if name.len() >= path.len() {
            fail(format_args!("file name too long: {name}"));
        }
        path[..name.len()].copy_from_slice(name.as_bytes());
        // SAFETY: a NUL-terminated path and its length, as SYS_OPEN takes them.
        let fd = unsafe { syscall!(OPEN, path.as_ptr(), nr::open::R_BINARY, name.len()) } as isize;
        if fd < 0 {
            fail(format_args!("cannot open {name}"));
        }
        File(fd as usize)
    }

    /// Fills `buf` completely, or fails naming the file.
    fn read_exact(&self, buf: &mut [u8], name: &str) {
        // SAFETY: SYS_READ writes at most `buf.len()` bytes into `buf`.
        let left = unsafe { syscall!(READ, self.0, buf.as_mut_ptr(), buf.len()) };
        if left != 0 {
            fail(format_args!("{name} is truncated"));
        }
    }
}

impl Drop for File {
    fn drop(&mut self) {
        // SAFETY: closes a handle this program opened.
        unsafe { syscall!(CLOSE, self.0) };
    }
}

/// Opens an export file and checks its header (magic, layout version, record size);
/// returns the file positioned at the first record and the record count.
fn open_export(name: &str, record: usize) -> (File, u64) {
    let f = File::open(name);
    let mut h = [0u8; 24];
    f.read_exact(&mut h, name);
    if &h[..8] != b"TJEXP001" {
        fail(format_args!("{name} is not a taiji export"));
    }
    let version = u32::from_le_bytes(h[8..12].try_into().unwrap_or_default());
    let size = u32::from_le_bytes(h[12..16].try_into().unwrap_or_default());
    let count = u64::from_le_bytes(h[16..24].try_into().unwrap_or_default());
    if version != taiji_layout_version() || size as usize != record {
        fail(format_args!(
            "{name} has layout version {version}, record {size} B; this build has version {}, record {record} B",
            taiji_layout_version()
        ));
    }
    (f, count)
}

/// SysTick, free-running over its 24 bits.
fn start_clock(syst: &mut SYST) {
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(0x00FF_FFFF);
    syst.clear_current();
    syst.enable_counter();
}

/// Ticks since `t0` (the counter counts down; one wrap at most).
fn ticks_since(t0: u32) -> u32 {
    t0.wrapping_sub(SYST::get_current()) & 0x00FF_FFFF
}

/// SysTick ticks per instruction: a loop of exactly 2 × `n` instructions, timed.
fn calibrate() -> f64 {
    let n: u32 = 1_000_000;
    let t0 = SYST::get_current();
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
    ticks_since(t0) as f64 / (2.0 * n as f64)
}

/// Paints the stack below the current frame; returns the painted range's low end.
#[inline(never)]
fn paint_stack() -> usize {
    let sp = cortex_m::register::msp::read() as usize;
    let low = sp - PAINT_BYTES;
    for a in low..sp - 256 {
        // SAFETY: free stack below the current frame, inside RAM (the stack is 3 MB).
        unsafe { core::ptr::write_volatile(a as *mut u8, PAINT) };
    }
    low
}

/// Depth of the deepest call since `paint_stack(low)`: the lowest byte that changed.
#[inline(never)]
fn painted_depth(low: usize) -> usize {
    let top = low + PAINT_BYTES;
    let mut a = low;
    // SAFETY: the painted range, free stack again.
    while a < top && unsafe { core::ptr::read_volatile(a as *const u8) } == PAINT {
        a += 1;
    }
    top - a
}

fn check(rc: i32, what: &str) {
    if rc != TAIJI_OK {
        fail(format_args!("{what} failed with code {rc}"));
    }
}

fn print_vec(out: &mut hio::HostStream, key: &str, v: &[f64; 3], last: bool) {
    let _ = writeln!(
        out,
        "      \"{key}\": [{:e}, {:e}, {:e}]{}",
        v[0],
        v[1],
        v[2],
        if last { "" } else { "," }
    );
}

fn print_param(out: &mut hio::HostStream, name: &str, est: &[f64; 3], sig: &[f64; 3], last: bool) {
    let _ = writeln!(out, "    \"{name}\": {{");
    print_vec(out, "estimate", est, false);
    print_vec(out, "sigma", sig, true);
    let _ = writeln!(out, "    }}{}", if last { "" } else { "," });
}

#[entry]
fn main() -> ! {
    let mut cp =
        cortex_m::Peripherals::take().unwrap_or_else(|| fail(format_args!("no core peripherals")));
    start_clock(&mut cp.SYST);
    let ticks_per_instr = calibrate();

    // SAFETY: the only references to these statics, taken once, on one thread.
    let (state, ckpt, samples, cost) = unsafe {
        (
            &mut *core::ptr::addr_of_mut!(STATE),
            &mut *core::ptr::addr_of_mut!(CKPT),
            &mut *core::ptr::addr_of_mut!(SAMPLES),
            &mut *core::ptr::addr_of_mut!(UPDATE_COST),
        )
    };
    let mem = state.as_mut_ptr() as *mut u8;
    let mem_size = core::mem::size_of_val(state);
    if taiji_estimator_size() > mem_size || taiji_estimator_align() > 8 {
        fail(format_args!("the state needs {} B", taiji_estimator_size()));
    }

    let (cfg_file, n_cfg) = open_export(
        "estimator_config.bin",
        core::mem::size_of::<EstimatorConfig>(),
    );
    if n_cfg != 1 {
        fail(format_args!(
            "estimator_config.bin holds {n_cfg} tables, not 1"
        ));
    }
    let mut cfg_bytes = [0u8; core::mem::size_of::<EstimatorConfig>()];
    cfg_file.read_exact(&mut cfg_bytes, "estimator_config.bin");
    let cfg: EstimatorConfig = bytemuck_read(&cfg_bytes);
    let (sample_file, n) = open_export("sensor_samples.bin", core::mem::size_of::<SensorSample>());
    if n as usize > MAX_UPDATES {
        fail(format_args!(
            "{n} samples; this image holds the costs of {MAX_UPDATES}"
        ));
    }

    // SAFETY: `mem` is static memory of `mem_size` bytes, 8-aligned; `cfg` a valid table.
    check(
        unsafe {
            taiji_estimator_init(
                mem,
                mem_size,
                &cfg,
                TAIJI_ABI_VERSION,
                core::mem::size_of::<EstimatorConfig>(),
                core::mem::size_of::<SensorSample>(),
                core::mem::size_of::<EstimateMsg>(),
            )
        },
        "init",
    );
    let (mut n_solves, mut solve_max, mut solve_failed) = (0u64, 0u32, 0u64);
    let (mut stack_update, mut stack_solve) = (0usize, 0usize);
    let mut done = 0u64;
    while done < n {
        let k = ((n - done) as usize).min(CHUNK);
        // SAFETY: the chunk is plain numbers; any bytes are valid samples.
        let bytes = unsafe {
            core::slice::from_raw_parts_mut(
                samples.as_mut_ptr() as *mut u8,
                k * core::mem::size_of::<SensorSample>(),
            )
        };
        sample_file.read_exact(bytes, "sensor_samples.bin");
        for (j, s) in samples[..k].iter().enumerate() {
            let i = done as usize + j;
            let (mut rejected, mut flags) = (0u64, 0u32);
            let measure = i.is_multiple_of(1000);
            let low = if measure { paint_stack() } else { 0 };
            let t0 = SYST::get_current();
            // SAFETY: an initialised state, a valid sample and two outputs.
            let rc = unsafe { taiji_estimator_update(mem, s, &mut rejected, &mut flags) };
            cost[i] = ticks_since(t0);
            check(rc, "update");
            if measure {
                stack_update = stack_update.max(painted_depth(low));
            }
            if flags & TAIJI_SOLVE_DUE != 0 {
                let low = paint_stack();
                let t0 = SYST::get_current();
                // SAFETY: an initialised state.
                let rc = unsafe { taiji_estimator_solve(mem) };
                solve_max = solve_max.max(ticks_since(t0));
                stack_solve = stack_solve.max(painted_depth(low));
                // A failed solve keeps the previous solution; the status word says so.
                if rc == TAIJI_ERR_SOLVE {
                    solve_failed += 1;
                } else {
                    check(rc, "solve");
                }
                n_solves += 1;
            }
        }
        done += k as u64;
    }
    drop(sample_file);

    // A checkpoint round trip: the final estimate comes from the restored state.
    let mut written = 0usize;
    // SAFETY: an initialised state and a buffer of CKPT_BYTES.
    check(
        unsafe { taiji_estimator_checkpoint(mem, ckpt.as_mut_ptr(), CKPT_BYTES, &mut written) },
        "checkpoint",
    );
    state.iter_mut().for_each(|w| *w = 0);
    // SAFETY: as above; `written` bytes of the checkpoint.
    check(
        unsafe { taiji_estimator_restore(mem, mem_size, ckpt.as_ptr(), written, &cfg) },
        "restore",
    );
    let mut est = EstimateMsg::default();
    let low = paint_stack();
    let t0 = SYST::get_current();
    // SAFETY: a restored state and an output message.
    check(unsafe { taiji_estimator_finish(mem, &mut est) }, "finish");
    let finish_cost = ticks_since(t0);
    let stack_finish = painted_depth(low);

    let mut out = hio::hstdout().unwrap_or_else(|_| fail(format_args!("no stdout")));
    let _ = writeln!(out, "{{\n  \"inertial_sensors\": [");
    let n_is = cfg.n_is.min(2) as usize;
    for i in 0..n_is {
        let _ = writeln!(out, "   {{\n    \"id\": {},", i + 1);
        print_param(&mut out, "beta", &est.beta[i], &est.beta_sigma[i], false);
        print_param(&mut out, "k", &est.k[i], &est.k_sigma[i], false);
        print_param(&mut out, "com_offset", &est.r_b[i], &est.r_sigma[i], true);
        let _ = writeln!(out, "   }}{}", if i + 1 < n_is { "," } else { "" });
    }
    let _ = writeln!(out, "  ],\n  \"estimator_status\": {},", est.status);
    let _ = writeln!(
        out,
        "  \"samples_used\": {},\n  \"samples_rejected\": {},",
        est.n_used, est.n_rejected
    );
    // Instructions per call: ticks over the calibrated ticks per instruction.
    let instr = |ticks: u32| (ticks as f64 / ticks_per_instr).round() as u64;
    let costs = &mut cost[..n as usize];
    costs.sort_unstable();
    let pick = |q: f64| {
        costs
            .get(((costs.len() as f64 * q) as usize).min(costs.len().saturating_sub(1)))
            .copied()
            .unwrap_or(0)
    };
    let _ = writeln!(out, "  \"flight\": {{");
    let _ = writeln!(out, "    \"cpu\": \"cortex-m7\",");
    let _ = writeln!(out, "    \"updates\": {n},\n    \"solves\": {n_solves},\n    \"solves_failed\": {solve_failed},");
    let _ = writeln!(
        out,
        "    \"update_instructions\": {{\"p50\": {}, \"p99\": {}, \"max\": {}}},",
        instr(pick(0.5)),
        instr(pick(0.99)),
        instr(costs.last().copied().unwrap_or(0))
    );
    let _ = writeln!(out, "    \"solve_instructions_max\": {},", instr(solve_max));
    let _ = writeln!(out, "    \"finish_instructions\": {},", instr(finish_cost));
    let _ = writeln!(out, "    \"systick_per_instruction\": {ticks_per_instr:e},");
    let _ = writeln!(
        out,
        "    \"state_bytes\": {},\n    \"checkpoint_bytes\": {written},",
        taiji_estimator_size()
    );
    let _ = writeln!(
        out,
        "    \"stack_bytes\": {{\"update\": {stack_update}, \"solve\": {stack_solve}, \"finish\": {stack_finish}}}\n  }}\n}}"
    );
    halt(debug::EXIT_SUCCESS)
}

/// A table from its export bytes (plain numbers: any bytes are a table, which `init`
/// then checks).
fn bytemuck_read(b: &[u8; core::mem::size_of::<EstimatorConfig>()]) -> EstimatorConfig {
    // SAFETY: EstimatorConfig is plain numbers without padding; the read is unaligned.
    unsafe { core::ptr::read_unaligned(b.as_ptr() as *const EstimatorConfig) }
}
