//! Scenario file (SPEC §4): what is simulated, with the paper's defaults.
//!
//! Every key has a default; unknown keys, wrong types, non-finite or physically
//! impossible values are rejected with a message that names the key.

use crate::estimate::EstimatorConfig;
use crate::model::noise::white_sigma;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::Path;

/// Arc-second in radians.
pub const ARCSEC: f64 = std::f64::consts::PI / (180.0 * 3600.0);

/// Longest campaign [s] the estimator's honesty has been verified for (docs/integrity.md).
pub const MAX_DURATION_S: f64 = 1.0e6;

/// Least ratio of the DC SRP [m/s²] to its fluctuation ASD at 3 mHz [m s⁻² Hz^-½].
pub const SRP_DC_OVER_ASD: f64 = 5.0;

/// A scenario that failed to load or validate; the message names the key.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioError(pub String);

impl fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}
impl std::error::Error for ScenarioError {}

fn default_name() -> String {
    "paper".into()
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct Scenario {
    pub name: String,
    /// Seed of every noise stream (the CLI's `--seed` overrides it).
    pub seed: u64,
    /// Campaign length [s].
    pub duration_s: f64,
    /// Output rate of plant, sensors and estimator [Hz].
    pub sample_rate_hz: f64,
    pub spacecraft: Spacecraft,
    pub maneuver: Maneuver,
    pub thruster: Thruster,
    pub star_tracker: StarTracker,
    pub srp: Srp,
    pub front_end: FrontEnd,
    pub ground_calibration: GroundCalibration,
    pub inertial_sensor: Vec<InertialSensor>,
    /// Injected faults (none by default).
    pub faults: crate::faults::FaultsConfig,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct Spacecraft {
    /// Inertia tensor about the spacecraft CoM, body frame [kg m²].
    pub inertia_kg_m2: [[f64; 3]; 3],
    /// Spacecraft mass [kg]; converts thruster force noise to acceleration.
    pub mass_kg: f64,
    /// Bandwidth of the attitude hold [Hz] (0: none). The drag-free and attitude
    /// control keeps the spacecraft pointed; without it the thrusters' noise and
    /// amplitude jitter let the attitude random-walk (4×10⁻³ rad at 3×10⁴ s, 0.3 rad at
    /// 10⁶ s). Far below the maneuver's frequency, it does not fight the rocking.
    pub attitude_hold_hz: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct Maneuver {
    /// Square-wave frequency [Hz].
    pub frequency_hz: f64,
    /// Torque amplitude per body axis [N m].
    pub torque_amplitude_nm: [f64; 3],
    /// Order in which the axes are rocked, one after the other (e.g. "xyz").
    pub axis_order: String,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct Thruster {
    /// First-order response time constant [s] (≤ 5 ms, §3.1).
    pub response_time_s: f64,
    /// White torque noise per axis [N m Hz^-1/2].
    pub torque_noise_nm_rthz: f64,
    /// Edge timing jitter, the duty-cycle change [s] (uniform ± this, after a mean delay of the same).
    pub edge_jitter_s: f64,
    /// Amplitude jitter per half period, relative 1σ.
    pub amplitude_jitter_rel: f64,
    /// Overshoot after each edge, relative to the step.
    pub overshoot_rel: f64,
    /// Overshoot decay time constant [s].
    pub overshoot_decay_s: f64,
    /// Net force noise on the spacecraft [N Hz^-1/2] per axis; 0 = off (the paper's case).
    pub force_noise_n_rthz: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct StarTracker {
    pub rate_hz: f64,
    /// Per-axis noise, 3σ [arcsec].
    pub noise_3sigma_arcsec: f64,
    /// Intervals [start, end] in seconds during which samples are invalid.
    pub outages_s: Vec<[f64; 2]>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct Srp {
    /// ASD of the SRP acceleration fluctuation at 3 mHz [m s^-2 Hz^-1/2], ∝ f^-1/3.
    pub asd_at_3mhz: f64,
    /// DC SRP acceleration g0 [m s^-2].
    pub dc_m_s2: f64,
    /// Sun direction in the body frame at zero attitude (normalised on load).
    pub sun_direction_b: [f64; 3],
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct FrontEnd {
    /// Multiplicative drive ripple δV/V [Hz^-1/2].
    pub ripple_rthz: f64,
    /// Additive readout noise, linear [m s^-2 Hz^-1/2].
    pub linear_noise_rthz: f64,
    /// Additive readout noise, angular [rad s^-2 Hz^-1/2].
    pub angular_noise_rthz: f64,
    /// Linear measurement range [m s^-2]; beyond it samples clip and are flagged.
    pub full_scale_m_s2: f64,
    /// Angular measurement range [rad s^-2].
    pub full_scale_rad_s2: f64,
    /// Design limit of the maneuver-induced acceleration |A r| [m s^-2] (§3.1).
    pub maneuver_limit_m_s2: f64,
}

/// How priors are drawn when an IS gives none: each component is off the truth by
/// exactly this much, with a random sign (the "ground-calibration error").
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct GroundCalibration {
    pub beta_rel_error: f64,
    pub com_offset_error_m: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct InertialSensor {
    /// Truth: TM CoM offset from the spacecraft CoM, body frame [m].
    pub com_offset_m: [f64; 3],
    /// Truth: angular scale factors [rad s^-2 V^-1].
    pub beta: [f64; 3],
    /// Known geometry ratios (Gx, Gy, Gz) of eq. 2 [m].
    pub geometry_m: [f64; 3],
    /// Ground-calibration prior of β; drawn from the truth when absent.
    pub beta_prior: Option<[f64; 3]>,
    /// Ground-calibration prior of r; drawn from the truth when absent.
    pub com_offset_prior_m: Option<[f64; 3]>,
}

impl Default for Scenario {
    fn default() -> Self {
        let is1 = InertialSensor::default();
        let is2 = InertialSensor {
            com_offset_m: [0.2164, 0.1251, 0.0002],
            ..Default::default()
        };
        Scenario {
            name: default_name(),
            seed: 1,
            duration_s: 10_000.0,
            sample_rate_hz: 10.0,
            spacecraft: Spacecraft::default(),
            maneuver: Maneuver::default(),
            thruster: Thruster::default(),
            star_tracker: StarTracker::default(),
            srp: Srp::default(),
            front_end: FrontEnd::default(),
            ground_calibration: GroundCalibration::default(),
            inertial_sensor: vec![is1, is2],
            faults: crate::faults::FaultsConfig::default(),
        }
    }
}

impl Default for Spacecraft {
    fn default() -> Self {
        Spacecraft {
            inertia_kg_m2: [[1000.0, 5.0, -3.0], [5.0, 1100.0, 4.0], [-3.0, 4.0, 900.0]],
            mass_kg: 2000.0,
            attitude_hold_hz: 3.0e-5,
        }
    }
}

impl Default for Maneuver {
    fn default() -> Self {
        // Chosen with the CRLB (README, "Choosing the maneuver").
        Maneuver {
            frequency_hz: 1.0e-3,
            torque_amplitude_nm: [2.5e-6; 3],
            axis_order: "xyz".into(),
        }
    }
}

impl Default for Thruster {
    fn default() -> Self {
        Thruster {
            response_time_s: 2.0e-3,
            torque_noise_nm_rthz: 1.0e-7,
            edge_jitter_s: 0.02,
            amplitude_jitter_rel: 0.01,
            overshoot_rel: 0.05,
            overshoot_decay_s: 0.5,
            force_noise_n_rthz: 0.0,
        }
    }
}

impl Default for StarTracker {
    fn default() -> Self {
        StarTracker {
            rate_hz: 10.0,
            noise_3sigma_arcsec: 0.2,
            outages_s: Vec::new(),
        }
    }
}

impl Default for Srp {
    fn default() -> Self {
        Srp {
            asd_at_3mhz: 1.1e-11,
            dc_m_s2: 3.0e-8,
            sun_direction_b: [0.5, 0.0, 0.866],
        }
    }
}

impl Default for FrontEnd {
    fn default() -> Self {
        FrontEnd {
            ripple_rthz: 8.0e-6,
            linear_noise_rthz: 3.0e-15,
            angular_noise_rthz: 1.0e-14,
            full_scale_m_s2: 1.0e-7,
            full_scale_rad_s2: 1.0e-6,
            maneuver_limit_m_s2: 1.0e-9,
        }
    }
}

impl Default for GroundCalibration {
    fn default() -> Self {
        GroundCalibration {
            beta_rel_error: 5.0e-3,
            com_offset_error_m: 2.0e-3,
        }
    }
}

impl Default for InertialSensor {
    fn default() -> Self {
        InertialSensor {
            com_offset_m: [0.2164, -0.1251, 0.0002],
            beta: [5.52143e-8, 5.52143e-8, 7.36191e-8],
            geometry_m: [0.02044452, 0.02044452, 0.03066663],
            beta_prior: None,
            com_offset_prior_m: None,
        }
    }
}

impl InertialSensor {
    /// Linear scale factors from eq. 2: kx = Gz βz, ky = Gx βx, kz = Gy βy [m s^-2 V^-1].
    pub fn k(&self) -> [f64; 3] {
        k_from_beta(&self.geometry_m, &self.beta)
    }
}

pub use crate::estimate::config::k_from_beta;

/// Ground-calibration priors of one IS, as the estimator receives them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Priors {
    pub beta: [f64; 3],
    pub com_offset_m: [f64; 3],
}

impl Scenario {
    /// Parse and validate a TOML text.
    pub fn from_toml_str(text: &str) -> Result<Self, ScenarioError> {
        let s: Scenario = toml::from_str(text).map_err(|e| {
            ScenarioError(format!(
                "scenario is not valid: {}",
                e.to_string().trim_end()
            ))
        })?;
        s.validated()
    }

    /// Load a scenario file; the error names the file, the key and the problem.
    pub fn load(path: &Path) -> Result<Self, ScenarioError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| ScenarioError(format!("cannot read scenario {}: {e}", path.display())))?;
        Self::from_toml_str(&text)
            .map_err(|e| ScenarioError(format!("{}: {}", path.display(), e.0)))
    }

    /// Load `path` if given, else the built-in default (the paper's case).
    pub fn load_or_default(path: Option<&Path>) -> Result<Self, ScenarioError> {
        match path {
            Some(p) => Self::load(p),
            None => Scenario::default().validated(),
        }
    }

    pub fn dt(&self) -> f64 {
        1.0 / self.sample_rate_hz
    }

    /// Number of output samples of the campaign.
    pub fn n_samples(&self) -> u64 {
        (self.duration_s * self.sample_rate_hz).round() as u64
    }

    /// Unit sun vector in the body frame at zero attitude.
    pub fn sun_unit(&self) -> [f64; 3] {
        let s = self.srp.sun_direction_b;
        let n = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
        [s[0] / n, s[1] / n, s[2] / n]
    }

    /// Maneuver axes in order, as indices 0..3.
    pub fn axis_order(&self) -> [usize; 3] {
        let mut out = [0usize; 3];
        for (i, c) in self.maneuver.axis_order.chars().enumerate().take(3) {
            out[i] = match c {
                'x' | 'X' => 0,
                'y' | 'Y' => 1,
                _ => 2,
            };
        }
        out
    }

    /// Priors of each IS: the scenario's, or drawn from the truth with the documented
    /// ground-calibration error (random sign per component, from the seed).
    pub fn priors(&self) -> Vec<Priors> {
        use rand::Rng;
        let mut rng = crate::rng::stream(self.seed, crate::rng::Stream::Priors);
        self.inertial_sensor
            .iter()
            .map(|is| {
                let mut sign = || if rng.gen::<bool>() { 1.0 } else { -1.0 };
                let drawn_beta: [f64; 3] = std::array::from_fn(|a| {
                    is.beta[a] * (1.0 + sign() * self.ground_calibration.beta_rel_error)
                });
                let drawn_r: [f64; 3] = std::array::from_fn(|a| {
                    is.com_offset_m[a] + sign() * self.ground_calibration.com_offset_error_m
                });
                Priors {
                    beta: is.beta_prior.unwrap_or(drawn_beta),
                    com_offset_m: is.com_offset_prior_m.unwrap_or(drawn_r),
                }
            })
            .collect()
    }

    /// Check every value; the first problem found is returned, naming its key.
    pub fn validated(self) -> Result<Self, ScenarioError> {
        self.validate()?;
        Ok(self)
    }

    fn validate(&self) -> Result<(), ScenarioError> {
        let err = |k: &str, m: &str| Err(ScenarioError(format!("`{k}`: {m}")));
        let pos = |k: &str, v: f64| -> Result<(), ScenarioError> {
            if !v.is_finite() {
                return err(k, &format!("must be finite, got {v}"));
            }
            if v <= 0.0 {
                return err(k, &format!("must be positive, got {v}"));
            }
            Ok(())
        };
        let nonneg = |k: &str, v: f64| -> Result<(), ScenarioError> {
            if !v.is_finite() || v < 0.0 {
                return err(k, &format!("must be finite and ≥ 0, got {v}"));
            }
            Ok(())
        };
        if self.name.is_empty() {
            return err("name", "must not be empty");
        }
        if self.name.chars().any(char::is_control) {
            return err(
                "name",
                "must be one line of text (no newline or other control character)",
            );
        }
        pos("duration_s", self.duration_s)?;
        pos("sample_rate_hz", self.sample_rate_hz)?;
        if self.n_samples() < 100 {
            return err(
                "duration_s",
                "gives fewer than 100 samples at sample_rate_hz",
            );
        }
        if self.duration_s > MAX_DURATION_S {
            return err(
                "duration_s",
                &format!(
                    "{} s is beyond the longest campaign the estimator is verified for ({MAX_DURATION_S:.0} s)",
                    self.duration_s
                ),
            );
        }
        if self.n_samples() > 100_000_000 {
            return err("duration_s", "gives more than 10^8 samples; shorten it");
        }
        let inertia = &self.spacecraft.inertia_kg_m2;
        for (i, row) in inertia.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                if !v.is_finite() {
                    return err(
                        "spacecraft.inertia_kg_m2",
                        &format!("element [{i}][{j}] is {v}"),
                    );
                }
                if (v - inertia[j][i]).abs() > 1e-9 * v.abs().max(1.0) {
                    return err("spacecraft.inertia_kg_m2", "must be symmetric");
                }
            }
        }
        let m = nalgebra::Matrix3::from_fn(|i, j| inertia[i][j]);
        if m.cholesky().is_none() {
            return err("spacecraft.inertia_kg_m2", "must be positive definite");
        }
        pos("spacecraft.mass_kg", self.spacecraft.mass_kg)?;
        nonneg(
            "spacecraft.attitude_hold_hz",
            self.spacecraft.attitude_hold_hz,
        )?;
        if self.spacecraft.attitude_hold_hz * 10.0 > self.maneuver.frequency_hz {
            return err(
                "spacecraft.attitude_hold_hz",
                "must stay below a tenth of maneuver.frequency_hz (the hold would fight the rocking)",
            );
        }

        let mv = &self.maneuver;
        pos("maneuver.frequency_hz", mv.frequency_hz)?;
        for (a, v) in mv.torque_amplitude_nm.iter().enumerate() {
            if !v.is_finite() || *v < 0.0 {
                return err(
                    "maneuver.torque_amplitude_nm",
                    &format!("axis {a}: must be ≥ 0, got {v}"),
                );
            }
        }
        let order: Vec<char> = mv.axis_order.chars().collect();
        let mut sorted = order.clone();
        sorted.sort_unstable();
        if sorted != ['x', 'y', 'z'] {
            return err(
                "maneuver.axis_order",
                "must name each of x, y, z once, e.g. \"xyz\"",
            );
        }
        if self.periods_per_axis() == 0 {
            return err(
                "maneuver.frequency_hz",
                &format!(
                    "a period ({} s) does not fit three times into duration_s = {}",
                    1.0 / mv.frequency_hz,
                    self.duration_s
                ),
            );
        }
        if 2.0 * mv.frequency_hz * 4.0 > self.sample_rate_hz {
            return err("maneuver.frequency_hz", "must be below sample_rate_hz / 8");
        }

        if let Err((k, m)) = self.faults.validate() {
            return err(&k, &m);
        }
        let th = &self.thruster;
        pos("thruster.response_time_s", th.response_time_s)?;
        if th.response_time_s > 5e-3 {
            return err("thruster.response_time_s", "must be ≤ 5 ms (§3.1)");
        }
        nonneg("thruster.torque_noise_nm_rthz", th.torque_noise_nm_rthz)?;
        nonneg("thruster.edge_jitter_s", th.edge_jitter_s)?;
        if 2.0 * th.edge_jitter_s >= self.dt() {
            return err(
                "thruster.edge_jitter_s",
                "must be below half a sample interval",
            );
        }
        nonneg("thruster.amplitude_jitter_rel", th.amplitude_jitter_rel)?;
        if th.amplitude_jitter_rel > 0.2 {
            return err("thruster.amplitude_jitter_rel", "must be ≤ 0.2");
        }
        nonneg("thruster.overshoot_rel", th.overshoot_rel)?;
        pos("thruster.overshoot_decay_s", th.overshoot_decay_s)?;
        nonneg("thruster.force_noise_n_rthz", th.force_noise_n_rthz)?;

        let st = &self.star_tracker;
        pos("star_tracker.rate_hz", st.rate_hz)?;
        if st.rate_hz > self.sample_rate_hz {
            return err("star_tracker.rate_hz", "must not exceed sample_rate_hz");
        }
        pos("star_tracker.noise_3sigma_arcsec", st.noise_3sigma_arcsec)?;
        for (i, o) in st.outages_s.iter().enumerate() {
            if !(o[0].is_finite() && o[1].is_finite() && o[0] <= o[1]) {
                return err(
                    "star_tracker.outages_s",
                    &format!("interval {i} must be [start, end] with start ≤ end"),
                );
            }
        }

        let srp = &self.srp;
        pos("srp.asd_at_3mhz", srp.asd_at_3mhz)?;
        pos("srp.dc_m_s2", srp.dc_m_s2)?;
        // The estimator learns the direction of the coloured SRP noise from the DC SRP
        // it measures; that needs the DC to dominate the fluctuation (verified down to
        // ~9× the ASD at 3 mHz; it fails at ~1×). Any sunlit spacecraft has ≳1e-8 m/s².
        if srp.dc_m_s2 < SRP_DC_OVER_ASD * srp.asd_at_3mhz {
            return err(
                "srp.dc_m_s2",
                &format!(
                    "the DC SRP must be at least {SRP_DC_OVER_ASD}× srp.asd_at_3mhz (×1 Hz^½) = {:.2e} m/s², \
                     got {:.2e}: the estimator takes the SRP noise direction from the DC",
                    SRP_DC_OVER_ASD * srp.asd_at_3mhz,
                    srp.dc_m_s2
                ),
            );
        }
        let s = srp.sun_direction_b;
        if s.iter().any(|v| !v.is_finite()) || s.iter().map(|v| v * v).sum::<f64>() < 1e-12 {
            return err("srp.sun_direction_b", "must be a finite non-zero vector");
        }

        let fe = &self.front_end;
        nonneg("front_end.ripple_rthz", fe.ripple_rthz)?;
        pos("front_end.linear_noise_rthz", fe.linear_noise_rthz)?;
        pos("front_end.angular_noise_rthz", fe.angular_noise_rthz)?;
        pos("front_end.full_scale_m_s2", fe.full_scale_m_s2)?;
        pos("front_end.full_scale_rad_s2", fe.full_scale_rad_s2)?;
        pos("front_end.maneuver_limit_m_s2", fe.maneuver_limit_m_s2)?;
        if srp.dc_m_s2 >= fe.full_scale_m_s2 {
            return err(
                "srp.dc_m_s2",
                "the DC SRP must fit in front_end.full_scale_m_s2",
            );
        }

        let gc = &self.ground_calibration;
        nonneg("ground_calibration.beta_rel_error", gc.beta_rel_error)?;
        if gc.beta_rel_error >= 0.5 {
            return err("ground_calibration.beta_rel_error", "must be < 0.5");
        }
        nonneg(
            "ground_calibration.com_offset_error_m",
            gc.com_offset_error_m,
        )?;

        if self.inertial_sensor.is_empty() || self.inertial_sensor.len() > 2 {
            return err(
                "inertial_sensor",
                "give one or two [[inertial_sensor]] tables",
            );
        }
        for (i, is) in self.inertial_sensor.iter().enumerate() {
            let key = |k: &str| format!("inertial_sensor[{i}].{k}");
            for a in 0..3 {
                let r = is.com_offset_m[a];
                if !r.is_finite() || r.abs() > 2.0 {
                    return err(
                        &key("com_offset_m"),
                        &format!("component {a} = {r} m is not a plausible CoM offset (|r| ≤ 2 m)"),
                    );
                }
                pos(&key("beta"), is.beta[a])?;
                pos(&key("geometry_m"), is.geometry_m[a])?;
            }
            if let Some(bp) = is.beta_prior {
                for (a, v) in bp.iter().enumerate() {
                    pos(&key("beta_prior"), *v)?;
                    if (v / is.beta[a] - 1.0).abs() > 0.2 {
                        return err(&key("beta_prior"), &format!("axis {a} is more than 20 % off the truth; the ground calibration cannot be that wrong"));
                    }
                }
            }
            if let Some(rp) = is.com_offset_prior_m {
                for (a, v) in rp.iter().enumerate() {
                    if !v.is_finite() || (v - is.com_offset_m[a]).abs() > 0.05 {
                        return err(
                            &key("com_offset_prior_m"),
                            &format!("component {a} must be finite and within 5 cm of the truth"),
                        );
                    }
                }
            }
        }
        let peak = self.peak_maneuver_acceleration();
        if peak.1 > fe.maneuver_limit_m_s2 {
            return err(
                "maneuver.torque_amplitude_nm",
                &format!(
                    "the maneuver would drive |A r| of inertial_sensor[{}] to {:.3e} m/s², above the IS design limit front_end.maneuver_limit_m_s2 = {:.1e}; lower the torque",
                    peak.0, peak.1, fe.maneuver_limit_m_s2
                ),
            );
        }
        Ok(())
    }

    /// Whole square-wave periods per maneuver axis (the rest of the run is quiet).
    pub fn periods_per_axis(&self) -> u64 {
        (self.duration_s * self.maneuver.frequency_hz / 3.0).floor() as u64
    }

    /// Worst maneuver-induced TM acceleration |A(ω, ω̇) r| over the IS: (index, m/s²).
    /// Uses the peak torque with overshoot and 3σ amplitude jitter.
    pub fn peak_maneuver_acceleration(&self) -> (usize, f64) {
        use nalgebra::{Matrix3, Vector3};
        let inertia = Matrix3::from_fn(|i, j| self.spacecraft.inertia_kg_m2[i][j]);
        let Some(inv) = inertia.try_inverse() else {
            return (0, f64::INFINITY);
        };
        let th = &self.thruster;
        let boost = 1.0 + 3.0 * th.amplitude_jitter_rel + 2.0 * th.overshoot_rel;
        let quarter = 0.25 / self.maneuver.frequency_hz;
        let mut worst = (0, 0.0);
        for axis in 0..3 {
            let mut tau = Vector3::zeros();
            tau[axis] = self.maneuver.torque_amplitude_nm[axis] * boost;
            let wdot = inv * tau;
            let w = wdot * quarter;
            for (i, is) in self.inertial_sensor.iter().enumerate() {
                let r = Vector3::from(is.com_offset_m);
                let a = wdot.cross(&r).norm() + w.cross(&w.cross(&r)).norm();
                if a > worst.1 {
                    worst = (i, a);
                }
            }
        }
        worst
    }
}

impl Scenario {
    /// The estimator's table: priors, known geometry and noise specifications only —
    /// never the truths.
    pub fn estimator_config(&self, priors: &[Priors]) -> EstimatorConfig {
        let s = self;
        let fs = s.sample_rate_hz;
        let fe = &s.front_end;
        let mut c = EstimatorConfig {
            fs,
            n_is: s.inertial_sensor.len() as u64,
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
