//! Loading and checking a scenario: TOML in, every key checked against its range and
//! against the others (the maneuver against the IS design limits and the sample
//! rate), the first problem named by its key. Above the schema (`super`) and the
//! maneuver's derived physics (`crate::maneuver`), which both sit below it.

use super::*;
use crate::sim::scenario::maneuver::{
    axis_frequencies, round_down_4, torque_boost, Envelope, Timeline,
};
use std::path::Path;

/// The farthest β's prior may be from the truth, relative: as far as the estimator
/// acquires β (measured over 20 seeds each: every run met the requirements with honest
/// σ at 0.12; at 0.15 eight runs of ten ended UNVERIFIED, the gates having rejected
/// the samples that would have corrected β), with a margin.
pub const MAX_BETA_PRIOR_REL: f64 = 0.1;
/// Farthest r's prior may be from the truth, per component [m]: the schema's limit, as
/// far as the estimator's first solves were tried from.
pub const MAX_COM_PRIOR_ERROR_M: f64 = 0.05;

/// The error of a value out of range, naming its key.
fn err<T>(key: &str, msg: &str) -> Result<T, ScenarioError> {
    Err(ScenarioError::key(key, msg))
}

/// `v` must be finite and positive.
fn pos(key: &str, v: f64) -> Result<(), ScenarioError> {
    if !v.is_finite() {
        return err(key, &format!("must be finite, got {v}"));
    }
    if v <= 0.0 {
        return err(key, &format!("must be positive, got {v}"));
    }
    Ok(())
}

/// `v` must be finite and ≥ 0.
fn nonneg(key: &str, v: f64) -> Result<(), ScenarioError> {
    if !v.is_finite() || v < 0.0 {
        return err(key, &format!("must be finite and ≥ 0, got {v}"));
    }
    Ok(())
}

/// `given(key)`: the file sets this dotted key.
type Given<'a> = &'a dyn Fn(&str) -> bool;

/// Of two keys in one check: the second only when the file sets it and not the first.
fn blame_second(given: Given, first: &str, second: &str) -> bool {
    given(second) && !given(first)
}

impl Scenario {
    /// Parse and validate a TOML text.
    pub fn from_toml_str(text: &str) -> Result<Self, ScenarioError> {
        let mut s: Scenario = toml::from_str(text).map_err(|source| ScenarioError::Parse {
            at: super::toml_error_at(text, &source),
            source: Box::new(source),
        })?;
        let given = keys_set(text);
        s.plan_pending = !WAVEFORM_KEYS.iter().any(|k| given.iter().any(|g| g == k));
        s.validate(&|k| given.iter().any(|g| g == k))?;
        Ok(s)
    }

    /// Load a scenario file; the error names the file, the key and the problem.
    pub fn load(path: &Path) -> Result<Self, ScenarioError> {
        let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_toml_str(&text).map_err(|e| ScenarioError::InFile {
            path: path.to_path_buf(),
            source: Box::new(e),
        })
    }

    /// Load `path` if given, else the built-in default (the paper's case; its maneuver
    /// is planned, as for any scenario without one).
    pub fn load_or_default(path: Option<&Path>) -> Result<Self, ScenarioError> {
        match path {
            Some(p) => Self::load(p),
            None => Scenario {
                plan_pending: true,
                ..Scenario::default()
            }
            .validated(),
        }
    }

    /// Check every value; the first problem found is returned, naming its key. With no
    /// file behind the values, a check between two keys names the first and mentions both.
    pub fn validated(self) -> Result<Self, ScenarioError> {
        self.validate(&|_| false)?;
        Ok(self)
    }

    /// `given(key)`: the file sets this dotted key. A check between two keys blames the
    /// one the user wrote, not its partner left at its default. Section by section, in
    /// the order of the file's documentation.
    fn validate(&self, given: Given) -> Result<(), ScenarioError> {
        self.validate_name_and_window()?;
        self.validate_spacecraft()?;
        self.faults.validate()?;
        self.validate_thruster()?;
        self.validate_star_tracker(given)?;
        self.validate_srp(given)?;
        self.validate_front_end(given)?;
        self.validate_ground_calibration()?;
        self.validate_inertial_sensors()?;
        nonneg("maneuver.max_attitude_rad", self.maneuver.max_attitude_rad)?;
        nonneg("maneuver.max_rate_rad_s", self.maneuver.max_rate_rad_s)?;
        pos("thruster.max_torque_nm", self.thruster.max_torque_nm)?;
        if self.plan_pending {
            // The planner picks the waveform; its result is checked here again.
            return Ok(());
        }
        self.validate_maneuver(given)
    }

    /// `name`, `duration_s` and `sample_rate_hz` on their own.
    fn validate_name_and_window(&self) -> Result<(), ScenarioError> {
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
        if self.duration_s > MAX_DURATION_S {
            return err(
                "duration_s",
                &format!(
                    "{} s is beyond the longest campaign the estimator is verified for ({MAX_DURATION_S:.0} s)",
                    self.duration_s
                ),
            );
        }
        Ok(())
    }

    /// `[spacecraft]`: a symmetric positive definite inertia, the mass, the hold.
    fn validate_spacecraft(&self) -> Result<(), ScenarioError> {
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
        )
    }

    /// `[thruster]`: response, noise, jitter and overshoot.
    fn validate_thruster(&self) -> Result<(), ScenarioError> {
        let th = &self.thruster;
        pos("thruster.response_time_s", th.response_time_s)?;
        if th.response_time_s > 5e-3 {
            return err("thruster.response_time_s", "must be ≤ 5 ms (§3.1)");
        }
        nonneg("thruster.torque_noise_nm_rthz", th.torque_noise_nm_rthz)?;
        nonneg("thruster.edge_jitter_s", th.edge_jitter_s)?;
        nonneg("thruster.amplitude_jitter_rel", th.amplitude_jitter_rel)?;
        if th.amplitude_jitter_rel > 0.2 {
            return err("thruster.amplitude_jitter_rel", "must be ≤ 0.2");
        }
        nonneg("thruster.overshoot_rel", th.overshoot_rel)?;
        pos("thruster.overshoot_decay_s", th.overshoot_decay_s)?;
        nonneg("thruster.force_noise_n_rthz", th.force_noise_n_rthz)
    }

    /// `[star_tracker]`, with the sample rate's bounds (the tracker's rate is one).
    fn validate_star_tracker(&self, given: Given) -> Result<(), ScenarioError> {
        let st = &self.star_tracker;
        pos("star_tracker.rate_hz", st.rate_hz)?;
        self.check_sample_rate(given)?;
        pos("star_tracker.noise_3sigma_arcsec", st.noise_3sigma_arcsec)?;
        for (i, o) in st.outages_s.iter().enumerate() {
            if !(o[0].is_finite() && o[1].is_finite() && o[0] <= o[1]) {
                return err(
                    "star_tracker.outages_s",
                    &format!("interval {i} must be [start, end] with start ≤ end"),
                );
            }
        }
        Ok(())
    }

    /// `[srp]`: the DC must dominate the fluctuation; a non-zero sun direction.
    fn validate_srp(&self, given: Given) -> Result<(), ScenarioError> {
        let srp = &self.srp;
        pos("srp.asd_at_3mhz", srp.asd_at_3mhz)?;
        pos("srp.dc_m_s2", srp.dc_m_s2)?;
        // The estimator learns the direction of the coloured SRP noise from the DC SRP
        // it measures; that needs the DC to dominate the fluctuation. σ stays honest
        // down to ~250× the ASD at 3 mHz (30 seeds: r's mean (err/σ)² 1.15–1.48 at
        // 270×, 1.8–2.0 at 100×, 2.7 at 27×; requirements are met far below). Any
        // sunlit spacecraft has ≳1e-8 m/s², ~10³× the default ASD.
        if srp.dc_m_s2 < SRP_DC_OVER_ASD * srp.asd_at_3mhz {
            if blame_second(given, "srp.dc_m_s2", "srp.asd_at_3mhz") {
                return err(
                    "srp.asd_at_3mhz",
                    &format!(
                        "{:.2e} m s⁻² Hz^-½ is too large for the DC SRP srp.dc_m_s2 = {:.2e} m/s²: it must be at most srp.dc_m_s2 / {SRP_DC_OVER_ASD} = {:.2e} (the estimator takes the SRP noise direction from the DC)",
                        srp.asd_at_3mhz,
                        srp.dc_m_s2,
                        srp.dc_m_s2 / SRP_DC_OVER_ASD
                    ),
                );
            }
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
        Ok(())
    }

    /// `[front_end]`: noise and ranges; the DC SRP must fit in the linear range.
    fn validate_front_end(&self, given: Given) -> Result<(), ScenarioError> {
        let (fe, srp) = (&self.front_end, &self.srp);
        nonneg("front_end.ripple_rthz", fe.ripple_rthz)?;
        pos("front_end.linear_noise_rthz", fe.linear_noise_rthz)?;
        pos("front_end.angular_noise_rthz", fe.angular_noise_rthz)?;
        pos("front_end.full_scale_m_s2", fe.full_scale_m_s2)?;
        pos("front_end.full_scale_rad_s2", fe.full_scale_rad_s2)?;
        pos("front_end.maneuver_limit_m_s2", fe.maneuver_limit_m_s2)?;
        if srp.dc_m_s2 >= fe.full_scale_m_s2 {
            return if blame_second(given, "srp.dc_m_s2", "front_end.full_scale_m_s2") {
                err(
                    "front_end.full_scale_m_s2",
                    &format!(
                        "{:.2e} m/s² must exceed the DC SRP srp.dc_m_s2 = {:.2e} m/s², which every linear channel measures",
                        fe.full_scale_m_s2, srp.dc_m_s2
                    ),
                )
            } else {
                err(
                    "srp.dc_m_s2",
                    &format!(
                        "the DC SRP ({:.2e} m/s²) must fit in front_end.full_scale_m_s2 = {:.2e} m/s²",
                        srp.dc_m_s2, fe.full_scale_m_s2
                    ),
                )
            };
        }
        Ok(())
    }

    /// `[ground_calibration]`: the priors' errors.
    fn validate_ground_calibration(&self) -> Result<(), ScenarioError> {
        let gc = &self.ground_calibration;
        nonneg("ground_calibration.beta_rel_error", gc.beta_rel_error)?;
        if gc.beta_rel_error > MAX_BETA_PRIOR_REL {
            return err(
                "ground_calibration.beta_rel_error",
                &format!(
                    "{} is more than the estimator acquires: β's prior may be at most {} off (10 %); farther, its gates reject the samples that would correct it",
                    gc.beta_rel_error, MAX_BETA_PRIOR_REL
                ),
            );
        }
        nonneg(
            "ground_calibration.com_offset_error_m",
            gc.com_offset_error_m,
        )?;
        if gc.com_offset_error_m > MAX_COM_PRIOR_ERROR_M {
            return err(
                "ground_calibration.com_offset_error_m",
                &format!(
                    "{} m is more than a prior may be off: r's prior may be at most {} m (5 cm) from the truth per component, as inertial_sensor[i].com_offset_prior_m",
                    gc.com_offset_error_m, MAX_COM_PRIOR_ERROR_M
                ),
            );
        }
        Ok(())
    }

    /// `[[inertial_sensor]]`: one or two, each with plausible offsets and priors.
    fn validate_inertial_sensors(&self) -> Result<(), ScenarioError> {
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
                if !r.is_finite() {
                    return err(
                        &key("com_offset_m"),
                        &format!("component {a} = {r} is not a finite number of metres"),
                    );
                }
                if r.abs() > 2.0 {
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
                    if (v / is.beta[a] - 1.0).abs() > MAX_BETA_PRIOR_REL {
                        return err(&key("beta_prior"), &format!("axis {a} is {:.1} % off the truth {} = {:e}: more than the estimator acquires (at most 10 %; farther, its gates reject the samples that would correct it)", 100.0 * (v / is.beta[a] - 1.0).abs(), key("beta"), is.beta[a]));
                    }
                }
            }
            if let Some(rp) = is.com_offset_prior_m {
                for (a, v) in rp.iter().enumerate() {
                    if !v.is_finite() || (v - is.com_offset_m[a]).abs() > MAX_COM_PRIOR_ERROR_M {
                        return err(
                            &key("com_offset_prior_m"),
                            &format!(
                                "component {a} must be finite and within 5 cm of the truth {} = {} m",
                                key("com_offset_m"),
                                is.com_offset_m[a]
                            ),
                        );
                    }
                }
            }
        }
        Ok(())
    }

    /// The maneuver's own checks: its keys, its fit in the window, the thrusters' torque,
    /// the attitude and rate limits and the IS design limit on |A r| at the true offsets.
    fn validate_maneuver(&self, given: Given) -> Result<(), ScenarioError> {
        self.validate_waveform(given)?;
        let timeline = self.timeline(given)?;
        let boost = torque_boost(self);
        self.check_peak_torque(given, boost)?;
        let inertia = nalgebra::Matrix3::from_fn(|i, j| self.spacecraft.inertia_kg_m2[i][j]);
        let env = timeline.envelope(&inertia);
        self.check_attitude_and_rate(&env, boost)?;
        self.check_is_range(given, &env, &inertia, boost)
    }

    /// The waveform keys of `[maneuver]` on their own, and its frequencies against the
    /// attitude hold.
    fn validate_waveform(&self, given: Given) -> Result<(), ScenarioError> {
        let mv = &self.maneuver;
        if !mv.frequency_hz.is_finite() || mv.frequency_hz <= 0.0 {
            return err(
                "maneuver.frequency_hz",
                &format!("must be positive, got {}", mv.frequency_hz),
            );
        }
        for (a, r) in mv.frequency_ratio.iter().enumerate() {
            if !r.is_finite() || *r <= 0.0 {
                return err(
                    "maneuver.frequency_ratio",
                    &format!("axis {a}: must be positive, got {r}"),
                );
            }
        }
        if !(0.0..1.0).contains(&mv.start_phase) {
            return err(
                "maneuver.start_phase",
                &format!("must be in [0, 1) periods, got {}", mv.start_phase),
            );
        }
        if !mv.start_s.is_finite() || mv.start_s < 0.0 || mv.start_s >= self.duration_s {
            return err(
                "maneuver.start_s",
                &format!(
                    "must be ≥ 0 and before the end of duration_s = {} s, got {}",
                    self.duration_s, mv.start_s
                ),
            );
        }
        let lowest = axis_frequencies(self)
            .into_iter()
            .fold(f64::INFINITY, f64::min);
        let hold = self.spacecraft.attitude_hold_hz;
        if hold * 10.0 > lowest {
            return if blame_second(
                given,
                "spacecraft.attitude_hold_hz",
                "maneuver.frequency_hz",
            ) {
                err(
                    "maneuver.frequency_hz",
                    &format!(
                        "{} Hz must be at least 10 × spacecraft.attitude_hold_hz = {} Hz on every axis (the attitude hold would fight the rocking)",
                        mv.frequency_hz,
                        sig4(10.0 * hold, true)
                    ),
                )
            } else {
                err(
                    "spacecraft.attitude_hold_hz",
                    &format!(
                        "{hold} Hz must stay below a tenth of the slowest maneuver frequency, {} Hz (the hold would fight the rocking)",
                        sig4(lowest / 10.0, false)
                    ),
                )
            };
        }
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
        Ok(())
    }

    /// The maneuver's timeline; the error when its periods do not fit in the window.
    fn timeline(&self, given: Given) -> Result<Timeline, ScenarioError> {
        let mv = &self.maneuver;
        let no = match Timeline::new(self) {
            Ok(t) => return Ok(t),
            Err(no) => no,
        };
        let what = match mv.schedule {
            Schedule::Sequential => "three periods (one per axis, one after the other)",
            Schedule::Simultaneous => "one period of every axis",
        };
        let quiet = if mv.start_s > 0.0 || mv.pause_in_outages {
            " after maneuver.start_s and outside the paused outages"
        } else {
            ""
        };
        if blame_second(given, "maneuver.frequency_hz", "duration_s") {
            err(
                "duration_s",
                &format!(
                    "{} s does not hold {what}{quiet}: axis {} has a period of {} s",
                    self.duration_s,
                    ["x", "y", "z"][no.axis],
                    sig4(no.period_s, true)
                ),
            )
        } else {
            err(
                "maneuver.frequency_hz",
                &format!(
                    "a period ({} s on axis {}) does not fit: duration_s = {} s must hold {what}{quiet}; raise the frequency, or leave [maneuver] out to have it planned",
                    sig4(no.period_s, true),
                    ["x", "y", "z"][no.axis],
                    self.duration_s,
                ),
            )
        }
    }

    /// The commanded torque, with overshoot and jitter (`boost`), within the thrusters'.
    fn check_peak_torque(&self, given: Given, boost: f64) -> Result<(), ScenarioError> {
        let mv = &self.maneuver;
        let peak_cmd = mv.torque_amplitude_nm.iter().fold(0.0f64, |m, v| m.max(*v));
        if peak_cmd * boost > self.thruster.max_torque_nm {
            return err(
                if given("thruster.max_torque_nm") && !given("maneuver.torque_amplitude_nm") {
                    "thruster.max_torque_nm"
                } else {
                    "maneuver.torque_amplitude_nm"
                },
                &format!(
                    "{peak_cmd:.3e} N m, with overshoot and 3σ amplitude jitter {:.3e} N m, exceeds the thrusters' maximum thruster.max_torque_nm = {:.3e} N m",
                    peak_cmd * boost,
                    self.thruster.max_torque_nm
                ),
            );
        }
        Ok(())
    }

    /// The maneuver's peak attitude and rate within `maneuver.max_attitude_rad` and
    /// `maneuver.max_rate_rad_s` (0: no limit).
    fn check_attitude_and_rate(&self, env: &Envelope, boost: f64) -> Result<(), ScenarioError> {
        let mv = &self.maneuver;
        if mv.max_attitude_rad > 0.0 && env.peak_attitude_rad * boost > mv.max_attitude_rad {
            return err(
                "maneuver.max_attitude_rad",
                &format!(
                    "the maneuver turns the spacecraft by up to {:.3e} rad (with 3σ jitter and overshoot), beyond this limit of {:.3e} rad; lower maneuver.torque_amplitude_nm or raise maneuver.frequency_hz",
                    env.peak_attitude_rad * boost,
                    mv.max_attitude_rad
                ),
            );
        }
        if mv.max_rate_rad_s > 0.0 && env.peak_rate_rad_s * boost > mv.max_rate_rad_s {
            return err(
                "maneuver.max_rate_rad_s",
                &format!(
                    "the maneuver turns the spacecraft at up to {:.3e} rad/s (with 3σ jitter and overshoot), beyond this limit of {:.3e} rad/s",
                    env.peak_rate_rad_s * boost,
                    mv.max_rate_rad_s
                ),
            );
        }
        Ok(())
    }

    /// The IS design limit on |A r| at the true offsets; the error names the torque
    /// that would fit.
    fn check_is_range(
        &self,
        given: Given,
        env: &Envelope,
        inertia: &nalgebra::Matrix3<f64>,
        boost: f64,
    ) -> Result<(), ScenarioError> {
        let truths: Vec<nalgebra::Vector3<f64>> = self
            .inertial_sensor
            .iter()
            .map(|is| nalgebra::Vector3::from(is.com_offset_m))
            .collect();
        let peak = env.peak_acceleration(&truths, boost);
        let limit = self.front_end.maneuver_limit_m_s2;
        if peak.1 <= limit {
            return Ok(());
        }
        if self.maneuver.planned {
            return Err(self.planned_over_range(peak));
        }
        let within = self.torque_within_range(env, inertia, &truths, boost);
        let offset = format!("inertial_sensor[{}].com_offset_m", peak.0);
        // Whichever of the keys behind |A r| the file sets, the torque first.
        let key = [
            "maneuver.torque_amplitude_nm",
            "maneuver.frequency_hz",
            offset.as_str(),
            "spacecraft.inertia_kg_m2",
            "front_end.maneuver_limit_m_s2",
        ]
        .into_iter()
        .find(|k| given(k))
        .unwrap_or("maneuver.torque_amplitude_nm");
        err(
            key,
            &format!(
                "the maneuver would drive |A r| of inertial_sensor[{}] to {:.3e} m/s², above the IS design limit front_end.maneuver_limit_m_s2 = {:.1e}; with this inertia, frequency and {offset}, maneuver.torque_amplitude_nm must be {within} (or leave the waveform keys out to have the maneuver planned)",
                peak.0,
                peak.1,
                limit,
            ),
        )
    }

    /// A planned maneuver over the IS range at the true offsets: the planner sized it
    /// for every offset within `ground_calibration.com_offset_error_m` of the priors
    /// (`plan::offset_corners`), so a truth that overshoots lies outside that
    /// uncertainty. The error says so, and what to change: never the waveform keys the
    /// user left out.
    fn planned_over_range(&self, peak: (usize, f64)) -> ScenarioError {
        let (i, acc) = peak;
        let e = self.ground_calibration.com_offset_error_m;
        let is = &self.inertial_sensor[i];
        let prior = self.priors()[i].com_offset_m;
        let far = (0..3)
            .map(|a| (is.com_offset_m[a] - prior[a]).abs())
            .fold(0.0, f64::max);
        let key = format!("inertial_sensor[{i}].com_offset_prior_m");
        ScenarioError::key(
            &key,
            format!(
                "the planned maneuver keeps |A r| within front_end.maneuver_limit_m_s2 = {:.1e} m/s² for every CoM offset within ground_calibration.com_offset_error_m = {:.2} mm of the priors, but inertial_sensor[{i}].com_offset_m is {:.2} mm from its prior, outside that uncertainty, and would drive |A r| to {acc:.3e} m/s²; raise ground_calibration.com_offset_error_m to at least {:.2} mm (the plan then leaves room for it), or give a com_offset_prior_m nearer the truth",
                self.front_end.maneuver_limit_m_s2,
                e * 1e3,
                far * 1e3,
                far * 1e3
            ),
        )
    }

    /// The torque that keeps |A r| within the IS range, as the error words it.
    fn torque_within_range(
        &self,
        env: &Envelope,
        inertia: &nalgebra::Matrix3<f64>,
        truths: &[nalgebra::Vector3<f64>],
        boost: f64,
    ) -> String {
        let mv = &self.maneuver;
        let limit = self.front_end.maneuver_limit_m_s2;
        match mv.schedule {
            // The axes take turns: each axis's own largest torque, where it overshoots.
            Schedule::Sequential => (0..3)
                .filter_map(|a| {
                    let mut one = self.clone();
                    one.maneuver.torque_amplitude_nm = [0.0; 3];
                    one.maneuver.torque_amplitude_nm[a] = mv.torque_amplitude_nm[a];
                    let env = Timeline::new(&one).ok()?.envelope(inertia);
                    (env.peak_acceleration(truths, boost).1 > limit).then(|| {
                        let t = round_down_4(
                            env.largest_scale(truths, limit, boost) / boost
                                * mv.torque_amplitude_nm[a],
                        );
                        format!("on axis {} at most {t:.3e} N m", ["x", "y", "z"][a])
                    })
                })
                .collect::<Vec<_>>()
                .join(", "),
            Schedule::Simultaneous => {
                let fits = env.largest_scale(truths, limit, boost) / boost;
                let t: Vec<String> = mv
                    .torque_amplitude_nm
                    .iter()
                    .map(|t| format!("{:.3e}", round_down_4(t * fits)))
                    .collect();
                format!("at most [{}] N m", t.join(", "))
            }
        }
    }

    /// The checks between `sample_rate_hz` and the keys that bound it. The file's
    /// `sample_rate_hz` (or, with neither key set, the rate) is blamed, with the range
    /// the other settings allow; a partner key that the file sets alone is blamed instead.
    fn check_sample_rate(&self, given: Given) -> Result<(), ScenarioError> {
        let bounds = self.rate_bounds();
        let Some(first) = bounds.iter().find(|b| b.violated) else {
            return Ok(());
        };
        if given(first.partner) && !given("sample_rate_hz") {
            return err(first.partner, &first.partner_msg);
        }
        let tightest = |low: bool| {
            let side = bounds.iter().filter(|b| b.low == low);
            if low {
                side.max_by(|a, b| a.limit.total_cmp(&b.limit))
            } else {
                side.min_by(|a, b| a.limit.total_cmp(&b.limit))
            }
        };
        let (Some(lo), Some(hi)) = (tightest(true), tightest(false)) else {
            return err("sample_rate_hz", &first.why);
        };
        let upper = |b: &RateBound| {
            let op = if b.strict { "below" } else { "at most" };
            format!("{op} {} Hz", sig4(b.limit, false))
        };
        let lower = |b: &RateBound| format!("at least {} Hz", sig4(b.limit, true));
        let (bad, other) = if first.low { (lo, hi) } else { (hi, lo) };
        let need = if first.low { lower(bad) } else { upper(bad) };
        let fits = lo.limit < hi.limit || (lo.limit == hi.limit && !hi.strict);
        let rest = if fits {
            format!(
                "these settings allow {} Hz to {}{} Hz (the {} bound because {})",
                sig4(lo.limit, true),
                if hi.strict { "just below " } else { "" },
                sig4(hi.limit, false),
                if first.low { "upper" } else { "lower" },
                other.why
            )
        } else {
            format!(
                "no sample rate fits these settings, since it must also be {} because {}; change one of those keys",
                if first.low { upper(other) } else { lower(other) },
                other.why
            )
        };
        err(
            "sample_rate_hz",
            &format!(
                "{} Hz is too {}: it must be {need} because {}; {rest}",
                self.sample_rate_hz,
                if first.low { "low" } else { "high" },
                bad.why
            ),
        )
    }

    /// Every bound the other settings put on `sample_rate_hz`, in the order checked.
    fn rate_bounds(&self) -> Vec<RateBound> {
        let (fs, d) = (self.sample_rate_hz, self.duration_s);
        // The fastest axis; a maneuver still to be planned keeps to this bound itself.
        let f = if self.plan_pending {
            0.0
        } else {
            crate::sim::scenario::maneuver::axis_frequencies(self)
                .into_iter()
                .fold(0.0, f64::max)
        };
        let st = self.star_tracker.rate_hz;
        let jitter = self.thruster.edge_jitter_s;
        let n = self.n_samples();
        vec![
            RateBound {
                partner: "duration_s",
                low: true,
                strict: false,
                limit: 100.0 / d,
                violated: n < 100,
                why: format!("duration_s = {d} s must hold at least 100 samples"),
                partner_msg: format!(
                    "{d} s gives {n} samples at sample_rate_hz = {fs} Hz; at least 100 are needed, so duration_s must be at least {} s",
                    sig4(100.0 / fs, true)
                ),
            },
            RateBound {
                partner: "maneuver.frequency_hz",
                low: true,
                strict: false,
                limit: 8.0 * f,
                violated: 8.0 * f > fs,
                why: format!("a period of maneuver.frequency_hz = {f} Hz needs at least 8 samples"),
                partner_msg: format!(
                    "{f} Hz must be at most sample_rate_hz / 8 = {} Hz",
                    sig4(fs / 8.0, false)
                ),
            },
            RateBound {
                partner: "star_tracker.rate_hz",
                low: true,
                strict: false,
                limit: st,
                violated: st > fs,
                why: format!("star_tracker.rate_hz = {st} Hz must not exceed the sample rate"),
                partner_msg: format!("{st} Hz must not exceed sample_rate_hz = {fs} Hz"),
            },
            RateBound {
                partner: "duration_s",
                low: false,
                strict: false,
                limit: 1e8 / d,
                violated: n > 100_000_000,
                why: format!("duration_s = {d} s may hold at most 10^8 samples"),
                partner_msg: format!(
                    "{d} s gives {n} samples at sample_rate_hz = {fs} Hz, more than 10^8: duration_s must be at most {} s",
                    sig4(1e8 / fs, false)
                ),
            },
            RateBound {
                partner: "thruster.edge_jitter_s",
                low: false,
                strict: true,
                limit: if jitter > 0.0 { 0.5 / jitter } else { f64::INFINITY },
                violated: 2.0 * jitter >= self.dt(),
                why: format!(
                    "a thruster edge, delayed by thruster.edge_jitter_s = {jitter} s ± as much, must stay within half a sample interval"
                ),
                partner_msg: format!(
                    "{jitter} s must be below half a sample interval, 1 / (2 × sample_rate_hz) = {} s",
                    sig4(0.5 / fs, false)
                ),
            },
        ]
    }
}

/// One bound on `sample_rate_hz` set by another key.
struct RateBound {
    /// The other key.
    partner: &'static str,
    /// A lower bound (else an upper one); `strict`: the rate must differ from `limit`.
    low: bool,
    strict: bool,
    /// The bound [Hz].
    limit: f64,
    violated: bool,
    /// Why the bound exists, naming the other key.
    why: String,
    /// The error when the other key is to blame.
    partner_msg: String,
}

/// `x` to 4 significant digits, rounded up or down (a bound shown rounded the other way
/// would name a value the check refuses).
fn sig4(x: f64, up: bool) -> String {
    if !x.is_finite() || x == 0.0 {
        return format!("{x}");
    }
    let scale = 10f64.powi(3 - x.abs().log10().floor() as i32);
    let m = x * scale;
    // A bound like 10 × 3e-5 carries rounding noise in its last bits: not a digit to round up.
    let v = if (m - m.round()).abs() < 1e-9 * m.abs() {
        m.round()
    } else if up {
        m.ceil()
    } else {
        m.floor()
    } / scale;
    if (1e-3..1e6).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// Dotted keys a TOML text sets (`thruster.edge_jitter_s`, `inertial_sensor[1].beta`).
fn keys_set(text: &str) -> Vec<String> {
    fn walk(prefix: &str, table: &toml::Table, out: &mut Vec<String>) {
        for (k, v) in table {
            let key = if prefix.is_empty() {
                k.clone()
            } else {
                format!("{prefix}.{k}")
            };
            match v {
                toml::Value::Table(t) => walk(&key, t, out),
                toml::Value::Array(items) if items.first().is_some_and(|i| i.is_table()) => {
                    for (i, item) in items.iter().enumerate() {
                        if let toml::Value::Table(t) = item {
                            walk(&format!("{key}[{i}]"), t, out);
                        }
                    }
                }
                _ => out.push(key),
            }
        }
    }
    let mut out = Vec::new();
    if let Ok(t) = text.parse::<toml::Table>() {
        walk("", &t, &mut out);
    }
    out
}
