//! Scenario file: what is simulated, with the paper's defaults (docs/physics.md
//! explains each quantity).
//!
//! Every key has a default; unknown keys, wrong types, non-finite or physically
//! impossible values are rejected with a message that names the key.

use crate::sim::estimate::EstimatorConfig;
use serde::{Deserialize, Serialize};
use taiji_core::model::noise::white_sigma;

mod check;
pub mod faults;
mod limits;
pub mod maneuver;
pub mod mission;

pub use check::{MAX_BETA_PRIOR_REL, MAX_COM_PRIOR_ERROR_M};
pub use mission::{CampaignDays, Drift, DriftStep, MissionTimeline};

/// Arc-second in radians.
pub const ARCSEC: f64 = std::f64::consts::PI / (180.0 * 3600.0);

/// Longest campaign [s] the estimator's honesty has been verified for (docs/integrity.md).
pub const MAX_DURATION_S: f64 = 1.0e6;

/// Least ratio of the DC SRP [m/s²] to its fluctuation ASD at 3 mHz [m s⁻² Hz^-½].
pub const SRP_DC_OVER_ASD: f64 = 250.0;

/// A scenario that failed to load or validate; the message names the file or the key.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// The file could not be read.
    #[error("cannot read scenario {}: {source}", path.display())]
    Read {
        path: std::path::PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// Not TOML, an unknown key or a value of the wrong type: one line, where
    /// (`at`, "line L, column C") and what.
    #[error("scenario is not valid: {at}: {}", toml_message(source))]
    Parse {
        at: String,
        #[source]
        source: Box<toml::de::Error>,
    },
    /// A value out of its range or at odds with another key.
    #[error("`{key}`: {msg}")]
    Key { key: String, msg: String },
    /// A problem in the scenario file `path`.
    #[error("{}: {source}", path.display())]
    InFile {
        path: std::path::PathBuf,
        #[source]
        source: Box<ScenarioError>,
    },
}

/// Where a TOML parser stopped, for a one-line error: "line L, column C (`the line`)",
/// 1-based; the line itself names the key (a type error's message does not).
pub fn toml_error_at(text: &str, e: &toml::de::Error) -> String {
    let Some(sp) = e.span() else {
        return "the file".to_string();
    };
    // A byte offset; never slice inside a character (no panic on any input).
    let mut end = sp.start.min(text.len());
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    let before = &text[..end];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    let src: String = text
        .lines()
        .nth(line - 1)
        .unwrap_or("")
        .trim()
        .chars()
        .take(60)
        .collect();
    format!("line {line}, column {col} (`{src}`)")
}

/// A TOML parser's message on one line.
pub fn toml_message(e: &toml::de::Error) -> String {
    e.message().trim_end().replace('\n', "; ")
}

impl ScenarioError {
    /// A problem with the value of `key`.
    pub fn key(key: impl Into<String>, msg: impl Into<String>) -> Self {
        ScenarioError::Key {
            key: key.into(),
            msg: msg.into(),
        }
    }
}

/// Where a campaign's priors come from (`priors_source`, also in report.json).
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PriorsSource {
    /// The scenario: its priors, or drawn from its truths with the
    /// ground-calibration error.
    #[default]
    Scenario,
    /// The onboard calibration table: a campaign's final estimate, applied.
    OnboardTable,
}

impl PriorsSource {
    pub fn is_scenario(&self) -> bool {
        *self == PriorsSource::Scenario
    }

    pub fn name(self) -> &'static str {
        match self {
            PriorsSource::Scenario => "scenario",
            PriorsSource::OnboardTable => "onboard_table",
        }
    }
}

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
    /// Where every IS's priors come from: the file (`beta_prior`, `com_offset_prior_m`,
    /// or drawn from the truth), or the onboard calibration table
    /// (`with_onboard_priors`), whose distance from the truth is not checked.
    #[serde(skip_serializing_if = "PriorsSource::is_scenario")]
    pub priors_source: PriorsSource,
    pub spacecraft: Spacecraft,
    pub maneuver: Maneuver,
    pub thruster: Thruster,
    pub star_tracker: StarTracker,
    pub srp: Srp,
    pub front_end: FrontEnd,
    pub ground_calibration: GroundCalibration,
    pub inertial_sensor: Vec<InertialSensor>,
    /// Injected faults (none by default).
    pub faults: faults::FaultsConfig,
    /// How the truths move with mission time (absent: they do not).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drift: Option<Drift>,
    /// The mission `taiji-calib timeline` flies (other commands ignore it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub timeline: Option<MissionTimeline>,
    /// Mission day at which this campaign starts (a timeline sets it; 0 otherwise).
    /// Not a key: with `[drift]` the truths are those of this epoch and on.
    #[serde(skip)]
    pub epoch_day: f64,
    /// Seed of the truths' history (`[drift]`'s random walks): the mission's, shared
    /// by its campaigns; `None`: the scenario's `seed`. Not a key.
    #[serde(skip)]
    pub mission_seed: Option<u64>,
    /// The maneuver is still to be planned (no waveform key was given); `plan::resolve`
    /// fills it in. Not a key: a written scenario carries its maneuver.
    #[serde(skip)]
    pub plan_pending: bool,
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

/// How the three axes share the window.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Schedule {
    /// One axis after the other, each for a third of the rocking time.
    Sequential,
    /// All axes at once, each at its own frequency (`frequency_ratio`), for the whole
    /// window: ratios 1, 2, 4 make the three square waves orthogonal.
    Simultaneous,
}

impl Schedule {
    pub fn name(self) -> &'static str {
        match self {
            Schedule::Sequential => "sequential",
            Schedule::Simultaneous => "simultaneous",
        }
    }
}

/// The calibration maneuver: square-wave torques, whole periods per axis. A scenario
/// that sets none of the waveform keys (`frequency_hz`, `torque_amplitude_nm`,
/// `axis_order`, `schedule`, `frequency_ratio`, `start_phase`, `start_s`,
/// `pause_in_outages`) gets the maneuver the planner chooses for its window
/// (`taiji-calib plan`, docs/planning.md); the limits below bind the planner too.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct Maneuver {
    /// Square-wave frequency [Hz] (simultaneous: of the axis whose ratio is 1).
    pub frequency_hz: f64,
    /// Torque amplitude per body axis [N m].
    pub torque_amplitude_nm: [f64; 3],
    /// Order in which the axes are rocked, one after the other (e.g. "xyz").
    pub axis_order: String,
    /// "sequential" or "simultaneous".
    pub schedule: Schedule,
    /// Simultaneous: each axis's frequency over `frequency_hz`.
    pub frequency_ratio: [f64; 3],
    /// Phase of the square wave at the start of every stretch, in periods [0, 1):
    /// 0 is the cosine phase (+A for T/4, −A for T/2, +A for T/4), which brings rate
    /// and angle back to zero every period; other phases let the angle drift.
    pub start_phase: f64,
    /// Quiet time before the rocking starts [s].
    pub start_s: f64,
    /// Rock only between star-tracker outages (`star_tracker.outages_s`): whole periods
    /// that would overlap one wait until it ends.
    pub pause_in_outages: bool,
    /// Largest attitude excursion allowed [rad]; 0: no limit.
    pub max_attitude_rad: f64,
    /// Largest body rate allowed [rad/s]; 0: no limit.
    pub max_rate_rad_s: f64,
    /// Set by the planner: this maneuver was planned, not written by hand.
    pub planned: bool,
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
    /// Largest torque the thrusters can apply per body axis [N m] (10⁻⁷–10⁻⁴, §3.1).
    pub max_torque_nm: f64,
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
            priors_source: PriorsSource::Scenario,
            spacecraft: Spacecraft::default(),
            maneuver: Maneuver::default(),
            thruster: Thruster::default(),
            star_tracker: StarTracker::default(),
            srp: Srp::default(),
            front_end: FrontEnd::default(),
            ground_calibration: GroundCalibration::default(),
            inertial_sensor: vec![is1, is2],
            faults: faults::FaultsConfig::default(),
            drift: None,
            timeline: None,
            epoch_day: 0.0,
            mission_seed: None,
            plan_pending: false,
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
        // The hand-made maneuver of the first CRLB study (docs/planning.md); a scenario
        // without waveform keys gets the planner's instead.
        Maneuver {
            frequency_hz: 1.0e-3,
            torque_amplitude_nm: [2.5e-6; 3],
            axis_order: "xyz".into(),
            schedule: Schedule::Sequential,
            frequency_ratio: [1.0, 2.0, 4.0],
            start_phase: 0.0,
            start_s: 0.0,
            pause_in_outages: false,
            max_attitude_rad: 0.0,
            max_rate_rad_s: 0.0,
            planned: false,
        }
    }
}

/// The waveform keys of `[maneuver]`: a file that sets none of them is planned.
pub const WAVEFORM_KEYS: [&str; 8] = [
    "maneuver.frequency_hz",
    "maneuver.torque_amplitude_nm",
    "maneuver.axis_order",
    "maneuver.schedule",
    "maneuver.frequency_ratio",
    "maneuver.start_phase",
    "maneuver.start_s",
    "maneuver.pause_in_outages",
];

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
            max_torque_nm: 1.0e-4,
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

pub use crate::sim::estimate::config::k_from_beta;

/// Ground-calibration priors of one IS, as the estimator receives them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Priors {
    pub beta: [f64; 3],
    pub com_offset_m: [f64; 3],
}

impl Scenario {
    /// Sample interval [s].
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
        let mut rng = crate::sim::rng::stream(self.seed, crate::sim::rng::Stream::Priors);
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
}

impl Scenario {
    /// The campaign that starts from the onboard calibration table: every IS's
    /// `beta_prior` and `com_offset_prior_m` are the table's β and r (IS i from the
    /// table's row i), `priors_source` says so. Nothing else changes: call it on the
    /// resolved scenario (`plan::resolve`), so that the maneuver stays the one planned
    /// for the file; `ground_calibration`'s errors stay the planner's margin and the
    /// yardstick of "not better than the ground calibration". The estimator's prior
    /// widths are its own (5 % of β, 5 cm of r), not the table's σ. Validation then
    /// checks the priors are finite (β positive), not how far they are from the truth,
    /// which onboard nothing knows.
    pub fn with_onboard_priors(&self, t: &crate::sim::msg::TableValues) -> Scenario {
        let mut s = self.clone();
        for (i, is) in s.inertial_sensor.iter_mut().enumerate().take(t.beta.len()) {
            is.beta_prior = Some(t.beta[i]);
            is.com_offset_prior_m = Some(t.r[i]);
        }
        s.priors_source = PriorsSource::OnboardTable;
        s
    }

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
            gate_sigma: EstimatorConfig::GATE_SIGMA,
            star_gate_sigma: EstimatorConfig::STAR_GATE_SIGMA,
            chi2_tolerance: EstimatorConfig::CHI2_TOLERANCE,
            degraded_one_in: EstimatorConfig::DEGRADED_ONE_IN,
        };
        for (i, (is, p)) in s.inertial_sensor.iter().zip(priors).enumerate() {
            c.geometry_m[i] = is.geometry_m;
            c.beta_prior[i] = p.beta;
            c.com_prior_m[i] = p.com_offset_m;
        }
        c
    }
}
