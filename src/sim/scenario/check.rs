//! Loading and checking a scenario: TOML in, every key checked against its range and
//! against the others (the maneuver against the IS design limits and the sample
//! rate), the first problem named by its key. Above the schema (`super`) and the
//! maneuver's derived physics (`crate::maneuver`), which both sit below it.

use super::*;
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
pub(super) fn err<T>(key: &str, msg: &str) -> Result<T, ScenarioError> {
    Err(ScenarioError::key(key, msg))
}

/// `v` must be finite and positive.
pub(super) fn pos(key: &str, v: f64) -> Result<(), ScenarioError> {
    if !v.is_finite() {
        return err(key, &format!("must be finite, got {v}"));
    }
    if v <= 0.0 {
        return err(key, &format!("must be positive, got {v}"));
    }
    Ok(())
}

/// `v` must be finite and ≥ 0.
pub(super) fn nonneg(key: &str, v: f64) -> Result<(), ScenarioError> {
    if !v.is_finite() || v < 0.0 {
        return err(key, &format!("must be finite and ≥ 0, got {v}"));
    }
    Ok(())
}

/// `given(key)`: the file sets this dotted key.
pub(super) type Given<'a> = &'a dyn Fn(&str) -> bool;

/// Of two keys in one check: the second only when the file sets it and not the first.
pub(super) fn blame_second(given: Given, first: &str, second: &str) -> bool {
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
        self.validate_mission()?;
        nonneg("maneuver.max_attitude_rad", self.maneuver.max_attitude_rad)?;
        nonneg("maneuver.max_rate_rad_s", self.maneuver.max_rate_rad_s)?;
        pos("thruster.max_torque_nm", self.thruster.max_torque_nm)?;
        if self.plan_pending {
            // The planner picks the waveform; its result is checked here again.
            return Ok(());
        }
        self.validate_maneuver(given)
    }

    /// `[drift]` over the mission's length (`[timeline]`'s, else a year) and `[timeline]`.
    fn validate_mission(&self) -> Result<(), ScenarioError> {
        let days = self.timeline.as_ref().map_or(365.0, |t| t.days);
        if let Some(t) = &self.timeline {
            t.validate(self.duration_s / 86_400.0)?;
        }
        if let Some(d) = &self.drift {
            d.validate(days.max(self.epoch_day + self.duration_s / 86_400.0))?;
        }
        Ok(())
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
            // The priors: present with the onboard table, finite (β positive) always.
            // How far they are from the truth is not checked: onboard nothing knows
            // it, and a truth outside the prior's box flies, with a warning
            // (`Scenario::truth_warnings`).
            let table = self.priors_source == PriorsSource::OnboardTable;
            if table && (is.beta_prior.is_none() || is.com_offset_prior_m.is_none()) {
                return err(
                    "priors_source",
                    &format!("\"onboard_table\" needs inertial_sensor[{i}].beta_prior and com_offset_prior_m (the table's values)"),
                );
            }
            if let Some(bp) = is.beta_prior {
                for v in bp {
                    pos(&key("beta_prior"), v)?;
                }
            }
            if let Some(rp) = is.com_offset_prior_m {
                for (a, v) in rp.iter().enumerate() {
                    if !v.is_finite() {
                        return err(
                            &key("com_offset_prior_m"),
                            &format!("component {a} must be finite"),
                        );
                    }
                    if v.abs() > 2.0 {
                        return err(
                            &key("com_offset_prior_m"),
                            &format!(
                                "component {a} = {v} m is not a plausible CoM offset (|r| ≤ 2 m)"
                            ),
                        );
                    }
                }
            }
        }
        Ok(())
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
