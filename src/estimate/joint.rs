//! Joint streaming estimator of β1, β2, r1, r2 (and nuisances) that reaches the
//! Cramér–Rao bound (SPEC §3).
//!
//! Every measurement residual is a linear combination of *data signals* (voltages,
//! their single and double integrals, star-tracker angles, 1, t) with coefficients that
//! are smooth functions of the parameters. So the weighted least-squares cost is
//! `Σ_g c_g(p)ᵀ M_g c_g(p)`, where the Gram matrices `M_g` of the (whitened) signals are
//! fixed-size sufficient statistics accumulated sample by sample. The coloured,
//! common-mode SRP noise lies along one direction of the linear channels; that
//! component is whitened with the innovations filter of its state-space model (the
//! same causal filter applied to every signal, i.e. to measurement and regressors
//! alike), the orthogonal components are white. Solving is Gauss–Newton on 30
//! parameters from those statistics, warm-started, every `solve_every` samples; the
//! covariance is the inverse Gauss–Newton Hessian, i.e. the Fisher information.
//!
//! Groups of residuals, per sample:
//! * star tracker, per axis: θ_st − κ − θ0 − θ̇0 t − ½(β1 Φ1 + β2 Φ2)   (angle domain)
//! * angular consistency, per axis: β1 ΔV1 − β2 ΔV2   (both IS see the same ω̇)
//! * linear, per IS and axis (eq. 15, in volts): ΣV − [A(ω, ω̇) r + (Rᵀ − I) a_srp] / k − b' − α' t
//!   with ω̇ = ½(β1 ΔV1 + β2 ΔV2), ω = β1 Ψ1, k = G β (eq. 2), and the attitude
//!   turning the SRP θ = β1 Φ1 + κ (κ: the rotation vector's non-commutative part).

use super::config::EstimatorConfig;
use crate::model::noise::{PowerLawBank, MAX_POLES};
use crate::msg::{EstimateMsg, Header, SensorSample};
use nalgebra::{Matrix3, Quaternion, SMatrix, SVector, UnitQuaternion, Vector3};

/// Signals of the linear group.
pub const NS: usize = 32;
/// Parameters.
pub const NP: usize = 30;
/// Noise regimes of the linear channels (by the dominant rotation axis).
const N_REG: usize = 3;

const S_SUM: usize = 0; // + 3 i + j : ΣV_ij − reference [V]
const S_DV: usize = 6; // + 3 l + a : ΔV_la [V]
const S_PHI: usize = 12; // + a : Φ1_a interval mean [V s²]
const S_PP: usize = 15; // + prod(a, b) : Ψ1_a Ψ1_b [V² s²]
const S_ONE: usize = 21;
const S_T: usize = 22;
const S_QQ: usize = 23; // + prod(a, b) : Φ1_a Φ1_b [V² s⁴], second-order SRP rotation
const S_KAP: usize = 29; // + a : κ_a [rad], non-commutative part of the rotation vector

pub const P_BETA: usize = 0; // + 3 i + a
pub const P_R: usize = 6; // + 3 i + a
const P_TH0: usize = 12;
const P_THD: usize = 15;
const P_B: usize = 18; // + 3 i + j
const P_AL: usize = 24; // + 3 i + j

type Sig = SVector<f64, NS>;
type Par = SVector<f64, NP>;
type Gram = SMatrix<f64, NS, NS>;

fn prod(a: usize, b: usize) -> usize {
    match (a.min(b), a.max(b)) {
        (0, 0) => 0,
        (1, 1) => 1,
        (2, 2) => 2,
        (0, 1) => 3,
        (0, 2) => 4,
        _ => 5,
    }
}

/// k index permutation of eq. 2: k_j = G_{PERM[j]} β_{PERM[j]}.
const PERM: [usize; 3] = [2, 0, 1];

/// Residual coefficients of every group for one parameter vector.
#[derive(Clone, Copy)]
struct Coeffs {
    lin: SMatrix<f64, 6, NS>,
    star: [SVector<f64, 5>; 3],
    ang: [SVector<f64, 2>; 3],
}

/// The estimator's whole state: fixed-size and `Copy`; a checkpoint is its serialised bytes.
#[derive(Clone, Copy, serde::Serialize, serde::Deserialize)]
pub struct JointEstimator {
    cfg: EstimatorConfig,
    started: bool,
    tick_start: u64,
    last_tick: u64,
    sum_ref: [[f64; 3]; 2],
    q_ref: Option<UnitQuaternion<f64>>,
    psi: [[f64; 3]; 2],
    phi: [[f64; 3]; 2],
    dv_last: [[f64; 3]; 2],
    q_model: UnitQuaternion<f64>,
    m_star: [SMatrix<f64, 5, 5>; 3],
    /// Innovations filter of the star-tracker residual, per axis: the IS angular noise
    /// double-integrated into Φ is an integrated random walk (angle, rate) [rad, rad/s];
    /// `st_x` is each signal's filter state, `st_p` the shared state covariance.
    st_x: [[[f64; 2]; 5]; 3],
    st_p: [[[f64; 2]; 2]; 3],
    m_ang: [SMatrix<f64, 2, 2>; 3],
    m_raw: [Gram; N_REG],
    m_filt: Gram,
    bank: PowerLawBank,
    wp: SMatrix<f64, MAX_POLES, MAX_POLES>,
    wx: [[f64; MAX_POLES]; NS],
    /// Gain of the SRP state onto the whitened common-mode channel.
    hn: f64,
    /// Row mapping the 6 linear residuals onto that channel: u0ᵀ L0⁻¹.
    t_u: SVector<f64, 6>,
    p: Par,
    p_prior: Par,
    p_sigma: Par,
    sigma: Par,
    solved_tick: u64,
    n_used: u64,
    n_rejected: u64,
    seq: u64,
}

/// Outcome of one IS sample.
struct IsData {
    valid: bool,
    dv: [f64; 3],
    sum: [f64; 3],
}

fn is_data(s: &crate::msg::IsSample) -> IsData {
    IsData {
        valid: s.usable(),
        dv: s.angular_volts(),
        sum: s.linear_volts(),
    }
}

fn skew(r: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -r.z, r.y, r.z, 0.0, -r.x, -r.y, r.x, 0.0)
}

/// Symmetric rank-one update of the upper triangle: m += w v vᵀ.
fn rank1_upper<const N: usize>(m: &mut SMatrix<f64, N, N>, v: &SVector<f64, N>, w: f64) {
    for j in 0..N {
        let vj = v[j] * w;
        if vj == 0.0 {
            continue;
        }
        for i in 0..=j {
            m[(i, j)] += v[i] * vj;
        }
    }
}

fn symmetric<const N: usize>(m: &SMatrix<f64, N, N>) -> SMatrix<f64, N, N> {
    SMatrix::from_fn(|i, j| if i <= j { m[(i, j)] } else { m[(j, i)] })
}

impl JointEstimator {
    pub fn new(cfg: EstimatorConfig) -> Self {
        let bank = PowerLawBank::new(cfg.srp_asd_at_3mhz, 3e-3, 2.0 / 3.0, cfg.fs);
        let mut p = Par::zeros();
        let mut ps = Par::zeros();
        for i in 0..2 {
            for a in 0..3 {
                p[P_BETA + 3 * i + a] = cfg.beta_prior[i][a];
                ps[P_BETA + 3 * i + a] = 0.05 * cfg.beta_prior[i][a];
                p[P_R + 3 * i + a] = cfg.com_prior_m[i][a];
                ps[P_R + 3 * i + a] = 0.05;
                ps[P_B + 3 * i + a] = 1.0;
                ps[P_AL + 3 * i + a] = 1e-3;
            }
        }
        for a in 0..3 {
            ps[P_TH0 + a] = 1e-2;
            ps[P_THD + a] = 1e-4;
        }
        let mut wp = SMatrix::zeros();
        for k in 0..bank.n {
            wp[(k, k)] = bank.var[k];
        }
        JointEstimator {
            cfg,
            started: false,
            tick_start: 0,
            last_tick: 0,
            sum_ref: [[0.0; 3]; 2],
            q_ref: None,
            psi: [[0.0; 3]; 2],
            phi: [[0.0; 3]; 2],
            dv_last: [[0.0; 3]; 2],
            q_model: UnitQuaternion::identity(),
            m_star: [SMatrix::zeros(); 3],
            st_x: [[[0.0; 2]; 5]; 3],
            st_p: [[[0.0; 2]; 2]; 3],
            m_ang: [SMatrix::zeros(); 3],
            m_raw: [Gram::zeros(); N_REG],
            m_filt: Gram::zeros(),
            bank,
            wp,
            wx: [[0.0; MAX_POLES]; NS],
            hn: 0.0,
            t_u: SVector::zeros(),
            p,
            p_prior: p,
            p_sigma: ps,
            sigma: ps,
            solved_tick: 0,
            n_used: 0,
            n_rejected: 0,
            seq: 0,
        }
    }

    pub fn config(&self) -> &EstimatorConfig {
        &self.cfg
    }

    fn n_is(&self) -> usize {
        self.cfg.n_is
    }

    /// Weight of IS l in the two-IS average angular acceleration.
    fn w(&self, l: usize) -> f64 {
        if l < self.n_is() {
            1.0 / self.n_is() as f64
        } else {
            0.0
        }
    }

    fn k_of(&self, p: &Par, i: usize, j: usize) -> f64 {
        self.cfg.geometry_m[i][PERM[j]] * p[P_BETA + 3 * i + PERM[j]]
    }

    /// White-noise covariance of the six linear residuals [V²], given per-slot mean
    /// squared voltage and per-IS, per-axis mean squared angular acceleration.
    fn white_cov(
        &self,
        p: &Par,
        mean_sq_sum: &[f64; 6],
        mean_sq_wdot: &[[f64; 3]; 2],
    ) -> SMatrix<f64, 6, 6> {
        let c = &self.cfg;
        let mut r = SMatrix::<f64, 6, 6>::identity();
        let n = self.n_is();
        let mut v = [0.0; 3];
        for (a, va) in v.iter_mut().enumerate() {
            for (l, msq) in mean_sq_wdot.iter().enumerate().take(n) {
                *va +=
                    self.w(l).powi(2) * (c.sigma_angular.powi(2) + c.sigma_ripple.powi(2) * msq[a]);
            }
        }
        for s in 0..3 * n {
            for s2 in 0..3 * n {
                let (i, j, i2, j2) = (s / 3, s % 3, s2 / 3, s2 % 3);
                let (k, k2) = (self.k_of(p, i, j), self.k_of(p, i2, j2));
                let xi = -skew(&Vector3::from_fn(|a, _| p[P_R + 3 * i + a]));
                let xi2 = -skew(&Vector3::from_fn(|a, _| p[P_R + 3 * i2 + a]));
                let mut val = (0..3)
                    .map(|a| xi[(j, a)] * xi2[(j2, a)] * v[a])
                    .sum::<f64>()
                    / (k * k2);
                if j == j2 {
                    val += c.sigma_force.powi(2) / (k * k2);
                }
                if s == s2 {
                    val += (c.sigma_linear / k).powi(2) + c.sigma_ripple.powi(2) * mean_sq_sum[s];
                }
                r[(s, s2)] = val;
            }
        }
        r
    }

    /// Whitening rows: `L⁻¹` of the white covariance, and the unit direction of the
    /// coloured SRP in the whitened space, with its gain |L⁻¹ h|.
    fn whitening(
        r: &SMatrix<f64, 6, 6>,
        h: &SVector<f64, 6>,
    ) -> Option<(SMatrix<f64, 6, 6>, SVector<f64, 6>, f64)> {
        let l = r.cholesky()?.l();
        let linv = l.try_inverse()?;
        let hp = linv * h;
        let hn = hp.norm();
        Some((linv, hp / hn, hn))
    }

    /// Rows spanning the complement of `u` (Householder), times `linv`: 5 × 6.
    fn complement_rows(linv: &SMatrix<f64, 6, 6>, u: &SVector<f64, 6>) -> SMatrix<f64, 5, 6> {
        let mut e1 = SVector::<f64, 6>::zeros();
        e1[0] = if u[0] >= 0.0 { 1.0 } else { -1.0 };
        let v = u - e1;
        let hh = if v.norm() < 1e-12 {
            SMatrix::<f64, 6, 6>::identity()
        } else {
            SMatrix::<f64, 6, 6>::identity() - v * v.transpose() * (2.0 / v.norm_squared())
        };
        let rows: SMatrix<f64, 5, 6> = hh.fixed_rows::<5>(1).into_owned();
        rows * linv
    }

    /// First usable sample: references, the coloured-noise direction and whitening.
    fn start(&mut self, tick: u64, data: &[IsData; 2]) {
        let n = self.n_is();
        self.tick_start = tick;
        for i in 0..n {
            self.sum_ref[i] = data[i].sum;
        }
        // SRP direction at the priors: the IS average in m/s² cancels the differential
        // A r of the first tick, and its volts per IS use the same prior k as the noise
        // model below, so it lies in that model's common-mode subspace.
        let h = self.srp_direction(&self.p);
        let mut msq = [0.0; 6];
        for s in 0..3 * n {
            msq[s] = self.sum_ref[s / 3][s % 3].powi(2);
        }
        let r0 = self.white_cov(&self.p, &msq, &[[0.0; 3]; 2]);
        if let Some((linv, u, hn)) = Self::whitening(&r0, &h) {
            self.t_u = linv.transpose() * u;
            self.hn = hn;
        }
        self.started = true;
    }

    /// Process one sensor sample; returns the estimate message for this tick (the last
    /// solution, refreshed every `solve_every` samples).
    pub fn step(&mut self, s: &SensorSample) -> EstimateMsg {
        let tick = s.header.tick;
        self.last_tick = tick;
        let data = [is_data(&s.is[0]), is_data(&s.is[1])];
        let n = self.n_is();
        let all_valid = (0..n).all(|i| data[i].valid);
        if !self.started {
            if all_valid {
                self.start(tick, &data);
            } else {
                self.n_rejected += 1;
                return self.message(tick);
            }
        }
        let dt = 1.0 / self.cfg.fs;
        // Angular voltages for the integrators; an invalid IS borrows the other's.
        let mut dv = [[0.0; 3]; 2];
        for i in 0..n {
            dv[i] = if data[i].valid {
                data[i].dv
            } else if let Some(o) = (0..n).find(|&o| data[o].valid) {
                std::array::from_fn(|a| {
                    data[o].dv[a] * self.cfg.beta_prior[o][a] / self.cfg.beta_prior[i][a]
                })
            } else {
                self.dv_last[i]
            };
        }
        self.dv_last = dv;
        let mut psi_mid = [[0.0; 3]; 2];
        let mut phi_mid = [[0.0; 3]; 2];
        for i in 0..n {
            for a in 0..3 {
                let psi_new = self.psi[i][a] + dt * dv[i][a];
                psi_mid[i][a] = 0.5 * (self.psi[i][a] + psi_new);
                let phi_new = self.phi[i][a] + dt * psi_mid[i][a];
                phi_mid[i][a] = 0.5 * (self.phi[i][a] + phi_new);
                self.psi[i][a] = psi_new;
                self.phi[i][a] = phi_new;
            }
        }
        let bp = self.cfg.beta_prior[0];
        let w_model = Vector3::from_fn(|a, _| bp[a] * psi_mid[0][a]);
        self.q_model *= UnitQuaternion::from_scaled_axis(w_model * dt);
        let t = (tick + 1) as f64 * dt;

        let kappa = self.kappa();
        if all_valid {
            self.n_used += 1;
            self.update_linear(&data, &dv, &psi_mid, &phi_mid, &kappa, t);
            if n == 2 {
                // Residual ΔV1 − (β2/β1) ΔV2 [V]: its noise (n1 − n2)/β1 weighted with the
                // prior β1, so the group constrains the ratio only and cannot pull the
                // common scale (the density's Jacobian would otherwise be missing).
                for a in 0..3 {
                    let wgt = (self.cfg.beta_prior[0][a] / self.cfg.sigma_angular).powi(2) / 2.0;
                    let v = SVector::<f64, 2>::new(dv[0][a], dv[1][a]);
                    rank1_upper(&mut self.m_ang[a], &v, wgt);
                }
            }
        } else {
            self.n_rejected += 1;
            self.whitening_time_update();
        }
        self.star_time_update(&data, &dv);
        self.update_star(s, &kappa, t);

        if (tick + 1 - self.tick_start) % self.cfg.solve_every == 0 {
            self.solve(1, true);
            self.solved_tick = tick;
        }
        self.message(tick)
    }

    fn update_linear(
        &mut self,
        data: &[IsData; 2],
        dv: &[[f64; 3]; 2],
        psi_mid: &[[f64; 3]; 2],
        phi_mid: &[[f64; 3]; 2],
        kappa: &Vector3<f64>,
        t: f64,
    ) {
        let n = self.n_is();
        let mut s = Sig::zeros();
        for i in 0..n {
            for j in 0..3 {
                s[S_SUM + 3 * i + j] = data[i].sum[j] - self.sum_ref[i][j];
                s[S_DV + 3 * i + j] = dv[i][j];
            }
        }
        for a in 0..3 {
            s[S_PHI + a] = phi_mid[0][a];
            s[S_KAP + a] = kappa[a];
            for b in a..3 {
                s[S_PP + prod(a, b)] = psi_mid[0][a] * psi_mid[0][b];
                s[S_QQ + prod(a, b)] = phi_mid[0][a] * phi_mid[0][b];
            }
        }
        s[S_ONE] = 1.0;
        s[S_T] = t;
        let bp = self.cfg.beta_prior[0];
        let mut reg = 0;
        for a in 1..3 {
            if (bp[a] * dv[0][a]).abs() > (bp[reg] * dv[0][reg]).abs() {
                reg = a;
            }
        }
        rank1_upper(&mut self.m_raw[reg], &s, 1.0);

        // Innovations filter of the common-mode SRP channel, applied to every signal.
        let nb = self.bank.n;
        let hn = self.hn;
        let mut pg = [0.0; MAX_POLES];
        let mut ptot = 0.0;
        for (i, pgi) in pg.iter_mut().enumerate().take(nb) {
            *pgi = (0..nb).map(|j| self.wp[(i, j)]).sum();
            ptot += *pgi;
        }
        let sv = hn * hn * ptot + 1.0;
        let inv_sqrt = 1.0 / sv.sqrt();
        let mut sf = Sig::zeros();
        for (m, x) in self.wx.iter_mut().enumerate() {
            let pred: f64 = x[..nb].iter().sum::<f64>() * hn;
            let innov = s[m] - pred;
            sf[m] = innov * inv_sqrt;
            let g = hn * innov / sv;
            for k in 0..nb {
                x[k] = self.bank.a[k] * (x[k] + pg[k] * g);
            }
        }
        rank1_upper(&mut self.m_filt, &sf, 1.0);
        let c = hn * hn / sv;
        for i in 0..nb {
            for j in 0..nb {
                let v = (self.wp[(i, j)] - c * pg[i] * pg[j]) * self.bank.a[i] * self.bank.a[j];
                self.wp[(i, j)] = v;
            }
            self.wp[(i, i)] += self.bank.s[i] * self.bank.s[i];
        }
    }

    /// A sample without linear data: the SRP model still evolves.
    fn whitening_time_update(&mut self) {
        let nb = self.bank.n;
        for x in self.wx.iter_mut() {
            for k in 0..nb {
                x[k] *= self.bank.a[k];
            }
        }
        for i in 0..nb {
            for j in 0..nb {
                self.wp[(i, j)] *= self.bank.a[i] * self.bank.a[j];
            }
            self.wp[(i, i)] += self.bank.s[i] * self.bank.s[i];
        }
    }

    /// Advance the star-tracker whitening filter by one sample: the angle error of the
    /// IS-propagated attitude ½(β1 Φ1 + β2 Φ2) grows as the double integral of the IS
    /// angular readout noise and drive ripple (per-sample variance from this sample's
    /// voltages, integrated exactly as `step` integrates Φ).
    fn star_time_update(&mut self, data: &[IsData; 2], dv: &[[f64; 3]; 2]) {
        let c = &self.cfg;
        let dt = 1.0 / c.fs;
        let n_valid = (0..self.n_is()).filter(|&i| data[i].valid).count().max(1);
        let (g0, g1) = (0.5 * dt * dt, dt);
        for a in 0..3 {
            let mut q = 0.0;
            for (l, dvl) in dv.iter().enumerate().take(self.n_is()) {
                let wd = c.beta_prior[l][a] * dvl[a];
                q += self.w(l).powi(2) * (c.sigma_angular.powi(2) + (c.sigma_ripple * wd).powi(2));
            }
            // Borrowed voltages carry the other IS's noise in full.
            q *= self.n_is() as f64 / n_valid as f64;
            for x in self.st_x[a].iter_mut() {
                x[0] += dt * x[1];
            }
            let p = &mut self.st_p[a];
            let p00 = p[0][0] + 2.0 * dt * p[0][1] + dt * dt * p[1][1] + q * g0 * g0;
            let p01 = p[0][1] + dt * p[1][1] + q * g0 * g1;
            let p11 = p[1][1] + q * g1 * g1;
            *p = [[p00, p01], [p01, p11]];
        }
    }

    /// Second-order kinematics [rad]: the IS-propagated attitude's rotation vector minus
    /// the plain double integral β Φ (prior β; κ is itself second order, so the prior's
    /// error enters only at third order).
    fn kappa(&self) -> Vector3<f64> {
        let bp = self.cfg.beta_prior[0];
        let lin = Vector3::from_fn(|a, _| bp[a] * self.phi[0][a]);
        crate::model::attitude::rotation_vector(&self.q_model) - lin
    }

    fn update_star(&mut self, s: &SensorSample, kappa: &Vector3<f64>, t: f64) {
        if !s.star.usable() {
            return;
        }
        let q = Quaternion::new(
            s.star.q_bn[0],
            s.star.q_bn[1],
            s.star.q_bn[2],
            s.star.q_bn[3],
        );
        if q.norm() < 0.5 {
            return;
        }
        let q = UnitQuaternion::from_quaternion(q);
        let q_ref = *self.q_ref.get_or_insert(q);
        let theta = crate::model::attitude::rotation_vector(&(q_ref.inverse() * q));
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

    /// DC SRP acceleration in the body frame [m/s²]: the fitted DC of the linear
    /// channels (reference sample plus bias), averaged over the IS.
    fn srp_dc(&self, p: &Par) -> [f64; 3] {
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
    fn srp_direction(&self, p: &Par) -> SVector<f64, 6> {
        let bc = self.srp_dc(p);
        let g0 = Vector3::from(bc).norm().max(1e-30);
        let mut h = SVector::<f64, 6>::zeros();
        for s in 0..3 * self.n_is() {
            h[s] = bc[s % 3] / self.k_of(p, s / 3, s % 3) / g0;
        }
        h
    }

    fn coeffs(&self, p: &Par) -> Coeffs {
        let n = self.n_is();
        let mut lin = SMatrix::<f64, 6, NS>::zeros();
        let bc = self.srp_dc(p);
        let beta1 = |a: usize| p[P_BETA + a];
        for i in 0..n {
            for j in 0..3 {
                let row = 3 * i + j;
                let inv_k = 1.0 / self.k_of(p, i, j);
                let r = |a: usize| p[P_R + 3 * i + a];
                let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
                lin[(row, S_SUM + row)] = 1.0;
                // ω̇ × r with ω̇ the IS average.
                for l in 0..n {
                    let bl = |a: usize| p[P_BETA + 3 * l + a];
                    lin[(row, S_DV + 3 * l + j1)] -= inv_k * self.w(l) * bl(j1) * r(j2);
                    lin[(row, S_DV + 3 * l + j2)] += inv_k * self.w(l) * bl(j2) * r(j1);
                }
                // ω × (ω × r) = Σ_{a≠j} (ω_j ω_a r_a − r_j ω_a²), ω = β1 Ψ1.
                for a in [j1, j2] {
                    lin[(row, S_PP + prod(j, a))] -= inv_k * beta1(j) * beta1(a) * r(a);
                    lin[(row, S_PP + prod(a, a))] += inv_k * r(j) * beta1(a) * beta1(a);
                }
                // SRP direction turning with the attitude: a_srp ≈ b − θ × b + ½ θ × (θ × b).
                lin[(row, S_PHI + j1)] += inv_k * beta1(j1) * bc[j2];
                lin[(row, S_PHI + j2)] -= inv_k * beta1(j2) * bc[j1];
                lin[(row, S_KAP + j1)] += inv_k * bc[j2];
                lin[(row, S_KAP + j2)] -= inv_k * bc[j1];
                for a in [j1, j2] {
                    lin[(row, S_QQ + prod(j, a))] -= 0.5 * inv_k * beta1(j) * beta1(a) * bc[a];
                    lin[(row, S_QQ + prod(a, a))] += 0.5 * inv_k * bc[j] * beta1(a) * beta1(a);
                }
                lin[(row, S_ONE)] = -p[P_B + row];
                lin[(row, S_T)] = -p[P_AL + row];
            }
        }
        let star = std::array::from_fn(|a| {
            SVector::<f64, 5>::new(
                1.0,
                -p[P_TH0 + a],
                -p[P_THD + a],
                -self.w(0) * p[P_BETA + a],
                -self.w(1) * p[P_BETA + 3 + a],
            )
        });
        let ang = std::array::from_fn(|a| {
            SVector::<f64, 2>::new(1.0, -p[P_BETA + 3 + a] / p[P_BETA + a])
        });
        Coeffs { lin, star, ang }
    }

    /// Mean squares per regime for the noise model: (samples, ΣV² per slot, ω̇² per IS/axis).
    fn regime_stats(&self, p: &Par, reg: usize) -> (f64, [f64; 6], [[f64; 3]; 2]) {
        let m = &self.m_raw[reg];
        let cnt = m[(S_ONE, S_ONE)];
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
                    + 2.0 * rf * m[(S_SUM + s, S_ONE)] / cnt
                    + m[(S_SUM + s, S_SUM + s)] / cnt;
                wsq[i][j] = p[P_BETA + 3 * i + j].powi(2) * m[(S_DV + s, S_DV + s)] / cnt;
            }
        }
        (cnt, msq, wsq)
    }

    /// Gauss–Newton normal equations (H, g) at `p`; with `priors`, the weak ground
    /// priors are included (they only matter before every axis has been excited).
    fn normal_equations(&self, p: &Par, priors: bool) -> (SMatrix<f64, NP, NP>, Par) {
        let c0 = self.coeffs(p);
        let mut dc = [Coeffs {
            lin: SMatrix::zeros(),
            star: [SVector::zeros(); 3],
            ang: [SVector::zeros(); 3],
        }; NP];
        for (k, d) in dc.iter_mut().enumerate() {
            let hk = 1e-6 * self.p_sigma[k];
            let mut pp = *p;
            pp[k] += hk;
            let cp = self.coeffs(&pp);
            pp[k] -= 2.0 * hk;
            let cm = self.coeffs(&pp);
            let f = 0.5 / hk;
            d.lin = (cp.lin - cm.lin) * f;
            for a in 0..3 {
                d.star[a] = (cp.star[a] - cm.star[a]) * f;
                d.ang[a] = (cp.ang[a] - cm.ang[a]) * f;
            }
        }
        let mut hm = SMatrix::<f64, NP, NP>::zeros();
        let mut g = Par::zeros();
        if priors {
            for k in 0..NP {
                let w = 1.0 / self.p_sigma[k].powi(2);
                hm[(k, k)] += w;
                g[k] += w * (p[k] - self.p_prior[k]);
            }
        } else {
            // Parameters of an absent IS are not part of the problem.
            for k in 0..NP {
                if !self.param_used(k) {
                    hm[(k, k)] += 1.0 / self.p_sigma[k].powi(2);
                }
            }
        }
        let mut add = |row: &SVector<f64, 6>, m: &Gram| {
            let c: Sig = c0.lin.transpose() * row;
            if c.iter().all(|v| *v == 0.0) {
                return;
            }
            let d = SMatrix::<f64, NS, NP>::from_fn(|s, k| {
                (0..6).map(|r| row[r] * dc[k].lin[(r, s)]).sum()
            });
            let md = m * d;
            hm += d.transpose() * md;
            g += md.transpose() * c;
        };
        let h = self.srp_direction(p);
        for reg in 0..N_REG {
            let (cnt, msq, wsq) = self.regime_stats(p, reg);
            if cnt < 1.0 {
                continue;
            }
            let r = self.white_cov(p, &msq, &wsq);
            let Some((linv, u, _)) = Self::whitening(&r, &h) else {
                continue;
            };
            let rows = Self::complement_rows(&linv, &u);
            let m = symmetric(&self.m_raw[reg]);
            for t in 0..5 {
                add(&rows.row(t).transpose(), &m);
            }
        }
        add(&self.t_u, &symmetric(&self.m_filt));
        for a in 0..3 {
            let m = symmetric(&self.m_star[a]);
            let d = SMatrix::<f64, 5, NP>::from_fn(|s, k| dc[k].star[a][s]);
            let md = m * d;
            hm += d.transpose() * md;
            g += md.transpose() * c0.star[a];
            let m = symmetric(&self.m_ang[a]);
            let d = SMatrix::<f64, 2, NP>::from_fn(|s, k| dc[k].ang[a][s]);
            let md = m * d;
            hm += d.transpose() * md;
            g += md.transpose() * c0.ang[a];
        }
        (hm, g)
    }

    fn param_used(&self, k: usize) -> bool {
        let second = (P_BETA + 3..P_BETA + 6).contains(&k)
            || (P_R + 3..P_R + 6).contains(&k)
            || (P_B + 3..P_B + 6).contains(&k)
            || (P_AL + 3..P_AL + 6).contains(&k);
        !(second && self.n_is() < 2)
    }

    /// Solve H δ = −g with Jacobi scaling; also returns diag(H⁻¹).
    fn newton_step(hm: &SMatrix<f64, NP, NP>, g: &Par) -> Option<(Par, Par)> {
        let sc = Par::from_fn(|k, _| 1.0 / hm[(k, k)].max(1e-300).sqrt());
        let hs = SMatrix::<f64, NP, NP>::from_fn(|i, j| hm[(i, j)] * sc[i] * sc[j]);
        let ch = hs.cholesky()?;
        let gs = g.component_mul(&sc);
        let delta = -ch.solve(&gs).component_mul(&sc);
        let inv = ch.inverse();
        let var = Par::from_fn(|k, _| inv[(k, k)] * sc[k] * sc[k]);
        Some((delta, var))
    }

    /// Gauss–Newton iterations from the current solution.
    pub fn solve(&mut self, iterations: usize, priors: bool) {
        for _ in 0..iterations {
            let (hm, g) = self.normal_equations(&self.p, priors);
            let Some((delta, var)) = Self::newton_step(&hm, &g) else {
                return;
            };
            self.p += delta;
            self.sigma = var.map(|v| v.max(0.0).sqrt());
            let converged = (0..NP).all(|k| delta[k].abs() < 1e-4 * self.sigma[k].max(1e-300));
            if converged {
                break;
            }
        }
    }

    /// Final solution: iterate to convergence, with the weak priors (as in the run).
    pub fn finish(&mut self) -> EstimateMsg {
        self.solve(20, true);
        self.solved_tick = self.last_tick;
        self.message(self.last_tick)
    }

    /// Fisher-information 1σ at `p` without priors (the Cramér–Rao bound when `p` is
    /// the truth and the statistics were accumulated from noise-free signals).
    pub fn fisher_sigma(&self, p: &Par) -> Option<Par> {
        let (hm, g) = self.normal_equations(p, false);
        Self::newton_step(&hm, &g).map(|(_, var)| var.map(|v| v.max(0.0).sqrt()))
    }

    /// Fit the nuisances (θ0, θ̇0, b', α') with β and r held at their values in `p`,
    /// without priors: the reference point of the Cramér–Rao bound.
    pub fn nuisance_fit(&self, mut p: Par) -> Par {
        for _ in 0..6 {
            let (mut hm, mut g) = self.normal_equations(&p, false);
            for k in P_BETA..P_TH0 {
                for j in 0..NP {
                    hm[(k, j)] = 0.0;
                    hm[(j, k)] = 0.0;
                }
                hm[(k, k)] = 1.0;
                g[k] = 0.0;
            }
            let Some((delta, _)) = Self::newton_step(&hm, &g) else {
                break;
            };
            p += delta;
        }
        p
    }

    /// Parameter vector with β, r set (nuisances at their reference values).
    pub fn params_with(&self, beta: &[[f64; 3]; 2], r: &[[f64; 3]; 2]) -> Par {
        let mut p = self.p_prior;
        for i in 0..2 {
            for a in 0..3 {
                p[P_BETA + 3 * i + a] = beta[i][a];
                p[P_R + 3 * i + a] = r[i][a];
            }
        }
        p
    }

    pub fn params(&self) -> &Par {
        &self.p
    }

    pub fn counts(&self) -> (u64, u64) {
        (self.n_used, self.n_rejected)
    }

    /// The estimate message from the current solution.
    pub fn message(&mut self, tick: u64) -> EstimateMsg {
        let mut m = EstimateMsg {
            header: Header::at(self.seq, tick, self.cfg.fs),
            ..Default::default()
        };
        self.seq += 1;
        Self::fill(&self.cfg, &self.p, &self.sigma, &mut m);
        m.solved_tick = self.solved_tick;
        m.n_used = self.n_used;
        m.n_rejected = self.n_rejected;
        m
    }

    /// β, k, r and their σ from a parameter vector and its 1σ.
    pub fn fill(cfg: &EstimatorConfig, p: &Par, sigma: &Par, m: &mut EstimateMsg) {
        for i in 0..cfg.n_is {
            for a in 0..3 {
                m.beta[i][a] = p[P_BETA + 3 * i + a];
                m.beta_sigma[i][a] = sigma[P_BETA + 3 * i + a];
                m.r_b[i][a] = p[P_R + 3 * i + a];
                m.r_sigma[i][a] = sigma[P_R + 3 * i + a];
            }
            for j in 0..3 {
                let g = cfg.geometry_m[i][PERM[j]];
                m.k[i][j] = g * m.beta[i][PERM[j]];
                m.k_sigma[i][j] = g * m.beta_sigma[i][PERM[j]];
            }
        }
    }
}
