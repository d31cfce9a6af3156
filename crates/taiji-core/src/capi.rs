//! The C ABI of the joint estimator, for flight software in C or C++ (a cFS app, an
//! F Prime component): the caller owns the state's memory (query its size and
//! alignment, then `taiji_estimator_init` into it), every call returns a status code
//! (`TAIJI_OK` = 0, errors after it) and nothing is global. `update` is bounded
//! per-sample work; `solve` is the Gauss–Newton step the host schedules in its own
//! rate group (`update` says when one is due). Checkpoints go to a caller's buffer.
//!
//! Every entry point checks its pointers (null, alignment) and the state's magic word
//! before touching anything, and the library is built with `panic = "abort"`, so
//! nothing unwinds into C. The header `include/taiji_estimator.h` is generated from
//! this file by cbindgen (a test keeps it up to date).

use crate::estimate::config::EstimatorConfig;
use crate::estimate::joint::{JointEstimator, SolveWork};
use crate::estimate::snapshot;
use crate::msg::{EstimateMsg, SensorSample, EST_FINAL, LAYOUT_VERSION};
use core::mem::{align_of, size_of};

mod seal;
use seal::{Mask, ALL, FLUSH, SCRUB_PARTS, SEALED};

/// Success.
pub const TAIJI_OK: i32 = 0;
/// A required pointer is null.
pub const TAIJI_ERR_NULL: i32 = 1;
/// The state's memory is not aligned to `taiji_estimator_align()`.
pub const TAIJI_ERR_ALIGNMENT: i32 = 2;
/// A buffer is smaller than needed (`taiji_estimator_size`, `taiji_checkpoint_size`).
pub const TAIJI_ERR_SIZE: i32 = 3;
/// The configuration table fails its check (a field out of range).
pub const TAIJI_ERR_CONFIG: i32 = 4;
/// The state's memory does not hold an initialised estimator.
pub const TAIJI_ERR_STATE: i32 = 5;
/// The checkpoint is not one: wrong magic, size or checksum, or an impossible state.
pub const TAIJI_ERR_CHECKPOINT: i32 = 6;
/// The checkpoint was written by a build with another layout or state version.
pub const TAIJI_ERR_VERSION: i32 = 7;
/// The solve failed (singular normal equations); the previous solution is kept and the
/// estimate's status word says so.
pub const TAIJI_ERR_SOLVE: i32 = 8;

/// `update`, `solve` or `checkpoint` after `finish`: the campaign is over (`finish` and
/// `estimate` still return the final estimate).
pub const TAIJI_ERR_FINISHED: i32 = 9;

/// The state changed since the library last left it: a bit flipped in the caller's
/// memory between calls (an upset), or in its statistics during a solve or finish,
/// or something else wrote to it. No estimate leaves; restore the last checkpoint (or
/// init) to go on (the header's UPSETS: when each call finds it).
pub const TAIJI_ERR_UPSET: i32 = 10;

/// The scratch passed to `solve` or `finish` overlaps the state: it would overwrite
/// it. Nothing is done; pass memory of its own.
pub const TAIJI_ERR_OVERLAP: i32 = 11;

/// Version of this C interface: the functions' signatures and every layout they pass
/// (bumped with `LAYOUT_VERSION` and whenever a signature changes). A host passes the
/// value of its header to `taiji_estimator_init` (`TAIJI_ABI_ARGS`), which refuses
/// another with `TAIJI_ERR_VERSION`.
pub const TAIJI_ABI_VERSION: u32 = 4;

/// `update` flag: a solve is due (the host may run it now or in its slower rate group).
pub const TAIJI_SOLVE_DUE: u32 = 1;

/// Parts of the state an update reads but does not write (the table, the SRP filter's
/// poles, the common-mode gain and row, the turn rows, the solution, the gates' rows,
/// the final estimate): `update` checks one of them in turn besides those it writes, so
/// a flip there is found within this many updates (header, UPSETS).
pub const TAIJI_SCRUB_PARTS: u32 = 7;
const _: () = assert!(TAIJI_SCRUB_PARTS as usize == SCRUB_PARTS);

/// Marks initialised state ("TAIJIEST").
const MAGIC: u64 = 0x5453_4549_4A49_4154;
/// Bits of the magic word an upset may have flipped and still be told from memory
/// that never held a state (`init` and `restore` write 0 there until they succeed).
const MAGIC_FLIPS: u32 = 4;

/// The caller-owned state: a magic word, the estimator, and once the campaign is
/// finished its final estimate (so `finish` is terminal and idempotent).
#[repr(C)]
struct State {
    magic: u64,
    est: JointEstimator,
    /// 1 after `finish` (any other value than 0 counts as finished).
    finished: u64,
    final_msg: EstimateMsg,
    /// Each part's digest as the library left it (`seal`: the estimator's
    /// `JointEstimator::PARTS`, then `finished` with the final estimate).
    seals: [u64; SEALED],
    /// Which part the next update checks besides those it writes (`seal::scrubbed`:
    /// taken modulo `TAIJI_SCRUB_PARTS`, so any value will do).
    scrub: u64,
}

/// 1 when this build seals the state (the calls check for upsets), 0 when it was
/// built for EDAC memory (feature `edac`: no check, `TAIJI_ERR_UPSET` never returned).
#[no_mangle]
pub extern "C" fn taiji_upset_check() -> u32 {
    u32::from(cfg!(not(feature = "edac")))
}

/// Bytes the estimator's state needs.
#[no_mangle]
pub extern "C" fn taiji_estimator_size() -> usize {
    // The seal covers the estimator and the final estimate as whole words.
    const _: () =
        assert!(size_of::<JointEstimator>() % 8 == 0 && align_of::<JointEstimator>() == 8);
    const _: () = assert!(size_of::<EstimateMsg>() % 8 == 0 && align_of::<EstimateMsg>() == 8);
    size_of::<State>()
}

/// Alignment the estimator's state needs [bytes].
#[no_mangle]
pub extern "C" fn taiji_estimator_align() -> usize {
    align_of::<State>()
}

/// Version of the message and state layouts this library was built with.
#[no_mangle]
pub extern "C" fn taiji_layout_version() -> u32 {
    LAYOUT_VERSION
}

/// Bytes a checkpoint needs.
#[no_mangle]
pub extern "C" fn taiji_checkpoint_size() -> usize {
    snapshot::size()
}

/// Bytes of the scratch memory `solve` and `finish` take (8-aligned): the Gauss–Newton
/// Jacobian, the normal equations and one residual group's products. Its contents do
/// not matter before or after a call, so one buffer may serve every estimator of a task.
#[no_mangle]
pub extern "C" fn taiji_solve_work_size() -> usize {
    size_of::<SolveWork>()
}

/// The scratch for the state at `mem`: checked for null, alignment, size, and that it
/// lies apart from the state.
fn work_mut<'a>(mem: *mut u8, work: *mut u8, size: usize) -> Result<&'a mut SolveWork, i32> {
    if work.is_null() {
        return Err(TAIJI_ERR_NULL);
    }
    let (s0, w0) = (mem as usize, work as usize);
    let (s1, w1) = (
        s0.saturating_add(size_of::<State>()),
        w0.saturating_add(size_of::<SolveWork>()),
    );
    if s0 < w1 && w0 < s1 {
        return Err(TAIJI_ERR_OVERLAP);
    }
    if (work as usize) % align_of::<SolveWork>() != 0 {
        return Err(TAIJI_ERR_ALIGNMENT);
    }
    if size < size_of::<SolveWork>() {
        return Err(TAIJI_ERR_SIZE);
    }
    // SAFETY: non-null, aligned, at least size_of::<SolveWork>() bytes the caller owns
    // (not the state's, by the contract); every bit pattern is a valid `SolveWork`.
    Ok(unsafe { &mut *(work as *mut SolveWork) })
}

fn state_mut<'a>(mem: *mut u8, size: usize) -> Result<&'a mut State, i32> {
    if mem.is_null() {
        return Err(TAIJI_ERR_NULL);
    }
    if (mem as usize) % align_of::<State>() != 0 {
        return Err(TAIJI_ERR_ALIGNMENT);
    }
    if size < size_of::<State>() {
        return Err(TAIJI_ERR_SIZE);
    }
    // SAFETY: non-null, aligned, at least size_of::<State>() bytes the caller owns;
    // every bit pattern is a valid `State` (plain numbers: `JointEstimator` is `Pod`).
    Ok(unsafe { &mut *(mem as *mut State) })
}

/// The state behind `mem` if it was initialised (its magic word), or why not.
fn initialised<'a>(mem: *mut u8) -> Result<&'a mut State, i32> {
    let st = state_mut(mem, size_of::<State>())?;
    if st.magic != MAGIC {
        // A magic word a few bits from ours is an initialised state whose first word
        // flipped: an upset. (The seal does not cover the magic word; `init` and
        // `restore` write 0 there until they succeed.)
        return Err(if (st.magic ^ MAGIC).count_ones() <= MAGIC_FLIPS {
            TAIJI_ERR_UPSET
        } else {
            TAIJI_ERR_STATE
        });
    }
    Ok(st)
}

/// The initialised state behind `mem` with the parts in `mask` checked against their
/// seal, or why not: it could have come from `init` and `update` (its table passes
/// its check, its counts index within their arrays). A state that could not have is
/// an upset where the seal says so.
fn checked<'a>(mem: *mut u8, mask: Mask) -> Result<&'a mut State, i32> {
    let st = initialised(mem)?;
    seal::check(st, mask)?;
    if !st.est.is_sane() {
        seal::check(st, ALL)?;
        return Err(TAIJI_ERR_STATE);
    }
    Ok(st)
}

/// The whole state, checked.
fn live<'a>(mem: *mut u8) -> Result<&'a mut State, i32> {
    checked(mem, ALL)
}

/// The whole state of a campaign still running, checked.
fn running<'a>(mem: *mut u8) -> Result<&'a mut State, i32> {
    let st = live(mem)?;
    if st.finished != 0 {
        return Err(TAIJI_ERR_FINISHED);
    }
    Ok(st)
}

/// A solve's or `finish`'s start: every Gram brought up to date, and what that wrote
/// resealed, so that the statistics' digests are those the solve must leave.
fn flush_grams(st: &mut State) {
    st.est.flush_grams();
    seal::reseal(st, FLUSH);
}

fn code(r: Result<i32, i32>) -> i32 {
    match r {
        Ok(c) | Err(c) => c,
    }
}

/// Version of this C interface (`TAIJI_ABI_VERSION` of the library's build).
#[no_mangle]
pub extern "C" fn taiji_abi_version() -> u32 {
    TAIJI_ABI_VERSION
}

/// Builds an estimator from the table `cfg` in the caller's memory `mem` of
/// `mem_size` bytes (at least `taiji_estimator_size()`, aligned to
/// `taiji_estimator_align()`). Nothing is allocated; `mem` is the whole state.
///
/// The last four arguments are what the host was compiled against: pass
/// `TAIJI_ABI_ARGS` (the header's `TAIJI_ABI_VERSION` and the sizes of its
/// `TaijiEstimatorConfig`, `TaijiSensorSample` and `TaijiEstimateMsg`). A host built
/// against another header is refused with `TAIJI_ERR_VERSION` before anything is read.
///
/// # Safety
/// `mem` must point to `mem_size` writable bytes and `cfg` to a readable table, or be
/// null (refused).
#[no_mangle]
pub unsafe extern "C" fn taiji_estimator_init(
    mem: *mut u8,
    mem_size: usize,
    cfg: *const EstimatorConfig,
    abi_version: u32,
    config_size: usize,
    sample_size: usize,
    estimate_size: usize,
) -> i32 {
    code((|| {
        if abi_version != TAIJI_ABI_VERSION
            || config_size != size_of::<EstimatorConfig>()
            || sample_size != size_of::<SensorSample>()
            || estimate_size != size_of::<EstimateMsg>()
        {
            return Err(TAIJI_ERR_VERSION);
        }
        if cfg.is_null() {
            return Err(TAIJI_ERR_NULL);
        }
        // SAFETY: non-null; read unaligned, so any readable bytes will do.
        let cfg = unsafe { core::ptr::read_unaligned(cfg) };
        let st = state_mut(mem, mem_size)?;
        st.magic = 0;
        cfg.check().map_err(|_| TAIJI_ERR_CONFIG)?;
        JointEstimator::init_in_place(&mut st.est, cfg);
        st.finished = 0;
        st.final_msg = EstimateMsg::default();
        st.scrub = 0;
        seal::reseal(st, ALL);
        st.magic = MAGIC;
        Ok(TAIJI_OK)
    })())
}

/// Takes one sensor sample (bounded work; no solve). `rejected` (may be null) receives
/// the causes this sample was rejected for (bit `1 << CAUSE_*`, 0 if accepted),
/// `flags` (may be null) `TAIJI_SOLVE_DUE` when a solve is due.
///
/// # Safety
/// Pointers must be valid for their types or null.
#[no_mangle]
pub unsafe extern "C" fn taiji_estimator_update(
    mem: *mut u8,
    sample: *const SensorSample,
    rejected: *mut u64,
    flags: *mut u32,
) -> i32 {
    code((|| {
        let st = initialised(mem)?;
        if st.finished != 0 {
            seal::check(st, ALL)?;
            return Err(TAIJI_ERR_FINISHED);
        }
        if sample.is_null() {
            return Err(TAIJI_ERR_NULL);
        }
        // What this update may write, checked before it reads it and resealed after;
        // and one more part in turn (the scrub).
        let (reads, slots) = seal::update_reads(&st.est);
        let scrub = st.scrub % SCRUB_PARTS as u64;
        let st = checked(mem, reads | 1 << seal::scrubbed(scrub))?;
        st.scrub = scrub + 1;
        // SAFETY: non-null; any bytes are a valid sample (plain numbers).
        let s = unsafe { core::ptr::read_unaligned(sample) };
        let causes = st.est.update(&s);
        let filled = seal::update_filled(&st.est, slots);
        seal::reseal(st, reads | filled);
        if !rejected.is_null() {
            // SAFETY: non-null, caller-provided.
            unsafe { rejected.write_unaligned(causes) };
        }
        if !flags.is_null() {
            let f = if st.est.solve_due() {
                TAIJI_SOLVE_DUE
            } else {
                0
            };
            // SAFETY: non-null, caller-provided.
            unsafe { flags.write_unaligned(f) };
        }
        Ok(TAIJI_OK)
    })())
}

/// One Gauss–Newton iteration on everything taken so far (warm-started; the host
/// schedules it, typically when `update` flags `TAIJI_SOLVE_DUE`). `work` is the
/// caller's scratch of `work_size` bytes (at least `taiji_solve_work_size()`, 8-aligned,
/// apart from the state: else `TAIJI_ERR_OVERLAP`): the Jacobian and the normal
/// equations go there, not on the stack.
///
/// # Safety
/// `mem` must be the state passed to `taiji_estimator_init`, or null (refused); `work`
/// must point to `work_size` writable bytes, or be null (refused).
#[no_mangle]
pub unsafe extern "C" fn taiji_estimator_solve(
    mem: *mut u8,
    work: *mut u8,
    work_size: usize,
) -> i32 {
    let w = match work_mut(mem, work, work_size) {
        Ok(w) => w,
        Err(e) => return e,
    };
    code((|| {
        let st = running(mem)?;
        flush_grams(st);
        let r = if st.est.solve_now_with(w) {
            Ok(TAIJI_OK)
        } else {
            Err(TAIJI_ERR_SOLVE)
        };
        // Resealed whatever the solve returns (a failed one has written its status),
        // unless its statistics changed during it.
        seal::reseal_checking(st)?;
        r
    })())
}

/// The current estimate (β, k, r with σ, status word, rejection counts) into `out`.
/// The state is checked again before the estimate leaves: a bit that flipped during
/// the call gives `TAIJI_ERR_UPSET` and leaves `out` untouched.
///
/// # Safety
/// Pointers must be valid for their types or null (refused).
#[no_mangle]
pub unsafe extern "C" fn taiji_estimator_estimate(mem: *mut u8, out: *mut EstimateMsg) -> i32 {
    code((|| {
        let st = live(mem)?;
        if out.is_null() {
            return Err(TAIJI_ERR_NULL);
        }
        let m = if st.finished != 0 {
            st.final_msg
        } else {
            st.est.message_unsent(st.est.next_tick().saturating_sub(1))
        };
        // Made from what the check passed, unless a bit flipped during the call:
        // checked again before it leaves.
        seal::check(st, ALL)?;
        if st.finished == 0 {
            // The message counts itself (its sequence number): that word's share of
            // its part's seal alone, just checked.
            let at = JointEstimator::SEQ_OFFSET;
            let old = est_u64(st, at);
            st.est.message_sent();
            seal::reseal_word(st, at, old);
        }
        // SAFETY: non-null, caller-provided.
        unsafe { out.write_unaligned(m) };
        Ok(TAIJI_OK)
    })())
}

/// The `u64` at byte `at` of the estimator (0 past its end).
fn est_u64(st: &State, at: usize) -> u64 {
    bytemuck::bytes_of(&st.est)
        .get(at..at.saturating_add(8))
        .and_then(|b| <[u8; 8]>::try_from(b).ok())
        .map_or(0, u64::from_ne_bytes)
}

/// End of campaign: runs a due solve, iterates to convergence and writes the final
/// estimate (flagged `EST_FINAL`) into `out`. Terminal and idempotent: a second call
/// writes the same estimate again, and `update`, `solve` and `checkpoint` are refused
/// from then on (`TAIJI_ERR_FINISHED`); `init` or `restore` starts afresh. `work` as
/// for `solve`, checked on every call (a repeated finish does not write it).
///
/// # Safety
/// Pointers must be valid for their types (`work` for `work_size` bytes) or null
/// (refused).
#[no_mangle]
pub unsafe extern "C" fn taiji_estimator_finish(
    mem: *mut u8,
    work: *mut u8,
    work_size: usize,
    out: *mut EstimateMsg,
) -> i32 {
    code((|| {
        let st = live(mem)?;
        if out.is_null() {
            return Err(TAIJI_ERR_NULL);
        }
        // Checked on every call, as the contract says, though a repeated finish does
        // not use it.
        let w = work_mut(mem, work, work_size)?;
        let m = if st.finished == 0 {
            flush_grams(st);
            let mut m = st.est.finish_with(w);
            m.flags |= EST_FINAL;
            st.final_msg = m;
            st.finished = 1;
            // Its solves only read the statistics: a change is a flip during the
            // call, and no estimate leaves (the state stays unsealed until a restore).
            seal::reseal_checking(st)?;
            m
        } else {
            let m = st.final_msg;
            // Checked again before it leaves.
            seal::check(st, ALL)?;
            m
        };
        // SAFETY: non-null, caller-provided.
        unsafe { out.write_unaligned(m) };
        Ok(TAIJI_OK)
    })())
}

/// Writes a checkpoint of the state into `buf` (`len` ≥ `taiji_checkpoint_size()`;
/// no alignment needed); `written` (may be null) receives its size. The state is
/// checked again after the copy: a bit that flipped during the call gives
/// `TAIJI_ERR_UPSET`, and `buf` is then spoilt (its first 8 bytes zeroed: `restore`
/// refuses it), so keep the previous checkpoint.
///
/// # Safety
/// `buf` must point to `len` writable bytes; other pointers valid or null.
#[no_mangle]
pub unsafe extern "C" fn taiji_estimator_checkpoint(
    mem: *mut u8,
    buf: *mut u8,
    len: usize,
    written: *mut usize,
) -> i32 {
    code((|| {
        let st = running(mem)?;
        if buf.is_null() {
            return Err(TAIJI_ERR_NULL);
        }
        // SAFETY: non-null, `len` bytes the caller owns.
        let out = unsafe { core::slice::from_raw_parts_mut(buf, len) };
        let n = snapshot::write(&st.est, out).map_err(|_| TAIJI_ERR_SIZE)?;
        // Copied from what the check passed, unless a bit flipped during the call:
        // checked again, and a copy that may hold the flip is spoilt (its magic word
        // zeroed, so `restore` refuses it).
        if seal::check(st, ALL).is_err() {
            out.iter_mut().take(8).for_each(|b| *b = 0);
            return Err(TAIJI_ERR_UPSET);
        }
        if !written.is_null() {
            // SAFETY: non-null, caller-provided.
            unsafe { written.write_unaligned(n) };
        }
        Ok(TAIJI_OK)
    })())
}

/// Restores the state in `mem` (as for `init`) from a checkpoint of `len` bytes,
/// made under the table `cfg`. A buffer that is not an intact checkpoint of this
/// layout is refused (`TAIJI_ERR_CHECKPOINT`, `_SIZE`, `_VERSION`), and so is one made
/// under another table (`TAIJI_ERR_CONFIG`: the host's table is the authority); `mem`
/// is then left uninitialised (calls on it return `TAIJI_ERR_STATE`).
///
/// # Safety
/// `mem` must point to `mem_size` writable bytes, `buf` to `len` readable bytes, `cfg`
/// to a readable table.
#[no_mangle]
pub unsafe extern "C" fn taiji_estimator_restore(
    mem: *mut u8,
    mem_size: usize,
    buf: *const u8,
    len: usize,
    cfg: *const EstimatorConfig,
) -> i32 {
    code((|| {
        if buf.is_null() || cfg.is_null() {
            return Err(TAIJI_ERR_NULL);
        }
        // SAFETY: non-null; read unaligned, so any readable bytes will do.
        let cfg = unsafe { core::ptr::read_unaligned(cfg) };
        let st = state_mut(mem, mem_size)?;
        st.magic = 0;
        // SAFETY: non-null, `len` readable bytes.
        let bytes = unsafe { core::slice::from_raw_parts(buf, len) };
        // In place: the state is read straight into `mem` (no state-sized value on the stack).
        snapshot::read_into(bytes, &mut st.est).map_err(|e| match e {
            snapshot::SnapshotError::TooSmall => TAIJI_ERR_SIZE,
            snapshot::SnapshotError::Version => TAIJI_ERR_VERSION,
            _ => TAIJI_ERR_CHECKPOINT,
        })?;
        if bytemuck::bytes_of(st.est.config()) != bytemuck::bytes_of(&cfg) {
            return Err(TAIJI_ERR_CONFIG);
        }
        st.finished = 0;
        st.final_msg = EstimateMsg::default();
        st.scrub = 0;
        seal::reseal(st, ALL);
        st.magic = MAGIC;
        Ok(TAIJI_OK)
    })())
}
