//! Input gates (docs/integrity.md): flags, range, stuck channels, the two IS against
//! each other and the linear residuals of the current solution. Each rejection is
//! counted by cause.

use super::*;

/// Outcome of one IS sample.
pub(super) struct IsData {
    pub(super) dv: [f64; 3],
    pub(super) sum: [f64; 3],
}

pub(super) fn is_data(s: &crate::msg::IsSample) -> IsData {
    IsData {
        dv: s.angular_volts(),
        sum: s.linear_volts(),
    }
}

/// `x > limit`, or not a number: a test that must fail on NaN.
pub(super) fn nan_or_above(x: f64, limit: f64) -> bool {
    x.is_nan() || x > limit
}

impl JointEstimator {
    pub(super) fn reject(&mut self, cause: usize) {
        self.causes[cause] += 1;
        self.tick_mask |= 1 << cause;
    }

    /// Per-IS checks that need no model: flags, finiteness, range, stuck channels.
    /// Returns whether each IS is wholly usable (its linear data too) and, per angular
    /// axis, whether its electrode pair is (a bad channel spoils one axis, not three).
    pub(super) fn is_checks(&mut self, s: &SensorSample) -> ([bool; 2], [[bool; 3]; 2]) {
        let mut ok = [false; 2];
        let mut axis = [[false; 3]; 2];
        for i in 0..self.n_is() {
            let is = &s.is[i];
            if is.flags != 0 {
                // (A dropout's filler does not reset the stuck-channel detector.)
                self.reject(CAUSE_IS_FLAGGED);
                continue;
            }
            let stuck = self.stuck[i].repeats(&is.volts);
            let mut pair_ok = [true; 3];
            for (p, good) in pair_ok.iter_mut().enumerate() {
                let cause = if !is.volts[p].iter().all(|v| v.is_finite()) {
                    Some(CAUSE_NON_FINITE)
                } else if !self.pair_in_range(i, p, &is.volts[p]) {
                    Some(CAUSE_OUT_OF_RANGE)
                } else if stuck[p] {
                    Some(CAUSE_STUCK)
                } else {
                    None
                };
                if let Some(c) = cause {
                    self.reject(c);
                    *good = false;
                }
            }
            ok[i] = pair_ok.iter().all(|g| *g);
            for (a, ax) in axis[i].iter_mut().enumerate() {
                *ax = pair_ok[PAIR_OF_ANGULAR[a]];
            }
        }
        (ok, axis)
    }

    /// Could an in-range acceleration have produced electrode pair `p`'s voltages
    /// (prior β, k)?
    pub(super) fn pair_in_range(&self, i: usize, p: usize, v: &[f64; 2]) -> bool {
        let c = &self.cfg;
        let a = ANGULAR_OF_PAIR[p];
        let k = self.k_of(&self.p_prior, i, p).abs();
        let b = c.beta_prior[i][a].abs();
        (v[0] - v[1]).abs() * b <= tuning::RANGE_MARGIN * c.full_scale_angular
            && (v[0] + v[1]).abs() * k <= tuning::RANGE_MARGIN * c.full_scale_linear
    }

    /// Cross-IS angular test, per axis where both IS have data: both see the same ω̇,
    /// so ΔV1 − ρ ΔV2 (ρ = β2/β1, fitted from accepted samples) is white readout noise
    /// and ripple. A corrupted voltage of either IS moves it by far more than the noise
    /// of that voltage. Returns, per axis, whether the pair passed (false where it was
    /// not tested).
    pub(super) fn angular_consistent(
        &mut self,
        d0: &[f64; 3],
        d1: &[f64; 3],
        tested: &[bool; 3],
    ) -> [bool; 3] {
        let c = &self.cfg;
        let mut pass = [false; 3];
        // A plain range (not `filter`): the index bound stays visible, no check is linked.
        for a in 0..3 {
            if !(tested[a]) {
                continue;
            }
            let (v1, v2) = (d0[a], d1[a]);
            let var1 =
                (c.sigma_angular / c.beta_prior[0][a]).powi(2) + (c.sigma_ripple * v1).powi(2);
            let var2 =
                (c.sigma_angular / c.beta_prior[1][a]).powi(2) + (c.sigma_ripple * v2).powi(2);
            let (rho, var_rho, tol) = match self.ratio[a].ratio() {
                Some((r, vr)) => (r, vr * (var1 + r * r * var2), 0.0),
                // Before the fit: the prior ratio, with room for the ground error (the
                // scenario allows each prior within 10 % of its truth, so the ratio
                // within 22 %). The fit learns from accepted samples only: too little
                // room would lock out an axis whose priors are off in opposite directions.
                None => {
                    let r = c.beta_prior[1][a] / c.beta_prior[0][a];
                    (r, 0.0, tuning::PRIOR_RATIO_ROOM * (r * v2).abs())
                }
            };
            let d = v1 - rho * v2;
            let var = var1 + rho * rho * var2 + var_rho * v2 * v2;
            pass[a] = d.is_finite() && d.abs() <= tol + c.gate_sigma * var.sqrt();
        }
        pass
    }

    /// Which IS to keep on angular axis `a` when the two disagree. A voltage upset
    /// shifts ΔV and ΣV of its electrode pair together, so under the right hypothesis
    /// ("IS i is corrupted": ω̇ from the other IS alone) the other IS's linear channel
    /// on that pair fits the current solution, under the wrong one it misses by about
    /// the mismatch. The linear signals other than ΣV and ΔV are taken from the last
    /// accepted sample (they move by far less in a tick). The IS nearer the previous
    /// ω̇ is kept only before the first accepted linear sample: at a torque edge ω̇
    /// changes by more than a mismatch, and that guess can keep the corrupted IS
    /// (`tests/integrity.rs`, an upset at a torque edge).
    pub(super) fn trusted_is(
        &self,
        a: usize,
        d: [&[f64; 3]; 2],
        sums: [&[f64; 3]; 2],
    ) -> [bool; 2] {
        let bp = &self.cfg.beta_prior;
        // a < 3 at every call; clamped, no index check is linked.
        let a = a.min(2);
        if self.n_used > 0 {
            let j = PAIR_OF_ANGULAR[a];
            // Residual of IS `keep`'s channel j with ω̇ on axis a from IS `keep` alone.
            // `move`: a copy of `a`; by reference, the optimiser would no longer know
            // a < 3 after the calls, and an index check would be linked.
            let miss = move |keep: usize| {
                let mut sig = self.gate_s;
                for i in 0..2 {
                    for m in 0..3 {
                        sig[S_SUM + 3 * i + m] = sums[i][m] - self.sum_ref[i][m];
                        sig[S_DV + 3 * i + m] = d[i][m];
                    }
                }
                // Clamped: compiled apart, the closure cannot see keep < 2, a < 3.
                let (keep, a) = (keep.min(1), a.min(2));
                let o = 1 - keep;
                sig[S_DV + 3 * o + a] = d[keep][a] * bp[keep][a] / bp[o][a];
                let row = self.gate_c.row((3 * keep + j).min(5));
                (row * sig)[0].abs()
            };
            let (m0, m1) = (miss(0), miss(1));
            if m0.is_finite() && m1.is_finite() && m0 != m1 {
                return [m0 < m1, m1 < m0];
            }
        }
        // As `(0..2).map(..).sum()` would add them (from −0, exactly the same).
        let prev =
            self.w(0) * bp[0][a] * self.dv_last[0][a] + self.w(1) * bp[1][a] * self.dv_last[1][a];
        let first = (bp[0][a] * d[0][a] - prev).abs() <= (bp[1][a] * d[1][a] - prev).abs();
        [first, !first]
    }

    /// An angular axis with one IS only (the other dropped out or failed its checks)
    /// has no cross test, and an upset of its voltage would turn straight into a rate
    /// error. The same upset shifts that IS's linear channel on the same electrode
    /// pair: it must fit the current solution (ω̇ from this IS alone) within its
    /// learned spread, or the axis is dropped (bridged). Returns whether any was.
    #[cfg_attr(not(target_arch = "x86_64"), inline(never))]
    pub(super) fn lone_misfit(
        &mut self,
        data: &[IsData; 2],
        axis_ok: &mut [[bool; 3]; 2],
        dv: &[[f64; 3]; 2],
        psi_mid: &[[f64; 3]; 2],
        phi_mid: &[[f64; 3]; 2],
        t: f64,
    ) -> bool {
        if self.n_used == 0 {
            return false;
        }
        let lone: [Option<usize>; 3] =
            core::array::from_fn(|a| match (axis_ok[0][a], axis_ok[1][a]) {
                (true, false) => Some(0),
                (false, true) => Some(1),
                _ => None,
            });
        if lone.iter().all(Option::is_none) {
            return false;
        }
        let turn = self.srp_turn(psi_mid);
        let mut sig = self.signals(data, dv, psi_mid, phi_mid, &turn, t);
        // The absent IS's channels are NaN; their coefficients in the rows used are 0.
        for x in sig.iter_mut() {
            if !x.is_finite() {
                *x = 0.0;
            }
        }
        let mut any = false;
        for (a, l) in lone.iter().enumerate() {
            let Some(i) = *l else { continue };
            // i < 2 and k < 6 by construction; clamped, no index check is linked.
            let i = i.min(1);
            let a = a.min(2);
            let k = (3 * i + PAIR_OF_ANGULAR[a]).min(5);
            let x = (self.gate_c.row(k) * sig)[0];
            if !self.lone_track[k].check(x, 0.0, self.cfg.gate_sigma) {
                self.lone_track[k].miss();
                axis_ok[i][a] = false;
                any = true;
            }
        }
        any
    }

    /// What the current solution's uncertainty leaves in each whitened linear
    /// residual of `sig`, as a variance: the residual's change were one β or r one σ
    /// off, summed over them (their correlations left out). Twelve evaluations of the
    /// model, so only for a sample the learned spread alone would refuse (out of line:
    /// its model's 2 kB stay off the stack of every other update).
    #[inline(never)]
    fn parameter_spread(&self, sig: &Sig) -> [f64; 6] {
        let mut v = [0.0; 6];
        for k in P_BETA..P_R + 6 {
            if !self.param_used(k) {
                continue;
            }
            let mut pp = self.p;
            pp[k] += self.sigma[k];
            let c = self.coeffs(&pp).lin;
            // (c − gate_c) sig, row by row: no 6 × 35 temporary on the stack.
            let raw = SVector::<f64, 6>::from_fn(|r, _| {
                (0..NS)
                    .map(|m| (c[(r, m)] - self.gate_c[(r, m)]) * sig[m])
                    .sum()
            });
            let d = self.gate_w * raw;
            for (vr, dr) in v.iter_mut().zip(d.iter()) {
                *vr += dr * dr;
            }
        }
        v
    }

    /// The linear group's whitened residuals at the current solution, each against
    /// its track (widened by the solution's uncertainty); every one must pass.
    #[cfg_attr(not(target_arch = "x86_64"), inline(never))]
    pub(super) fn linear_consistent(&mut self, sig: &Sig, var: &[f64; 6]) -> bool {
        // By reference: the owned matrices would be copied (gate_c is 1.5 kB) every
        // sample, which the lint does not know.
        #[allow(clippy::op_ref)]
        let raw = &self.gate_c * sig;
        let z = self.gate_w * raw;
        let gate = self.cfg.gate_sigma;
        // `var`: each row's white variance at this sample's drive (1 at the first
        // sample's). A corrupted voltage widens its own test only by the ripple's
        // share of it: an error passes only if below gate × ripple (~10⁻⁴) of the
        // whole drive. (The last accepted sample's drive would refuse clean samples at
        // the torque edges.)
        let mut ok = (0..6).all(|k| self.lin_track[k].check(z[k], var[k], gate));
        if !ok {
            // Before calling it an outlier: could the solution's own uncertainty
            // explain it? (When the maneuver starts exciting a parameter, the residual
            // grows with that parameter's error; refusing it, hundreds of samples in a
            // row until the track starts over, would refuse exactly the samples that
            // determine it.)
            let v = self.parameter_spread(sig);
            ok = (0..6).all(|k| self.lin_track[k].check_wider(z[k], var[k], v[k], gate));
        }
        for k in 0..6 {
            if ok {
                self.lin_track[k].learn(z[k], tuning::ALPHA_LIN);
                // Each channel alone, for the lone-IS test (`lone_misfit`).
                if self.n_is() == 2 {
                    self.lone_track[k].learn(raw[k], tuning::ALPHA_LIN);
                }
            } else {
                self.lin_track[k].miss();
            }
        }
        ok
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nan_fails_every_threshold_test() {
        assert!(nan_or_above(f64::NAN, 1.0));
        assert!(nan_or_above(1.0 + 1e-12, 1.0));
        assert!(!nan_or_above(1.0, 1.0));
        assert!(!nan_or_above(f64::NEG_INFINITY, 1.0));
    }

    /// The range gate of one electrode pair sits at 1.25 times the full scale, in the
    /// prior's volts: the difference for the angular axis, the sum for the linear one;
    /// anything not a number is out of range.
    #[test]
    fn the_range_gate_is_the_full_scale_times_its_margin() {
        let cfg = test_config();
        let e = JointEstimator::new(cfg);
        for i in 0..2 {
            for p in 0..3 {
                let a = ANGULAR_OF_PAIR[p];
                let b = cfg.beta_prior[i][a].abs();
                let k = (cfg.geometry_m[i][PERM[p]] * cfg.beta_prior[i][PERM[p]]).abs();
                let (ang, lin) = (
                    1.25 * cfg.full_scale_angular / b,
                    1.25 * cfg.full_scale_linear / k,
                );
                // Just inside either limit: accepted.
                let half = 0.5 * 0.999;
                assert!(e.pair_in_range(i, p, &[half * ang, -half * ang]), "{i} {p}");
                assert!(e.pair_in_range(i, p, &[half * lin, half * lin]), "{i} {p}");
                // Just beyond: refused.
                let over = 0.5 * 1.001;
                assert!(
                    !e.pair_in_range(i, p, &[over * ang, -over * ang]),
                    "{i} {p}"
                );
                assert!(!e.pair_in_range(i, p, &[over * lin, over * lin]), "{i} {p}");
                assert!(!e.pair_in_range(i, p, &[f64::NAN, 0.0]), "{i} {p}");
            }
        }
    }

    /// Before the ratio fit, the cross-IS test allows half the priors' ratio: an IS2
    /// voltage 40 % off the priors' ratio passes, 60 % off fails (far above the noise).
    #[test]
    fn before_the_fit_the_cross_test_allows_half_the_ratio() {
        let cfg = test_config();
        let mut e = JointEstimator::new(cfg);
        let v2 = [1.0; 3];
        let r: [f64; 3] = core::array::from_fn(|a| cfg.beta_prior[1][a] / cfg.beta_prior[0][a]);
        let off = |f: f64| core::array::from_fn::<f64, 3, _>(|a| r[a] * v2[a] * f);
        assert_eq!(e.angular_consistent(&off(1.4), &v2, &[true; 3]), [true; 3]);
        assert_eq!(e.angular_consistent(&off(0.6), &v2, &[true; 3]), [true; 3]);
        assert_eq!(e.angular_consistent(&off(1.6), &v2, &[true; 3]), [false; 3]);
        assert_eq!(e.angular_consistent(&off(0.4), &v2, &[true; 3]), [false; 3]);
    }

    /// The linear tracks forget at 1/64 a sample: after a warm-up at 0, an accepted
    /// residual d leaves the spread (1 − α) α d².
    #[test]
    fn the_linear_track_forgets_at_one_sixty_fourth() {
        let mut e = JointEstimator::new(test_config());
        e.gate_c = SMatrix::zeros();
        e.gate_w = SMatrix::identity();
        for k in 0..6 {
            e.gate_c[(k, k)] = 1.0;
        }
        for _ in 0..100 {
            assert!(e.linear_consistent(&Sig::zeros(), &[1.0; 6]));
        }
        let mut sig = Sig::zeros();
        for k in 0..6 {
            sig[k] = 3.0;
        }
        assert!(e.linear_consistent(&sig, &[1.0; 6]));
        let alpha = 1.0 / 64.0;
        let want = (1.0 - alpha) * alpha * 9.0;
        for k in 0..6 {
            assert!((e.lin_track[k].var() / want - 1.0).abs() < 1e-12);
            assert!((e.lone_track[k].var() / want - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn a_rejection_counts_its_cause_and_marks_the_tick() {
        let mut e = JointEstimator::new(test_config());
        e.reject(CAUSE_STUCK);
        e.reject(CAUSE_STUCK);
        e.reject(CAUSE_STAR_OUTLIER);
        assert_eq!(e.causes[CAUSE_STUCK], 2);
        assert_eq!(e.causes[CAUSE_STAR_OUTLIER], 1);
        assert_eq!(e.tick_mask, (1 << CAUSE_STUCK) | (1 << CAUSE_STAR_OUTLIER));
    }
}
