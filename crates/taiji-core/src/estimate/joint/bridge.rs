//! Attitude: the double integrals of the angular voltages, the attitude propagated
//! with the running β̂, the bridging of ticks without angular data, and what that
//! attitude's error adds to the turn filters' noise (`turn_pq`).

use super::*;

impl JointEstimator {
    /// A tick with no sample at all (missing on the bus): every model propagates as in
    /// a dropout of every sensor.
    pub(super) fn bridge(&mut self, tick: u64) {
        self.reject(CAUSE_TICK_MISSING);
        self.n_rejected += 1;
        if self.started == START_NONE {
            return;
        }
        let dv = self.dv_last;
        self.n_bridged += 1;
        for a in 0..3 {
            self.bridge_run[a] = self.bridge_run[a].saturating_add(1);
            self.turn_bridged(a);
            self.forget_jerk(a);
        }
        let (psi_mid, _) = self.integrate(&dv);
        self.propagate_model(&psi_mid);
        self.whitening_time_update();
        self.star_time_update(&dv, &[0; 3]);
        self.tick_done(tick);
    }

    /// Advance the angle integrators by one sample of `dv`; returns the interval means
    /// (Ψ, Φ) used by the linear model.
    ///
    /// The thrusters hold their torque over a tick, so within it ω̇ is the IS's mean,
    /// Ψ a line and Φ a parabola: Ψ's mean is its midpoint, but Φ's mean is the
    /// midpoint of its ends less dv dt²/12 (the parabola's ω̇ s²/2 averages ω̇ dt²/6
    /// over the tick, its ends' midpoint ω̇ dt²/4). The IS measure the
    /// SRP turned by that mean attitude; the ends' midpoint, dv dt²/12 ahead, turned
    /// it as ω̇ × r does, a CoM offset of b dt²/12 along the SRP (2.2 nm of r_z at
    /// 1 Hz).
    pub(super) fn integrate(&mut self, dv: &[[f64; 3]; 2]) -> ([[f64; 3]; 2], [[f64; 3]; 2]) {
        let dt = 1.0 / self.cfg.fs;
        let mut psi_mid = [[0.0; 3]; 2];
        let mut phi_mid = [[0.0; 3]; 2];
        for i in 0..self.n_is() {
            for a in 0..3 {
                let psi_new = self.psi[i][a] + dt * dv[i][a];
                psi_mid[i][a] = 0.5 * (self.psi[i][a] + psi_new);
                let phi_new = self.phi[i][a] + dt * psi_mid[i][a];
                phi_mid[i][a] = 0.5 * (self.phi[i][a] + phi_new) - dt * dt * dv[i][a] / 12.0;
                self.psi[i][a] = psi_new;
                self.phi[i][a] = phi_new;
            }
        }
        self.dv_last = *dv;
        (psi_mid, phi_mid)
    }

    /// Advance the running-β̂ attitude by one sample (and the turn filters' noise).
    pub(super) fn propagate_model(&mut self, psi_mid: &[[f64; 3]; 2]) {
        let dt = 1.0 / self.cfg.fs;
        let w_model = Vector3::from_fn(|a, _| self.p[P_BETA + a] * psi_mid[0][a]);
        for a in 0..3 {
            self.phi_hat[a] += dt * w_model[a];
        }
        self.q_model *= UnitQuaternion::from_scaled_axis(w_model * dt);
        let (g0, g1) = (0.5 * dt * dt, dt);
        // IS1's ω̇ noise (readout and drive ripple) integrates twice into the propagated
        // attitude: a random walk of angle and rate that grows as t^1.5 (2×10⁻⁷ rad at
        // 10⁵ s) and, turning the 3×10⁻⁸ m/s² SRP, would pose as a CoM offset in long
        // campaigns: the turn filters' noise (`turn_pq`).
        for a in 0..3 {
            let q = self.readout_var(0, a, self.dv_last[0][a]);
            self.turn_pq[a][0] += self.intra_tick_walk(a);
            if q > 0.0 && q.is_finite() {
                self.turn_pq[a][0] += q * g0 * g0;
                self.turn_pq[a][1] += q * g0 * g1;
                self.turn_pq[a][2] += q * g1 * g1;
            }
        }
    }

    /// The variance of IS `l`'s ω̇ on axis `a` in a tick whose angular voltage is `dv`
    /// [rad²/s⁴]: its readout noise and the drive ripple, which scales with the drive.
    pub(super) fn readout_var(&self, l: usize, a: usize, dv: f64) -> f64 {
        let c = &self.cfg;
        let wd = c.beta_prior[l.min(1)][a.min(2)] * dv;
        c.sigma_angular.powi(2) + (c.sigma_ripple * wd).powi(2)
    }

    /// The variance [rad²] a tick adds to the angle the IS's means propagate, on axis
    /// `a`. The thrusters' torque noise moves ω̇ within each tick and the IS reports
    /// its mean: the angle at the tick's end is off by ∫(dt − s)(ω̇ − ω̄) ds, a random
    /// walk of variance S dt³/12 a tick (S = var_tick dt its spectral density,
    /// var_tick = jerk_var/1.5 the learned tick-to-tick spread, mostly the torque
    /// noise's). Real motion, both IS alike: the star tracker sees it and so do the turn
    /// rows. At 1 Hz it is five times IS1's own double-integrated noise at the
    /// maneuver's frequency; left out, β's σ in the star group would be optimistic
    /// wherever the torque noise is large.
    pub(super) fn intra_tick_walk(&self, a: usize) -> f64 {
        let dt = 1.0 / self.cfg.fs;
        let walk = self.jerk_var[a] * dt * dt * dt * dt / 18.0;
        if walk.is_finite() {
            walk.max(0.0)
        } else {
            0.0
        }
    }

    /// W of the linear model at the middle of this sample's interval (before the
    /// attitude takes its step): R̂ᵀ − I + [Φ̂]×, R̂ IS1's integrals alone (their error
    /// is the turn filters' noise; pulled onto the star tracker it would carry the star
    /// tracker's noise, which the star group counts already).
    pub(super) fn srp_turn(&self, psi_mid: &[[f64; 3]; 2]) -> Matrix3<f64> {
        let h = 0.5 / self.cfg.fs;
        let w_model = Vector3::from_fn(|a, _| self.p[P_BETA + a] * psi_mid[0][a]);
        let q_mid = self.q_model * UnitQuaternion::from_scaled_axis(w_model * h);
        let q = q_mid;
        let phi_hat = Vector3::from_fn(|a, _| self.phi_hat[a] + h * w_model[a]);
        q.to_rotation_matrix().into_inner().transpose() - Matrix3::identity() + skew(&phi_hat)
    }

    pub(super) fn angular_inputs(&self, data: &[IsData; 2], ok: &[[bool; 3]; 2]) -> [[f64; 3]; 2] {
        let n = self.n_is();
        let mut dv = [[0.0; 3]; 2];
        for i in 0..n {
            for a in 0..3 {
                dv[i][a] = if ok[i][a] {
                    data[i].dv[a]
                } else if let Some(o) = (0..n).find(|&o| ok[o][a]) {
                    // ΔV_i = (β_o/β_i) ΔV_o, with the ratio fitted from the voltages
                    // (the priors' ratio is only good to the ground calibration's 1 %,
                    // and every borrowed sample would carry that error into the angle).
                    let prior = self.cfg.beta_prior[o][a] / self.cfg.beta_prior[i][a];
                    let r = match self.ratio[a].ratio() {
                        Some((rho, _)) if i == 0 => rho,
                        Some((rho, _)) => 1.0 / rho,
                        None => prior,
                    };
                    data[o].dv[a] * r
                } else {
                    self.dv_last[i][a]
                };
            }
        }
        dv
    }

    /// IS1's axes that borrowed IS2's voltage this tick (`angular_inputs`) put the
    /// fitted ratio's error into IS1's rate: dt β1 ΔV2 δρ, a step of the attitude that
    /// turns the SRP (`turn_pq`). δρ's variance is the fit's (its residual's readout
    /// noise and ripple over Σ ΔV2²), or the priors' ratio's before the fit (at 1 Hz
    /// the fit after 100 pairs is off by 10⁻⁵; left out, IS dropouts would make β's σ
    /// optimistic, the turn counting as evidence).
    pub(super) fn note_borrowed(&mut self, axis_ok: &[[bool; 3]; 2], data: &[IsData; 2]) {
        let c = &self.cfg;
        let dt = 1.0 / c.fs;
        for a in 0..3 {
            if axis_ok[0][a] || !axis_ok[1][a] {
                continue;
            }
            let v2 = data[1].dv[a];
            let (b1, b2) = (c.beta_prior[0][a], c.beta_prior[1][a]);
            let var_rho = match self.ratio[a].ratio() {
                Some((rho, inv_syy)) => {
                    let res = (c.sigma_angular / b1).powi(2)
                        + (rho * c.sigma_angular / b2).powi(2)
                        + 2.0 * (c.sigma_ripple * v2).powi(2);
                    res * inv_syy
                }
                None => 2.0 * (PRIOR_BETA_REL * b2 / b1).powi(2),
            };
            let v = (dt * b1 * v2).powi(2) * var_rho;
            if v.is_finite() {
                self.turn_pq[a][2] += v;
            }
        }
    }

    /// Angular data on axis `a` are back after `bridge_run` = n ticks bridged with the
    /// last ω̇ measured before them (the anchor): replace those n held values by the
    /// straight line from the anchor to this sample's ω̇. Holding lags the attitude
    /// behind a changing ω̇ (a thruster's overshoot after an edge); the line leaves
    /// only its curvature and the torque noise's own scatter. The integrals move by
    /// dt Σ δ_k (rate) and dt² Σ δ_k (n − k + ½) (angle), δ_k = k Δ/(n + 1): Δ dt n/2
    /// and Δ dt² n(2n + 1)/12. The propagated attitude moves with them. With one IS
    /// configured the linear test may still undo this sample's angular data, so the
    /// line is drawn only with two.
    pub(super) fn interpolate_bridge(&mut self, a: usize, dv: &[[f64; 3]; 2]) {
        let n = self.bridge_run[a] as f64;
        let dt = 1.0 / self.cfg.fs;
        let mut d_psi = [0.0; 2];
        let mut d_phi = [0.0; 2];
        for l in 0..self.n_is() {
            let delta = dv[l][a] - self.dv_anchor[l][a];
            if !delta.is_finite() {
                return;
            }
            d_psi[l] = dt * delta * n / 2.0;
            d_phi[l] = dt * dt * delta * n * (2.0 * n + 1.0) / 12.0;
        }
        for l in 0..self.n_is() {
            self.psi[l][a] += d_psi[l];
            self.phi[l][a] += d_phi[l];
        }
        let turn = self.p[P_BETA + a] * d_phi[0];
        self.phi_hat[a] += turn;
        self.q_model *= UnitQuaternion::from_scaled_axis(Vector3::ith(a, turn));
    }

    /// Angular data on axis `a` are back after `bridge_run` ticks bridged with the previous ω̇: if
    /// ω̇ jumped meanwhile (a torque edge), the integrated rate is off by up to the
    /// gap's length times the jump, at an unknown tick of the gap; the straight line
    /// (`interpolate_bridge`) halves it. Widen the star filter's rate (and the angle it
    /// drags along) by that uniform uncertainty, ±span·jump/2.
    pub(super) fn close_bridge(&mut self, a: usize, dv: &[[f64; 3]; 2]) {
        let run = self.bridge_run[a];
        self.bridge_run[a] = 0;
        if run > 0 {
            let span = run as f64 / self.cfg.fs;
            let mut jump = 0.0;
            for l in 0..self.n_is() {
                jump += self.w(l) * self.cfg.beta_prior[l][a] * (dv[l][a] - self.dv_anchor[l][a]);
            }
            let v = (span * jump).powi(2) / 12.0;
            let (vs, vt) = (tuning::STEP_IN_STAR * v, tuning::STEP_IN_TURN * v);
            if v.is_finite() {
                let h = 0.5 * span;
                let p = &mut self.st_p[a];
                p[0][0] += vs * h * h;
                p[0][1] += vs * h;
                p[1][0] += vs * h;
                p[1][1] += vs;
                self.turn_pq[a][0] += vt * h * h;
                self.turn_pq[a][1] += vt * h;
                self.turn_pq[a][2] += vt;
            }
        }
        for l in 0..2 {
            self.dv_anchor[l][a] = dv[l][a];
        }
    }

    /// A tick without angular data on axis `a`: the propagated rate is off by dt times
    /// ω̇'s departure from the line later drawn across the gap, a step of the attitude
    /// that turns the SRP.
    pub(super) fn turn_bridged(&mut self, a: usize) {
        let dt = 1.0 / self.cfg.fs;
        self.turn_pq[a][2] += tuning::STEP_IN_TURN * dt * dt * self.jerk_var[a];
    }

    /// Add this linear sample to the excitation's moments (`rate_moments`,
    /// `rate_cross`), on every `MOMENT_EVERY`th: the maneuver is slow against any
    /// sample rate, and an update on a flight CPU then pays for a branch, not for 9
    /// software floating-point operations. They change only here, so here too is where
    /// the first tick with motion of its own on every axis is noted (`rocked_tick`).
    pub(super) fn note_excitation(&mut self, dv: &[[f64; 3]; 2]) {
        if self.n_used & (tuning::MOMENT_EVERY - 1) != 1 {
            return;
        }
        for (m, v) in self.rate_moments.iter_mut().zip(&dv[0]) {
            m[0] += v;
            m[1] += v * v;
        }
        let v = &dv[0];
        self.rate_cross[0] += v[0] * v[1];
        self.rate_cross[1] += v[0] * v[2];
        self.rate_cross[2] += v[1] * v[2];
        if self.rocked_tick == 0 && self.motion_on_every_axis() {
            self.rocked_tick = self.next_tick + 1;
        }
    }

    /// Learn the spread of ω̇'s departure from the line through its neighbours (prior
    /// β): half the change of the sample-to-sample change, for the previous sample.
    /// White ω̇ noise of variance σ² gives 1.5 σ², what a one-tick gap bridged by the
    /// line is off by; the maneuver's own change cancels but at its edges, which
    /// `close_bridge` measures instead and which are clipped here (`JERK_CLIP_VAR`).
    pub(super) fn learn_jerk(&mut self, a: usize, dv: &[[f64; 3]; 2], last: &[[f64; 3]; 2]) {
        let mut change = 0.0;
        for l in 0..self.n_is() {
            change += self.w(l) * self.cfg.beta_prior[l][a] * (dv[l][a] - last[l][a]);
        }
        if !change.is_finite() {
            self.forget_jerk(a);
            return;
        }
        if self.jerk_last_ok & (1 << a) != 0 {
            let d = 0.5 * (change - self.jerk_last[a]);
            let v = &mut self.jerk_var[a];
            if *v > 0.0 {
                *v += tuning::ALPHA_JERK * ((d * d).min(tuning::JERK_CLIP_VAR * *v) - *v);
            } else {
                // The running mean starts at its first value.
                *v = d * d;
            }
        }
        self.jerk_last[a] = change;
        self.jerk_last_ok |= 1 << a;
    }

    /// The sample on axis `a` was not clean: the next change starts a new pair.
    pub(super) fn forget_jerk(&mut self, a: usize) {
        self.jerk_last_ok &= !(1 << a);
    }
}
