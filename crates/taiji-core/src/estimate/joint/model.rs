//! The model: each residual group's coefficients on the data signals as functions of
//! the parameters, and the SRP's direction and DC.

use super::*;

/// Residual coefficients of every group for one parameter vector.
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub(super) struct Coeffs {
    pub(super) lin: SMatrix<f64, 6, NS>,
    pub(super) star: [SVector<f64, 5>; 3],
    pub(super) ang: [SVector<f64, 2>; 3],
}

/// Residual coefficients at the current parameters and their derivatives by each.
pub(super) struct Linearised<'a> {
    pub(super) c0: &'a Coeffs,
    pub(super) dc: &'a [Coeffs; NP],
}

pub(super) fn skew(r: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -r.z, r.y, r.z, 0.0, -r.x, -r.y, r.x, 0.0)
}

impl JointEstimator {
    /// DC SRP acceleration in the body frame [m/s²]: the fitted DC of the linear
    /// channels (reference sample plus bias), averaged over the IS.
    pub(super) fn srp_dc(&self, p: &Par) -> [f64; 3] {
        let n = self.n_is();
        let mut bc = [0.0; 3];
        for i in 0..n {
            for (j, b) in bc.iter_mut().enumerate() {
                *b += self.k_of(p, i, j) * (self.sum_ref[i][j] + p[P_B + 3 * i + j]) / n as f64;
            }
        }
        bc
    }

    /// Direction of the coloured SRP noise in volts per slot, from the fitted DC: the
    /// reference sample alone also holds the maneuver's A r at the first tick (≈1 %).
    pub(super) fn srp_direction(&self, p: &Par) -> SVector<f64, 6> {
        self.direction_in_volts(p, &Vector3::from(self.srp_dc(p)))
    }

    /// An acceleration's direction in volts per slot (unit norm of `bc` [m/s²]), each
    /// slot through its k at `p`.
    pub(super) fn direction_in_volts(&self, p: &Par, bc: &Vector3<f64>) -> SVector<f64, 6> {
        let g0 = bc.norm().max(1e-30);
        let mut h = SVector::<f64, 6>::zeros();
        for s in 0..3 * self.n_is() {
            h[s.min(5)] = bc[s % 3] / self.k_of(p, s / 3, s % 3) / g0;
        }
        h
    }

    /// ω̇ at `p` [rad/s²]: the IS average of β ΔV (angular voltages `dv`).
    pub(super) fn omega_dot(&self, p: &Par, dv: &[[f64; 3]; 2]) -> Vector3<f64> {
        Vector3::from_fn(|a, _| {
            (0..self.n_is())
                .map(|l| self.w(l) * p[P_BETA + (3 * l + a).min(5)] * dv[l.min(1)][a])
                .sum::<f64>()
        })
    }

    /// The priors' ratio β2/β1 on axis `a`, the angular group's reference
    /// (`add_angular_pairs`).
    pub(super) fn prior_ratio(&self, a: usize) -> f64 {
        let b = &self.cfg.beta_prior;
        b[1][a.min(2)] / b[0][a.min(2)]
    }

    pub(super) fn coeffs(&self, p: &Par) -> Coeffs {
        let n = self.n_is();
        let mut lin = SMatrix::<f64, 6, NS>::zeros();
        let bc = self.srp_dc(p);
        let beta1 = |a: usize| p[P_BETA + a];
        for i in 0..n {
            let i = i.min(1); // i < n ≤ 2, lost by the optimiser
            for j in 0..3 {
                let row = 3 * i + j;
                let inv_k = 1.0 / self.k_of(p, i, j);
                // Every `(3 x + a).min(5)` below is 3 x + a (x < 2, a < 3): the clamp keeps
                // an index check the optimiser cannot drop out of the library.
                let r = |a: usize| p[P_R + (3 * i + a).min(5)];
                let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
                lin[(row, S_SUM + row)] = 1.0;
                // ω̇ × r with ω̇ the IS average.
                for l in 0..n {
                    let bl = |a: usize| p[P_BETA + (3 * l + a).min(5)];
                    lin[(row, S_DV + (3 * l + j1).min(5))] -= inv_k * self.w(l) * bl(j1) * r(j2);
                    lin[(row, S_DV + (3 * l + j2).min(5))] += inv_k * self.w(l) * bl(j2) * r(j1);
                }
                // ω × (ω × r) = Σ_{a≠j} (ω_j ω_a r_a − r_j ω_a²), ω = β1 Ψ1.
                for a in [j1, j2] {
                    let a = a.min(2); // lost through the array's iterator: no check linked
                    lin[(row, S_PP + prod(j, a))] -= inv_k * beta1(j) * beta1(a) * r(a);
                    lin[(row, S_PP + prod(a, a))] += inv_k * r(j) * beta1(a) * beta1(a);
                }
                // SRP turning with the attitude: a_srp = R̂ᵀ a − (β1 Φ1 − Φ̂) × a to first
                // order in β1 − β̂1, i.e. a − (β1 Φ1) × a + W a. The SRP a(t) as IS1
                // measures it: a level a0 (`srp_level`, IS1's volts times the parameter
                // k) turned with the parameter β1, and its change since, a(t) − a0
                // (the fluctuation, ~10⁻¹² m/s²), turned with the running β̂1 (`S_TF`):
                // the running β̂'s error then multiplies only the change (the turn, up to
                // 5×10⁻¹⁴ m/s² across the sun, is no white noise).
                // Before the level is known, the fitted DC (no `S_TF` yet); the samples
                // taken then keep it after (`S_PHI0`: their Φ1 on the difference), so
                // the level's own error, the running solution's, reaches only the
                // samples whose measured change cancels it (which matters most without
                // thruster noise, where the level is fixed early).
                let a0 = |m: usize| match self.srp_level_set {
                    LEVEL_SET => self.k_of(p, 0, m) * self.srp_level[m.min(2)],
                    _ => bc[m.min(2)],
                };
                lin[(row, S_PHI + j1)] += inv_k * beta1(j1) * a0(j2);
                lin[(row, S_PHI + j2)] -= inv_k * beta1(j2) * a0(j1);
                lin[(row, S_TF + j)] = inv_k;
                let d0 = |m: usize| bc[m.min(2)] - a0(m);
                lin[(row, S_PHI0 + j1)] += inv_k * beta1(j1) * d0(j2);
                lin[(row, S_PHI0 + j2)] -= inv_k * beta1(j2) * d0(j1);
                for m in 0..3 {
                    lin[(row, S_W + 3 * j + m)] = -inv_k * bc[m];
                }
                lin[(row, S_ONE)] = -p[P_B + row];
                lin[(row, S_T)] = -p[P_AL + row];
            }
        }
        let star = core::array::from_fn(|a| {
            SVector::<f64, 5>::new(
                1.0,
                -p[P_TH0 + a],
                -p[P_THD + a],
                -self.w(0) * p[P_BETA + a],
                -self.w(1) * p[P_BETA + 3 + a],
            )
        });
        // On the signals (ΔV1 − ρ0 ΔV2, ΔV2) (`add_angular_pairs`): the residual
        // ΔV1 − (β2/β1) ΔV2 is the first plus (ρ0 − β2/β1) times the second.
        let ang = core::array::from_fn(|a| {
            SVector::<f64, 2>::new(1.0, self.prior_ratio(a) - p[P_BETA + 3 + a] / p[P_BETA + a])
        });
        Coeffs { lin, star, ang }
    }

    /// Mean squares per regime for the noise model: (samples, ΣV² per slot, ω̇² per IS/axis).
    pub(super) fn regime_stats(&self, p: &Par, reg: usize) -> (f64, [f64; 6], [[f64; 3]; 2]) {
        let m = &self.m_raw[reg];
        let cnt = m.get(S_ONE, S_ONE);
        let mut msq = [0.0; 6];
        let mut wsq = [[0.0; 3]; 2];
        if cnt < 1.0 {
            return (0.0, msq, wsq);
        }
        for i in 0..self.n_is() {
            for j in 0..3 {
                let s = 3 * i + j;
                let rf = self.sum_ref[i][j];
                msq[s] = rf * rf
                    + 2.0 * rf * m.get(S_SUM + s, S_ONE) / cnt
                    + m.get(S_SUM + s, S_SUM + s) / cnt;
                wsq[i][j] = p[P_BETA + 3 * i + j].powi(2) * m.get(S_DV + s, S_DV + s) / cnt;
            }
        }
        (cnt, msq, wsq)
    }
}
