//! The maneuver a run used, described for the report (`report.json` → `maneuver`): its
//! waveform, schedule and envelope, and the bound it predicts. Not planner logic: the
//! report of any run, planned or written by hand.

use super::*;
use crate::analysis::crlb::Bounds;

/// The maneuver a run used, for the report: its waveform and schedule, whether it was
/// planned, its envelope over the priors' CoM box and the bound it predicts.
#[derive(Debug, Clone, Serialize, serde::Deserialize, PartialEq)]
pub struct ManeuverReport {
    pub planned: bool,
    pub waveform: String,
    pub schedule: String,
    pub axis_order: String,
    pub frequencies_hz: [f64; 3],
    pub periods: [u64; 3],
    pub torque_amplitude_nm: [f64; 3],
    pub start_phase: f64,
    pub start_s: f64,
    pub pause_in_outages: bool,
    pub peak_acceleration_m_s2: f64,
    pub peak_attitude_rad: f64,
    pub peak_rate_rad_s: f64,
    /// Worst Cramér–Rao bound / requirement, and its parameter.
    pub predicted_worst_ratio: f64,
    pub predicted_worst_parameter: String,
    /// The planner's search: candidates weighed, its time [s], the binding constraint.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub search: Option<serde_json::Value>,
}

impl ManeuverReport {
    /// One line for the result table.
    pub fn line(&self) -> String {
        let f: Vec<String> = if self.schedule == "sequential" {
            vec![format!("{:.3e} Hz", self.frequencies_hz[0])]
        } else {
            self.frequencies_hz
                .iter()
                .map(|f| format!("{f:.3e}"))
                .collect()
        };
        let f = if f.len() == 1 {
            f[0].clone()
        } else {
            format!("[{}] Hz", f.join(", "))
        };
        format!(
            "Maneuver ({}): {} {}{}, {f}, {:?} periods, torque [{:.3e}, {:.3e}, {:.3e}] N m; peak |A r| {:.2e} m/s², attitude {:.2e} rad; CRLB/requirement ≤ {:.3} ({})",
            if self.planned { "planned" } else { "as given" },
            self.schedule,
            if self.schedule == "sequential" { self.axis_order.as_str() } else { "axes" },
            if self.start_phase == 0.0 { String::new() } else { format!(", start phase {}", self.start_phase) },
            self.periods,
            self.torque_amplitude_nm[0],
            self.torque_amplitude_nm[1],
            self.torque_amplitude_nm[2],
            self.peak_acceleration_m_s2,
            self.peak_attitude_rad,
            self.predicted_worst_ratio,
            self.predicted_worst_parameter
        )
    }
}

/// The bound `s`'s maneuver promises before any run: its motion alone, no data lost,
/// at the rate the planner would search it at alone (`SEARCH_SAMPLES` over the window,
/// at least `SEARCH_SAMPLES_PER_PERIOD` a period of its fastest axis; the planner's
/// search takes the fastest axis of all its candidates, which gives the same rate
/// unless a candidate rocks faster than 10⁴ samples allow): a few per cent
/// pessimistic, a tenth of a run's bound's work in the default campaign.
pub fn maneuver_bound(s: &Scenario) -> Option<Crlb> {
    let f_fast = axis_frequencies(s).into_iter().fold(0.0, f64::max);
    let rate = s
        .sample_rate_hz
        .min((SEARCH_SAMPLES / s.duration_s).max(SEARCH_SAMPLES_PER_PERIOD * f_fast));
    crlb_at_rate(s, rate)
}

/// Both bounds of a run of `s` (`crlb::Bounds`), the maneuver's on a thread of its
/// own; `None` where the run's is singular.
pub fn bounds(s: &Scenario) -> Option<Bounds> {
    std::thread::scope(|sc| {
        let m = sc.spawn(|| maneuver_bound(s));
        let run = crate::analysis::crlb::crlb(s);
        let maneuver = m.join().unwrap_or_else(|e| std::panic::resume_unwind(e));
        Some(Bounds {
            run: run?,
            maneuver,
        })
    })
}

/// Describe `s`'s maneuver with the bound `crlb` (and the plan that chose it).
pub fn describe(s: &Scenario, crlb: Option<&Crlb>, plan: Option<&PlanInfo>) -> ManeuverReport {
    let mv = &s.maneuver;
    let boost = torque_boost(s);
    let (periods, env) = match Timeline::new(s) {
        Ok(t) => (t.periods(), Some(t.envelope(&inertia(s)))),
        Err(_) => ([0; 3], None),
    };
    let (ratio, param) = match (crlb, plan) {
        (Some(c), _) => worst_ratio(s, c),
        (None, Some(p)) => (p.worst_ratio, p.worst_parameter.clone()),
        _ => (f64::NAN, String::new()),
    };
    ManeuverReport {
        planned: mv.planned,
        waveform: if mv.start_phase == 0.0 {
            "square, cosine phase".into()
        } else {
            format!("square, start phase {} period", mv.start_phase)
        },
        schedule: mv.schedule.name().into(),
        axis_order: mv.axis_order.clone(),
        frequencies_hz: axis_frequencies(s),
        periods,
        torque_amplitude_nm: mv.torque_amplitude_nm,
        start_phase: mv.start_phase,
        start_s: mv.start_s,
        pause_in_outages: mv.pause_in_outages,
        peak_acceleration_m_s2: env.as_ref().map_or(f64::NAN, |e| {
            e.peak_acceleration(&offset_corners(s), boost).1
        }),
        peak_attitude_rad: env
            .as_ref()
            .map_or(f64::NAN, |e| e.peak_attitude_rad * boost),
        peak_rate_rad_s: env.as_ref().map_or(f64::NAN, |e| e.peak_rate_rad_s * boost),
        predicted_worst_ratio: ratio,
        predicted_worst_parameter: param,
        search: plan.map(PlanInfo::search_json),
    }
}
