//! Front-end electronics: IS drive voltages by inverting Table 1 with the true β, k,
//! with readout noise, multiplicative drive ripple and saturation; and the star tracker.
//! The only stage that sees truth besides the plant.

use crate::sim::model::noise::white_sigma;
use crate::sim::msg::{
    Header, IsSample, SensorSample, StarSample, TruthState, ANGULAR_OF_PAIR, FLAG_ABSENT,
};
use crate::sim::rng::{gauss, stream, stream_n, Rng, Stream};
use crate::sim::scenario::{Scenario, ARCSEC};
use nalgebra::{UnitQuaternion, Vector3};

#[derive(Debug, Clone)]
pub struct FrontEnd {
    n_is: usize,
    beta: [[f64; 3]; 2],
    k: [[f64; 3]; 2],
    fs: f64,
    st_rate: f64,
    outages: heapless::Vec<[f64; 2], 64>,
    sigma_lin: f64,
    sigma_ang: f64,
    sigma_ripple: f64,
    sigma_star: f64,
    full_lin: f64,
    full_ang: f64,
    rng_is: [Rng; 2],
    rng_star: Rng,
    /// False for the noise-free sensors: no draws at all (see [`FrontEnd::new`]).
    noisy: bool,
    seq: u64,
    /// With `[drift]`: the truths' history and the campaign's epoch [days]; β and k
    /// follow it, taken at each tick's middle.
    drift: Option<(crate::sim::drift::History, f64)>,
}

impl FrontEnd {
    /// `noisy = false` gives noise-free sensors (for the Cramér–Rao bound's signals).
    /// They draw no noise at all: a draw times a zero σ is ±0, which leaves every
    /// voltage as it is (x + ±0 = x, x × (1 ± 0) = x) and the star tracker's noise
    /// rotation the identity. The one exception is the sign of an exact zero (an input
    /// of exactly −0 plus +0), which no estimate can see; the draws were a quarter of
    /// the noise-free simulation's time.
    pub fn new(s: &Scenario, seed: u64, noisy: bool) -> Self {
        let fs = s.sample_rate_hz;
        let fe = &s.front_end;
        let on = if noisy { 1.0 } else { 0.0 };
        let mut beta = [[1.0; 3]; 2];
        let mut k = [[1.0; 3]; 2];
        for (i, is) in s.inertial_sensor.iter().enumerate() {
            beta[i] = is.beta;
            k[i] = is.k();
        }
        let mut outages = heapless::Vec::new();
        for o in s.star_tracker.outages_s.iter().take(64) {
            let _ = outages.push(*o);
        }
        FrontEnd {
            n_is: s.inertial_sensor.len(),
            beta,
            k,
            fs,
            st_rate: s.star_tracker.rate_hz,
            outages,
            sigma_lin: on * white_sigma(fe.linear_noise_rthz, fs),
            sigma_ang: on * white_sigma(fe.angular_noise_rthz, fs),
            sigma_ripple: on * white_sigma(fe.ripple_rthz, fs),
            sigma_star: on * s.star_tracker.noise_3sigma_arcsec / 3.0 * ARCSEC,
            full_lin: fe.full_scale_m_s2,
            full_ang: fe.full_scale_rad_s2,
            rng_is: [
                stream_n(seed, Stream::InertialSensor, 0),
                stream_n(seed, Stream::InertialSensor, 1),
            ],
            rng_star: stream(seed, Stream::StarTracker),
            noisy,
            seq: 0,
            drift: crate::sim::drift::History::for_campaign(s).map(|h| (h, s.epoch_day)),
        }
    }

    /// Is a star-tracker sample taken at the end of interval `tick`?
    fn star_due(&self, tick: u64) -> bool {
        let n = |t: u64| (t as f64 * self.st_rate / self.fs + 1e-9).floor();
        n(tick + 1) > n(tick)
    }

    fn in_outage(&self, t: f64) -> bool {
        self.outages.iter().any(|o| t >= o[0] && t <= o[1])
    }

    pub fn step(&mut self, truth: &TruthState) -> SensorSample {
        let tick = truth.header.tick;
        let t_end = (tick + 1) as f64 / self.fs;
        if let Some((h, epoch)) = &self.drift {
            let truths = h.at(epoch + (tick as f64 + 0.5) / self.fs / crate::sim::drift::DAY_S);
            (self.beta, self.k) = (truths.beta, truths.k);
        }
        let mut out = SensorSample {
            header: Header::at(self.seq, tick, self.fs),
            ..Default::default()
        };
        for i in 0..2 {
            if i >= self.n_is {
                out.is[i].flags = FLAG_ABSENT;
                continue;
            }
            out.is[i] = self.inertial_sensor(i, &truth.omega_dot_b, &truth.a_tm_b[i]);
        }
        // Always draw the star noise, so outages do not shift the stream.
        let noise = match self.noisy {
            true => Vector3::from_fn(|_, _| self.sigma_star * gauss(&mut self.rng_star)),
            false => Vector3::zeros(),
        };
        if self.star_due(tick) && !self.in_outage(t_end) {
            let q_true = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                truth.q_bn[0],
                truth.q_bn[1],
                truth.q_bn[2],
                truth.q_bn[3],
            ));
            let q = (q_true * UnitQuaternion::from_scaled_axis(noise)).into_inner();
            out.star = StarSample {
                q_bn: [q.w, q.i, q.j, q.k],
                valid: 1,
                _pad: [0; 7],
            };
        }
        self.seq += 1;
        out
    }

    fn inertial_sensor(&mut self, i: usize, omega_dot: &[f64; 3], a: &[f64; 3]) -> IsSample {
        let noisy = self.noisy;
        let rng = &mut self.rng_is[i];
        let mut flags = 0u8;
        let mut volts = [[0.0; 2]; 3];
        for p in 0..3 {
            let axis = ANGULAR_OF_PAIR[p];
            let mut wd = omega_dot[axis];
            if noisy {
                wd += self.sigma_ang * gauss(rng);
            }
            if wd.abs() > self.full_ang {
                wd = wd.signum() * self.full_ang;
                flags |= 1 << (3 + axis);
            }
            let mut lin = a[p];
            if noisy {
                lin += self.sigma_lin * gauss(rng);
            }
            if lin.abs() > self.full_lin {
                lin = lin.signum() * self.full_lin;
                flags |= 1 << p;
            }
            // Ripple multiplies each degree of freedom's drive (sum and difference).
            let (ripple_diff, ripple_sum) = match noisy {
                true => (
                    1.0 + self.sigma_ripple * gauss(rng),
                    1.0 + self.sigma_ripple * gauss(rng),
                ),
                false => (1.0, 1.0),
            };
            let diff = wd / self.beta[i][axis] * ripple_diff;
            let sum = lin / self.k[i][p] * ripple_sum;
            volts[p] = [0.5 * (sum + diff), 0.5 * (sum - diff)];
        }
        IsSample {
            volts,
            flags,
            _pad: [0; 7],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_free_voltages_invert_table_1_exactly() {
        let s = Scenario::default();
        let mut fe = FrontEnd::new(&s, 1, false);
        let truth = TruthState {
            omega_dot_b: [2.5e-9, -1.0e-9, 0.5e-9],
            a_tm_b: [[1.5e-8, 5e-10, 2.6e-8], [1.5e-8, -5e-10, 2.6e-8]],
            q_bn: [1.0, 0.0, 0.0, 0.0],
            ..Default::default()
        };
        let out = fe.step(&truth);
        let is = &s.inertial_sensor[0];
        let k = is.k();
        let v = out.is[0].volts;
        // Table 1 rows.
        assert!((is.beta[0] * (v[1][0] - v[1][1]) - 2.5e-9).abs() < 1e-22);
        assert!((is.beta[1] * (v[2][0] - v[2][1]) + 1.0e-9).abs() < 1e-22);
        assert!((is.beta[2] * (v[0][0] - v[0][1]) - 0.5e-9).abs() < 1e-22);
        for p in 0..3 {
            assert!((k[p] * (v[p][0] + v[p][1]) - truth.a_tm_b[0][p]).abs() < 1e-22);
        }
        assert_eq!(out.is[0].flags, 0);
        assert_eq!(out.star.valid, 1);
    }

    #[test]
    fn noise_free_sensors_without_draws_equal_zero_noise_drawn_bit_for_bit() {
        // The noise-free front-end draws nothing; one that draws every noise with
        // σ = 0 must give the same samples, on the noise-free plant of the bound.
        let mut s = Scenario::default();
        let mut free = FrontEnd::new(&s, 4, false);
        s.front_end.ripple_rthz = 0.0;
        s.front_end.linear_noise_rthz = 0.0;
        s.front_end.angular_noise_rthz = 0.0;
        s.star_tracker.noise_3sigma_arcsec = 0.0;
        let mut drawn = FrontEnd::new(&s, 4, true);
        let mut cmd = crate::sim::commander::Commander::new(&s);
        let noise = crate::sim::model::plant::PlantNoise::NONE;
        let mut plant = crate::sim::model::plant::Plant::new(&s, 4, noise);
        let mut stars = 0;
        for tick in 0..5_000 {
            let truth = plant.step(tick, &cmd.step(tick).torque_cmd_b);
            let (a, b) = (free.step(&truth), drawn.step(&truth));
            let bits = |m: &SensorSample| {
                let mut w: Vec<u64> = m.star.q_bn.iter().map(|x| x.to_bits()).collect();
                w.push(m.star.valid as u64);
                for is in &m.is {
                    w.extend(is.volts.iter().flatten().map(|x| x.to_bits()));
                    w.push(is.flags as u64);
                }
                w
            };
            assert_eq!(bits(&a), bits(&b), "tick {tick}");
            assert_eq!(a.header, b.header);
            stars += a.star.valid as u32;
        }
        assert!(stars > 100, "{stars} star-tracker samples");
    }

    #[test]
    fn out_of_range_samples_are_clipped_and_flagged() {
        let s = Scenario::default();
        let mut fe = FrontEnd::new(&s, 1, false);
        let truth = TruthState {
            a_tm_b: [[2e-7, 0.0, 0.0], [0.0; 3]],
            q_bn: [1.0, 0.0, 0.0, 0.0],
            ..Default::default()
        };
        let out = fe.step(&truth);
        assert_eq!(out.is[0].flags & 1, 1);
        let k = s.inertial_sensor[0].k();
        assert!((k[0] * (out.is[0].volts[0][0] + out.is[0].volts[0][1]) - 1e-7).abs() < 1e-20);
    }
}
