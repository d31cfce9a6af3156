//! The mission's keys: `[drift]` (how the truths move with mission time) and
//! `[timeline]` (the mission `taiji-calib timeline` flies), and their checks.
//! docs/mission.md says where the defaults come from.

use super::check::{err, nonneg};
use super::ScenarioError;
use serde::{Deserialize, Serialize};

/// Longest mission [days] a timeline may fly (ten years).
pub const MAX_MISSION_DAYS: f64 = 3650.0;
/// Most steps `[[drift.step]]` may list.
pub const MAX_STEPS: usize = 64;
/// `timeline.max_interval_days` by default: a campaign at least every month, about
/// a dozen a year, so a change no drift model has (a step) is found within a month.
pub const DEFAULT_MAX_INTERVAL_DAYS: f64 = 30.0;

/// Most campaigns a timeline may list.
pub const MAX_CAMPAIGNS: usize = 1000;
/// The drifted β must stay within this relative distance of the file's β over the
/// mission (at 5σ of the random walk): a scale factor that changes by half is no
/// longer the same instrument.
pub const MAX_BETA_EXCURSION: f64 = 0.5;
/// Likewise for r, per component [m].
pub const MAX_COM_EXCURSION_M: f64 = 0.5;

/// `[drift]`: the truths' change with mission time t [days]. For IS i, axis a:
/// β(t) = β₀ (1 + `beta_rel_per_day` t + w_β(t) + Σ steps' `beta_rel`) and
/// r(t) = r₀ + `com_m_per_day` t + w_r(t) + Σ steps' `com_m`, where w are random
/// walks of `*_per_sqrt_day` (variance σ² t), independent per IS and axis, and a step
/// counts from its `day` on; k follows β through the geometry. Absent: nothing
/// drifts. Present, every key left out takes the published figure of docs/mission.md.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct Drift {
    /// Relative rate of every angular scale factor, both IS [1/day].
    pub beta_rel_per_day: f64,
    /// Random walk of every angular scale factor, relative [1/√day].
    pub beta_rel_per_sqrt_day: f64,
    /// Rate of each IS's CoM offset, body frame [m/day].
    pub com_m_per_day: [[f64; 3]; 2],
    /// Random walk of every CoM offset component [m/√day].
    pub com_m_per_sqrt_day: f64,
    /// Sudden changes (a tank switch, a thermal event).
    pub step: Vec<DriftStep>,
}

/// One sudden change of the truths, from `day` on.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields, default)]
pub struct DriftStep {
    /// Mission day it happens [days].
    pub day: f64,
    /// Change of each IS's CoM offset [m].
    pub com_m: [[f64; 3]; 2],
    /// Relative change of each IS's β per axis.
    pub beta_rel: [[f64; 3]; 2],
}

impl Default for Drift {
    /// The published figures (docs/mission.md#what-drifts).
    fn default() -> Self {
        Drift {
            beta_rel_per_day: 1.5e-6,
            beta_rel_per_sqrt_day: 4.0e-7,
            com_m_per_day: [[0.9e-6, -1.1e-6, 0.4e-6], [0.7e-6, 1.3e-6, 0.2e-6]],
            com_m_per_sqrt_day: 2.5e-7,
            step: Vec::new(),
        }
    }
}

impl Drift {
    /// No drift at all: every key 0, no step.
    pub fn none() -> Self {
        Drift {
            beta_rel_per_day: 0.0,
            beta_rel_per_sqrt_day: 0.0,
            com_m_per_day: [[0.0; 3]; 2],
            com_m_per_sqrt_day: 0.0,
            step: Vec::new(),
        }
    }
}

/// When the campaigns of a timeline fall.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "toml::Value", into = "toml::Value")]
pub enum CampaignDays {
    /// Each next campaign on the last day the values in use still meet every
    /// requirement with `timeline.confidence` (the first on day 0).
    Auto,
    /// On these mission days.
    Days(Vec<f64>),
}

impl TryFrom<toml::Value> for CampaignDays {
    type Error = String;
    fn try_from(v: toml::Value) -> Result<Self, String> {
        let bad = || "`timeline.campaigns` must be \"auto\" or a list of days".to_string();
        match v {
            toml::Value::String(s) if s == "auto" => Ok(CampaignDays::Auto),
            toml::Value::Array(items) => items
                .into_iter()
                .map(|x| match x {
                    toml::Value::Float(f) => Ok(f),
                    toml::Value::Integer(i) => Ok(i as f64),
                    _ => Err(bad()),
                })
                .collect::<Result<Vec<f64>, String>>()
                .map(CampaignDays::Days),
            _ => Err(bad()),
        }
    }
}

impl From<CampaignDays> for toml::Value {
    fn from(c: CampaignDays) -> toml::Value {
        match c {
            CampaignDays::Auto => toml::Value::String("auto".into()),
            CampaignDays::Days(d) => {
                toml::Value::Array(d.into_iter().map(toml::Value::Float).collect())
            }
        }
    }
}

/// `[timeline]`: the mission `taiji-calib timeline` flies.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct MissionTimeline {
    /// Mission length [days].
    pub days: f64,
    /// "auto" or the campaigns' days.
    pub campaigns: CampaignDays,
    /// Probability with which every in-use value must meet its requirement (auto).
    pub confidence: f64,
    /// With "auto", the longest wait from one campaign's start to the next's [days],
    /// whatever the trend predicts: a change no drift model has (a step) is found no
    /// later than this. The mission's length leaves the schedule to the trend alone.
    pub max_interval_days: f64,
}

impl Default for MissionTimeline {
    fn default() -> Self {
        MissionTimeline {
            days: 365.0,
            campaigns: CampaignDays::Auto,
            confidence: 0.997,
            max_interval_days: DEFAULT_MAX_INTERVAL_DAYS,
        }
    }
}

/// Finite, or an error naming `key`.
fn finite(key: &str, v: f64) -> Result<(), ScenarioError> {
    if !v.is_finite() {
        return err(key, &format!("must be finite, got {v}"));
    }
    Ok(())
}

impl Drift {
    /// Every key finite and in range, over a mission of `days` (the truths stay
    /// within [`MAX_BETA_EXCURSION`] and [`MAX_COM_EXCURSION_M`] of the file's, at 5σ
    /// of the walks).
    pub fn validate(&self, days: f64) -> Result<(), ScenarioError> {
        finite("drift.beta_rel_per_day", self.beta_rel_per_day)?;
        nonneg("drift.beta_rel_per_sqrt_day", self.beta_rel_per_sqrt_day)?;
        for row in &self.com_m_per_day {
            for v in row {
                finite("drift.com_m_per_day", *v)?;
            }
        }
        nonneg("drift.com_m_per_sqrt_day", self.com_m_per_sqrt_day)?;
        if self.step.len() > MAX_STEPS {
            return err("drift.step", &format!("at most {MAX_STEPS} steps"));
        }
        let (mut beta_steps, mut com_steps) = (0.0, 0.0f64);
        for (n, st) in self.step.iter().enumerate() {
            let key = |k: &str| format!("drift.step[{n}].{k}");
            if !st.day.is_finite() || st.day < 0.0 {
                return err(&key("day"), &format!("must be a day ≥ 0, got {}", st.day));
            }
            for v in st.com_m.iter().flatten() {
                finite(&key("com_m"), *v)?;
            }
            for v in st.beta_rel.iter().flatten() {
                finite(&key("beta_rel"), *v)?;
            }
            beta_steps += st
                .beta_rel
                .iter()
                .flatten()
                .fold(0.0f64, |m, v| m.max(v.abs()));
            com_steps += st
                .com_m
                .iter()
                .flatten()
                .fold(0.0f64, |m, v| m.max(v.abs()));
        }
        let beta = self.beta_rel_per_day.abs() * days
            + 5.0 * self.beta_rel_per_sqrt_day * days.sqrt()
            + beta_steps;
        if beta > MAX_BETA_EXCURSION {
            return err(
                "drift.beta_rel_per_day",
                &format!(
                    "with drift.beta_rel_per_sqrt_day and the steps' beta_rel, β would move by up to {:.3} of itself over the {days} days (5σ of the walk); at most {MAX_BETA_EXCURSION}",
                    beta
                ),
            );
        }
        let rate = self
            .com_m_per_day
            .iter()
            .flatten()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let com = rate * days + 5.0 * self.com_m_per_sqrt_day * days.sqrt() + com_steps;
        if com > MAX_COM_EXCURSION_M {
            return err(
                "drift.com_m_per_day",
                &format!(
                    "with drift.com_m_per_sqrt_day and the steps' com_m, r would move by up to {com:.3} m over the {days} days (5σ of the walk); at most {MAX_COM_EXCURSION_M} m"
                ),
            );
        }
        Ok(())
    }
}

impl MissionTimeline {
    /// The mission's length, confidence and campaign days; `campaign_days` is one
    /// campaign's length [days].
    pub fn validate(&self, campaign_days: f64) -> Result<(), ScenarioError> {
        if !self.days.is_finite() || self.days <= 0.0 || self.days > MAX_MISSION_DAYS {
            return err(
                "timeline.days",
                &format!("must be in (0, {MAX_MISSION_DAYS}] days, got {}", self.days),
            );
        }
        if self.days < campaign_days {
            return err(
                "timeline.days",
                &format!(
                    "{} days do not hold one campaign of duration_s ({campaign_days:.3} days)",
                    self.days
                ),
            );
        }
        if !(self.confidence > 0.5 && self.confidence < 1.0) {
            return err(
                "timeline.confidence",
                &format!("must be a probability in (0.5, 1), got {}", self.confidence),
            );
        }
        if !self.max_interval_days.is_finite()
            || self.max_interval_days < 2.0 * campaign_days.max(0.5)
        {
            return err(
                "timeline.max_interval_days",
                &format!(
                    "must be finite and at least two campaigns long (and at least a day), got {}",
                    self.max_interval_days
                ),
            );
        }
        if let CampaignDays::Days(d) = &self.campaigns {
            if d.is_empty() || d.len() > MAX_CAMPAIGNS {
                return err(
                    "timeline.campaigns",
                    &format!("list 1 to {MAX_CAMPAIGNS} days, or \"auto\""),
                );
            }
            for (n, day) in d.iter().enumerate() {
                if !day.is_finite() || *day < 0.0 || day + campaign_days > self.days {
                    return err(
                        "timeline.campaigns",
                        &format!(
                            "day {n} = {day}: each campaign must start on a day ≥ 0 and end within timeline.days = {}",
                            self.days
                        ),
                    );
                }
                if n > 0 && *day < d[n - 1] + campaign_days {
                    return err(
                        "timeline.campaigns",
                        &format!(
                            "day {n} = {day} starts before campaign {} ends (day {} + duration_s): list the days in order, one campaign at a time",
                            n - 1,
                            d[n - 1]
                        ),
                    );
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use crate::sim::scenario::Scenario;

    fn err(text: &str) -> String {
        Scenario::from_toml_str(text).unwrap_err().to_string()
    }

    #[test]
    fn absent_tables_mean_no_drift_and_present_ones_take_the_published_figures() {
        let s = Scenario::from_toml_str("").unwrap();
        assert!(s.drift.is_none() && s.timeline.is_none());
        let s = Scenario::from_toml_str("[drift]\n[timeline]\n").unwrap();
        assert_eq!(s.drift, Some(super::Drift::default()));
        assert_eq!(s.timeline, Some(super::MissionTimeline::default()));
        let s = Scenario::from_toml_str(
            "[drift]\nbeta_rel_per_day = -2e-6\n[[drift.step]]\nday = 40\n\
             com_m = [[0.0, 0.0, 4e-5], [0.0, 0.0, 4e-5]]\n[timeline]\ncampaigns = [0, 30.5, 90]\n",
        )
        .unwrap();
        let d = s.drift.unwrap();
        assert_eq!((d.beta_rel_per_day, d.step.len()), (-2e-6, 1));
        assert_eq!(d.step[0].beta_rel, [[0.0; 3]; 2]);
        assert_eq!(
            s.timeline.unwrap().campaigns,
            super::CampaignDays::Days(vec![0.0, 30.5, 90.0])
        );
    }

    #[test]
    fn a_written_mission_reads_back_the_same() {
        for campaigns in ["\"auto\"", "[0, 12.5, 40]"] {
            let s = Scenario::from_toml_str(&format!(
                "[drift]\n[[drift.step]]\nday = 3\n[timeline]\ncampaigns = {campaigns}\n"
            ))
            .unwrap();
            let back = Scenario::from_toml_str(&toml::to_string(&s).unwrap()).unwrap();
            assert_eq!((&back.drift, &back.timeline), (&s.drift, &s.timeline));
        }
    }

    #[test]
    fn every_mission_key_is_checked_by_name() {
        for (text, key) in [
            ("[drift]\nbeta_rel_per_day = nan", "drift.beta_rel_per_day"),
            ("[drift]\nbeta_rel_per_day = 0.01", "drift.beta_rel_per_day"),
            (
                "[drift]\nbeta_rel_per_sqrt_day = -1e-7",
                "drift.beta_rel_per_sqrt_day",
            ),
            (
                "[drift]\ncom_m_per_day = [[inf, 0, 0], [0, 0, 0]]",
                "drift.com_m_per_day",
            ),
            (
                "[drift]\ncom_m_per_day = [[0.01, 0, 0], [0, 0, 0]]",
                "drift.com_m_per_day",
            ),
            (
                "[drift]\ncom_m_per_sqrt_day = -1.0",
                "drift.com_m_per_sqrt_day",
            ),
            ("[drift]\nfoo = 1", "foo"),
            ("[[drift.step]]\nday = -1", "drift.step[0].day"),
            (
                "[[drift.step]]\nday = 3\ncom_m = [[nan, 0, 0], [0, 0, 0]]",
                "drift.step[0].com_m",
            ),
            (
                "[[drift.step]]\nbeta_rel = [[0, 0, 0], [0, inf, 0]]",
                "drift.step[0].beta_rel",
            ),
            ("[[drift.step]]\ndays = 3", "days"),
            ("[timeline]\ndays = 0", "timeline.days"),
            ("[timeline]\ndays = 1e5", "timeline.days"),
            ("[timeline]\ndays = 0.05", "timeline.days"),
            ("[timeline]\nconfidence = 1.0", "timeline.confidence"),
            ("[timeline]\nconfidence = nan", "timeline.confidence"),
            (
                "[timeline]\nmax_interval_days = 0.2",
                "timeline.max_interval_days",
            ),
            (
                "[timeline]\nmax_interval_days = inf",
                "timeline.max_interval_days",
            ),
            ("[timeline]\ncampaigns = \"often\"", "timeline.campaigns"),
            ("[timeline]\ncampaigns = []", "timeline.campaigns"),
            ("[timeline]\ncampaigns = [10, 5]", "timeline.campaigns"),
            ("[timeline]\ncampaigns = [0, 400]", "timeline.campaigns"),
            ("[timeline]\ncampaigns = [\"a\"]", "timeline.campaigns"),
            ("[timeline]\nweeks = 3", "weeks"),
        ] {
            let e = err(text);
            assert!(e.contains(key) && !e.contains('\n'), "{text}: {e}");
        }
    }
}
