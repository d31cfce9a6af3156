//! Cramér–Rao bound of β, k and r for a scenario: the Fisher information of the full
//! problem (every unknown, SRP as coloured noise whitened), from noise-free signals of
//! the scenario's maneuver and the estimator's own noise model.

use crate::campaign::Threads;
use crate::commander::Commander;
use crate::estimate::joint::{P_BETA, P_R};
use crate::estimate::JointEstimator;
use crate::fee::FrontEnd;
use crate::model::plant::{Plant, PlantNoise};
use crate::msg::SensorSample;
use crate::scenario::{k_from_beta, Scenario};

/// 1σ bounds per IS [same units as the parameters].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Crlb {
    pub beta: [[f64; 3]; 2],
    pub k: [[f64; 3]; 2],
    pub com_offset_m: [[f64; 3]; 2],
}

impl Crlb {
    /// Every bound a finite number.
    pub fn is_finite(&self) -> bool {
        [self.beta, self.k, self.com_offset_m]
            .iter()
            .flatten()
            .flatten()
            .all(|v| v.is_finite())
    }
}

pub fn crlb(s: &Scenario) -> Option<Crlb> {
    crlb_on(s, Threads::available())
}

/// The bound of `s` with the campaign's samples computed at `rate_hz` instead of its
/// own rate (at most it): white noises keep their spectral densities and the star
/// tracker its information per second, so the bound is that of the same maneuver
/// observed more coarsely (a few per cent looser on r at 2 Hz than at 10 Hz). The
/// planner ranks candidates with it; one thread.
pub fn crlb_at_rate(s: &Scenario, rate_hz: f64) -> Option<Crlb> {
    let mut d = s.clone();
    if rate_hz < s.sample_rate_hz {
        d.sample_rate_hz = rate_hz;
        let st = s.star_tracker.rate_hz.min(rate_hz);
        d.star_tracker.rate_hz = st;
        d.star_tracker.noise_3sigma_arcsec *= (st / s.star_tracker.rate_hz).sqrt();
    }
    crlb_on(&d, Threads::One)
}

/// The bound, with the noise-free simulation on `threads`.
pub fn crlb_on(s: &Scenario, threads: Threads) -> Option<Crlb> {
    let mut est = noise_free_estimator(s);
    // The simulation on a second core, ahead of the estimator.
    noise_free_samples(s, threads, |m| {
        est.step(m);
    });
    bound_of(s, &est)
}

/// The bound as the campaign goes: at `points` ticks evenly spread over it (the last
/// one its end), the Cramér–Rao bound of the samples up to that tick — the Fisher
/// information accumulated so far, not the whole campaign's scaled with time: a
/// sequential maneuver has not yet excited the later axes early on (their bound is
/// then not finite), and the last point is `crlb(s)` exactly. What a live run's σ is
/// compared with (the supervisor's status, `taiji-calib monitor`).
pub fn crlb_curve(s: &Scenario, points: usize, threads: Threads) -> Vec<(u64, Option<Crlb>)> {
    let n = s.n_samples();
    let points = (points.max(1) as u64).min(n.max(1));
    let at: Vec<u64> = (1..=points).map(|k| k * n / points).collect();
    let mut out = Vec::with_capacity(at.len());
    let mut est = noise_free_estimator(s);
    let mut seen = 0u64;
    noise_free_samples(s, threads, |m| {
        est.step(m);
        seen += 1;
        if at.get(out.len()) == Some(&seen) {
            out.push((seen, bound_of(s, &est)));
        }
    });
    out
}

/// The bound at `tick` from a curve of `crlb_curve`: interpolated between the points
/// around it as a power of the tick (a bound falls as 1/√t under steady excitation,
/// faster while a new axis is excited); None before the first point at which every
/// parameter has a finite bound.
pub fn bound_at(curve: &[(u64, Option<Crlb>)], tick: u64) -> Option<Crlb> {
    let known = |i: usize| curve[i].1.filter(Crlb::is_finite).map(|c| (curve[i].0, c));
    let after = curve.iter().position(|(t, _)| *t >= tick)?;
    let (t1, c1) = known(after)?;
    if t1 == tick || after == 0 {
        return (t1 == tick).then_some(c1);
    }
    let (t0, c0) = known(after - 1)?;
    let x = (tick as f64 / t0 as f64).ln() / (t1 as f64 / t0 as f64).ln();
    let mix = |a: f64, b: f64| a * (b / a).powf(x);
    let mut out = c0;
    for i in 0..2 {
        for a in 0..3 {
            out.beta[i][a] = mix(c0.beta[i][a], c1.beta[i][a]);
            out.k[i][a] = mix(c0.k[i][a], c1.k[i][a]);
            out.com_offset_m[i][a] = mix(c0.com_offset_m[i][a], c1.com_offset_m[i][a]);
        }
    }
    Some(out)
}

/// The joint estimator that accumulates the bound's statistics (it never solves).
fn noise_free_estimator(s: &Scenario) -> JointEstimator {
    let priors = s.priors();
    let mut cfg = s.estimator_config(&priors);
    cfg.solve_every = u64::MAX;
    let mut est = JointEstimator::new(cfg);
    est.level_at_end();
    est
}

/// The scenario's samples without noise. A campaign that loses data (dropouts, ticks
/// the bus never delivers) loses the same ticks here as its run at the scenario's seed,
/// and its motion then keeps the thrusters' torque noise: a lost tick hides real
/// motion, what the estimator allows a bridged tick is learned from that motion, and
/// without it the bound would count a lost tick as free (with 1 % IS dropouts, β's
/// bound 1.01× the clean one with it left out, 1.1–1.4× with it in, as the runs'
/// errors are). Without losses the bound is that of the noise-free signals alone.
fn noise_free_samples(s: &Scenario, threads: Threads, take: impl FnMut(&SensorSample)) {
    let cmd = Commander::new(s);
    let fee = FrontEnd::new(s, s.seed, false);
    let losing = s.faults.loses_data();
    let noise = PlantNoise {
        torque: losing,
        ..PlantNoise::NONE
    };
    let plant = Plant::new(s, s.seed, noise);
    if losing {
        crate::campaign::samples_losing(s, s.seed, cmd, plant, fee, threads, take);
    } else {
        crate::campaign::samples(s, cmd, plant, fee, threads, take);
    }
}

/// The bound of the statistics `est` accumulated: the Fisher σ at the truth.
fn bound_of(s: &Scenario, est: &JointEstimator) -> Option<Crlb> {
    let mut beta = [[0.0; 3]; 2];
    let mut r = [[0.0; 3]; 2];
    for (i, is) in s.inertial_sensor.iter().enumerate() {
        beta[i] = is.beta;
        r[i] = is.com_offset_m;
    }
    // Nuisances at their noise-free best fit, β and r at the truth.
    let p = est.params_with(&beta, &r);
    let p = est.nuisance_fit(p);
    let mut est = *est;
    est.fix_srp_level_at(&p);
    let p = est.nuisance_fit(p);
    let sigma = est.fisher_sigma(&p)?;
    let mut out = Crlb::default();
    for (i, is) in s.inertial_sensor.iter().enumerate() {
        for a in 0..3 {
            out.beta[i][a] = sigma[P_BETA + 3 * i + a];
            out.com_offset_m[i][a] = sigma[P_R + 3 * i + a];
        }
        out.k[i] = k_from_beta(&is.geometry_m, &out.beta[i]);
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default scenario, `duration_s` long, its maneuver planned.
    fn planned(duration_s: f64) -> Scenario {
        let s = Scenario {
            duration_s,
            ..Default::default()
        };
        crate::plan::resolve(s).unwrap().0
    }

    #[test]
    fn a_campaign_that_loses_data_has_the_bound_of_its_own_losses() {
        let clean = planned(4000.0);
        let mut lossy = clean.clone();
        lossy.faults.is_dropout_rate = 0.05;
        let b0 = crlb_on(&clean, Threads::One).unwrap();
        let b1 = crlb_on(&lossy, Threads::One).unwrap();
        // Ticks without either IS hide the thrusters' noisy motion: every bound looser,
        // β's and r_z's much looser (measured 1.4–3×).
        for i in 0..2 {
            for a in 0..3 {
                assert!(b1.beta[i][a] > b0.beta[i][a], "{b0:?}\n{b1:?}");
                assert!(b1.com_offset_m[i][a] >= b0.com_offset_m[i][a] * (1.0 - 1e-9));
            }
            assert!(b1.beta[i][0] > 1.2 * b0.beta[i][0], "{b0:?}\n{b1:?}");
        }
        // Another seed loses other ticks: another bound. Without losses the seed
        // changes next to nothing.
        let other = |s: &Scenario| Scenario {
            seed: s.seed + 1,
            ..s.clone()
        };
        let b1_other = crlb_on(&other(&lossy), Threads::One).unwrap();
        let b0_other = crlb_on(&other(&clean), Threads::One).unwrap();
        let moved = |x: &Crlb, y: &Crlb| (x.beta[0][0] / y.beta[0][0] - 1.0).abs();
        assert!(moved(&b1_other, &b1) > 1e-3, "{b1:?}\n{b1_other:?}");
        assert!(moved(&b0_other, &b0) < 1e-4, "{b0:?}\n{b0_other:?}");
    }

    #[test]
    fn the_bound_shrinks_as_the_campaign_goes_and_ends_at_the_campaigns() {
        let s = planned(3000.0);
        let curve = crlb_curve(&s, 10, Threads::One);
        assert_eq!(curve.len(), 10);
        assert_eq!(curve.last().unwrap().0, s.n_samples());
        // The last point is the campaign's bound, bit for bit.
        assert_eq!(curve.last().unwrap().1, crlb_on(&s, Threads::One));
        // Once every parameter has a bound, more samples only tighten it.
        let known: Vec<&Crlb> = curve
            .iter()
            .filter_map(|(_, c)| c.as_ref().filter(|c| c.is_finite()))
            .collect();
        assert!(known.len() >= 2, "{curve:?}");
        for w in known.windows(2) {
            for i in 0..s.inertial_sensor.len() {
                for a in 0..3 {
                    assert!(w[1].beta[i][a] <= w[0].beta[i][a] * (1.0 + 1e-9));
                    assert!(w[1].com_offset_m[i][a] <= w[0].com_offset_m[i][a] * (1.0 + 1e-9));
                }
            }
        }
        // Between points the bound lies between theirs; at a point it is that point's.
        let (t9, c9) = (curve[8].0, curve[8].1.unwrap());
        let (t10, c10) = (curve[9].0, curve[9].1.unwrap());
        assert_eq!(bound_at(&curve, t10), Some(c10));
        let mid = bound_at(&curve, (t9 + t10) / 2).unwrap();
        let (lo, hi) = (c10.beta[0][0], c9.beta[0][0]);
        assert!(
            lo < mid.beta[0][0] && mid.beta[0][0] < hi,
            "{lo} {mid:?} {hi}"
        );
        assert_eq!(bound_at(&curve, 0), None);
        assert_eq!(bound_at(&curve, s.n_samples() + 1), None);
    }
}
