//! One sample's path through the estimator: the references of the first usable
//! sample, the gates, attitude and signals, and the statistics it adds to.

use super::*;

impl JointEstimator {
    /// First usable sample: references, the coloured-noise direction and whitening,
    /// and the residual rows the linear input test uses.
    #[cfg_attr(not(target_arch = "x86_64"), inline(never))]
    pub(super) fn start(&mut self, data: &[IsData; 2]) {
        let n = self.n_is();
        for i in 0..n {
            self.sum_ref[i] = data[i].sum;
        }
        let bc = self.first_srp_dc(data);
        let h = self.direction_in_volts(&self.p, &bc);
        let mut msq = [0.0; 6];
        for s in 0..3 * n {
            msq[s] = self.sum_ref[s / 3][s % 3].powi(2);
        }
        let r0 = self.white_cov(&self.p, &msq, &[[0.0; 3]; 2]);
        if let Some((linv, u, hn)) = Self::whitening(&r0, &h) {
            self.t_u = linv.transpose() * u;
            self.hn = hn;
            let z = Self::turn_plane(&linv, &u, &self.turn_levers(&self.p, &bc));
            if let Some(e) = Self::plane_basis(&z) {
                for (k, ek) in e.iter().enumerate() {
                    self.turn_w.set_row(k, &(linv.transpose() * ek).transpose());
                    self.turn_z[k] = core::array::from_fn(|a| ek.dot(&z[a]));
                }
                self.turn_lever = self.row_levers(&self.turn_w);
            }
            let rows = Self::complement_rows(&linv, &u);
            for k in 0..5 {
                self.gate_w.set_row(k, &rows.row(k));
            }
            self.gate_w.set_row(5, &self.t_u.transpose());
            self.gate_lever = self.row_levers(&self.gate_w);
        }
        self.gate_c = self.coeffs(&self.p).lin;
        self.started = START_FULL;
    }

    /// Direction of the SRP at the first sample, in volts per slot (unit), at the
    /// priors: each IS's acceleration with the maneuver's A r̂ of this sample taken
    /// out (its ω̇; ω is ~0: the integrals start here or a few ticks before), averaged
    /// over the IS, and in volts with the same prior k as the noise model, so that it
    /// lies in that model's common-mode subspace. It fixes the common-mode channel for
    /// the whole campaign, where a slot of little white noise weighs its share of the
    /// direction by the inverse of that noise: the thrusters' torque noise times a CoM
    /// offset, left in, would tilt it towards the sunless axis and make that axis the
    /// channel.
    fn first_srp_dc(&self, data: &[IsData; 2]) -> Vector3<f64> {
        let p = &self.p;
        let n = self.n_is();
        let wdot = self.omega_dot(p, &[data[0].dv, data[1].dv]);
        let mut bc = Vector3::<f64>::zeros();
        for i in 0..n {
            let i = i.min(1);
            let ar = wdot.cross(&Vector3::from_fn(|a, _| p[P_R + 3 * i + a]));
            for j in 0..3 {
                bc[j] += (self.k_of(p, i, j) * self.sum_ref[i][j] - ar[j]) / n as f64;
            }
        }
        bc
    }

    /// A tick processed or bridged: solve on schedule.
    pub(super) fn tick_done(&mut self, tick: u64) {
        self.n_ticks += 1;
        // `max(1)`: the table is checked (≥ 1); no division by zero is linked either.
        if self.n_ticks % self.cfg.solve_every.max(1) == 0 {
            self.solve_due = [1, tick];
        }
    }

    pub(super) fn process(&mut self, tick: u64, s: &SensorSample) {
        let n = self.n_is();
        let (mut ok, mut axis_ok) = self.is_checks(s);
        // Per axis: did both IS pass the cross test (the pair then enters the
        // angular-consistency group and the ratio fit)?
        let pair = match n {
            2 => self.cross_check(s, &mut ok, &mut axis_ok),
            _ => [false; 3],
        };
        let data = [is_data(&s.is[0]), is_data(&s.is[1])];
        let all_valid = (0..n).all(|i| ok[i]);
        if self.started != START_FULL {
            // Angular data on every axis, from either IS (plain loops: no index check
            // is linked).
            let mut angular = true;
            for a in 0..3 {
                let mut any = false;
                for row in axis_ok.iter().take(n) {
                    any |= row[a];
                }
                angular &= any;
            }
            if all_valid {
                self.start(&data);
            } else if angular {
                // The integrals start here; the linear data wait for the references.
                self.started = START_ANGULAR;
            } else if self.started == START_NONE {
                self.n_rejected += 1;
                return;
            }
        }
        // Angular voltages for the integrators; a rejected IS axis borrows the other's,
        // and with neither the previous ω̇ bridges it.
        let mut dv = self.angular_inputs(&data, &axis_ok);
        if n == 2 {
            for a in 0..3 {
                if self.bridge_run[a] > 0 && (axis_ok[0][a] || axis_ok[1][a]) {
                    self.interpolate_bridge(a, &dv);
                }
            }
        }
        let saved = (self.psi, self.phi, self.dv_last);
        let (mut psi_mid, phi_mid) = self.integrate(&dv);
        let t = (self.n_ticks + 1) as f64 / self.cfg.fs;
        // The linear data, once they pass their test (the signals need this sample's
        // attitude step, not yet taken).
        let mut lin_sig = None;
        if all_valid {
            let turn = self.srp_turn(&psi_mid);
            let sig = self.signals(&data, &dv, &psi_mid, &phi_mid, &turn, t);
            // Each residual row's white variance at this sample's drive: for the
            // linear test now and the common-mode filter once accepted.
            let var = self.row_white_vars(&sig);
            if self.linear_consistent(&sig, &[var[0], var[1], var[2], var[3], var[4], var[5]]) {
                lin_sig = Some((sig, var));
            } else {
                self.reject(CAUSE_LINEAR_OUTLIER);
                if n == 1 {
                    // One IS: its angular voltages may be the corrupted ones.
                    axis_ok = [[false; 3]; 2];
                    (self.psi, self.phi, self.dv_last) = saved;
                    dv = self.angular_inputs(&data, &axis_ok);
                    (psi_mid, _) = self.integrate(&dv);
                }
            }
        }
        if n == 2 && !all_valid && self.lone_misfit(&data, &mut axis_ok, &dv, &psi_mid, &phi_mid, t)
        {
            self.reject(CAUSE_LINEAR_OUTLIER);
            (self.psi, self.phi, self.dv_last) = saved;
            dv = self.angular_inputs(&data, &axis_ok);
            (psi_mid, _) = self.integrate(&dv);
        }
        if n == 2 {
            self.note_borrowed(&axis_ok, &data);
        }
        self.propagate_model(&psi_mid);
        let n_ang: [usize; 3] = core::array::from_fn(|a| (0..n).filter(|&i| axis_ok[i][a]).count());
        // Only clean samples teach the spread of ω̇'s change.
        for a in 0..3 {
            if n_ang[a] == n && (n == 1 || pair[a]) {
                self.learn_jerk(a, &dv, &saved.2);
            } else {
                self.forget_jerk(a);
            }
        }
        if let Some((sig, var)) = lin_sig {
            self.n_used += 1;
            self.update_linear(&sig, &dv, &var);
            self.note_excitation(&dv);
            self.fix_srp_level(&sig, &dv, &psi_mid, &phi_mid);
            self.gate_s = sig;
        } else {
            self.n_rejected += 1;
            self.whitening_time_update();
        }
        self.add_angular_pairs(&pair, &dv);
        self.end_bridges(&n_ang, &dv);
        self.star_time_update(&dv, &n_ang);
        let kappa = self.kappa();
        self.update_star(s, &kappa, t);
        self.tick_done(tick);
    }

    /// The two IS's cross test per axis (both IS present): returns which axes passed
    /// with both (the pair then enters the angular-consistency group and the ratio
    /// fit); on a mismatch the sample's linear data are refused (`ok`) and the IS to
    /// keep is chosen per failed axis (`axis_ok`).
    fn cross_check(
        &mut self,
        s: &SensorSample,
        ok: &mut [bool; 2],
        axis_ok: &mut [[bool; 3]; 2],
    ) -> [bool; 3] {
        let (d0, d1) = (s.is[0].angular_volts(), s.is[1].angular_volts());
        let tested: [bool; 3] = core::array::from_fn(|a| axis_ok[0][a] && axis_ok[1][a]);
        let pair = self.angular_consistent(&d0, &d1, &tested);
        if (0..3).any(|a| tested[a] && !pair[a]) {
            // One of them is corrupted, its linear data too: the sample's linear
            // data are not used. The attitude must still be propagated, and bridging
            // with the previous ω̇ would cost far more than either IS: on the failed
            // axis, keep the one nearer the previous ω̇.
            self.reject(CAUSE_ANGULAR_MISMATCH);
            *ok = [false; 2];
            let sums = [s.is[0].linear_volts(), s.is[1].linear_volts()];
            // A plain range (not `filter`): the index bound stays visible, no check is linked.
            for a in 0..3 {
                if !tested[a] || pair[a] {
                    continue;
                }
                let t = self.trusted_is(a, [&d0, &d1], [&sums[0], &sums[1]]);
                axis_ok[0][a] = t[0];
                axis_ok[1][a] = t[1];
                // Should the kept IS be the corrupted one, the propagated rate is off
                // by dt times the mismatch from here on: the turn filters must allow
                // that step of its rate, or they would smear the ramp over the maneuver.
                let c = &self.cfg;
                let step = (c.beta_prior[0][a] * d0[a] - c.beta_prior[1][a] * d1[a]) / c.fs;
                if step.is_finite() {
                    self.turn_pq[a][2] += step * step;
                }
            }
        }
        // A plain range (not `filter`): the index bound stays visible, no check is linked.
        for a in 0..3 {
            if !pair[a] {
                continue;
            }
            self.ratio[a].add(d0[a], d1[a]);
        }
        pair
    }

    /// The angular-consistency group: the pair's voltages of every axis both IS passed.
    fn add_angular_pairs(&mut self, pair: &[bool; 3], dv: &[[f64; 3]; 2]) {
        // A plain range (not `filter`): the index bound stays visible, no check is linked.
        for a in 0..3 {
            if !pair[a] {
                continue;
            }
            // Residual ΔV1 − (β2/β1) ΔV2 [V], weighted with its noise at the priors
            // (readout and drive ripple), so the group constrains the ratio only and
            // cannot pull the common scale. Its Gram is kept on ΔV1 − ρ0 ΔV2 and ΔV2,
            // ρ0 the priors' ratio: on ΔV1 and ΔV2 themselves the residual's sum of
            // squares would be the small difference of sums 10¹³ times larger (the
            // signals' SNR squared with a quiet IS), whose rounding (10⁻¹³ of them over
            // 10⁶ samples) would move the group's χ²/dof by ±0.5.
            let c = &self.cfg;
            let rho = self.prior_ratio(a);
            let var = 2.0 * (c.sigma_angular / c.beta_prior[0][a]).powi(2)
                + c.sigma_ripple.powi(2) * (dv[0][a].powi(2) + (rho * dv[1][a]).powi(2));
            let v = SVector::<f64, 2>::new(dv[0][a] - rho * dv[1][a], dv[1][a]);
            rank1_upper(&mut self.m_ang[a], &v, 1.0 / var);
        }
    }

    /// Per axis: a bridge starts or runs on when no IS's angular data were used, and
    /// ends (closed against the data) when some were.
    fn end_bridges(&mut self, n_ang: &[usize; 3], dv: &[[f64; 3]; 2]) {
        if n_ang.contains(&0) {
            self.n_bridged += 1;
        }
        for a in 0..3 {
            if n_ang[a] == 0 {
                self.bridge_run[a] = self.bridge_run[a].saturating_add(1);
                self.turn_bridged(a);
            } else {
                self.close_bridge(a, dv);
            }
        }
    }

    /// The SRP in IS1's channels against the reference sample [V], inertial: the
    /// maneuver's A r̂ / k̂ (this sample's ω̇, ω at the running solution) and the
    /// running DC turned by θ̂ = β̂1 Φ1 taken out. `s` holds this sample's signals up
    /// to `S_TF`.
    pub(super) fn srp_change(&self, s: &Sig, phi_mid: &[[f64; 3]; 2]) -> [f64; 3] {
        let bc = self.srp_dc(&self.p);
        let theta = Vector3::from_fn(|a, _| self.p[P_BETA + a] * phi_mid[0][a]);
        let turn = theta.cross(&Vector3::from(bc));
        core::array::from_fn(|m| {
            let mut eps = s[S_SUM + m] + turn[m] / self.k_of(&self.p, 0, m);
            for c in (S_DV..S_DV + 6).chain(S_PP..S_PP + 6) {
                eps += self.gate_c[(m, c)] * s[c];
            }
            eps
        })
    }

    /// Signals of the linear group for one sample.
    pub(super) fn signals(
        &self,
        data: &[IsData; 2],
        dv: &[[f64; 3]; 2],
        psi_mid: &[[f64; 3]; 2],
        phi_mid: &[[f64; 3]; 2],
        w_turn: &Matrix3<f64>,
        t: f64,
    ) -> Sig {
        let mut s = Sig::zeros();
        for i in 0..self.n_is() {
            for j in 0..3 {
                s[S_SUM + 3 * i + j] = data[i].sum[j] - self.sum_ref[i][j];
                s[S_DV + 3 * i + j] = dv[i][j];
            }
        }
        for a in 0..3 {
            for b in a..3 {
                s[S_PP + prod(a, b)] = psi_mid[0][a] * psi_mid[0][b];
            }
        }
        for a in 0..3 {
            let phi = phi_mid[0][a];
            s[S_PHI + a] = phi;
            if self.srp_level_set == LEVEL_NONE {
                s[S_PHI0 + a] = phi;
            }
            for m in 0..3 {
                s[S_W + 3 * a + m] = w_turn[(a, m)];
            }
        }
        s[S_ONE] = 1.0;
        s[S_T] = t;
        // The SRP's change since its level, in m/s² with the running k̂ (none before
        // the level is fixed: the turn then uses the fitted DC alone).
        if self.srp_level_set == LEVEL_SET {
            let eps = self.srp_change(&s, phi_mid);
            let change = Vector3::from_fn(|m, _| {
                self.k_of(&self.p, 0, m) * (self.sum_ref[0][m] + eps[m] - self.srp_level[m])
            });
            let theta = Vector3::from_fn(|a, _| self.p[P_BETA + a] * phi_mid[0][a]);
            let tf = theta.cross(&change);
            for j in 0..3 {
                s[S_TF + j] = tf[j];
            }
        }
        s
    }

    /// The SRP level the turn uses from now on, once the running solution can tell
    /// it: from this accepted sample's signals `sig`.
    fn fix_srp_level(
        &mut self,
        sig: &Sig,
        dv: &[[f64; 3]; 2],
        psi_mid: &[[f64; 3]; 2],
        phi_mid: &[[f64; 3]; 2],
    ) {
        if self.srp_level_set != LEVEL_NONE
            || !self.every_axis_rocked()
            || !self.srp_change_known(dv, psi_mid, phi_mid)
        {
            return;
        }
        let eps = self.srp_change(sig, phi_mid);
        let a: [f64; 3] = core::array::from_fn(|m| self.sum_ref[0][m] + eps[m]);
        if a.iter().all(|v| v.is_finite()) {
            self.srp_level = a;
            self.srp_level_set = LEVEL_SET;
        }
    }

    /// Has real motion dominated IS1's angular readout noise on every axis
    /// (`ROCKED_VAR_RATIO`), and has a solve run since? Until then the running solution
    /// is not one to measure the SRP's level with, whatever its σ says: on an axis whose
    /// ω̇ is readout noise alone (a thruster without torque noise, before the maneuver
    /// rocks that axis) the fit's errors in variables pull r towards 0 with a σ that
    /// counts that noise as excitation (docs/integrity.md), and a level measured with
    /// r̂ a millimetre off carries its A r error, which the measured change then turns.
    /// The samples before the level turn the fitted DC (`S_PHI0`) and lose only the turn
    /// of the SRP's fluctuation by waiting (without thruster noise, two thirds of the
    /// planned campaign).
    pub(super) fn every_axis_rocked(&self) -> bool {
        self.rocked_tick != 0
            && self.solved_tick >= self.rocked_tick
            && self.status & ST_NO_SOLUTION == 0
    }

    /// Does real motion dominate IS1's angular readout noise on every axis, on its own
    /// (`ROCKED_VAR_RATIO`)? From the excitation's moments (`note_excitation`, which
    /// asks when they change and keeps the answer in `rocked_tick`).
    pub(super) fn motion_on_every_axis(&self) -> bool {
        let n = self.n_used.div_ceil(tuning::MOMENT_EVERY) as f64;
        if n < 2.0 {
            return false;
        }
        // ω̇'s covariance [rad²/s⁴] at the prior β.
        let c = &self.cfg;
        let mut cov = Matrix3::<f64>::zeros();
        for a in 0..3 {
            let (ma, ba) = (&self.rate_moments[a], c.beta_prior[0][a]);
            for b in 0..3 {
                let (mb, bb) = (&self.rate_moments[b], c.beta_prior[0][b]);
                let prod = match a + b {
                    _ if a == b => ma[1],
                    1 => self.rate_cross[0],
                    2 => self.rate_cross[1],
                    _ => self.rate_cross[2],
                };
                cov[(a, b)] = ba * bb * (prod / n - (ma[0] / n) * (mb[0] / n));
            }
        }
        rocking(&cov, c.sigma_angular.powi(2)) > 1.0
    }

    /// Is the running solution good enough to measure the SRP's fluctuation with
    /// (`srp_change`)? What its uncertainty (σ of the last solve) leaves in IS1's
    /// channels — the maneuver's A r through r and β (and the k that divides it) and
    /// the DC's turn through β — must be below the fluctuation itself (the SRP model's
    /// stationary variance, [m²/s⁴]): the measured level is then as good as the SRP
    /// model could tell. Until the maneuver has excited the parameters, it is not.
    #[inline(never)]
    fn srp_change_known(
        &self,
        dv: &[[f64; 3]; 2],
        psi_mid: &[[f64; 3]; 2],
        phi_mid: &[[f64; 3]; 2],
    ) -> bool {
        let (p, sg) = (&self.p, &self.sigma);
        let n = self.n_is();
        let wdot = self.omega_dot(p, dv);
        let omega = Vector3::from_fn(|a, _| p[P_BETA + a] * psi_mid[0][a]);
        let r = Vector3::from_fn(|a, _| p[P_R + a]);
        let bc = Vector3::from(self.srp_dc(p));
        let a_r = wdot.cross(&r) + omega.cross(&omega.cross(&r));
        let mut lev = 0.0;
        for a in 0..3 {
            let e = Vector3::ith(a, 1.0);
            // r1_a.
            let d = wdot.cross(&e) + omega.cross(&omega.cross(&e));
            lev += d.norm_squared() * sg[P_R + a].powi(2);
            // β1_a: ω̇ (its share), ω, the DC's turn θ × b.
            let d = e.cross(&r) * (self.w(0) * dv[0][a])
                + (e.cross(&omega.cross(&r)) + omega.cross(&e.cross(&r))) * psi_mid[0][a]
                + e.cross(&bc) * phi_mid[0][a];
            lev += d.norm_squared() * sg[P_BETA + a].powi(2);
            if n == 2 {
                // β2_a through ω̇.
                let d = e.cross(&r) * (self.w(1) * dv[1][a]);
                lev += d.norm_squared() * sg[P_BETA + 3 + a].powi(2);
            }
            // Channel a: A r̂ / k̂ (k through its β's relative error).
            let kb = PERM[a];
            lev += (a_r[a] * sg[P_BETA + kb] / p[P_BETA + kb]).powi(2);
        }
        let nb = self.bank.poles();
        let var_srp: f64 = self.bank.var[..nb].iter().sum();
        lev <= var_srp
    }
}
