//! The seal: a digest of each part of the state (`JointEstimator::PARTS`, then the
//! `finished` word with the final estimate), kept in the state. `update` checks the
//! parts it may write before it runs and reseals them after, and checks in turn one of
//! the parts it reads but never writes (the scrub, `SCRUBBED`); every other call
//! checks every part. A flip is so found before an update uses it where the update
//! writes, within `TAIJI_SCRUB_PARTS` updates where updates only read, and before
//! anything uses it where no update reads (the update that reads it, or the next
//! `solve`, `estimate`, `checkpoint` or `finish`); no estimate or checkpoint leaves
//! unchecked.

use super::{State, TAIJI_ERR_UPSET};
use crate::estimate::joint::{Extent, JointEstimator, Writer, N_PARTS, PEND, TARGETS};

/// The parts the seal keeps a digest of: the estimator's, and the tail (`finished`
/// and the final estimate).
pub(super) const SEALED: usize = N_PARTS + 1;
const TAIL: usize = N_PARTS;

/// A set of parts, bit i part i.
pub(super) type Mask = u64;
pub(super) const ALL: Mask = {
    assert!(SEALED < 64);
    (1 << SEALED) - 1
};

/// The parts whose writer is of kind `k`: 0 `Update`, 1 `Start`, 2 `Gram` (any).
const fn parts_of(k: u8) -> Mask {
    let mut m = 0;
    let mut i = 0;
    while i < N_PARTS {
        let hit = match JointEstimator::PARTS[i].writer {
            Writer::Update => k == 0,
            Writer::Start => k == 1,
            Writer::Gram(_) => k == 2,
            _ => false,
        };
        if hit {
            m |= 1 << i;
        }
        i += 1;
    }
    m
}
const UPDATE: Mask = parts_of(0);
const START: Mask = parts_of(1);
/// The parts an update may read but not write, which only the scrub checks between
/// whole checks: the table, the SRP filter's poles, the references, the solution, the
/// gates' rows (`Writer::Never` and `Writer::Start` of every word) and the tail. The
/// parts no update reads (the Grams and waiting samples not due, the pole words not in
/// use) are checked by the update that reads them or by the next whole check, before
/// anything uses them.
const SCRUBBED: [usize; SCRUB_PARTS] = {
    let mut out = [TAIL; SCRUB_PARTS];
    let (mut i, mut k) = (0, 0);
    while i < N_PARTS {
        if only_read(i) {
            out[k] = i;
            k += 1;
        }
        i += 1;
    }
    out
};
/// How many parts the scrub takes in turn, one an update (`SCRUBBED`, the tail last).
pub(super) const SCRUB_PARTS: usize = {
    let mut k = 1;
    let mut i = 0;
    while i < N_PARTS {
        k += only_read(i) as usize;
        i += 1;
    }
    k
};

/// Whether updates read every word of part `i` but write none (`SCRUBBED`).
const fn only_read(i: usize) -> bool {
    let p = JointEstimator::PARTS[i];
    matches!(p.writer, Writer::Never | Writer::Start) && matches!(p.extent, Extent::All)
}

/// The part the scrub checks at cursor `c` (any value).
pub(super) fn scrubbed(c: u64) -> usize {
    SCRUBBED[(c % SCRUB_PARTS as u64) as usize % SCRUB_PARTS]
}
/// The statistics: what `solve` and `finish` leave as they found it once the Grams
/// are up to date.
pub(super) const STATISTICS: Mask = {
    let mut m = 0;
    let mut i = 0;
    while i < N_PARTS {
        if JointEstimator::PARTS[i].statistic {
            m |= 1 << i;
        }
        i += 1;
    }
    m
};
/// Where bringing every Gram up to date writes (`flush_grams`): the Gram matrices
/// and the waiting counts.
pub(super) const FLUSH: Mask = parts_of(2) | 1 << (N_PARTS - 1);
/// Part number of `Writer::Gram(g)`, and of `Writer::Pend(t, 0)`.
const GRAM: [usize; 6] = {
    let mut out = [0; 6];
    let mut i = 0;
    while i < N_PARTS {
        if let Writer::Gram(g) = JointEstimator::PARTS[i].writer {
            out[g as usize] = i;
        }
        i += 1;
    }
    out
};
const PEND0: usize = {
    let mut i = 0;
    while !matches!(JointEstimator::PARTS[i].writer, Writer::Pend(0, 0)) {
        i += 1;
    }
    i
};

/// The machine word the seal folds: 64 bits on every CPU (a Cortex-M7's `ldrd` and a
/// LEON3's `ldd` load two registers at once, and a 64-bit sum is two instructions).
type Word = u64;
const W: usize = size_of::<Word>();

/// Bytes as the machine words the seal folds (whole, aligned words: every part is;
/// were one not, it would seal nothing rather than panic).
#[inline(always)]
fn words(b: &[u8]) -> &[Word] {
    bytemuck::try_cast_slice(b).unwrap_or(&[])
}

/// Folds `words` into the digest `d`: each block of eight words (the last may be
/// shorter) is XORed into one word, and the blocks are summed (wrapping). Any single
/// flipped bit changes its block's word by ±2ⁱ, so the sum. Two flips cancel only at
/// the same bit i, in one block, or in two blocks whose words change by +2ⁱ and −2ⁱ
/// (which depends on the bit's value in each block's XOR; at bit 63 both signs
/// cancel): what a single-event upset does not do. About a load and an XOR a word; the
/// blocks are summed, not rotated, because a 64-bit rotation costs a LEON3 six
/// instructions and an addition two.
#[inline(always)]
fn fold(d: Word, words: &[Word]) -> Word {
    let mut d = d;
    let mut chunks = words.chunks_exact(8);
    for c in &mut chunks {
        let x = (c[0] ^ c[1]) ^ (c[2] ^ c[3]) ^ (c[4] ^ c[5]) ^ (c[6] ^ c[7]);
        d = d.wrapping_add(x);
    }
    let rest = chunks.remainder();
    if !rest.is_empty() {
        d = d.wrapping_add(xor(rest));
    }
    d
}

/// The XOR of `words`.
#[inline(always)]
fn xor(words: &[Word]) -> Word {
    let mut x = 0;
    for w in words {
        x ^= w;
    }
    x
}

/// Part `i`'s words, as the seal folds them.
fn part_words(st: &State, i: usize) -> &[Word] {
    let Some(p) = JointEstimator::PARTS.get(i) else {
        return &[];
    };
    // In 8-byte words of the part, then in the seal's words.
    let held = p.extent.words((p.end - p.start) / 8, st.est.poles_in_use());
    let (a, b) = ((p.start + 8 * held.start) / W, (p.start + 8 * held.end) / W);
    words(bytemuck::bytes_of(&st.est)).get(a..b).unwrap_or(&[])
}

/// Part `i`'s digest.
fn digest(st: &State, i: usize) -> Word {
    if i == TAIL {
        let d = fold(0, words(bytemuck::bytes_of(&st.finished)));
        return fold(d, words(bytemuck::bytes_of(&st.final_msg)));
    }
    fold(0, part_words(st, i))
}

/// The parts an update may read before it writes them, from the state before it: what
/// it always may, the references while they wait, the Gram matrices it brings up to
/// date and the samples waiting for them (`JointEstimator::due_grams`); and the slot of
/// `pend` each Gram matrix's next sample would go to (`next_slot`), which it only
/// writes.
pub(super) fn update_reads(e: &JointEstimator) -> (Mask, [usize; TARGETS]) {
    let mut m = UPDATE;
    if e.may_start() {
        m |= START;
    }
    let (due, grams) = e.due_grams();
    for (g, &part) in GRAM.iter().enumerate() {
        if grams & (1 << g) != 0 {
            m |= 1 << part;
        }
    }
    for k in 0..e.waiting(due) {
        m |= 1 << (PEND0 + due * PEND + k).min(N_PARTS - 1);
    }
    (m, core::array::from_fn(|t| e.next_slot(t)))
}

/// The slots of `pend` an update wrote, from the slots `next` it would write
/// (`update_reads`): those it filled (whole: nothing of what they held is read).
pub(super) fn update_filled(e: &JointEstimator, next: [usize; TARGETS]) -> Mask {
    let mut m = 0;
    for (t, &k) in next.iter().enumerate() {
        if e.waiting(t) > k {
            m |= 1 << (PEND0 + t * PEND + k).min(N_PARTS - 1);
        }
    }
    m
}

/// Whether every part in `mask` still has its digest (`Err(TAIJI_ERR_UPSET)` if not).
/// With EDAC memory (feature `edac`) nothing is sealed, and everything passes.
pub(super) fn check(st: &State, mask: Mask) -> Result<(), i32> {
    if cfg!(feature = "edac") {
        return Ok(());
    }
    for (i, &seal) in st.seals.iter().enumerate() {
        if mask & (1 << i) != 0 && digest(st, i) as u64 != seal {
            return Err(TAIJI_ERR_UPSET);
        }
    }
    Ok(())
}

/// Takes the parts in `mask` as they are into the seal.
pub(super) fn reseal(st: &mut State, mask: Mask) {
    if cfg!(feature = "edac") {
        return;
    }
    for i in 0..SEALED {
        if mask & (1 << i) != 0 {
            let d = digest(st, i) as u64;
            if let Some(s) = st.seals.get_mut(i) {
                *s = d;
            }
        }
    }
}

/// After a call that only read the statistics (`solve`, `finish`, once the Grams were
/// brought up to date and resealed): whether they still have their digests, and every
/// part resealed, from one pass. `Err(TAIJI_ERR_UPSET)` when a statistic changed: a bit
/// flipped during the call, and the state is left as the call wrote it, its seal not
/// (every call refuses it until a restore).
pub(super) fn reseal_checking(st: &mut State) -> Result<(), i32> {
    if cfg!(feature = "edac") {
        return Ok(());
    }
    let mut fresh = [0u64; SEALED];
    for (i, f) in fresh.iter_mut().enumerate() {
        *f = digest(st, i) as u64;
    }
    for (i, (f, s)) in fresh.iter().zip(&st.seals).enumerate() {
        if STATISTICS & (1 << i) != 0 && f != s {
            return Err(TAIJI_ERR_UPSET);
        }
    }
    st.seals = fresh;
    Ok(())
}

/// The seal after the `u64` at byte `at` of the estimator changed from `old` to what
/// it holds now, in a part it holds whole (`Extent::All`): only its block's share of
/// the part's digest changes (the block's XOR, old and new, from its words now and the
/// word's change). A flip elsewhere in the block meanwhile leaves the seal off by what
/// it changed, so the next check finds it.
pub(super) fn reseal_word(st: &mut State, at: usize, old: u64) {
    if cfg!(feature = "edac") {
        return;
    }
    let Some((i, p)) = JointEstimator::PARTS
        .iter()
        .enumerate()
        .find(|(_, p)| p.start <= at && at.saturating_add(8) <= p.end)
    else {
        return;
    };
    if p.extent != Extent::All {
        reseal(st, 1 << i);
        return;
    }
    // The u64 is one or two of the seal's words, in one block (8-aligned in the part).
    let k = (at - p.start) / W;
    let block = k / 8 * 8;
    let now = xor(part_words(st, i)
        .get(block..(block + 8).min((p.end - p.start) / W))
        .unwrap_or(&[]));
    let mut change: Word = 0;
    for h in (old ^ super::est_u64(st, at)).to_ne_bytes().chunks_exact(W) {
        change ^= <[u8; W]>::try_from(h).map_or(0, Word::from_ne_bytes);
    }
    let before = now ^ change;
    if let Some(s) = st.seals.get_mut(i) {
        *s = (*s as Word).wrapping_sub(before).wrapping_add(now) as u64;
    }
}
