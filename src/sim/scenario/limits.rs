//! The maneuver's limits, checked on a scenario: the waveform, the timeline, the peak
//! torque, the attitude and rate, the IS measurement range, and the sample rate.

use super::check::{blame_second, err, Given};
use super::*;
use crate::sim::scenario::maneuver::{
    axis_frequencies, round_down_4, torque_boost, Envelope, Timeline,
};

impl Scenario {
    /// The maneuver's own checks: its keys, its fit in the window, the thrusters' torque,
    /// the attitude and rate limits and the IS design limit on |A r| at the true offsets.
    pub(super) fn validate_maneuver(&self, given: Given) -> Result<(), ScenarioError> {
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
    pub(super) fn validate_waveform(&self, given: Given) -> Result<(), ScenarioError> {
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
    pub(super) fn timeline(&self, given: Given) -> Result<Timeline, ScenarioError> {
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
    pub(super) fn check_peak_torque(&self, given: Given, boost: f64) -> Result<(), ScenarioError> {
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
    pub(super) fn check_attitude_and_rate(
        &self,
        env: &Envelope,
        boost: f64,
    ) -> Result<(), ScenarioError> {
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

    /// The IS design limit on |A r| at the offsets the ground states: each IS's
    /// `com_offset_prior_m`, or without one its `com_offset_m` (the value its prior is
    /// drawn around); the error names the torque that would fit. What the truth does
    /// is the run's to show (`Scenario::truth_warnings`): onboard, only the priors are
    /// known. A planned maneuver was sized by the planner for the priors' whole box.
    pub(super) fn check_is_range(
        &self,
        given: Given,
        env: &Envelope,
        inertia: &nalgebra::Matrix3<f64>,
        boost: f64,
    ) -> Result<(), ScenarioError> {
        if self.maneuver.planned {
            return Ok(());
        }
        let stated: Vec<nalgebra::Vector3<f64>> = self
            .inertial_sensor
            .iter()
            .map(|is| nalgebra::Vector3::from(is.com_offset_prior_m.unwrap_or(is.com_offset_m)))
            .collect();
        let peak = env.peak_acceleration(&stated, boost);
        let limit = self.front_end.maneuver_limit_m_s2;
        if peak.1 <= limit {
            return Ok(());
        }
        let within = self.torque_within_range(env, inertia, &stated, boost);
        let is = &self.inertial_sensor[peak.0];
        let offset = if is.com_offset_prior_m.is_some() {
            format!("inertial_sensor[{}].com_offset_prior_m", peak.0)
        } else {
            format!("inertial_sensor[{}].com_offset_m", peak.0)
        };
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

    /// The torque that keeps |A r| within the IS range, as the error words it.
    pub(super) fn torque_within_range(
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
    pub(super) fn check_sample_rate(&self, given: Given) -> Result<(), ScenarioError> {
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
    pub(super) fn rate_bounds(&self) -> Vec<RateBound> {
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
pub(super) struct RateBound {
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
pub(super) fn sig4(x: f64, up: bool) -> String {
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
