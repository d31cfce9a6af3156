//! The paper's route (§2.1–2.2), kept so users can reproduce it and compare on the same
//! data: star-tracker attitude differentiated twice, 0.05 Hz low-pass on both sides,
//! static-state KF for β per IS, k from eq. 2, then a static-state KF for (r, α, b) per
//! IS with the SRP folded into R (2×10⁻¹² m/s², §3.2.2). This route misses the
//! requirement (docs/method.md, "The paper's route"); it is not the default.

use super::config::EstimatorConfig;
use super::kalman::StaticKf;
// Unused where std is linked anywhere in the build (the std binaries, unit tests):
// std's inherent f64 methods then win for these exact operations, with the same bits.
#[allow(unused_imports)]
use crate::math::{self, Real};
use crate::model::attitude::coupling_matrix;
use crate::msg::{EstimateMsg, Header, SensorSample};
use nalgebra::{Quaternion, SMatrix, SVector, UnitQuaternion, Vector3};

use crate::tuning;

/// The β regression starts once both low-passes have settled: their start-up
/// transients, driven by the star noise, would otherwise bias the axis rocked first.
const SETTLE_S: f64 = tuning::PAPER_SETTLE_PERIODS / tuning::PAPER_LOWPASS_HZ;

/// Second-order Butterworth low-pass (bilinear transform), direct form II transposed.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub struct Biquad {
    b: [f64; 3],
    a: [f64; 2],
    z: [f64; 2],
}

impl Biquad {
    pub fn lowpass(fc: f64, fs: f64) -> Self {
        let k = math::tan(core::f64::consts::PI * fc / fs);
        let q = core::f64::consts::FRAC_1_SQRT_2;
        let norm = 1.0 / (1.0 + k / q + k * k);
        let b0 = k * k * norm;
        Biquad {
            b: [b0, 2.0 * b0, b0],
            a: [2.0 * (k * k - 1.0) * norm, (1.0 - k / q + k * k) * norm],
            z: [0.0; 2],
        }
    }

    pub fn step(&mut self, x: f64) -> f64 {
        let y = self.b[0] * x + self.z[0];
        self.z[0] = self.b[1] * x - self.a[0] * y + self.z[1];
        self.z[1] = self.b[2] * x - self.a[1] * y;
        y
    }
}

/// Paper-route streaming estimator.
#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub struct PaperEstimator {
    cfg: EstimatorConfig,
    q_ref: Option<UnitQuaternion<f64>>,
    theta_hist: [Option<Vector3<f64>>; 2],
    dv_prev: [[f64; 3]; 2],
    lp_star: [Biquad; 3],
    lp_dv: [[Biquad; 3]; 2],
    beta_kf: [[StaticKf<1>; 3]; 2],
    com_kf: [StaticKf<9>; 2],
    r_beta: f64,
    psi: [[f64; 3]; 2],
    t0: Option<f64>,
    n_used: u64,
    n_rejected: u64,
    seq: u64,
    last_tick: u64,
}

impl PaperEstimator {
    pub fn new(cfg: EstimatorConfig) -> Self {
        let fs = cfg.fs;
        let lp = Biquad::lowpass(tuning::PAPER_LOWPASS_HZ, fs);
        // Variance of the low-passed double-differentiated star noise (impulse response).
        let mut f = lp;
        let dt2 = fs * fs;
        let mut var = 0.0;
        for n in 0..20_000 {
            let x = match n {
                0 | 2 => dt2,
                1 => -2.0 * dt2,
                _ => 0.0,
            };
            let y = f.step(x);
            var += y * y;
        }
        let r_beta = var * cfg.sigma_star_rad.powi(2);
        let beta_kf = core::array::from_fn(|i| {
            core::array::from_fn(|a| {
                let b = cfg.beta_prior[i][a];
                StaticKf::new(
                    SVector::<f64, 1>::new(b),
                    SMatrix::<f64, 1, 1>::new((tuning::PAPER_PRIOR_BETA_REL * b).powi(2)),
                )
            })
        });
        let com_kf = core::array::from_fn(|i| {
            let mut x = SVector::<f64, 9>::zeros();
            let mut p = SMatrix::<f64, 9, 9>::zeros();
            for a in 0..3 {
                x[a] = cfg.com_prior_m[i][a];
                p[(a, a)] = tuning::PAPER_PRIOR_COM_M.powi(2);
                p[(3 + a, 3 + a)] = tuning::PAPER_PRIOR_DRIFT.powi(2);
                p[(6 + a, 6 + a)] = tuning::PAPER_PRIOR_BIAS.powi(2);
            }
            StaticKf::new(x, p)
        });
        PaperEstimator {
            cfg,
            q_ref: None,
            theta_hist: [None; 2],
            dv_prev: [[0.0; 3]; 2],
            lp_star: [lp; 3],
            lp_dv: [[lp; 3]; 2],
            beta_kf,
            com_kf,
            r_beta,
            psi: [[0.0; 3]; 2],
            t0: None,
            n_used: 0,
            n_rejected: 0,
            seq: 0,
            last_tick: 0,
        }
    }

    fn beta(&self, i: usize) -> [f64; 3] {
        core::array::from_fn(|a| self.beta_kf[i][a].x[0])
    }

    fn k(&self, i: usize) -> [f64; 3] {
        super::config::k_from_beta(&self.cfg.geometry_m[i], &self.beta(i))
    }

    /// The tick after the newest one taken (0 before any).
    pub fn next_tick(&self) -> u64 {
        if self.n_used + self.n_rejected == 0 {
            0
        } else {
            self.last_tick.saturating_add(1)
        }
    }

    pub fn step(&mut self, s: &SensorSample) -> EstimateMsg {
        let tick = s.header.tick;
        if tick < self.next_tick() {
            // Duplicates and late ticks are not the paper's route's business: skip them.
            return self.message(self.last_tick);
        }
        self.last_tick = tick;
        let dt = 1.0 / self.cfg.fs;
        let t = (tick as f64 + 1.0) * dt;
        let n = self.cfg.n_is.min(2) as usize;
        let ok = (0..n).all(|i| s.is[i].usable());
        let star_ok = s.star.usable();
        if !ok || !star_ok {
            self.n_rejected += 1;
            self.theta_hist = [None; 2];
            return self.message(tick);
        }
        self.n_used += 1;
        let q = UnitQuaternion::from_quaternion(Quaternion::new(
            s.star.q_bn[0],
            s.star.q_bn[1],
            s.star.q_bn[2],
            s.star.q_bn[3],
        ));
        let q_ref = *self.q_ref.get_or_insert(q);
        let theta = crate::model::attitude::rotation_vector(&(q_ref.inverse() * q));
        let t0 = *self.t0.get_or_insert(t);
        // Star ω̇ centred on the previous sample, low-passed once for both IS.
        let y_star: Option<[f64; 3]> = match self.theta_hist {
            [Some(t1), Some(t2)] => {
                let wdot_st = (theta - 2.0 * t1 + t2) / (dt * dt);
                Some(core::array::from_fn(|a| self.lp_star[a].step(wdot_st[a])))
            }
            _ => None,
        };
        for i in 0..n {
            let dv = s.is[i].angular_volts();
            let sum = s.is[i].linear_volts();
            // ↔ the mean of the two intervals around that sample, low-passed the same way.
            if let Some(y) = y_star {
                for a in 0..3 {
                    let x = self.lp_dv[i][a].step(0.5 * (dv[a] + self.dv_prev[i][a]));
                    if t - t0 >= SETTLE_S {
                        self.beta_kf[i][a].update(&SVector::<f64, 1>::new(x), y[a], self.r_beta);
                    }
                }
            }
            self.dv_prev[i] = dv;
            // CoM KF with the current scale factors.
            let beta = self.beta(i);
            let k = self.k(i);
            let wdot = Vector3::from_fn(|a, _| beta[a] * dv[a]);
            let psi_old = self.psi[i];
            for a in 0..3 {
                self.psi[i][a] += dt * dv[a];
            }
            let w = Vector3::from_fn(|a, _| beta[a] * 0.5 * (psi_old[a] + self.psi[i][a]));
            let am = coupling_matrix(&w, &wdot);
            for j in 0..3 {
                let mut h = SVector::<f64, 9>::zeros();
                for a in 0..3 {
                    h[a] = am[(j, a)];
                }
                h[3 + j] = t - t0;
                h[6 + j] = 1.0;
                self.com_kf[i].update(&h, k[j] * sum[j], tuning::PAPER_SRP_SIGMA.powi(2));
            }
        }
        self.theta_hist = [Some(theta), self.theta_hist[0]];
        self.message(tick)
    }

    pub fn finish(&mut self) -> EstimateMsg {
        self.message(self.last_tick)
    }

    fn message(&mut self, tick: u64) -> EstimateMsg {
        let mut m = EstimateMsg {
            header: Header::at(self.seq, tick, self.cfg.fs),
            ..Default::default()
        };
        self.seq += 1;
        for i in 0..self.cfg.n_is.min(2) as usize {
            for a in 0..3 {
                m.beta[i][a] = self.beta_kf[i][a].x[0];
                m.beta_sigma[i][a] = self.beta_kf[i][a].sigma(0);
                m.r_b[i][a] = self.com_kf[i].x[a];
                m.r_sigma[i][a] = self.com_kf[i].sigma(a);
            }
            let g = self.cfg.geometry_m[i];
            m.k[i] = self.k(i);
            let bs = m.beta_sigma[i];
            m.k_sigma[i] = super::config::k_from_beta(&g, &bs);
        }
        m.solved_tick = tick;
        m.n_used = self.n_used;
        m.n_rejected = self.n_rejected;
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paper's values (§2.1, §3.2.2): a 0.05 Hz corner, settled after 100 s; priors of
    /// 5 % of β, 5 mm of r, 10⁻¹⁰ m/s³ of drift and 10⁻⁶ m/s² of bias; the SRP as
    /// 2×10⁻¹² m/s² of measurement noise.
    #[test]
    fn the_paper_routes_values_are_the_papers() {
        let cfg = super::super::joint::test_config();
        let e = PaperEstimator::new(cfg);
        let lp = Biquad::lowpass(0.05, cfg.fs);
        assert_eq!((e.lp_star[0].b, e.lp_star[0].a), (lp.b, lp.a));
        assert_eq!(SETTLE_S, 100.0);
        for i in 0..2 {
            for a in 0..3 {
                let b = cfg.beta_prior[i][a];
                assert!((e.beta_kf[i][a].sigma(0) / (0.05 * b).abs() - 1.0).abs() < 1e-15);
                assert!((e.com_kf[i].sigma(a) / 5e-3 - 1.0).abs() < 1e-15);
                assert!((e.com_kf[i].sigma(3 + a) / 1e-10 - 1.0).abs() < 1e-15);
                assert!((e.com_kf[i].sigma(6 + a) / 1e-6 - 1.0).abs() < 1e-15);
            }
        }
        assert_eq!(tuning::PAPER_SRP_SIGMA, 2e-12);
    }
}
