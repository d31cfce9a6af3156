//! Cramér–Rao bound of β, k and r for a scenario: the Fisher information of the full
//! problem (every unknown, SRP as coloured noise whitened), from noise-free signals of
//! the scenario's maneuver and the estimator's own noise model.

use crate::campaign::Threads;
use crate::commander::Commander;
use crate::estimate::joint::{P_BETA, P_R};
use crate::estimate::JointEstimator;
use crate::fee::FrontEnd;
use crate::model::plant::{Plant, PlantNoise};
use crate::scenario::{k_from_beta, Scenario};

/// 1σ bounds per IS [same units as the parameters].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Crlb {
    pub beta: [[f64; 3]; 2],
    pub k: [[f64; 3]; 2],
    pub com_offset_m: [[f64; 3]; 2],
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
    let priors = s.priors();
    let mut cfg = s.estimator_config(&priors);
    cfg.solve_every = u64::MAX;
    let mut est = JointEstimator::new(cfg);
    let cmd = Commander::new(s);
    let plant = Plant::new(s, s.seed, PlantNoise::NONE);
    let fee = FrontEnd::new(s, s.seed, false);
    // The simulation on a second core, ahead of the estimator.
    crate::campaign::samples(s, cmd, plant, fee, threads, |m| {
        est.step(m);
    });
    let mut beta = [[0.0; 3]; 2];
    let mut r = [[0.0; 3]; 2];
    for (i, is) in s.inertial_sensor.iter().enumerate() {
        beta[i] = is.beta;
        r[i] = is.com_offset_m;
    }
    // Nuisances at their noise-free best fit, β and r at the truth.
    let p = est.params_with(&beta, &r);
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
