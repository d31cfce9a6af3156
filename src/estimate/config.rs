//! What the estimators may know: priors, known geometry and the noise specifications —
//! never the truths. Built from a scenario by copying only those fields.

use crate::model::noise::white_sigma;
use crate::scenario::{Priors, Scenario, ARCSEC};

#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EstimatorConfig {
    /// Sample rate [Hz].
    pub fs: f64,
    /// Number of inertial sensors (1 or 2).
    pub n_is: usize,
    /// Known geometry ratios (Gx, Gy, Gz) of eq. 2 per IS [m].
    pub geometry_m: [[f64; 3]; 2],
    /// Ground-calibration priors per IS.
    pub beta_prior: [[f64; 3]; 2],
    pub com_prior_m: [[f64; 3]; 2],
    /// Star-tracker noise per axis per sample, 1σ [rad].
    pub sigma_star_rad: f64,
    /// Per-sample 1σ of the IS readout noise: angular [rad/s²], linear [m/s²].
    pub sigma_angular: f64,
    pub sigma_linear: f64,
    /// Per-sample 1σ of the relative drive ripple [-].
    pub sigma_ripple: f64,
    /// ASD of the SRP fluctuation at 3 mHz [m s^-2 Hz^-1/2] (∝ f^-1/3).
    pub srp_asd_at_3mhz: f64,
    /// Per-sample 1σ of the common-mode thruster force-noise acceleration [m/s²] (0 = off).
    pub sigma_force: f64,
    /// Solve (publish new estimates) every this many samples.
    pub solve_every: u64,
    /// IS measurement ranges (the front-end clips and flags beyond them): linear
    /// [m/s²] and angular [rad/s²]; a voltage no in-range acceleration can give is rejected.
    pub full_scale_linear: f64,
    pub full_scale_angular: f64,
    /// Longest run of missing ticks bridged as a dropout (bounds the work of one call);
    /// a longer jump of the tick is rejected as implausible.
    pub max_gap_ticks: u64,
}

impl EstimatorConfig {
    pub fn from_scenario(s: &Scenario, priors: &[Priors]) -> Self {
        let fs = s.sample_rate_hz;
        let fe = &s.front_end;
        let mut c = EstimatorConfig {
            fs,
            n_is: s.inertial_sensor.len(),
            geometry_m: [[1.0; 3]; 2],
            beta_prior: [[1.0; 3]; 2],
            com_prior_m: [[0.0; 3]; 2],
            sigma_star_rad: s.star_tracker.noise_3sigma_arcsec / 3.0 * ARCSEC,
            sigma_angular: white_sigma(fe.angular_noise_rthz, fs),
            sigma_linear: white_sigma(fe.linear_noise_rthz, fs),
            sigma_ripple: white_sigma(fe.ripple_rthz, fs),
            srp_asd_at_3mhz: s.srp.asd_at_3mhz,
            sigma_force: white_sigma(s.thruster.force_noise_n_rthz / s.spacecraft.mass_kg, fs),
            solve_every: (60.0 * fs).round().max(1.0) as u64,
            full_scale_linear: fe.full_scale_m_s2,
            full_scale_angular: fe.full_scale_rad_s2,
            max_gap_ticks: (600.0 * fs).round().max(1.0) as u64,
        };
        for (i, (is, p)) in s.inertial_sensor.iter().zip(priors).enumerate() {
            c.geometry_m[i] = is.geometry_m;
            c.beta_prior[i] = p.beta;
            c.com_prior_m[i] = p.com_offset_m;
        }
        c
    }
}
