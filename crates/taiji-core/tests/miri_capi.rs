//! The C ABI driven from Rust exactly as a C host drives it (examples/c/host.c,
//! include/taiji_estimator.h): only the `extern "C"` functions, with raw pointers into
//! memory the host owns and reaches only through those pointers (never a Rust
//! reference to it between calls). The state and the solve's scratch are fresh
//! allocations that were never written (as `malloc` gives them); the table, the
//! samples and every out-parameter sit at odd addresses in byte buffers (as a packed
//! telemetry frame or a byte stream would hold them). A short recording that starts
//! with an IS dropout and has a gap longer than one update bridges, a duplicate tick
//! and a non-finite sample goes through init, update, solve, estimate, checkpoint,
//! restore and finish, and every refusal the header lists is provoked: null pointers,
//! misaligned or small memory, overlapping scratch, another header's sizes, a bad
//! table, torn and corrupted checkpoints, a flipped bit, calls after finish.
//!
//! Sized for Miri (`tools/miri`), which interprets this code about 10⁶ times slower
//! than it runs natively: an update takes about 2 s there, one Gauss–Newton iteration
//! about 2 minutes. So under Miri the recording is 30 ticks and its estimator is not
//! solved (the solve's calls are refused or run on an estimator without data, which
//! returns at once); `a_solve_reads_only_what_it_wrote_in_uninitialised_scratch` runs
//! one real iteration there. Natively (`cargo test`) the recording is 300 ticks, solved
//! on schedule and finished.

use std::alloc::{alloc, dealloc, Layout};
use std::mem::{align_of, size_of};
use std::ptr::{self, null, null_mut};
use taiji_core::capi::*;
use taiji_core::estimate::snapshot::fnv1a;
use taiji_core::estimate::EstimatorConfig;
use taiji_core::msg::*;

/// Sample rate of the recording [Hz].
const FS: f64 = 10.0;
/// Interpreted (Miri) or compiled: the recording's size and whether it is solved.
const MIRI: bool = cfg!(miri);
/// Ticks in the recording.
const TICKS: u64 = if MIRI { 30 } else { 300 };
/// Natively two scheduled solves; under Miri none (`a_solve_reads_only_…` solves).
const SOLVE_EVERY: u64 = if MIRI { 1 << 20 } else { 100 };
/// Ticks left out of the recording: more than one update bridges (8), so the update
/// after it bridges 8 and the next ones catch up.
const GAP: std::ops::Range<u64> = if MIRI { 6..16 } else { 60..72 };
/// A tick whose voltages are not finite (rejected), and one sent twice (refused).
const BAD_TICK: u64 = if MIRI { 20 } else { 130 };
const REPEATED_TICK: u64 = if MIRI { 23 } else { 170 };

/// What the host's header says (`TAIJI_ABI_ARGS`).
const ABI: (u32, usize, usize, usize) = (
    TAIJI_ABI_VERSION,
    size_of::<EstimatorConfig>(),
    size_of::<SensorSample>(),
    size_of::<EstimateMsg>(),
);

/// Memory a C host owns: a raw allocation (never written by this test before the
/// library writes it, unless `fill` says so), reached only through raw pointers and
/// freed on drop.
struct Memory {
    base: *mut u8,
    layout: Layout,
}

impl Memory {
    /// `len` bytes aligned to `align`, uninitialised (`malloc`).
    fn uninit(len: usize, align: usize) -> Self {
        let layout = Layout::from_size_align(len, align).unwrap();
        // SAFETY: `len` > 0 at every call.
        let base = unsafe { alloc(layout) };
        assert!(!base.is_null());
        Memory { base, layout }
    }

    /// `len` bytes aligned to `align`, every byte `fill` (`static` memory, `memset`).
    fn filled(len: usize, align: usize, fill: u8) -> Self {
        let m = Self::uninit(len, align);
        // SAFETY: the allocation holds `len` bytes.
        unsafe { ptr::write_bytes(m.base, fill, len) };
        m
    }

    /// The address `off` bytes into the allocation.
    fn at(&self, off: usize) -> *mut u8 {
        assert!(off <= self.layout.size());
        // SAFETY: within the allocation (or one past its end).
        unsafe { self.base.add(off) }
    }

    fn len(&self) -> usize {
        self.layout.size()
    }
}

impl Drop for Memory {
    fn drop(&mut self) {
        // SAFETY: allocated by `alloc` with this layout, freed once.
        unsafe { dealloc(self.base, self.layout) };
    }
}

/// A value of type `T` written at an odd address of a byte buffer; `ptr()` is that
/// (misaligned) address and `get()` reads the value back.
struct Odd<T: Copy> {
    mem: Memory,
    off: usize,
    _t: std::marker::PhantomData<T>,
}

impl<T: Copy> Odd<T> {
    fn new(value: T, off: usize) -> Self {
        assert!(off % 2 == 1, "an odd offset is misaligned for every T here");
        let mem = Memory::filled(size_of::<T>() + off, 8, 0xA5);
        // SAFETY: the buffer holds size_of::<T>() bytes from `off`.
        unsafe { ptr::write_unaligned(mem.at(off) as *mut T, value) };
        Odd {
            mem,
            off,
            _t: std::marker::PhantomData,
        }
    }

    fn ptr(&self) -> *mut T {
        self.mem.at(self.off) as *mut T
    }

    fn get(&self) -> T {
        // SAFETY: written in `new` (or by the library through `ptr`).
        unsafe { ptr::read_unaligned(self.ptr()) }
    }
}

/// The host's table: the default Taiji case's magnitudes, a solve every `SOLVE_EVERY`.
fn table() -> EstimatorConfig {
    EstimatorConfig {
        fs: FS,
        n_is: 2,
        geometry_m: [[0.02, 0.025, 0.03], [0.021, 0.024, 0.031]],
        beta_prior: [[2e-6, 2.1e-6, 1.9e-6], [2.05e-6, 1.95e-6, 2e-6]],
        com_prior_m: [[1e-4, -2e-4, 5e-5], [0.0, 1e-4, -1e-4]],
        sigma_star_rad: 3.2e-7,
        sigma_angular: 3e-10,
        sigma_linear: 1e-12,
        sigma_ripple: 1e-6,
        srp_asd_at_3mhz: 1.1e-11,
        sigma_force: 0.0,
        solve_every: SOLVE_EVERY,
        full_scale_linear: 1e-8,
        full_scale_angular: 1e-7,
        max_gap_ticks: 6000,
        gate_sigma: EstimatorConfig::GATE_SIGMA,
        star_gate_sigma: EstimatorConfig::STAR_GATE_SIGMA,
        chi2_tolerance: EstimatorConfig::CHI2_TOLERANCE,
        degraded_one_in: EstimatorConfig::DEGRADED_ONE_IN,
    }
}

/// Unit normal draws (xorshift64, Box–Muller): the same numbers on every host.
struct Noise(u64);

impl Noise {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn gauss(&mut self) -> f64 {
        (-2.0 * self.uniform().ln()).sqrt() * (std::f64::consts::TAU * self.uniform()).cos()
    }
}

/// The recording's sample of tick `k`: both IS see the same slow rocking ω̇ about
/// every axis (their angular voltages ω̇/β plus readout noise), small linear signals,
/// and a star tracker on the attitude it integrates to, with its noise.
fn sample(k: u64, cfg: &EstimatorConfig, noise: &mut Noise) -> SensorSample {
    let t = k as f64 / cfg.fs;
    let (amp, w, phase) = ([3e-9, 2e-9, 2.5e-9], [0.21, 0.33, 0.47], [0.0, 1.0, 2.0]);
    let mut s = SensorSample {
        header: Header::at(k, k, cfg.fs),
        ..Default::default()
    };
    let mut theta = [0.0; 3];
    for a in 0..3 {
        let x = w[a] * t + phase[a];
        let wdot = amp[a] * x.sin();
        // ∬ ω̇ from rest.
        theta[a] = amp[a] / (w[a] * w[a]) * (phase[a].sin() - x.sin())
            + amp[a] / w[a] * phase[a].cos() * t;
        for i in 0..2 {
            let dv = wdot / cfg.beta_prior[i][a]
                + cfg.sigma_angular / cfg.beta_prior[i][a] * noise.gauss();
            let sum = 1e-4 * (0.05 * t + a as f64).sin() + 1e-7 * noise.gauss();
            s.is[i].volts[PAIR_OF_ANGULAR[a]] = [0.5 * (sum + dv), 0.5 * (sum - dv)];
        }
    }
    let half: [f64; 3] =
        std::array::from_fn(|a| 0.5 * (theta[a] + cfg.sigma_star_rad * noise.gauss()));
    let n = (1.0 + half.iter().map(|h| h * h).sum::<f64>()).sqrt();
    s.star.q_bn = [1.0 / n, half[0] / n, half[1] / n, half[2] / n];
    s.star.valid = 1;
    s
}

/// The recording of ticks `0..n` as a host receives it: the samples back to back in a
/// byte stream at an odd offset (so every sample is misaligned); with `faults`, IS 2
/// dropped out at the first tick, a gap, a non-finite sample and a tick sent twice.
fn recording(cfg: &EstimatorConfig, n: u64, faults: bool) -> (Memory, Vec<usize>, Vec<u64>) {
    let mut noise = Noise(0x2545_f491_4f6c_dd1d);
    let mut ticks = Vec::new();
    for k in 0..n {
        if faults && GAP.contains(&k) {
            continue;
        }
        ticks.push(k);
        if faults && k == REPEATED_TICK {
            ticks.push(k);
        }
    }
    let stride = size_of::<SensorSample>();
    let mem = Memory::filled(3 + stride * ticks.len(), 8, 0);
    let mut offsets = Vec::new();
    for (n, &k) in ticks.iter().enumerate() {
        let mut s = sample(k, cfg, &mut noise);
        if faults && k == BAD_TICK {
            s.is[1].volts[2][0] = f64::NAN;
        }
        if faults && k == 0 {
            s.is[1].flags = FLAG_DROPOUT;
        }
        let off = 3 + stride * n;
        // SAFETY: the stream holds `stride` bytes at `off`.
        unsafe { ptr::write_unaligned(mem.at(off) as *mut SensorSample, s) };
        offsets.push(off);
    }
    (mem, offsets, ticks)
}

/// `taiji_estimator_init` as the header's `TAIJI_ABI_ARGS` call it.
unsafe fn init(mem: *mut u8, len: usize, cfg: *const EstimatorConfig) -> i32 {
    unsafe { taiji_estimator_init(mem, len, cfg, ABI.0, ABI.1, ABI.2, ABI.3) }
}

/// The estimate of `mem` (into a misaligned out-parameter), or the call's code.
fn estimate(mem: *mut u8) -> Result<EstimateMsg, i32> {
    let out = Odd::new(EstimateMsg::default(), 5);
    // SAFETY: `out` is writable for an EstimateMsg; `mem` is checked by the library.
    match unsafe { taiji_estimator_estimate(mem, out.ptr()) } {
        TAIJI_OK => Ok(out.get()),
        rc => Err(rc),
    }
}

fn same_bytes(a: &EstimateMsg, b: &EstimateMsg) -> bool {
    // SAFETY: plain numbers without padding (`Pod`), read as their bytes.
    let bytes = |m: &EstimateMsg| unsafe {
        std::slice::from_raw_parts(
            m as *const EstimateMsg as *const u8,
            size_of::<EstimateMsg>(),
        )
        .to_vec()
    };
    bytes(a) == bytes(b)
}

#[test]
fn a_c_host_runs_a_short_recording_through_every_call_and_every_refusal() {
    // The sizes the host queries (the header's MEMORY figures).
    let (size, align) = (taiji_estimator_size(), taiji_estimator_align());
    let (work_size, ckpt_size) = (taiji_solve_work_size(), taiji_checkpoint_size());
    assert_eq!(taiji_abi_version(), TAIJI_ABI_VERSION);
    assert_eq!(taiji_layout_version(), LAYOUT_VERSION);
    assert!(align.is_power_of_two() && align >= align_of::<u64>());
    assert!(ckpt_size < size && work_size > 0);

    let cfg = table();
    let table_at = Odd::new(cfg, 3);
    // The state: uninitialised, with 8 spare bytes to misalign it by.
    let state = Memory::uninit(size + 8, align);
    let mem = state.at(0);
    // SAFETY (the whole test): every pointer passed is null on purpose, or points into
    // a live allocation of at least the length passed with it; the library checks the
    // rest (alignment, sizes, the state's magic word and seal).
    unsafe {
        // --- init and its refusals ---
        assert_eq!(init(null_mut(), size, table_at.ptr()), TAIJI_ERR_NULL);
        assert_eq!(init(mem, size, null()), TAIJI_ERR_NULL);
        for off in [1, 4, 7] {
            assert_eq!(
                init(state.at(off), size, table_at.ptr()),
                TAIJI_ERR_ALIGNMENT
            );
        }
        assert_eq!(init(mem, size - 1, table_at.ptr()), TAIJI_ERR_SIZE);
        assert_eq!(
            taiji_estimator_init(mem, size, table_at.ptr(), ABI.0 + 1, ABI.1, ABI.2, ABI.3),
            TAIJI_ERR_VERSION
        );
        assert_eq!(
            taiji_estimator_init(mem, size, table_at.ptr(), ABI.0, ABI.1, ABI.2 - 8, ABI.3),
            TAIJI_ERR_VERSION
        );
        let mut bad = cfg;
        bad.fs = f64::NAN;
        let bad_at = Odd::new(bad, 1);
        assert_eq!(init(mem, size, bad_at.ptr()), TAIJI_ERR_CONFIG);
        // A refused init leaves no estimator (the magic word is cleared first).
        assert_eq!(estimate(mem).unwrap_err(), TAIJI_ERR_STATE);
        assert_eq!(init(mem, state.len(), table_at.ptr()), TAIJI_OK);
        let first = estimate(mem).unwrap();
        assert_ne!(first.status & ST_NO_SOLUTION, 0, "no solution before data");

        // --- update, with the solve when it is due ---
        let (stream, offsets, ticks) = recording(&cfg, TICKS, true);
        // Scratch for the solve: uninitialised, 8 spare bytes to misalign it by.
        let work = Memory::uninit(work_size + 8, 8);
        let rejected = Odd::new(u64::MAX, 3);
        let flags = Odd::new(u32::MAX, 1);
        let (mut solves, mut solved_ok) = (0, 0);
        let mut order_refused = 0;
        for (&off, &k) in offsets.iter().zip(&ticks) {
            let s = stream.at(off) as *const SensorSample;
            let rc = taiji_estimator_update(mem, s, rejected.ptr(), flags.ptr());
            assert_eq!(rc, TAIJI_OK, "tick {k}");
            let causes = rejected.get();
            if k == BAD_TICK {
                assert_ne!(causes & 1 << CAUSE_NON_FINITE, 0, "the NaN sample");
            }
            if causes & 1 << CAUSE_TICK_ORDER != 0 {
                order_refused += 1;
                assert_eq!(k, REPEATED_TICK);
            }
            if k == GAP.end {
                assert_ne!(causes & 1 << CAUSE_TICK_MISSING, 0, "the gap bridged");
            }
            if k == 0 {
                assert_eq!(causes, 1 << CAUSE_IS_FLAGGED, "IS 2 dropped out");
            }
            assert!(flags.get() & !TAIJI_SOLVE_DUE == 0);
            if flags.get() & TAIJI_SOLVE_DUE != 0 {
                let rc = taiji_estimator_solve(mem, work.at(0), work_size);
                assert!(rc == TAIJI_OK || rc == TAIJI_ERR_SOLVE, "solve: {rc}");
                solves += 1;
                solved_ok += (rc == TAIJI_OK) as u32;
            }
        }
        assert!(
            if MIRI { solves == 0 } else { solves >= 2 },
            "{solves} solves"
        );
        assert!(MIRI || solved_ok >= 1, "no solve succeeded");
        assert_eq!(order_refused, 1);
        // The scratch's refusals, the state left as it was (nothing is solved).
        let before = estimate(mem).unwrap();
        let w = work.at(0);
        assert_eq!(
            taiji_estimator_solve(mem, null_mut(), work_size),
            TAIJI_ERR_NULL
        );
        assert_eq!(taiji_estimator_solve(mem, w, work_size - 1), TAIJI_ERR_SIZE);
        assert_eq!(
            taiji_estimator_solve(mem, work.at(4), work_size),
            TAIJI_ERR_ALIGNMENT
        );
        let overlap = work_size.max(size);
        assert_eq!(taiji_estimator_solve(mem, mem, overlap), TAIJI_ERR_OVERLAP);
        let tail = mem.add(size - 8);
        assert_eq!(
            taiji_estimator_solve(mem, tail, work_size),
            TAIJI_ERR_OVERLAP
        );
        assert_eq!(
            taiji_estimator_solve(null_mut(), w, work_size),
            TAIJI_ERR_NULL
        );
        assert_eq!(
            taiji_estimator_solve(state.at(1), w, work_size),
            TAIJI_ERR_ALIGNMENT
        );
        let after = estimate(mem).unwrap();
        assert_eq!(before.solved_tick, after.solved_tick);
        assert!(before.beta == after.beta && before.status == after.status);
        // The optional out-parameters may be null.
        let last = *ticks.last().unwrap();
        let mut s = ptr::read_unaligned(stream.at(*offsets.last().unwrap()) as *const SensorSample);
        s.header.tick = last + 1;
        let next = Odd::new(s, 7);
        assert_eq!(
            taiji_estimator_update(mem, next.ptr(), null_mut(), null_mut()),
            TAIJI_OK
        );
        assert_eq!(
            taiji_estimator_update(mem, null(), null_mut(), null_mut()),
            TAIJI_ERR_NULL
        );

        // --- the estimate ---
        assert_eq!(taiji_estimator_estimate(mem, null_mut()), TAIJI_ERR_NULL);
        assert_eq!(estimate(null_mut()).unwrap_err(), TAIJI_ERR_NULL);
        assert_eq!(estimate(state.at(2)).unwrap_err(), TAIJI_ERR_ALIGNMENT);
        let est = estimate(mem).unwrap();
        assert_eq!(est.status & ST_NO_SOLUTION == 0, !MIRI, "{:#x}", est.status);
        let gap = GAP.end - GAP.start;
        // The gap, and the sample that arrived while its catch-up went on.
        assert_eq!(est.rejected_by_cause[CAUSE_TICK_MISSING], gap + 1);
        assert_eq!(est.rejected_by_cause[CAUSE_TICK_ORDER], 1);
        assert!(est.rejected_by_cause[CAUSE_NON_FINITE] >= 1);
        assert_eq!(est.n_used + est.n_rejected, TICKS + 1);
        assert!(est.n_used > (TICKS - gap) * 3 / 4, "{} used", est.n_used);
        for v in est.beta.iter().chain(&est.beta_sigma).flatten() {
            assert!(v.is_finite() && *v != 0.0);
        }

        // --- checkpoint into a misaligned buffer, and its refusals ---
        let ckpt = Memory::filled(ckpt_size + 3, 8, 0x5A);
        let (buf, len) = (ckpt.at(3), ckpt_size);
        let written = Odd::new(0usize, 7);
        assert_eq!(
            taiji_estimator_checkpoint(mem, null_mut(), len, written.ptr()),
            TAIJI_ERR_NULL
        );
        assert_eq!(
            taiji_estimator_checkpoint(mem, buf, len - 1, written.ptr()),
            TAIJI_ERR_SIZE
        );
        assert_eq!(
            taiji_estimator_checkpoint(null_mut(), buf, len, written.ptr()),
            TAIJI_ERR_NULL
        );
        assert_eq!(
            taiji_estimator_checkpoint(mem, buf, len, null_mut()),
            TAIJI_OK
        );
        assert_eq!(
            taiji_estimator_checkpoint(mem, buf, len, written.ptr()),
            TAIJI_OK
        );
        assert_eq!(written.get(), ckpt_size);

        // --- restore into other uninitialised memory, and its refusals ---
        let other = Memory::uninit(size, align);
        let q = other.at(0);
        let restore = |bytes: *const u8, n: usize, cfg: *const EstimatorConfig| {
            taiji_estimator_restore(q, size, bytes, n, cfg)
        };
        assert_eq!(restore(null(), len, table_at.ptr()), TAIJI_ERR_NULL);
        assert_eq!(restore(buf, len, null()), TAIJI_ERR_NULL);
        assert_eq!(
            taiji_estimator_restore(other.at(0), size - 1, buf, len, table_at.ptr()),
            TAIJI_ERR_SIZE
        );
        assert_eq!(
            restore(buf, 31, table_at.ptr()),
            TAIJI_ERR_SIZE,
            "shorter than its header"
        );
        assert_eq!(
            restore(buf, len - 1, table_at.ptr()),
            TAIJI_ERR_CHECKPOINT,
            "torn"
        );
        // Corrupted copies: magic, version, size, checksum, and the state's first,
        // middle and last bytes, each flipped by one bit.
        let copy = Memory::uninit(len + 1, 8);
        let c = copy.at(1);
        let header = 32;
        for (at, want) in [
            (0, TAIJI_ERR_CHECKPOINT),
            (8, TAIJI_ERR_VERSION),
            (16, TAIJI_ERR_CHECKPOINT),
            (24, TAIJI_ERR_CHECKPOINT),
            (header, TAIJI_ERR_CHECKPOINT),
            (header + (len - header) / 2, TAIJI_ERR_CHECKPOINT),
            (len - 1, TAIJI_ERR_CHECKPOINT),
        ] {
            ptr::copy_nonoverlapping(buf, c, len);
            *c.add(at) ^= 0x10;
            assert_eq!(restore(c, len, table_at.ptr()), want, "byte {at} flipped");
            assert_eq!(
                estimate(q).unwrap_err(),
                TAIJI_ERR_STATE,
                "byte {at} flipped"
            );
        }
        // Intact (its checksum rewritten) but an impossible state: a table that fails
        // its check.
        ptr::copy_nonoverlapping(buf, c, len);
        ptr::write_unaligned(c.add(header) as *mut f64, f64::NAN); // the table's fs
        let state_bytes = std::slice::from_raw_parts(c.add(header), len - header);
        let sum = fnv1a(state_bytes).to_le_bytes();
        ptr::copy_nonoverlapping(sum.as_ptr(), c.add(24), 8);
        assert_eq!(restore(c, len, table_at.ptr()), TAIJI_ERR_CHECKPOINT);
        // Made under another table than the host's.
        let mut other_cfg = cfg;
        other_cfg.beta_prior[1][2] *= 1.01;
        let other_at = Odd::new(other_cfg, 5);
        assert_eq!(restore(buf, len, other_at.ptr()), TAIJI_ERR_CONFIG);
        assert_eq!(estimate(q).unwrap_err(), TAIJI_ERR_STATE);
        // The intact one, from its misaligned buffer: the same estimator.
        assert_eq!(restore(buf, len, table_at.ptr()), TAIJI_OK);
        assert!(same_bytes(&estimate(q).unwrap(), &estimate(mem).unwrap()));

        // --- both go on alike: a few more samples and (natively) a solve ---
        for k in last + 2..last + 6 {
            let mut s = ptr::read_unaligned(next.ptr());
            s.header.tick = k;
            let at = Odd::new(s, 1);
            assert_eq!(
                taiji_estimator_update(mem, at.ptr(), null_mut(), null_mut()),
                TAIJI_OK
            );
            assert_eq!(
                taiji_estimator_update(q, at.ptr(), null_mut(), null_mut()),
                TAIJI_OK
            );
        }
        if !MIRI {
            let rc = taiji_estimator_solve(mem, w, work_size);
            assert_eq!(taiji_estimator_solve(q, w, work_size), rc);
        }
        assert!(same_bytes(&estimate(q).unwrap(), &estimate(mem).unwrap()));

        // --- a bit flipped while the state rests is found before it is used (a build
        // for EDAC memory has no seal: the hardware corrects it) ---
        assert_eq!(taiji_upset_check(), u32::from(!cfg!(feature = "edac")));
        let flips: &[(usize, u32)] = if cfg!(feature = "edac") {
            &[]
        } else {
            // (The state's last word, which part the next update scrubs, is not sealed.)
            &[(1, 0), (size / 16, 62), (size / 8 - 2, 7)]
        };
        for &(word, bit) in flips {
            let at = (q as *mut u64).add(word);
            *at ^= 1 << bit;
            assert_eq!(estimate(q).unwrap_err(), TAIJI_ERR_UPSET, "word {word}");
            assert_eq!(taiji_estimator_solve(q, w, work_size), TAIJI_ERR_UPSET);
            *at ^= 1 << bit;
            assert!(estimate(q).is_ok(), "word {word} flipped back");
        }

        // --- an estimator without data: nothing to solve, finish gives the priors ---
        let fresh = Memory::uninit(size, align);
        let f = fresh.at(0);
        assert_eq!(init(f, size, table_at.ptr()), TAIJI_OK);
        assert_eq!(taiji_estimator_solve(f, w, work_size), TAIJI_ERR_SOLVE);
        let prior = estimate(f).unwrap();
        assert_ne!(prior.status & ST_NO_SOLUTION, 0);

        // --- finish: terminal and idempotent (under Miri the estimator without data:
        // the recording's would iterate, minutes each) ---
        let (fin_mem, ticks_seen) = if MIRI { (f, 0) } else { (mem, last + 6) };
        let out = Odd::new(EstimateMsg::default(), 3);
        let finish = |m: *mut u8, w: *mut u8, n: usize, o: *mut EstimateMsg| {
            taiji_estimator_finish(m, w, n, o)
        };
        assert_eq!(
            finish(fin_mem, null_mut(), work_size, out.ptr()),
            TAIJI_ERR_NULL
        );
        assert_eq!(finish(fin_mem, w, work_size - 1, out.ptr()), TAIJI_ERR_SIZE);
        assert_eq!(finish(fin_mem, w, work_size, null_mut()), TAIJI_ERR_NULL);
        assert_eq!(finish(null_mut(), w, work_size, out.ptr()), TAIJI_ERR_NULL);
        assert_eq!(finish(fin_mem, w, work_size, out.ptr()), TAIJI_OK);
        let fin = out.get();
        assert_ne!(fin.flags & EST_FINAL, 0);
        assert_eq!(fin.n_used + fin.n_rejected, ticks_seen);
        // A second finish writes the same estimate without writing the scratch, which
        // is still checked (null is refused), and estimate gives it too.
        let again = Odd::new(EstimateMsg::default(), 1);
        assert_eq!(
            finish(fin_mem, null_mut(), work_size, again.ptr()),
            TAIJI_ERR_NULL
        );
        assert_eq!(finish(fin_mem, w, work_size, again.ptr()), TAIJI_OK);
        assert!(same_bytes(&fin, &again.get()));
        assert!(same_bytes(&fin, &estimate(fin_mem).unwrap()));
        let s = Odd::new(ptr::read_unaligned(next.ptr()), 3);
        assert_eq!(
            taiji_estimator_update(fin_mem, s.ptr(), null_mut(), null_mut()),
            TAIJI_ERR_FINISHED
        );
        assert_eq!(
            taiji_estimator_solve(fin_mem, w, work_size),
            TAIJI_ERR_FINISHED
        );
        assert_eq!(
            taiji_estimator_checkpoint(fin_mem, buf, len, null_mut()),
            TAIJI_ERR_FINISHED
        );

        // --- memory that never held an estimator ---
        let garbage = Memory::filled(size, align, 0xC3);
        assert_eq!(estimate(garbage.at(0)).unwrap_err(), TAIJI_ERR_STATE);
        assert_eq!(
            taiji_estimator_solve(garbage.at(0), w, work_size),
            TAIJI_ERR_STATE
        );
        // The magic word alone is no state either (the seal and the table fail).
        ptr::write_bytes(garbage.at(0), 0, size);
        ptr::write(garbage.at(0) as *mut u64, u64::from_le_bytes(*b"TAIJIEST"));
        assert!(estimate(garbage.at(0)).is_err());
    }
}

/// A solve in scratch that was never written (`malloc`'s) reads only what it wrote:
/// under Miri, a read of an uninitialised byte of it would stop the test. One
/// scheduled Gauss–Newton iteration on a short recording (about 2 minutes under Miri:
/// `tools/miri` runs it in the full suite, not in `--ci`); natively also `finish`,
/// whose estimate is the same whatever the scratch held before (uninitialised here,
/// 0xFF-filled for a second estimator).
#[test]
fn a_solve_reads_only_what_it_wrote_in_uninitialised_scratch() {
    let (size, align, work_size) = (
        taiji_estimator_size(),
        taiji_estimator_align(),
        taiji_solve_work_size(),
    );
    let n = if MIRI { 12 } else { 120 };
    let mut cfg = table();
    cfg.solve_every = n;
    let (stream, offsets, ticks) = recording(&cfg, n, false);
    let runs = if MIRI { 1 } else { 2 };
    let mut finals = Vec::new();
    for run in 0..runs {
        let state = Memory::uninit(size, align);
        let work = if run == 0 {
            Memory::uninit(work_size, 8)
        } else {
            Memory::filled(work_size, 8, 0xFF)
        };
        let (mem, w) = (state.at(0), work.at(0));
        let flags = Odd::new(0u32, 1);
        // SAFETY: live allocations of the sizes passed; the library checks the rest.
        unsafe {
            assert_eq!(init(mem, size, &cfg), TAIJI_OK);
            let mut solved = 0;
            for (&off, &k) in offsets.iter().zip(&ticks) {
                let s = stream.at(off) as *const SensorSample;
                assert_eq!(
                    taiji_estimator_update(mem, s, null_mut(), flags.ptr()),
                    TAIJI_OK
                );
                if flags.get() & TAIJI_SOLVE_DUE != 0 {
                    assert_eq!(
                        taiji_estimator_solve(mem, w, work_size),
                        TAIJI_OK,
                        "tick {k}"
                    );
                    solved += 1;
                }
            }
            assert_eq!(solved, 1);
            let est = estimate(mem).unwrap();
            assert_eq!(est.status & (ST_NO_SOLUTION | ST_SOLVE_FAILED), 0);
            assert!(est
                .beta_sigma
                .iter()
                .flatten()
                .all(|s| s.is_finite() && *s > 0.0));
            if !MIRI {
                let out = Odd::new(EstimateMsg::default(), 5);
                assert_eq!(
                    taiji_estimator_finish(mem, w, work_size, out.ptr()),
                    TAIJI_OK
                );
                finals.push(out.get());
            }
        }
    }
    if let [a, b] = &finals[..] {
        assert!(
            same_bytes(a, b),
            "the scratch's contents reached the estimate"
        );
    }
}
