//! Cramér–Rao bound of β, k and r for a scenario: the Fisher information of the full
//! problem (every unknown, SRP as coloured noise whitened), from noise-free signals of
//! the scenario's maneuver and the random motion its thrusters add at the scenario's
//! seed (torque noise, edge and amplitude jitter), and the estimator's own noise model.

use crate::analysis::campaign::Threads;
use crate::sim::commander::Commander;
use crate::sim::estimate::joint::{P_BETA, P_R};
use crate::sim::estimate::JointEstimator;
use crate::sim::fee::FrontEnd;
use crate::sim::model::plant::{Plant, PlantNoise};
use crate::sim::msg::SensorSample;
use crate::sim::scenario::{k_from_beta, Scenario};

/// 1σ bounds per IS [same units as the parameters].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Crlb {
    pub beta: [[f64; 3]; 2],
    pub k: [[f64; 3]; 2],
    pub com_offset_m: [[f64; 3]; 2],
}

impl Crlb {
    /// No bound: the data leave every parameter unbounded.
    pub const INFINITE: Crlb = Crlb {
        beta: [[f64::INFINITY; 3]; 2],
        k: [[f64::INFINITY; 3]; 2],
        com_offset_m: [[f64::INFINITY; 3]; 2],
    };

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
/// planner ranks candidates with it, on the maneuver's motion alone
/// (`maneuver_bound_on`); one thread.
pub fn crlb_at_rate(s: &Scenario, rate_hz: f64) -> Option<Crlb> {
    let mut d = s.clone();
    if rate_hz < s.sample_rate_hz {
        d.sample_rate_hz = rate_hz;
        let st = s.star_tracker.rate_hz.min(rate_hz);
        d.star_tracker.rate_hz = st;
        d.star_tracker.noise_3sigma_arcsec *= (st / s.star_tracker.rate_hz).sqrt();
    }
    maneuver_bound_on(&d, Threads::One)
}

/// The bound of the run at the scenario's seed, with the noise-free simulation on
/// `threads`.
pub fn crlb_on(s: &Scenario, threads: Threads) -> Option<Crlb> {
    bound_with(s, threads, Motion::Seed)
}

/// The bound of the maneuver alone: its motion without the thrusters' random motion,
/// and no data lost (the same for every seed; the planner's, which chooses a maneuver,
/// not a run).
pub fn maneuver_bound_on(s: &Scenario, threads: Threads) -> Option<Crlb> {
    if !s.faults.loses_data() {
        return bound_with(s, threads, Motion::Maneuver);
    }
    let mut d = s.clone();
    d.faults = Default::default();
    bound_with(&d, threads, Motion::Maneuver)
}

/// Whether the run's bound depends on its seed (the thrusters' random motion, or data
/// lost); without, it is the maneuver's bound at the scenario's rate, bit for bit.
pub fn seed_matters(s: &Scenario) -> bool {
    let t = &s.thruster;
    t.torque_noise_nm_rthz > 0.0
        || t.edge_jitter_s > 0.0
        || t.amplitude_jitter_rel > 0.0
        || s.faults.loses_data()
}

/// The two bounds a report states: the run's (`crlb`: the parameters' CRLB column) and
/// the maneuver's alone (`plan::maneuver_bound`: the maneuver's predicted ratio, the
/// prediction before the run and the written-maneuver warning). The maneuver's is
/// `None` where it is singular: the maneuver alone leaves a parameter unbounded.
#[derive(Debug, Clone, PartialEq)]
pub struct Bounds {
    pub run: Crlb,
    pub maneuver: Option<Crlb>,
}

fn bound_with(s: &Scenario, threads: Threads, motion: Motion) -> Option<Crlb> {
    let mut est = noise_free_estimator(s);
    // The simulation on a second core, ahead of the estimator.
    noise_free_samples(s, threads, motion, |m| {
        est.step(m);
    });
    bound_of(s, &est)
}

/// Which motion the bound's noise-free signals carry.
#[derive(Clone, Copy, PartialEq)]
enum Motion {
    /// The maneuver's, with the thrusters' torque noise and their edge and amplitude
    /// jitter at the scenario's seed: the motion the run had. The estimator sees that
    /// motion, and it informs β through the star tracker: with the IS's angular noise
    /// and ripple a hundred times smaller, over 10⁵ s (30 seeds), the maneuver's alone
    /// gave β a bound 3.2× above the RMS the runs reached (the jitter's motion: RMS/CRLB
    /// 0.31; 0.81 with it). In the default campaign β's bound is 2–4 % tighter with it,
    /// and equal to the estimator's σ to three digits.
    Seed,
    /// The maneuver's alone.
    Maneuver,
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
    noise_free_samples(s, threads, Motion::Seed, |m| {
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

/// The campaign at `seed` (`campaign::run_with`) and the bound of that run
/// (`crlb_on` of `s` at `seed`), bit for bit: its noise-free samples are the twin of
/// the run's simulation (the same motion, simulated once), taken by the bound's
/// estimator pass on the simulating thread while the run's estimator takes the run's
/// on the other. `None` for the bound where it is singular.
pub fn run_with_bound(
    s: &Scenario,
    seed: u64,
    method: crate::sim::estimate::Method,
    threads: Threads,
    progress: impl FnMut(f64),
    rec: Option<&mut dyn crate::telemetry::Sink>,
) -> Result<
    (crate::analysis::campaign::CampaignResult, Option<Crlb>),
    crate::telemetry::TelemetryError,
> {
    let sb = Scenario { seed, ..s.clone() };
    let mut est = noise_free_estimator(&sb);
    let res = crate::analysis::campaign::run_with(
        s,
        seed,
        method,
        threads,
        progress,
        rec,
        Some(&mut |m: &SensorSample| {
            est.step(m);
        }),
    )?;
    Ok((res, bound_of(&sb, &est)))
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

/// The scenario's samples without noise, with the motion `motion` says. A campaign
/// that loses data (dropouts, ticks the bus never delivers) loses the same ticks here
/// as its run at the scenario's seed, and its motion (`Motion::Seed`) keeps the
/// thrusters' random motion: a lost tick hides real motion, what the estimator allows a bridged tick is
/// learned from that motion, and without it the bound would count a lost tick as free
/// (with 1 % IS dropouts, β's bound 1.01× the clean one with it left out, 1.1–1.4× with
/// it in, as the runs' errors are).
fn noise_free_samples(
    s: &Scenario,
    threads: Threads,
    motion: Motion,
    take: impl FnMut(&SensorSample),
) {
    let cmd = Commander::new(s);
    let fee = FrontEnd::new(s, s.seed, false);
    let losing = s.faults.loses_data();
    let noise = PlantNoise {
        torque: motion == Motion::Seed,
        thruster_nonideal: motion == Motion::Seed,
        ..PlantNoise::NONE
    };
    let plant = Plant::new(s, s.seed, noise);
    if losing {
        crate::analysis::campaign::samples_losing(s, s.seed, cmd, plant, fee, threads, take);
    } else {
        crate::analysis::campaign::samples(s, cmd, plant, fee, threads, take);
    }
}

/// The bound of the statistics `est` accumulated: the Fisher σ at the truth.
fn bound_of(s: &Scenario, est: &JointEstimator) -> Option<Crlb> {
    // The campaign's truths (with `[drift]`, at its middle).
    let t = s.truths();
    let mut beta = [[0.0; 3]; 2];
    let mut r = [[0.0; 3]; 2];
    let n = s.inertial_sensor.len();
    beta[..n].copy_from_slice(&t.beta[..n]);
    r[..n].copy_from_slice(&t.com_offset_m[..n]);
    // Nuisances at their noise-free best fit, β and r at the truth.
    let mut est = *est;
    let p = est.params_with(&beta, &r);
    let p = est.nuisance_fit(p);
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
    use crate::sim::estimate::Method;

    /// The default scenario, `duration_s` long, its maneuver planned.
    fn planned(duration_s: f64) -> Scenario {
        let s = Scenario {
            duration_s,
            ..Default::default()
        };
        crate::analysis::plan::resolve(s).unwrap().0
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
        // changes only the torque noise's motion: next to nothing.
        let b1_other = crlb_on(&other_seed(&lossy), Threads::One).unwrap();
        let b0_other = crlb_on(&other_seed(&clean), Threads::One).unwrap();
        assert!(moved(&b1_other, &b1) > 1e-3, "{b1:?}\n{b1_other:?}");
        assert!(moved(&b0_other, &b0) < 1e-2, "{b0:?}\n{b0_other:?}");
    }

    /// The bound beside the run (its noise-free twin) is the bound of its own campaign,
    /// bit for bit, on one thread or three, with and without lost data (dropouts of
    /// both IS and the star tracker, ticks the bus never delivers), and the run's
    /// estimate is the run's alone.
    #[test]
    fn the_bound_beside_the_run_is_the_runs_bound_to_the_bit() {
        let clean = planned(2000.0);
        let mut lossy = clean.clone();
        lossy.faults.is_dropout_rate = 0.02;
        lossy.faults.star_dropout_rate = 0.02;
        lossy.faults.missing_rate = 0.005;
        for s in [clean, lossy] {
            let want = crlb_on(&s, Threads::One).unwrap();
            let alone =
                crate::analysis::campaign::run_on(&s, s.seed, Method::Joint, Threads::One, |_| {});
            for threads in [Threads::One, Threads::Two] {
                let (r, got) =
                    run_with_bound(&s, s.seed, Method::Joint, threads, |_| {}, None).unwrap();
                assert_eq!(got.unwrap(), want, "{threads:?}");
                assert_eq!(
                    bytemuck::bytes_of(&r.estimate),
                    bytemuck::bytes_of(&alone.estimate),
                    "{threads:?}"
                );
            }
        }
    }

    fn other_seed(s: &Scenario) -> Scenario {
        Scenario {
            seed: s.seed + 1,
            ..s.clone()
        }
    }

    /// β's bound of one against the other, relative.
    fn moved(x: &Crlb, y: &Crlb) -> f64 {
        (x.beta[0][0] / y.beta[0][0] - 1.0).abs()
    }

    #[test]
    fn the_bound_keeps_the_runs_torque_noise_and_the_planners_does_not() {
        let mut s = planned(3000.0);
        // Without torque noise and jitter the two bounds are one, bit for bit.
        s.thruster.torque_noise_nm_rthz = 0.0;
        s.thruster.edge_jitter_s = 0.0;
        s.thruster.amplitude_jitter_rel = 0.0;
        assert!(!seed_matters(&s));
        assert_eq!(
            crlb_on(&s, Threads::One),
            maneuver_bound_on(&s, Threads::One)
        );
        // The jitter alone is motion of the run too.
        s.thruster.edge_jitter_s = 0.02;
        s.thruster.amplitude_jitter_rel = 0.01;
        assert!(seed_matters(&s));
        assert_ne!(
            crlb_on(&s, Threads::One),
            maneuver_bound_on(&s, Threads::One)
        );
        // With thirty times the default, the torque noise rocks the spacecraft as much
        // as the maneuver does, and the estimator sees that motion: the run's bound on
        // r is far tighter (measured 4.7× on r_x), and each seed's its own. The
        // maneuver's alone is all but the same for every seed.
        s.thruster.torque_noise_nm_rthz = 3e-6;
        let run = crlb_on(&s, Threads::One).unwrap();
        let maneuver = maneuver_bound_on(&s, Threads::One).unwrap();
        for i in 0..2 {
            for a in 0..3 {
                let (r, m) = (run.com_offset_m[i][a], maneuver.com_offset_m[i][a]);
                assert!(r < 0.8 * m, "{run:?}\n{maneuver:?}");
            }
        }
        let other = other_seed(&s);
        let r_other = crlb_on(&other, Threads::One).unwrap().com_offset_m[0][0];
        assert!(
            (r_other / run.com_offset_m[0][0] - 1.0).abs() > 1e-3,
            "{r_other} {run:?}"
        );
        let m_other = maneuver_bound_on(&other, Threads::One).unwrap();
        assert!(
            moved(&m_other, &maneuver) < 1e-4,
            "{m_other:?}\n{maneuver:?}"
        );
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
