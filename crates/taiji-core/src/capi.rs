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
/// or something else wrote to it. Nothing of it is used and no estimate leaves;
/// restore the last checkpoint (or init) to go on.
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
    /// Digest of everything above but the magic word, as the library left it: every
    /// call checks it before it reads the state, and every call that writes reseals it,
    /// so a bit flipped while the state rests between calls is found before it is used.
    seal: u64,
}

/// The machine word the seal folds: 64 bits where the CPU has them (half the loads)
/// and on SPARC, whose `ldd` loads two registers at once (a LEON3's update: 150 300
/// instructions against 173 700 folding 32-bit words); 32 on the other 32-bit CPUs
/// (a Cortex-M7's: 120 500 against 132 100 folding 64-bit ones, whose rotation costs
/// there). The seal never leaves the state, so the CPUs need not agree.
#[cfg(any(target_pointer_width = "64", target_arch = "sparc"))]
#[cfg_attr(feature = "edac", allow(dead_code))]
type Word = u64;
#[cfg(not(any(target_pointer_width = "64", target_arch = "sparc")))]
#[cfg_attr(feature = "edac", allow(dead_code))]
type Word = u32;

/// Bytes as the machine words the seal folds (whole, aligned words: every part the
/// seal covers is; were one not, it would seal nothing rather than panic).
#[cfg_attr(feature = "edac", allow(dead_code))]
#[inline(always)]
fn words(b: Option<&[u8]>) -> &[Word] {
    bytemuck::try_cast_slice(b.unwrap_or(&[])).unwrap_or(&[])
}

/// Folds `words` into the digest `d`: each block of eight is XORed into one word, and
/// the running digest is rotated by one bit before each block (and before each word
/// of a part's last, shorter block). Any single flipped bit changes it. It is linear:
/// the digest is the XOR of every word rotated by the number of steps that follow its
/// own, so two flips cancel only when their bits line up after those rotations (the
/// same bit in one block; bit i in one block and bit i + 1 in the next, and so on),
/// which is what a single-event upset does not do. It runs about twice a call (check,
/// reseal), so it is kept to about a load and an XOR a word.
#[cfg_attr(feature = "edac", allow(dead_code))]
#[inline(always)]
fn fold(d: Word, words: &[Word]) -> Word {
    let mut d = d;
    let mut chunks = words.chunks_exact(8);
    for c in &mut chunks {
        let x = (c[0] ^ c[1]) ^ (c[2] ^ c[3]) ^ (c[4] ^ c[5]) ^ (c[6] ^ c[7]);
        d = d.rotate_left(1) ^ x;
    }
    for w in chunks.remainder() {
        d = d.rotate_left(1) ^ w;
    }
    d
}

/// The fold's steps over `n` words (one a block of eight, one a word of the rest).
#[cfg_attr(feature = "edac", allow(dead_code))]
const fn steps(n: usize) -> usize {
    n / 8 + n % 8
}

/// The digests the seal is made of: of the estimator's statistics
/// (`JointEstimator::STATISTICS`, which `solve` and `finish` only read), and of the
/// rest of what it covers.
#[cfg_attr(feature = "edac", allow(dead_code))]
#[derive(Clone, Copy, PartialEq, Eq)]
struct Digests {
    stats: Word,
    rest: Word,
}

impl Digests {
    /// The seal: both digests in one word (a flip in either changes it).
    #[cfg_attr(feature = "edac", allow(dead_code))]
    #[allow(clippy::unnecessary_cast)]
    fn seal(self) -> u64 {
        (self.stats as u64).rotate_left(32) ^ self.rest as u64
    }
}

/// The parts of the state the seal covers that are not statistics, in the order the
/// rest's digest folds them: the estimator around its statistics, `finished`, the
/// final estimate (plain numbers, 8-aligned, whole words).
#[cfg_attr(feature = "edac", allow(dead_code))]
fn rest_parts(st: &State) -> [&[u8]; 5] {
    let e = bytemuck::bytes_of(&st.est);
    let [s0, s1] = JointEstimator::STATISTICS;
    [
        e.get(..s0.start).unwrap_or(&[]),
        e.get(s0.end..s1.start).unwrap_or(&[]),
        e.get(s1.end..).unwrap_or(&[]),
        bytemuck::bytes_of(&st.finished),
        bytemuck::bytes_of(&st.final_msg),
    ]
}

/// Both digests, in one pass over the state.
#[cfg_attr(feature = "edac", allow(dead_code))]
fn digests(st: &State) -> Digests {
    let e = bytemuck::bytes_of(&st.est);
    let mut stats: Word = 0;
    for range in JointEstimator::STATISTICS {
        stats = fold(stats, words(e.get(range)));
    }
    let mut rest: Word = 0;
    for part in rest_parts(st) {
        rest = fold(rest, words(Some(part)));
    }
    Digests { stats, rest }
}

/// The seal after the `u64` at byte `at` of the estimator (outside its statistics)
/// changed from `old` to what it holds now, from the digests `d` the state had before:
/// the fold is linear, so only that word's share of the rest's digest changes, and
/// nothing else is read (a flip elsewhere meanwhile is not taken in: the next check
/// finds it).
#[cfg(not(feature = "edac"))]
fn reseal_word(st: &mut State, d: Digests, at: usize, old: u64) {
    const W: usize = size_of::<Word>();
    let [s0, s1] = JointEstimator::STATISTICS;
    let parts = rest_parts(st);
    // Where each part of the rest starts in the estimator (the last two are not in it).
    let starts = [0, s0.end, s1.end, usize::MAX, usize::MAX];
    let total: usize = parts.iter().map(|p| steps(p.len() / W)).sum();
    let (mut before, mut hit) = (0usize, None);
    for (p, &start) in parts.iter().zip(&starts) {
        if hit.is_none() && at >= start && at.saturating_add(8) <= start.saturating_add(p.len()) {
            hit = Some((before, start, p.len() / W));
        }
        before += steps(p.len() / W);
    }
    let Some((first, start, n)) = hit else {
        st.seal = digests(st).seal();
        return;
    };
    let new = est_u64(st, at);
    let word = |b: Option<&[u8]>| {
        b.and_then(|b| <[u8; W]>::try_from(b).ok())
            .map_or(0, Word::from_ne_bytes)
    };
    let full = n / 8 * 8;
    let mut rest = d.rest;
    let (old, new) = (old.to_ne_bytes(), new.to_ne_bytes());
    for j in 0..8 / W {
        let delta = word(old.get(j * W..(j + 1) * W)) ^ word(new.get(j * W..(j + 1) * W));
        let i = (at - start) / W + j;
        let step = first
            + if i < full {
                i / 8
            } else {
                full / 8 + (i - full)
            };
        let rot = (total.saturating_sub(1 + step) % Word::BITS as usize) as u32;
        rest ^= delta.rotate_left(rot);
    }
    st.seal = Digests { rest, ..d }.seal();
}

#[cfg(not(feature = "edac"))]
fn reseal(st: &mut State) {
    st.seal = digests(st).seal();
}

/// With EDAC memory the hardware corrects what the seal would find: no seal.
#[cfg(feature = "edac")]
fn reseal(_: &mut State) {}

/// The digests when the state still matches its seal.
#[cfg(not(feature = "edac"))]
fn sealed(st: &State) -> Option<Digests> {
    let d = digests(st);
    (d.seal() == st.seal).then_some(d)
}

/// Without a seal: always, and digests of nothing.
#[cfg(feature = "edac")]
fn sealed(_: &State) -> Option<Digests> {
    Some(Digests { stats: 0, rest: 0 })
}

/// After a call's work: whether its statistics still have the digest `before` that
/// its check found (when it only read them), and the seal, both from one pass.
/// `Err(TAIJI_ERR_UPSET)` when they changed: a bit flipped during the call, and the
/// state is left unsealed, so every call refuses it until a restore.
#[cfg(not(feature = "edac"))]
fn reseal_checking(st: &mut State, before: Option<Digests>) -> Result<(), i32> {
    let d = digests(st);
    if before.is_some_and(|b| b.stats != d.stats) {
        return Err(TAIJI_ERR_UPSET);
    }
    st.seal = d.seal();
    Ok(())
}

#[cfg(feature = "edac")]
fn reseal_checking(_: &mut State, _: Option<Digests>) -> Result<(), i32> {
    Ok(())
}

#[cfg(feature = "edac")]
fn reseal_word(_: &mut State, _: Digests, _: usize, _: u64) {}

/// 1 when this build seals the state (every call checks for upsets), 0 when it was
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

/// The initialised state behind `mem`, or why not: the magic word, and a state that
/// could have come from `init` and `update` (its table passes its check, its counts
/// index within their arrays).
fn live<'a>(mem: *mut u8) -> Result<(&'a mut State, Digests), i32> {
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
    let Some(d) = sealed(st) else {
        return Err(TAIJI_ERR_UPSET);
    };
    if !st.est.is_sane() {
        return Err(TAIJI_ERR_STATE);
    }
    Ok((st, d))
}

/// Runs `f` on the running campaign's state and reseals it whatever `f` returns (a
/// failed solve has written its status). `reads_statistics`: `f` only reads the
/// statistics (a solve), so the pass that reseals also checks they did not change
/// during it (`reseal_checking`).
fn mutate(
    mem: *mut u8,
    reads_statistics: bool,
    f: impl FnOnce(&mut State) -> Result<i32, i32>,
) -> i32 {
    code((|| {
        let (st, d) = running(mem)?;
        let r = f(st);
        reseal_checking(st, reads_statistics.then_some(d))?;
        r
    })())
}

/// The initialised state of a campaign still running, and its digests.
fn running<'a>(mem: *mut u8) -> Result<(&'a mut State, Digests), i32> {
    let (st, d) = live(mem)?;
    if st.finished != 0 {
        return Err(TAIJI_ERR_FINISHED);
    }
    Ok((st, d))
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
        reseal(st);
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
    mutate(mem, false, |st| {
        if sample.is_null() {
            return Err(TAIJI_ERR_NULL);
        }
        // SAFETY: non-null; any bytes are a valid sample (plain numbers).
        let s = unsafe { core::ptr::read_unaligned(sample) };
        let causes = st.est.update(&s);
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
    })
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
    mutate(mem, true, |st| {
        if st.est.solve_now_with(w) {
            Ok(TAIJI_OK)
        } else {
            Err(TAIJI_ERR_SOLVE)
        }
    })
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
        let (st, _) = live(mem)?;
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
        let Some(d) = sealed(st) else {
            return Err(TAIJI_ERR_UPSET);
        };
        if st.finished == 0 {
            // The message counts itself (its sequence number): that word's share of
            // the seal alone, from the digests just checked.
            let at = JointEstimator::SEQ_OFFSET;
            let old = est_u64(st, at);
            st.est.message_sent();
            reseal_word(st, d, at, old);
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
        let (st, d) = live(mem)?;
        if out.is_null() {
            return Err(TAIJI_ERR_NULL);
        }
        // Checked on every call, as the contract says, though a repeated finish does
        // not use it.
        let w = work_mut(mem, work, work_size)?;
        let m = if st.finished == 0 {
            let mut m = st.est.finish_with(w);
            m.flags |= EST_FINAL;
            st.final_msg = m;
            st.finished = 1;
            // Its solves only read the statistics: a change is a flip during the
            // call, and no estimate leaves (the state stays unsealed until a restore).
            reseal_checking(st, Some(d))?;
            m
        } else {
            let m = st.final_msg;
            // Checked again before it leaves.
            if sealed(st).is_none() {
                return Err(TAIJI_ERR_UPSET);
            }
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
        let (st, _) = running(mem)?;
        if buf.is_null() {
            return Err(TAIJI_ERR_NULL);
        }
        // SAFETY: non-null, `len` bytes the caller owns.
        let out = unsafe { core::slice::from_raw_parts_mut(buf, len) };
        let n = snapshot::write(&st.est, out).map_err(|_| TAIJI_ERR_SIZE)?;
        // Copied from what the check passed, unless a bit flipped during the call:
        // checked again, and a copy that may hold the flip is spoilt (its magic word
        // zeroed, so `restore` refuses it).
        if sealed(st).is_none() {
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
        reseal(st);
        st.magic = MAGIC;
        Ok(TAIJI_OK)
    })())
}
