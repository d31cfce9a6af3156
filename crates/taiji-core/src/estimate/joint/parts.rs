//! The estimator's bytes as the parts the C ABI's seal keeps a digest of, and which
//! call writes each: an update checks and reseals only what it may write, and checks
//! in turn one of the parts it reads but never writes (`capi::seal`).

use super::*;
use core::mem::{offset_of, size_of};

/// Who writes a part, besides `init`, `restore`, `solve` and `finish` (which check and
/// reseal every part).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Writer {
    /// No update.
    Never,
    /// Any update.
    Update,
    /// The update that sets the references (`start`: while `started` is not full).
    Start,
    /// The update that brings this Gram matrix up to date (`due_grams`): 0–2
    /// `m_raw[r]`, 3 `m_filt`, 4–5 `m_turn[k]`.
    Gram(u8),
    /// The update whose sample waits in this slot of `pend` (Gram matrix, slot), or that
    /// brings that Gram matrix up to date (it reads the slot).
    Pend(u8, u8),
}

/// Which of a part's words the part holds: `wp` and `wx` keep the SRP filter's `n`
/// poles in use (`poles_in_use`) in their first words (n² and n `NS`), which an update
/// writes, and the rest never changes after `init`.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Extent {
    /// All its words.
    All,
    /// The first n² words (`square`: `wp`) or n `NS` (`wx`).
    Poles { square: bool },
    /// The words after those.
    Rest { square: bool },
}

impl Extent {
    /// The words held of a part of `len` words, `n` poles in use.
    pub fn words(self, len: usize, n: usize) -> core::ops::Range<usize> {
        let n = n.min(MAX_POLES);
        let used = |square: bool| (if square { n * n } else { n * NS }).min(len);
        match self {
            Extent::All => 0..len,
            Extent::Poles { square } => 0..used(square),
            Extent::Rest { square } => used(square)..len,
        }
    }
}

/// A part of the estimator's bytes: `start..end`, `extent` of them, written by `writer`;
/// `statistic`: `solve` and `finish` leave it as they found it once the Grams are up
/// to date (so the C ABI checks after them that it did not change).
#[derive(Clone, Copy, Debug)]
pub struct Part {
    pub start: usize,
    pub end: usize,
    pub extent: Extent,
    pub writer: Writer,
    pub statistic: bool,
}

const fn part(start: usize, end: usize, writer: Writer, statistic: bool) -> Part {
    Part {
        start,
        end,
        extent: Extent::All,
        writer,
        statistic,
    }
}

/// How many parts (`JointEstimator::PARTS`).
pub const N_PARTS: usize = 22 + TARGETS * PEND;

impl JointEstimator {
    /// The parts, in the order of the bytes: every byte of the estimator in exactly one
    /// (`wp` and `wx` in two each: the words of the poles in use, and the rest), in
    /// whole 8-byte words (compile-time checks below).
    pub const PARTS: [Part; N_PARTS] = {
        use Writer::*;
        let g = size_of::<Packed>();
        let raw = offset_of!(Self, m_raw);
        let filt = offset_of!(Self, m_filt);
        let turn = offset_of!(Self, m_turn);
        let (wp, wx, hn) = (
            offset_of!(Self, wp),
            offset_of!(Self, wx),
            offset_of!(Self, hn),
        );
        let tx = offset_of!(Self, tx);
        let turn_w = offset_of!(Self, turn_w);
        let turn_pq = offset_of!(Self, turn_pq);
        let p = offset_of!(Self, p);
        let solve_due = offset_of!(Self, solve_due);
        let gate_c = offset_of!(Self, gate_c);
        let gate_s = offset_of!(Self, gate_s);
        let pend = offset_of!(Self, pend);
        let pend_n = offset_of!(Self, pend_n);
        let bank = offset_of!(Self, bank);
        let started = offset_of!(Self, started);
        let s = size_of::<Sig>();
        let mut out = [part(0, 0, Never, false); N_PARTS];
        out[0] = part(0, started, Never, false);
        out[1] = part(started, raw, Update, false);
        out[2] = part(raw, raw + g, Gram(0), true);
        out[3] = part(raw + g, raw + 2 * g, Gram(1), true);
        out[4] = part(raw + 2 * g, filt, Gram(2), true);
        out[5] = part(filt, bank, Gram(3), true);
        out[6] = part(bank, wp, Never, true);
        out[7] = Part {
            extent: Extent::Poles { square: true },
            ..part(wp, wx, Update, true)
        };
        out[8] = Part {
            extent: Extent::Rest { square: true },
            ..part(wp, wx, Never, true)
        };
        out[9] = Part {
            extent: Extent::Poles { square: false },
            ..part(wx, hn, Update, true)
        };
        out[10] = Part {
            extent: Extent::Rest { square: false },
            ..part(wx, hn, Never, true)
        };
        out[11] = part(hn, turn, Start, false);
        out[12] = part(turn, turn + g, Gram(4), true);
        out[13] = part(turn + g, tx, Gram(5), true);
        out[14] = part(tx, turn_w, Update, true);
        out[15] = part(turn_w, turn_pq, Start, false);
        out[16] = part(turn_pq, p, Update, false);
        out[17] = part(p, solve_due, Never, false);
        out[18] = part(solve_due, gate_c, Update, false);
        out[19] = part(gate_c, gate_s, Start, false);
        out[20] = part(gate_s, pend, Update, false);
        let mut k = 0;
        while k < TARGETS * PEND {
            let at = pend + k * s;
            out[21 + k] = part(at, at + s, Pend((k / PEND) as u8, (k % PEND) as u8), true);
            k += 1;
        }
        out[N_PARTS - 1] = part(pend_n, size_of::<Self>(), Update, true);
        // The layout these parts assume (`repr(C)`, fields in this order).
        assert!(filt == raw + N_REG * g && tx == turn + 2 * g);
        assert!(wx == wp + MAX_POLES * MAX_POLES * 8 && hn == wx + NS * MAX_POLES * 8);
        assert!(pend_n == pend + TARGETS * PEND * s);
        let mut i = 0;
        let mut end = 0;
        while i < N_PARTS {
            let q = out[i];
            assert!(q.start % 8 == 0 && q.end % 8 == 0 && q.start <= q.end);
            match q.extent {
                Extent::Rest { .. } => assert!(q.start == out[i - 1].start && q.end == end),
                _ => assert!(q.start == end),
            }
            end = q.end;
            i += 1;
        }
        assert!(end == size_of::<Self>());
        out
    };

    /// The SRP filter's poles in use (`Extent`), at most
    /// `MAX_POLES` whatever the state holds.
    pub fn poles_in_use(&self) -> usize {
        self.bank.poles().min(MAX_POLES)
    }

    /// Whether the next update may set the references (`Writer::Start`).
    pub fn may_start(&self) -> bool {
        self.started != START_FULL
    }

    /// The slot of `pend` the next linear sample's signals for Gram matrix `t` go to
    /// (`defer`, after the due matrix is brought up to date).
    pub fn next_slot(&self, t: usize) -> usize {
        let t = t.min(TARGETS - 1);
        let due = (self.pend_turn % TARGETS as u64) as usize;
        match self.pend_n[t] as usize {
            _ if t == due => 0,
            n if n >= PEND => 0,
            n => n,
        }
    }

    /// Samples waiting for Gram matrix `t`.
    pub fn waiting(&self, t: usize) -> usize {
        (self.pend_n[t.min(TARGETS - 1)] as usize).min(PEND)
    }
}
