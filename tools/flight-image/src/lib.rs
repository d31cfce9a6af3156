//! A flight host of the estimator on bare metal, the same on every emulated flight CPU
//! (tools/flight-qemu): the same cycle as the C host (examples/c/host.c) — the table
//! in, one `update` per sensor sample, the solve whenever `update` flags it due, a
//! checkpoint round trip, `finish` — with the estimator's state in static memory.
//!
//! What differs between CPUs is a [`Board`]: where the export's bytes come from, where
//! the result goes, the timer, the stack pointer and how the program stops. The
//! Cortex-M7 board is `main.rs` (semihosting, SysTick); the LEON3 board is `leon3.rs`
//! (the input preloaded in RAM, the APBUART, GPTIMER 0).
//!
//! Per call it measures the work in instructions (QEMU's `-icount shift=0` makes
//! virtual time one nanosecond per instruction; the board's timer counts that time,
//! calibrated against a loop of known length) and the stack depth, by painting.
//!
//! The export is little-endian (src/analysis/export.rs); its records are decoded field by field
//! into this CPU's byte order, so the same code reads it on a big-endian SPARC.
#![no_std]

use core::fmt::Write;
use taiji_core::capi::*;
use taiji_core::estimate::EstimatorConfig;
use taiji_core::math::Real;
use taiji_core::msg::{EstimateMsg, Header, IsSample, SensorSample, StarSample};

#[cfg(target_arch = "sparc")]
pub mod leon3;

/// What the replay needs of a board (a CPU and its machine under QEMU).
pub trait Board {
    /// The CPU's name in the result (`flight.cpu`).
    const CPU: &'static str;
    /// The program's name, in front of its messages.
    const NAME: &'static str;
    /// Instructions per round of [`Board::spin`]'s loop.
    const SPIN_INSTRUCTIONS: u32;
    /// The timer's name in the result (`flight.timer`).
    const TIMER: &'static str;
    /// Where the result goes.
    type Out: Write;
    /// An input file.
    type Input: Input;

    /// Opens the export file `name`, or `None`.
    fn open(&mut self, name: &str) -> Option<Self::Input>;
    /// The result's stream.
    fn out(&mut self) -> Self::Out;
    /// The timer's counter now.
    fn clock(&self) -> u32;
    /// Timer ticks since the counter read `t0` (one wrap at most).
    fn ticks_since(&self, t0: u32) -> u32;
    /// Runs a loop of exactly `SPIN_INSTRUCTIONS` instructions `n` times.
    fn spin(&self, n: u32);
    /// The stack pointer of the caller.
    fn stack_pointer(&self) -> usize;
    /// Ends the program: success or failure.
    fn halt(&mut self, ok: bool) -> !;
}

/// An export file being read.
pub trait Input {
    /// Fills `buf` completely; false if the file ends first.
    fn read_exact(&mut self, buf: &mut [u8]) -> bool;
}

/// The state's memory (static, as a flight host has it), with margin over its size.
const STATE_WORDS: usize = 96 * 1024 / 8;
static mut STATE: [u64; STATE_WORDS] = [0; STATE_WORDS];
/// The solve's scratch (`taiji_solve_work_size()`, checked at start).
const WORK_WORDS: usize = 160 * 1024 / 8;
static mut WORK: [u64; WORK_WORDS] = [0; WORK_WORDS];
const CKPT_BYTES: usize = 96 * 1024;
static mut CKPT: [u8; CKPT_BYTES] = [0; CKPT_BYTES];
/// Bytes of one sample in the export.
const SAMPLE_BYTES: usize = core::mem::size_of::<SensorSample>();
/// Samples are read from the export in chunks of this many.
const CHUNK: usize = 256;
static mut CHUNK_BYTES: [u8; CHUNK * SAMPLE_BYTES] = [0; CHUNK * SAMPLE_BYTES];
/// Instruction counts of every update (the p50/p99 need them all).
const MAX_UPDATES: usize = 200_000;
static mut UPDATE_COST: [u32; MAX_UPDATES] = [0; MAX_UPDATES];

/// Stack painting: this many bytes below the caller's frame.
pub const PAINT_BYTES: usize = 256 * 1024;
const PAINT: u8 = 0xA5;

/// Ends the program with a message and failure.
pub fn fail<B: Board>(board: &mut B, msg: core::fmt::Arguments) -> ! {
    let _ = writeln!(board.out(), "{}: {msg}", B::NAME);
    board.halt(false)
}

/// Little-endian fields read in order from an export record.
struct Le<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Le<'_> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut b = [0u8; N];
        b.copy_from_slice(&self.bytes[self.at..self.at + N]);
        self.at += N;
        b
    }
    fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take())
    }
    fn i64(&mut self) -> i64 {
        i64::from_le_bytes(self.take())
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
    fn u8(&mut self) -> u8 {
        self.take::<1>()[0]
    }
    fn f64s<const N: usize>(&mut self) -> [f64; N] {
        core::array::from_fn(|_| self.f64())
    }
    fn f64x3x2(&mut self) -> [[f64; 3]; 2] {
        [self.f64s(), self.f64s()]
    }
}

/// The table from its export record (fields in declaration order; the struct literal
/// names every field, so a field added to the table stops this build).
fn decode_config(bytes: &[u8]) -> EstimatorConfig {
    let mut r = Le { bytes, at: 0 };
    EstimatorConfig {
        fs: r.f64(),
        n_is: r.u64(),
        geometry_m: r.f64x3x2(),
        beta_prior: r.f64x3x2(),
        com_prior_m: r.f64x3x2(),
        sigma_star_rad: r.f64(),
        sigma_angular: r.f64(),
        sigma_linear: r.f64(),
        sigma_ripple: r.f64(),
        srp_asd_at_3mhz: r.f64(),
        sigma_force: r.f64(),
        solve_every: r.u64(),
        full_scale_linear: r.f64(),
        full_scale_angular: r.f64(),
        max_gap_ticks: r.u64(),
        gate_sigma: r.f64(),
        star_gate_sigma: r.f64(),
        chi2_tolerance: r.f64(),
        degraded_one_in: r.u64(),
    }
}

/// A sample from its export record.
fn decode_sample(bytes: &[u8]) -> SensorSample {
    let mut r = Le { bytes, at: 0 };
    let header = Header {
        seq: r.u64(),
        tick: r.u64(),
        sim_time_ns: r.i64(),
        publish_ns: r.u64(),
        origin_ns: r.u64(),
        due_ns: r.u64(),
        epoch: r.u64(),
    };
    let star = StarSample {
        q_bn: r.f64s(),
        valid: r.u8(),
        _pad: r.take(),
    };
    let mut is = || IsSample {
        volts: [r.f64s(), r.f64s(), r.f64s()],
        flags: r.u8(),
        _pad: r.take(),
    };
    SensorSample {
        header,
        star,
        is: [is(), is()],
    }
}

/// Opens an export file and checks its header (magic, layout version, record size);
/// returns the file positioned at the first record and the record count.
fn open_export<B: Board>(board: &mut B, name: &str, record: usize) -> (B::Input, u64) {
    let Some(mut f) = board.open(name) else {
        fail(board, format_args!("cannot open {name}"))
    };
    let mut h = [0u8; 24];
    if !f.read_exact(&mut h) {
        fail(board, format_args!("{name} is truncated"));
    }
    if &h[..8] != b"TJEXP001" {
        fail(board, format_args!("{name} is not a taiji export"));
    }
    let mut r = Le {
        bytes: &h[8..],
        at: 0,
    };
    let version = u32::from_le_bytes(r.take());
    let size = u32::from_le_bytes(r.take());
    let count = r.u64();
    if version != taiji_layout_version() || size as usize != record {
        fail(
            board,
            format_args!(
                "{name} has layout version {version}, record {size} B; this build has version {}, record {record} B",
                taiji_layout_version()
            ),
        );
    }
    (f, count)
}

/// Timer ticks per instruction: `spin` of 2n rounds less `spin` of n rounds, so the
/// call's own instructions cancel.
fn calibrate<B: Board>(board: &B) -> f64 {
    let n: u32 = 1_000_000;
    let time = |rounds: u32| {
        let t0 = board.clock();
        board.spin(rounds);
        board.ticks_since(t0) as f64
    };
    let (one, two) = (time(n), time(2 * n));
    (two - one) / (n as f64 * B::SPIN_INSTRUCTIONS as f64)
}

/// Paints the stack below the current frame; returns the painted range's low end.
#[inline(never)]
fn paint_stack<B: Board>(board: &B) -> usize {
    let sp = board.stack_pointer();
    let low = sp - PAINT_BYTES;
    for a in low..sp - 256 {
        // SAFETY: free stack below the current frame (the boards' stacks are larger
        // than PAINT_BYTES).
        unsafe { core::ptr::write_volatile(a as *mut u8, PAINT) };
    }
    low
}

/// Depth of the deepest call since `paint_stack` returned `low`: the lowest byte that
/// changed.
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

fn check<B: Board>(board: &mut B, rc: i32, what: &str) {
    if rc != TAIJI_OK {
        fail(board, format_args!("{what} failed with code {rc}"));
    }
}

/// The statics, taken once.
struct Memory {
    state: &'static mut [u64; STATE_WORDS],
    work: &'static mut [u64; WORK_WORDS],
    ckpt: &'static mut [u8; CKPT_BYTES],
    chunk: &'static mut [u8; CHUNK * SAMPLE_BYTES],
    cost: &'static mut [u32; MAX_UPDATES],
}

impl Memory {
    /// # Safety
    /// Called once: the only references to these statics.
    unsafe fn take() -> Memory {
        // SAFETY: the caller takes them once, on one thread.
        unsafe {
            Memory {
                state: &mut *core::ptr::addr_of_mut!(STATE),
                work: &mut *core::ptr::addr_of_mut!(WORK),
                ckpt: &mut *core::ptr::addr_of_mut!(CKPT),
                chunk: &mut *core::ptr::addr_of_mut!(CHUNK_BYTES),
                cost: &mut *core::ptr::addr_of_mut!(UPDATE_COST),
            }
        }
    }

    fn mem(&mut self) -> (*mut u8, usize) {
        (
            self.state.as_mut_ptr() as *mut u8,
            core::mem::size_of_val(self.state),
        )
    }

    fn work(&mut self) -> (*mut u8, usize) {
        (
            self.work.as_mut_ptr() as *mut u8,
            core::mem::size_of_val(self.work),
        )
    }
}

/// What the replay measured, in timer ticks and bytes.
#[derive(Default)]
struct Figures {
    n: u64,
    n_solves: u64,
    solves_failed: u64,
    solve_max: u32,
    finish: u32,
    ticks_per_instr: f64,
    checkpoint_bytes: usize,
    stack_init: usize,
    stack_update: usize,
    stack_solve: usize,
    stack_checkpoint: usize,
    stack_restore: usize,
    stack_finish: usize,
    /// The deepest update among those that bridged a gap in the ticks (0: no gap).
    stack_update_after_gap: usize,
    /// The longest gap in the ticks [ticks].
    gap_ticks_max: u64,
}

/// Reads the table and initialises the estimator in `m.state`; returns the table and
/// the samples' file and count.
fn init<B: Board>(board: &mut B, m: &mut Memory) -> (EstimatorConfig, B::Input, u64, usize) {
    const CFG_BYTES: usize = core::mem::size_of::<EstimatorConfig>();
    let (mem, mem_size) = m.mem();
    if taiji_estimator_size() > mem_size || taiji_estimator_align() > 8 {
        fail(
            board,
            format_args!("the state needs {} B", taiji_estimator_size()),
        );
    }
    if taiji_solve_work_size() > WORK_WORDS * 8 {
        fail(
            board,
            format_args!("the solve needs {} B of scratch", taiji_solve_work_size()),
        );
    }
    let (mut cfg_file, n_cfg) = open_export(board, "estimator_config.bin", CFG_BYTES);
    if n_cfg != 1 {
        fail(
            board,
            format_args!("estimator_config.bin holds {n_cfg} tables, not 1"),
        );
    }
    let mut cfg_bytes = [0u8; CFG_BYTES];
    if !cfg_file.read_exact(&mut cfg_bytes) {
        fail(board, format_args!("estimator_config.bin is truncated"));
    }
    let cfg = decode_config(&cfg_bytes);
    let (samples, n) = open_export(board, "sensor_samples.bin", SAMPLE_BYTES);
    if n as usize > MAX_UPDATES {
        fail(
            board,
            format_args!("{n} samples; this image holds the costs of {MAX_UPDATES}"),
        );
    }
    let low = paint_stack(board);
    // SAFETY: `mem` is static memory of `mem_size` bytes, 8-aligned; `cfg` a valid table.
    let rc = unsafe {
        taiji_estimator_init(
            mem,
            mem_size,
            &cfg,
            TAIJI_ABI_VERSION,
            CFG_BYTES,
            SAMPLE_BYTES,
            core::mem::size_of::<EstimateMsg>(),
        )
    };
    let stack = painted_depth(low);
    check(board, rc, "init");
    (cfg, samples, n, stack)
}

/// One `update` per sample of `samples`, the solve whenever it is due; every update's
/// ticks go into `m.cost`, the solves' and the stack's figures into `fig`.
fn replay<B: Board>(board: &mut B, m: &mut Memory, samples: &mut B::Input, fig: &mut Figures) {
    let (mem, _) = m.mem();
    let n = fig.n;
    let mut done = 0u64;
    // After a gap in the ticks the updates bridge it, BRIDGE_PER_UPDATE ticks a call
    // (one of them the sample's own): each is measured.
    let (mut prev, mut catch_up) = (None::<u64>, 0u64);
    while done < n {
        let k = ((n - done) as usize).min(CHUNK);
        if !samples.read_exact(&mut m.chunk[..k * SAMPLE_BYTES]) {
            fail(board, format_args!("sensor_samples.bin is truncated"));
        }
        for j in 0..k {
            let s = decode_sample(&m.chunk[j * SAMPLE_BYTES..(j + 1) * SAMPLE_BYTES]);
            let i = done as usize + j;
            let (mut rejected, mut flags) = (0u64, 0u32);
            let tick = s.header.tick;
            if let Some(p) = prev.filter(|&p| tick > p.saturating_add(1)) {
                let gap = tick - p - 1;
                fig.gap_ticks_max = fig.gap_ticks_max.max(gap);
                catch_up = gap / (taiji_core::tuning::BRIDGE_PER_UPDATE - 1) + 2;
            }
            prev = Some(tick);
            let measure = i.is_multiple_of(1000) || catch_up > 0;
            let low = if measure { paint_stack(board) } else { 0 };
            let t0 = board.clock();
            // SAFETY: an initialised state, a valid sample and two outputs.
            let rc = unsafe { taiji_estimator_update(mem, &s, &mut rejected, &mut flags) };
            m.cost[i] = board.ticks_since(t0);
            check(board, rc, "update");
            if i.is_multiple_of(1000) {
                // The host's housekeeping reads the estimate now and then (it counts
                // itself: the seal of its sequence number alone is updated).
                let mut est = EstimateMsg::default();
                // SAFETY: an initialised state and an output.
                let rc = unsafe { taiji_estimator_estimate(mem, &mut est) };
                check(board, rc, "estimate");
            }
            if measure {
                let depth = painted_depth(low);
                fig.stack_update = fig.stack_update.max(depth);
                if catch_up > 0 {
                    fig.stack_update_after_gap = fig.stack_update_after_gap.max(depth);
                    catch_up -= 1;
                }
            }
            if flags & TAIJI_SOLVE_DUE != 0 {
                let low = paint_stack(board);
                let t0 = board.clock();
                let (work, work_size) = m.work();
                // SAFETY: an initialised state and the scratch.
                let rc = unsafe { taiji_estimator_solve(mem, work, work_size) };
                fig.solve_max = fig.solve_max.max(board.ticks_since(t0));
                fig.stack_solve = fig.stack_solve.max(painted_depth(low));
                // A failed solve keeps the previous solution; the status word says so.
                if rc == TAIJI_ERR_SOLVE {
                    fig.solves_failed += 1;
                } else {
                    check(board, rc, "solve");
                }
                fig.n_solves += 1;
            }
        }
        done += k as u64;
    }
}

/// A checkpoint round trip, then `finish` on the restored state: the final estimate.
fn finish<B: Board>(
    board: &mut B,
    m: &mut Memory,
    cfg: &EstimatorConfig,
    fig: &mut Figures,
) -> EstimateMsg {
    let (mem, mem_size) = m.mem();
    let mut written = 0usize;
    let low = paint_stack(board);
    // SAFETY: an initialised state and a buffer of CKPT_BYTES.
    let rc =
        unsafe { taiji_estimator_checkpoint(mem, m.ckpt.as_mut_ptr(), CKPT_BYTES, &mut written) };
    fig.stack_checkpoint = painted_depth(low);
    check(board, rc, "checkpoint");
    fig.checkpoint_bytes = written;
    m.state.iter_mut().for_each(|w| *w = 0);
    let low = paint_stack(board);
    // SAFETY: as above; `written` bytes of the checkpoint.
    let rc = unsafe { taiji_estimator_restore(mem, mem_size, m.ckpt.as_ptr(), written, cfg) };
    fig.stack_restore = painted_depth(low);
    check(board, rc, "restore");
    let mut est = EstimateMsg::default();
    let low = paint_stack(board);
    let t0 = board.clock();
    let (work, work_size) = m.work();
    // SAFETY: a restored state, the scratch and an output message.
    let rc = unsafe { taiji_estimator_finish(mem, work, work_size, &mut est) };
    fig.finish = board.ticks_since(t0);
    fig.stack_finish = painted_depth(low);
    check(board, rc, "finish");
    est
}

fn print_vec(out: &mut impl Write, key: &str, v: &[f64; 3], last: bool) {
    let _ = writeln!(
        out,
        "      \"{key}\": [{:e}, {:e}, {:e}]{}",
        v[0],
        v[1],
        v[2],
        if last { "" } else { "," }
    );
}

fn print_param(out: &mut impl Write, name: &str, est: &[f64; 3], sig: &[f64; 3], last: bool) {
    let _ = writeln!(out, "    \"{name}\": {{");
    print_vec(out, "estimate", est, false);
    print_vec(out, "sigma", sig, true);
    let _ = writeln!(out, "    }}{}", if last { "" } else { "," });
}

/// The final estimates and σ, shaped like report.json's `inertial_sensors`.
fn print_estimates(out: &mut impl Write, cfg: &EstimatorConfig, est: &EstimateMsg) {
    let _ = writeln!(out, "{{\n  \"inertial_sensors\": [");
    let n_is = cfg.n_is.min(2) as usize;
    for i in 0..n_is {
        let _ = writeln!(out, "   {{\n    \"id\": {},", i + 1);
        print_param(out, "beta", &est.beta[i], &est.beta_sigma[i], false);
        print_param(out, "k", &est.k[i], &est.k_sigma[i], false);
        print_param(out, "com_offset", &est.r_b[i], &est.r_sigma[i], true);
        let _ = writeln!(out, "   }}{}", if i + 1 < n_is { "," } else { "" });
    }
    let _ = writeln!(out, "  ],\n  \"estimator_status\": {},", est.status);
    let _ = writeln!(
        out,
        "  \"samples_used\": {},\n  \"samples_rejected\": {},",
        est.n_used, est.n_rejected
    );
}

/// The `flight` object: instructions and stack per call, sizes.
fn print_figures<B: Board>(out: &mut impl Write, costs: &mut [u32], fig: &Figures) {
    // Instructions per call: ticks over the calibrated ticks per instruction.
    let instr = |ticks: u32| (ticks as f64 / fig.ticks_per_instr).round() as u64;
    // The sample whose update cost most (the first of equals), before the sort.
    let max_at = costs
        .iter()
        .enumerate()
        .fold(
            (0, 0),
            |(bi, b), (i, &c)| if c > b { (i, c) } else { (bi, b) },
        )
        .0;
    // The mean, from the ticks' sum (the mean load's figure).
    let sum: u64 = costs.iter().map(|&c| u64::from(c)).sum();
    let mean = (sum as f64 / costs.len().max(1) as f64 / fig.ticks_per_instr).round() as u64;
    costs.sort_unstable();
    let pick = |q: f64| {
        costs
            .get(((costs.len() as f64 * q) as usize).min(costs.len().saturating_sub(1)))
            .copied()
            .unwrap_or(0)
    };
    let _ = writeln!(out, "  \"flight\": {{");
    let _ = writeln!(out, "    \"cpu\": \"{}\",", B::CPU);
    let _ = writeln!(out, "    \"upset_check\": {},", taiji_upset_check());
    let _ = writeln!(
        out,
        "    \"updates\": {},\n    \"solves\": {},\n    \"solves_failed\": {},",
        fig.n, fig.n_solves, fig.solves_failed
    );
    let _ = writeln!(
        out,
        "    \"update_instructions\": {{\"mean\": {}, \"p50\": {}, \"p99\": {}, \"max\": {}, \"max_at\": {}}},",
        mean,
        instr(pick(0.5)),
        instr(pick(0.99)),
        instr(costs.last().copied().unwrap_or(0)),
        max_at
    );
    let _ = writeln!(
        out,
        "    \"solve_instructions_max\": {},",
        instr(fig.solve_max)
    );
    let _ = writeln!(out, "    \"finish_instructions\": {},", instr(fig.finish));
    let _ = writeln!(out, "    \"timer\": \"{}\",", B::TIMER);
    let _ = writeln!(
        out,
        "    \"timer_ticks_per_instruction\": {:e},",
        fig.ticks_per_instr
    );
    let _ = writeln!(
        out,
        "    \"state_bytes\": {},\n    \"checkpoint_bytes\": {},",
        taiji_estimator_size(),
        fig.checkpoint_bytes
    );
    let _ = writeln!(out, "    \"gap_ticks_max\": {},", fig.gap_ticks_max);
    let _ = writeln!(
        out,
        "    \"solve_work_bytes\": {},\n    \"stack_bytes\": {{\"init\": {}, \"update\": {}, \"update_after_gap\": {}, \"solve\": {}, \"checkpoint\": {}, \"restore\": {}, \"finish\": {}}}\n  }}\n}}",
        taiji_solve_work_size(),
        fig.stack_init,
        fig.stack_update,
        fig.stack_update_after_gap,
        fig.stack_solve,
        fig.stack_checkpoint,
        fig.stack_restore,
        fig.stack_finish
    );
}

/// The whole program on `board`: replays the export, prints the result, halts.
///
/// # Safety
/// Called once (it takes the program's static memory), with a stack deeper than
/// [`PAINT_BYTES`] below the caller's frame.
pub unsafe fn run<B: Board>(board: &mut B) -> ! {
    let ticks_per_instr = calibrate(board);
    // SAFETY: `run` is called once.
    let mut m = unsafe { Memory::take() };
    let (cfg, mut samples, n, stack_init) = init(board, &mut m);
    let mut fig = Figures {
        n,
        ticks_per_instr,
        stack_init,
        ..Figures::default()
    };
    replay(board, &mut m, &mut samples, &mut fig);
    drop(samples);
    let est = finish(board, &mut m, &cfg, &mut fig);
    let mut out = board.out();
    print_estimates(&mut out, &cfg, &est);
    print_figures::<B>(&mut out, &mut m.cost[..n as usize], &fig);
    drop(out);
    board.halt(true)
}
