//! Deferred Gram updates: a linear sample's signals wait in the state, and each of the
//! four Gram matrices a linear sample adds to (its regime's `m_raw`, `m_filt`, the two
//! `m_turn`) takes the samples waiting for it at once, one matrix a sample. An element
//! is then loaded and stored once for up to `PEND` samples instead of once for each,
//! and an update writes one Gram matrix instead of four (the raw Grams: one per
//! regime among the waiting samples), which is what the C ABI's seal passes over.
//! Every element takes the same products and sums in the same order as rank-one
//! updates sample by sample would give it, so the same bits; whatever reads the Grams
//! (`solve`, the bound's fits) brings them all up to date first (`flush_grams`).

use super::*;

/// Samples that may wait for one Gram matrix.
pub const PEND: usize = 4;
/// The matrices that take them: the sample's regime's raw Gram, the SRP-whitened one,
/// the two turn rows'.
pub const TARGETS: usize = 4;
pub(super) const T_RAW: usize = 0;
pub(super) const T_FILT: usize = 1;
pub(super) const T_TURN: usize = 2;

/// m += Σ_k v_k v_kᵀ (upper triangle) over the samples `vs` that `take` picks, in their
/// order: element by element the same sums as `rank1_packed(m, v_k, 1)` one sample
/// after another, a column whose multiplier is zero skipped for that sample as there.
#[inline(always)]
pub(super) fn rank_n(m: &mut Packed, vs: &[Sig; PEND], take: [bool; PEND], w: f64) {
    for j in 0..NS {
        let mut cols: [&[f64]; PEND] = [&[]; PEND];
        let mut mul = [0.0; PEND];
        let mut n = 0;
        for (v, &t) in vs.iter().zip(&take) {
            let vj = v.as_slice().get(j).copied().unwrap_or(0.0) * w;
            if t && vj != 0.0 {
                if let (Some(c), Some(x)) = (cols.get_mut(n), mul.get_mut(n)) {
                    (*c, *x) = (v.as_slice(), vj);
                    n += 1;
                }
            }
        }
        let col = m.column_mut(j);
        let [c0, c1, c2, c3] = cols;
        let [m0, m1, m2, m3] = mul;
        match n {
            1 => {
                for (x, a) in col.iter_mut().zip(c0) {
                    *x += a * m0;
                }
            }
            2 => {
                for ((x, a), b) in col.iter_mut().zip(c0).zip(c1) {
                    let mut s = *x;
                    s += a * m0;
                    s += b * m1;
                    *x = s;
                }
            }
            3 => {
                for (((x, a), b), c) in col.iter_mut().zip(c0).zip(c1).zip(c2) {
                    let mut s = *x;
                    s += a * m0;
                    s += b * m1;
                    s += c * m2;
                    *x = s;
                }
            }
            4 => {
                for ((((x, a), b), c), d) in col.iter_mut().zip(c0).zip(c1).zip(c2).zip(c3) {
                    let mut s = *x;
                    s += a * m0;
                    s += b * m1;
                    s += c * m2;
                    s += d * m3;
                    *x = s;
                }
            }
            _ => {}
        }
    }
}

impl JointEstimator {
    /// The Gram matrix whose turn it is at this linear sample, brought up to date
    /// (before the sample's signals wait: so none ever waits for more than `PEND`).
    #[inline(always)]
    pub(super) fn flush_due(&mut self) {
        let t = (self.pend_turn % TARGETS as u64) as usize;
        self.pend_turn = self.pend_turn.wrapping_add(1);
        self.flush_target(t);
    }

    /// The Gram matrices the next linear sample brings up to date, as bits of their
    /// `Writer::Gram` numbers (0–2 `m_raw[r]`, 3 `m_filt`, 4–5 `m_turn[k]`): what an
    /// update may write of them (the C ABI's seal), and the target whose waiting
    /// samples it reads.
    pub fn due_grams(&self) -> (usize, u32) {
        let t = (self.pend_turn % TARGETS as u64) as usize;
        let bits = match t {
            T_RAW => {
                let mut regs = 0;
                for &r in self.pend_reg.iter().take(self.waiting(T_RAW)) {
                    regs |= 1 << r.min(N_REG as u64 - 1);
                }
                regs
            }
            T_FILT => 1 << 3,
            _ => 1 << (4 + t - T_TURN).min(5),
        };
        (t, bits)
    }

    /// A linear sample's signals `v` wait for Gram matrix `t` (`reg`: the raw Gram's
    /// regime). Were `PEND` already waiting (only a state that did not come from
    /// `update` can hold that), they are taken first.
    #[inline(always)]
    pub(super) fn defer(&mut self, t: usize, v: &Sig, reg: usize) {
        let t = t.min(TARGETS - 1);
        if self.pend_n[t] as usize >= PEND {
            self.flush_target(t);
        }
        let n = (self.pend_n[t] as usize).min(PEND - 1);
        if let Some(slot) = self.pend.get_mut(t).and_then(|p| p.get_mut(n)) {
            *slot = *v;
        }
        if t == T_RAW {
            if let Some(r) = self.pend_reg.get_mut(n) {
                *r = reg as u64;
            }
        }
        self.pend_n[t] = n as u64 + 1;
    }

    /// Gram matrix `t` takes the samples waiting for it.
    #[inline(always)]
    fn flush_target(&mut self, t: usize) {
        let t = t.min(TARGETS - 1);
        let n = (self.pend_n[t] as usize).min(PEND);
        let waiting: [bool; PEND] = core::array::from_fn(|k| k < n);
        let vs = &self.pend[t];
        match t {
            T_RAW => {
                for (r, m) in self.m_raw.iter_mut().enumerate() {
                    let take = core::array::from_fn(|k| {
                        k < n
                            && self
                                .pend_reg
                                .get(k)
                                .is_some_and(|&g| g.min(N_REG as u64 - 1) == r as u64)
                    });
                    if take.contains(&true) {
                        rank_n(m, vs, take, 1.0);
                    }
                }
            }
            T_FILT => rank_n(&mut self.m_filt, vs, waiting, 1.0),
            _ => {
                let [m0, m1] = &mut self.m_turn;
                let m = if t == T_TURN { m0 } else { m1 };
                rank_n(m, vs, waiting, 1.0);
            }
        }
        self.pend_n[t] = 0;
    }

    /// Every Gram matrix takes the samples waiting for it: before anything reads them.
    pub fn flush_grams(&mut self) {
        for t in 0..TARGETS {
            self.flush_target(t);
        }
    }

    /// Whether the samples waiting are as updates leave them: the matrix whose turn is
    /// next (`pend_turn`) waits for at most `PEND`, the one after it for `PEND` − 1, and
    /// so on (each took one sample a linear sample since its turn). A state that holds
    /// more (not one `update` made) is refused, so the next update writes only what
    /// `due_grams` and `next_slot` say.
    pub(super) fn waiting_as_updates_leave_it(&self) -> bool {
        let due = (self.pend_turn % TARGETS as u64) as usize;
        (0..TARGETS).all(|j| {
            let n = self.pend_n.get((due + j) % TARGETS).copied().unwrap_or(0);
            n <= (PEND - j) as u64
        })
    }

    /// Whether no sample waits for a Gram matrix.
    pub(super) fn grams_flushed(&self) -> bool {
        self.pend_n.iter().all(|&n| n == 0)
    }
}
