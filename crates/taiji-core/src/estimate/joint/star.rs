//! The star-tracker group: its innovations filter (the IS angular noise integrated
//! twice is an integrated random walk) and its Gram statistics.

use super::*;

impl JointEstimator {
    /// Advance the star-tracker whitening filter by one sample: the angle error of the
    /// IS-propagated attitude ½(β1 Φ1 + β2 Φ2) grows as the double integral of the IS
    /// angular readout noise and drive ripple (per-sample variance from this sample's
    /// voltages, integrated exactly as `step` integrates Φ), and by the motion within
    /// each tick that the IS's means miss (`intra_tick_walk`).
    pub(super) fn star_time_update(&mut self, dv: &[[f64; 3]; 2], n_valid: &[usize; 3]) {
        let c = &self.cfg;
        let dt = 1.0 / c.fs;
        let (g0, g1) = (0.5 * dt * dt, dt);
        for a in 0..3 {
            let mut q = 0.0;
            for (l, dvl) in dv.iter().enumerate().take(self.n_is()) {
                q += self.w(l).powi(2) * self.readout_var(l, a, dvl[a]);
            }
            if n_valid[a] == 0 {
                // Bridged (the line drawn once data return): off by ω̇'s departure
                // from that line, a step the turn rows see too (`STEP_IN_STAR`).
                q += tuning::STEP_IN_STAR * self.jerk_var[a];
            } else {
                // Borrowed voltages carry the other IS's noise in full.
                q *= self.n_is() as f64 / n_valid[a] as f64;
            }
            for x in self.st_x[a].iter_mut() {
                x[0] += dt * x[1];
            }
            // The thrusters' motion within the tick, which the IS's mean misses.
            let walk = self.intra_tick_walk(a);
            let p = &mut self.st_p[a];
            let p00 = p[0][0] + 2.0 * dt * p[0][1] + dt * dt * p[1][1] + q * g0 * g0 + walk;
            let p01 = p[0][1] + dt * p[1][1] + q * g0 * g1;
            let p11 = p[1][1] + q * g1 * g1;
            *p = [[p00, p01], [p01, p11]];
        }
    }

    /// Second-order kinematics [rad]: the propagated attitude's rotation vector minus
    /// its first-order part Φ̂ (both with the running β̂, so κ errs only by (β − β̂)
    /// times second order).
    pub(super) fn kappa(&self) -> Vector3<f64> {
        crate::model::attitude::rotation_vector(&self.q_model) - Vector3::from(self.phi_hat)
    }

    #[cfg_attr(not(target_arch = "x86_64"), inline(never))]
    pub(super) fn update_star(&mut self, s: &SensorSample, kappa: &Vector3<f64>, t: f64) {
        if s.star.valid == 0 {
            return; // no sample this tick
        }
        let q = Quaternion::new(
            s.star.q_bn[0],
            s.star.q_bn[1],
            s.star.q_bn[2],
            s.star.q_bn[3],
        );
        // A star-tracker quaternion is normalised far better than this.
        if !s.star.usable() || nan_or_above((q.norm() - 1.0).abs(), tuning::STAR_NORM_TOLERANCE) {
            self.reject(CAUSE_STAR_INVALID);
            return;
        }
        let q = UnitQuaternion::from_quaternion(q);
        if self.q_ref_set == 0 {
            self.q_ref = q;
            self.q_ref_set = 1;
        }
        let q_ref = self.q_ref;
        let theta = crate::model::attitude::rotation_vector(&(q_ref.inverse() * q));
        // The attitude the IS predicts (prior β) differs from the star tracker's by its
        // white noise around a slowly moving offset: a glitch (a mis-identified star,
        // an upset) stands out of it.
        let var_star = self.cfg.sigma_star_rad.powi(2);
        let mut e = [0.0; 3];
        for (a, ea) in e.iter_mut().enumerate() {
            let mut pred = kappa[a];
            for l in 0..self.n_is() {
                pred += self.w(l) * self.cfg.beta_prior[l][a] * self.phi[l][a];
            }
            *ea = theta[a] - pred;
        }
        let ok = (0..3).all(|a| self.star_track[a].check(e[a], var_star, self.cfg.star_gate_sigma));
        for a in 0..3 {
            if ok {
                self.star_track[a].learn(e[a], tuning::ALPHA_STAR);
            } else {
                self.star_track[a].miss();
            }
        }
        if !ok {
            self.reject(CAUSE_STAR_OUTLIER);
            return;
        }
        self.n_star += 1;
        let r = self.cfg.sigma_star_rad.powi(2);
        for a in 0..3 {
            let v =
                SVector::<f64, 5>::new(theta[a] - kappa[a], 1.0, t, self.phi[0][a], self.phi[1][a]);
            // Innovations of every signal through the same filter (measurement and
            // regressors alike), normalised to unit variance.
            let p = self.st_p[a];
            let sv = p[0][0] + r;
            let (k0, k1) = (p[0][0] / sv, p[0][1] / sv);
            let inv_sqrt = 1.0 / sv.sqrt();
            let mut vf = SVector::<f64, 5>::zeros();
            for (m, x) in self.st_x[a].iter_mut().enumerate() {
                let innov = v[m] - x[0];
                vf[m] = innov * inv_sqrt;
                x[0] += k0 * innov;
                x[1] += k1 * innov;
            }
            self.st_p[a] = [
                [p[0][0] - k0 * p[0][0], p[0][1] - k0 * p[0][1]],
                [p[0][1] - k0 * p[0][1], p[1][1] - k1 * p[0][1]],
            ];
            rank1_upper(&mut self.m_star[a], &vf, 1.0);
        }
    }
}
