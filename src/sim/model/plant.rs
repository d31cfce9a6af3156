//! The plant: spacecraft attitude, thrusters, SRP and the TM accelerations of eq. 15.

use super::attitude::RigidBody;
use super::noise::{white_sigma, Generate, PowerLawBank};
use super::thruster::Thrusters;
use crate::sim::msg::{Header, TruthState};
use crate::sim::rng::{gauss, stream, Rng, Stream};
use crate::sim::scenario::Scenario;
use nalgebra::{Matrix3, Vector3};
use taiji_core::tuning::{SRP_PSD_EXPONENT, SRP_REF_HZ};

/// Integration sub-steps per output sample (100 Hz internal for 10 Hz output).
pub const SUBSTEPS: usize = 10;

/// Noise switches; all on in a real run, off for the Cramér–Rao bound's noise-free signals.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlantNoise {
    pub torque: bool,
    pub thruster_nonideal: bool,
    pub srp: bool,
    pub force: bool,
}

impl PlantNoise {
    pub const ALL: PlantNoise = PlantNoise {
        torque: true,
        thruster_nonideal: true,
        srp: true,
        force: true,
    };
    pub const NONE: PlantNoise = PlantNoise {
        torque: false,
        thruster_nonideal: false,
        srp: false,
        force: false,
    };
}

#[derive(Debug, Clone)]
pub struct Plant {
    body: RigidBody,
    thrusters: Thrusters,
    srp_bank: PowerLawBank,
    rng_torque: Rng,
    rng_edges: Rng,
    rng_srp: Rng,
    rng_force: Rng,
    r_tm_b: [Vector3<f64>; 2],
    sun_n: Vector3<f64>,
    g0: f64,
    torque_sigma: f64,
    force_sigma: f64,
    noise: PlantNoise,
    fs: f64,
    seq: u64,
    /// Attitude hold (PD on the attitude relative to the start, body frame):
    /// proportional [N m/rad] and derivative [N m s/rad] gains per axis.
    hold_kp: Vector3<f64>,
    hold_kd: Vector3<f64>,
    q0: nalgebra::UnitQuaternion<f64>,
    /// The last step's TM and SRP accelerations without the SRP's fluctuation and the
    /// thrusters' force noise (`noise_free_twin`).
    twin_a: ([[f64; 3]; 2], [f64; 3]),
    /// With `[drift]`: the truths' history and the campaign's epoch [days]; the CoM
    /// offsets follow it, taken at each tick's middle.
    drift: Option<(crate::sim::drift::History, f64)>,
}

impl Plant {
    /// The last step's truth `truth` as a plant of the same motion without the SRP's
    /// fluctuation and the thrusters' force noise gives it, bit for bit: the
    /// Cramér–Rao bound's noise-free campaign (`crlb`), whose plant keeps the torque
    /// noise and the thrusters' jitter (the motion), beside the run's own, so the run
    /// simulates its motion once. Neither noise moves the spacecraft (they are
    /// accelerations of the TMs, drawn from streams of their own).
    pub fn noise_free_twin(&self, truth: &TruthState) -> TruthState {
        TruthState {
            a_tm_b: self.twin_a.0,
            a_srp_b: self.twin_a.1,
            ..*truth
        }
    }

    pub fn new(s: &Scenario, seed: u64, noise: PlantNoise) -> Self {
        let inertia = Matrix3::from_fn(|i, j| s.spacecraft.inertia_kg_m2[i][j]);
        let fs = s.sample_rate_hz;
        let h = 1.0 / (fs * SUBSTEPS as f64);
        let mut thr_params = s.thruster.clone();
        if !noise.thruster_nonideal {
            thr_params.edge_jitter_s = 0.0;
            thr_params.amplitude_jitter_rel = 0.0;
        }
        let mut srp_bank = PowerLawBank::new(s.srp.asd_at_3mhz, SRP_REF_HZ, SRP_PSD_EXPONENT, fs);
        let mut rng_srp = stream(seed, Stream::Srp);
        srp_bank.init_stationary(&mut rng_srp);
        let mut r_tm_b = [Vector3::zeros(); 2];
        for (i, is) in s.inertial_sensor.iter().enumerate() {
            r_tm_b[i] = Vector3::from(is.com_offset_m);
        }
        Plant {
            body: RigidBody::new(inertia),
            thrusters: Thrusters::new(&thr_params),
            srp_bank,
            rng_torque: stream(seed, Stream::ThrusterTorque),
            rng_edges: stream(seed, Stream::ThrusterEdges),
            rng_srp,
            rng_force: stream(seed, Stream::ThrusterForce),
            r_tm_b,
            sun_n: Vector3::from(s.sun_unit()),
            g0: s.srp.dc_m_s2,
            torque_sigma: if noise.torque {
                s.thruster.torque_noise_nm_rthz / (2.0 * h).sqrt()
            } else {
                0.0
            },
            force_sigma: if noise.force {
                white_sigma(s.thruster.force_noise_n_rthz / s.spacecraft.mass_kg, fs)
            } else {
                0.0
            },
            noise,
            fs,
            seq: 0,
            hold_kp: {
                let w = 2.0 * std::f64::consts::PI * s.spacecraft.attitude_hold_hz;
                Vector3::from_fn(|a, _| inertia[(a, a)] * w * w)
            },
            hold_kd: {
                let w = 2.0 * std::f64::consts::PI * s.spacecraft.attitude_hold_hz;
                Vector3::from_fn(|a, _| 2.0 * 0.7 * inertia[(a, a)] * w)
            },
            q0: nalgebra::UnitQuaternion::identity(),
            twin_a: ([[0.0; 3]; 2], [0.0; 3]),
            drift: crate::sim::drift::History::for_campaign(s).map(|h| (h, s.epoch_day)),
        }
    }

    /// Advance one output interval under `cmd` (the commander's torque for `tick`).
    pub fn step(&mut self, tick: u64, torque_cmd_b: &[f64; 3]) -> TruthState {
        let dt = 1.0 / self.fs;
        let h = dt / SUBSTEPS as f64;
        let t0 = tick as f64 * dt;
        if let Some((h, epoch)) = &self.drift {
            let truths = h.at(epoch + (t0 + 0.5 * dt) / crate::sim::drift::DAY_S);
            self.r_tm_b = truths.com_offset_m.map(Vector3::from);
        }
        self.thrusters
            .command(t0, torque_cmd_b, &mut self.rng_edges);
        let omega_start = self.body.omega_b;
        // The attitude hold's torque for this interval (zero-order hold, like a
        // controller running at the sample rate).
        let hold = if self.hold_kp.iter().any(|k| *k > 0.0) {
            let theta = super::attitude::rotation_vector(&(self.q0.inverse() * self.body.q_bn));
            -(self.hold_kp.component_mul(&theta) + self.hold_kd.component_mul(&self.body.omega_b))
        } else {
            Vector3::zeros()
        };
        // The thrusters' mean torques of every sub-step first: they do not depend on
        // the attitude, so the CPU overlaps them with the integration's long chain of
        // dependent steps (the same values; the torque noise is drawn below, as before).
        let mut taus = [Vector3::zeros(); SUBSTEPS];
        for (k, tau) in taus.iter_mut().enumerate() {
            *tau = Vector3::from(self.thrusters.mean_over(t0 + k as f64 * h, h)) + hold;
        }
        let mut a_couple = [Vector3::zeros(); 2];
        let mut sun_b = Vector3::zeros();
        // The sun's direction at each sub-step's start; the sub-step's mean is the
        // mean of its ends (trapezoid), so the tick's SRP is the attitude's mean over
        // the tick, as ω̇ and the coupling are (the sub-steps' ends alone sat h/2
        // late: 0.05 of a tick, a turn error of 10⁻¹⁵ m/s² at 1 Hz).
        let mut sun_a = self.body.q_bn.inverse_transform_vector(&self.sun_n);
        let mut torque_sum = Vector3::zeros();
        for mut tau in taus {
            if self.torque_sigma > 0.0 {
                for a in 0..3 {
                    tau[a] += self.torque_sigma * gauss(&mut self.rng_torque);
                }
            }
            let w_a = self.body.omega_b;
            self.body.step(&tau, h);
            let w_b = self.body.omega_b;
            let wd = (w_b - w_a) / h;
            let w_mid = (w_a + w_b) * 0.5;
            for (acc, r) in a_couple.iter_mut().zip(&self.r_tm_b) {
                *acc += super::attitude::coupling_acceleration(&w_mid, &wd, r);
            }
            let sun_end = self.body.q_bn.inverse_transform_vector(&self.sun_n);
            sun_b += (sun_a + sun_end) * 0.5;
            sun_a = sun_end;
            torque_sum += tau;
        }
        let n = SUBSTEPS as f64;
        let delta = if self.noise.srp {
            self.srp_bank.next(&mut self.rng_srp)
        } else {
            0.0
        };
        let mut a_srp = sun_b / n * (self.g0 + delta);
        if self.force_sigma > 0.0 {
            for a in 0..3 {
                a_srp[a] += self.force_sigma * gauss(&mut self.rng_force);
            }
        }
        // The same expressions a plant without the SRP's fluctuation and the force
        // noise evaluates (`delta` 0, no force term): the same bits as its step.
        let a_srp_twin = sun_b / n * (self.g0 + 0.0);
        self.twin_a = (
            std::array::from_fn(|i| (a_couple[i] / n + a_srp_twin).into()),
            a_srp_twin.into(),
        );
        let q = self.body.q_bn.quaternion();
        let a_tm: [[f64; 3]; 2] = std::array::from_fn(|i| (a_couple[i] / n + a_srp).into());
        let out = TruthState {
            header: Header::at(self.seq, tick, self.fs),
            q_bn: [q.w, q.i, q.j, q.k],
            omega_b: self.body.omega_b.into(),
            omega_dot_b: ((self.body.omega_b - omega_start) / dt).into(),
            a_tm_b: a_tm,
            a_srp_b: a_srp.into(),
            torque_b: (torque_sum / n).into(),
            torque_cmd_b: *torque_cmd_b,
        };
        self.seq += 1;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Turning at a constant rate about a principal axis, the tick's SRP is g0 times
    /// the sun's body direction averaged over the tick, as the IS measures it, not the
    /// direction at its end nor at its sub-steps' ends (0.05 of a tick late: 5×10⁻⁵ g0
    /// here, the turn rows' misfit at 1 Hz).
    #[test]
    fn the_tick_srp_is_the_mean_over_the_tick_of_the_turning_sun() {
        let mut s = Scenario::default();
        s.spacecraft.inertia_kg_m2 = [[800.0, 0.0, 0.0], [0.0, 900.0, 0.0], [0.0, 0.0, 700.0]];
        let mut p = Plant::new(&s, 1, PlantNoise::NONE);
        let turn = 1e-3; // rad per tick, about y
        p.body.omega_b = Vector3::new(0.0, turn * s.sample_rate_hz, 0.0);
        let a = Vector3::from(p.step(0, &[0.0; 3]).a_srp_b);
        let sun = Vector3::from(s.sun_unit());
        let (c, sn) = (turn.sin() / turn, (1.0 - turn.cos()) / turn);
        let want =
            Vector3::new(c * sun.x - sn * sun.z, 0.0, sn * sun.x + c * sun.z) * s.srp.dc_m_s2;
        assert!(
            (a - want).norm() < 1e-7 * s.srp.dc_m_s2,
            "SRP {a:?}, the tick's mean {want:?}: off by {:e} g0",
            (a - want).norm() / s.srp.dc_m_s2
        );
    }
}
