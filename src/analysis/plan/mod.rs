//! Maneuver planner: the square-wave maneuver that minimises the worst ratio of
//! Cramér–Rao bound to requirement over every calibrated parameter (β, k and r of
//! every IS) for a given window, under the IS range, thruster, attitude, rate and
//! star-tracker-outage constraints (docs/planning.md).
//!
//! The search: for each schedule (sequential axes; simultaneous axes at frequency
//! ratios 1 : 2 : 4, each axis taking the slow wave in turn) and a grid of frequencies
//! that fill the window with whole periods, the torque amplitude is the largest every
//! constraint allows (more torque is always more information); each candidate's bound
//! is computed from its noise-free campaign at a reduced sample rate, the best is
//! refined (start phase, axis order, pausing in outages), and the winner's bound is
//! computed again at the scenario's own rate.

use crate::analysis::campaign::Threads;
use crate::analysis::crlb::{crlb_at_rate, maneuver_bound_on, Crlb};
use crate::sim::files::FileError;
use crate::sim::requirements::{REQ_COM_M, REQ_SCALE_FACTOR_REL};
use crate::sim::scenario::maneuver::{axis_frequencies, torque_boost, Timeline};
use crate::sim::scenario::{k_from_beta, Maneuver, Scenario, Schedule};
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;
use std::time::Instant;
use taiji_core::estimate::joint::rocking;
use taiji_core::model::noise::white_sigma;

pub use crate::tuning::MODEL_ATTITUDE_RAD;
use crate::tuning::{FINAL_SAMPLES, QUIET_ROCKING, SEARCH_SAMPLES, SEARCH_SAMPLES_PER_PERIOD};

/// The attitude limit of the plan: the scenario's, within the estimator's model.
pub fn attitude_limit(s: &Scenario) -> (f64, &'static str) {
    let model = MODEL_ATTITUDE_RAD * (1.1e-11 / s.srp.asd_at_3mhz).min(1.0);
    let user = s.maneuver.max_attitude_rad;
    if user > 0.0 && user <= model {
        (user, "maneuver.max_attitude_rad")
    } else {
        (model, "estimator model (attitude limit)")
    }
}

/// What to plan.
#[derive(Debug, Clone, Copy)]
pub struct PlanOptions {
    /// The window [s]; the scenario's `duration_s` when `None`.
    pub duration_s: Option<f64>,
    /// Also draw the bound at half and a quarter of the largest torque (the figure).
    pub amplitude_sweep: bool,
    /// Bound the winner again at the scenario's own rate (else its search bound
    /// stands: a few per cent looser, used while bisecting the window).
    pub exact: bool,
}

impl Default for PlanOptions {
    fn default() -> Self {
        PlanOptions {
            duration_s: None,
            amplitude_sweep: false,
            exact: true,
        }
    }
}

/// One maneuver the planner weighed.
#[derive(Debug, Clone, Serialize)]
pub struct Candidate {
    pub maneuver: Maneuver,
    /// Each axis's frequency [Hz] and whole periods.
    pub frequencies_hz: [f64; 3],
    pub periods: [u64; 3],
    /// The constraint that set the torque amplitude (its scenario key).
    pub binding: String,
    /// Peak |A(ω, ω̇) r| over every CoM offset within the priors' uncertainty, with
    /// overshoot and 3σ amplitude jitter [m/s²].
    pub peak_acceleration_m_s2: f64,
    pub peak_attitude_rad: f64,
    pub peak_rate_rad_s: f64,
    /// The bound (at `rate_hz`).
    #[serde(skip)]
    pub crlb: Option<Crlb>,
    pub rate_hz: f64,
    /// Worst CRLB / requirement and the parameter it belongs to.
    pub worst_ratio: f64,
    pub worst_parameter: String,
    /// Fraction of the largest allowed torque (1 but in the figure's sweep).
    #[serde(skip)]
    pub amplitude_fraction: f64,
}

/// The planner's answer.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The chosen maneuver, its bound at the scenario's rate (or `final_rate_hz`).
    pub chosen: Candidate,
    /// Every candidate of the search (bounds at `search_rate_hz`), best first.
    pub candidates: Vec<Candidate>,
    pub search_rate_hz: f64,
    pub duration_s: f64,
    pub elapsed_s: f64,
    /// Best worst-ratio of each schedule (at the search rate).
    pub best_by_schedule: Vec<(Schedule, f64)>,
    /// Why even the chosen maneuver's bound misses a requirement, naming the binding
    /// constraint (`plan` refuses such a window; `run` flies the best and says so).
    pub shortfall: Option<String>,
}

/// What a run keeps of the plan that chose its maneuver (also what the plan cache
/// stores): the search's size and time, the binding constraint, the search bound.
#[derive(Debug, Clone, Serialize, serde::Deserialize, PartialEq)]
pub struct PlanInfo {
    pub candidates: usize,
    pub search_rate_hz: f64,
    pub elapsed_s: f64,
    pub binding: String,
    /// Best worst-ratio of each schedule (search bound).
    pub best_by_schedule: Vec<(String, f64)>,
    /// The chosen maneuver's worst CRLB / requirement and its parameter (search bound).
    pub worst_ratio: f64,
    pub worst_parameter: String,
    pub peak_acceleration_m_s2: f64,
    pub shortfall: Option<String>,
    /// Taken from the plan cache (`cache.rs`) rather than searched now.
    pub cached: bool,
}

impl PlanInfo {
    /// The report's `maneuver.search` object.
    pub fn search_json(&self) -> serde_json::Value {
        serde_json::json!({
            "candidates": self.candidates,
            "search_rate_hz": self.search_rate_hz,
            "elapsed_s": self.elapsed_s,
            "binding": self.binding,
            "cached": self.cached,
            "best_by_schedule": self.best_by_schedule.iter().map(|(s, r)| serde_json::json!({"schedule": s, "worst_ratio": r})).collect::<Vec<_>>(),
        })
    }
}

impl From<&Plan> for PlanInfo {
    fn from(p: &Plan) -> Self {
        PlanInfo {
            candidates: p.candidates.len(),
            search_rate_hz: p.search_rate_hz,
            elapsed_s: p.elapsed_s,
            binding: p.chosen.binding.clone(),
            best_by_schedule: p
                .best_by_schedule
                .iter()
                .map(|(s, r)| (s.name().to_string(), *r))
                .collect(),
            worst_ratio: p.chosen.worst_ratio,
            worst_parameter: p.chosen.worst_parameter.clone(),
            peak_acceleration_m_s2: p.chosen.peak_acceleration_m_s2,
            shortfall: p.shortfall.clone(),
            cached: false,
        }
    }
}

/// The planner could not find a maneuver, or could not write its plan; the message
/// names the binding constraint or the file.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// The window holds no maneuver at all; `why` says what the periods need.
    #[error("`duration_s`: {duration_s} s is too short for any maneuver: {why}")]
    WindowTooShort { duration_s: f64, why: String },
    /// No candidate has room for any torque.
    #[error("no torque fits: thruster.max_torque_nm = {max_torque_nm:.3e} N m, front_end.maneuver_limit_m_s2 = {maneuver_limit_m_s2:.1e} m/s² and the maneuver limits leave no room")]
    NoTorque {
        max_torque_nm: f64,
        maneuver_limit_m_s2: f64,
    },
    #[error("no candidate could be bounded")]
    NothingBounded,
    /// `--margin` is not a number ≥ 1.
    #[error("`--margin`: must be a number ≥ 1, got {margin}")]
    Margin { margin: f64 },
    /// No window up to `max_s` meets the requirements on the search bound.
    #[error("no window up to the longest verified campaign ({max_s} s) meets every requirement with margin {margin} on the bound")]
    NoWindow { max_s: f64, margin: f64 },
    /// No window up to `max_s` meets the requirements on the exact bound.
    #[error(
        "no window up to {max_s} s meets every requirement with margin {margin} on the exact bound"
    )]
    NoExactWindow { max_s: f64, margin: f64 },
    /// Planning a scenario's maneuver (`resolve`) failed.
    #[error("planning the maneuver: {0}")]
    Planning(#[source] Box<PlanError>),
    /// The planned maneuver fails the scenario's own checks.
    #[error("the planned maneuver does not pass the scenario's checks: {0}")]
    PlannedInvalid(#[source] crate::sim::scenario::ScenarioError),
    /// A file or folder that could not be read, created or written.
    #[error(transparent)]
    File(#[from] FileError),
    #[error("{0}")]
    Json(#[from] serde_json::Error),
    /// The figure could not be drawn.
    #[error(transparent)]
    Figure(#[from] crate::analysis::plots::PlotError),
}

/// The CoM offsets the planner must keep within the IS range: every corner of the
/// box the priors' uncertainty allows. A given prior ± the ground-calibration error;
/// a drawn prior is itself ± that error around the scenario's offset, so ± twice it.
pub fn offset_corners(s: &Scenario) -> Vec<Vector3<f64>> {
    let e = s.ground_calibration.com_offset_error_m;
    let mut out = Vec::new();
    for is in &s.inertial_sensor {
        let (c, h) = match is.com_offset_prior_m {
            Some(p) => (p, e),
            None => (is.com_offset_m, 2.0 * e),
        };
        for k in 0..8 {
            out.push(Vector3::from_fn(|a, _| {
                c[a] + if k >> a & 1 == 1 { h } else { -h }
            }));
        }
    }
    out
}

fn inertia(s: &Scenario) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| s.spacecraft.inertia_kg_m2[i][j])
}

/// How well the thrusters' torque noise alone rocks the spacecraft, in units of the
/// estimator's test for real motion on every axis (`joint::rocking`), for ω̇'s
/// covariance from that noise alone, σ_τ² (f_s/2) I⁻² [rad²/s⁴] (white, the same on
/// every body axis). The default scenario's is ~4×10³; 0 without torque noise;
/// infinite without angular readout noise (any motion then dominates it).
pub fn torque_noise_rocking(s: &Scenario) -> f64 {
    let fs = s.sample_rate_hz;
    let inv = inertia(s).try_inverse().unwrap_or_else(Matrix3::zeros);
    let cov = inv * inv * white_sigma(s.thruster.torque_noise_nm_rthz, fs).powi(2);
    let r = rocking(
        &cov,
        white_sigma(s.front_end.angular_noise_rthz, fs).powi(2),
    );
    // NaN: no motion (no torque noise, or no inertia to invert: a scenario refuses it).
    if r.is_nan() {
        0.0
    } else {
        r
    }
}

/// The schedules the planner weighs for `s`: both, unless the thrusters are too quiet
/// to rock every axis on their own (`torque_noise_rocking`). The estimator then fixes
/// the SRP's level only once the maneuver has rocked every axis, and a sequential
/// schedule rocks its last axis from two thirds of the window on: the samples before
/// turn the SRP without its fluctuation, and r_z's σ is optimistic (by 1.3× at 10⁴ s,
/// 2× at 10⁵ s; docs/planning.md). Rocking every axis from the start costs a few per
/// cent of r_z's RMS at 10⁴ s (about 25 % with one IS) and 20–40 % of β's, far inside
/// its requirement, for an honest σ.
pub fn schedules(s: &Scenario) -> &'static [Schedule] {
    if torque_noise_rocking(s) < QUIET_ROCKING {
        &[Schedule::Simultaneous]
    } else {
        &[Schedule::Sequential, Schedule::Simultaneous]
    }
}

/// Worst CRLB / requirement over every parameter, and its name.
pub fn worst_ratio(s: &Scenario, c: &Crlb) -> (f64, String) {
    let priors = s.priors();
    let mut worst = (0.0, String::new());
    let ax = ["x", "y", "z"];
    for (i, (is, p)) in s.inertial_sensor.iter().zip(&priors).enumerate() {
        let k = k_from_beta(&is.geometry_m, &p.beta);
        for a in 0..3 {
            let cands = [
                (
                    c.beta[i][a] / p.beta[a] / REQ_SCALE_FACTOR_REL,
                    format!("β{} of IS{}", ax[a], i + 1),
                ),
                (
                    c.k[i][a] / k[a] / REQ_SCALE_FACTOR_REL,
                    format!("k{} of IS{}", ax[a], i + 1),
                ),
                (
                    c.com_offset_m[i][a] / REQ_COM_M,
                    format!("r{} of IS{}", ax[a], i + 1),
                ),
            ];
            for (v, name) in cands {
                if v.is_nan() || v > worst.0 {
                    worst = (v, name);
                }
            }
        }
    }
    worst
}

/// Plan the maneuver for `s`'s window (or `opts.duration_s`).
pub fn plan(s: &Scenario, opts: &PlanOptions) -> Result<Plan, PlanError> {
    let t0 = Instant::now();
    let mut base = s.clone();
    if let Some(d) = opts.duration_s {
        base.duration_s = d;
    }
    base.plan_pending = false;
    base.faults = Default::default();
    let d = base.duration_s;
    let mut cands = coarse_candidates(&base)?;
    // One search rate for every candidate (the bound's coarseness then ranks fairly),
    // fine enough for the fastest wave of the grid.
    let f_fast = cands
        .iter()
        .flat_map(|c| c.frequencies_hz)
        .fold(0.0, f64::max);
    let rate = base
        .sample_rate_hz
        .min((SEARCH_SAMPLES / d).max(SEARCH_SAMPLES_PER_PERIOD * f_fast));
    evaluate(&base, &mut cands, rate);
    best_first(&mut cands);
    let mut finer = finer_counts(&base, &cands);
    evaluate(&base, &mut finer, rate);
    cands.extend(finer);
    best_first(&mut cands);
    let mut best_by_schedule = Vec::new();
    for sch in [Schedule::Sequential, Schedule::Simultaneous] {
        if let Some(c) = cands.iter().find(|c| c.maneuver.schedule == sch) {
            best_by_schedule.push((sch, c.worst_ratio));
        }
    }
    let mut refined = variants_of(&base, &cands[0]);
    evaluate(&base, &mut refined, rate);
    cands.extend(refined);
    best_first(&mut cands);
    if opts.amplitude_sweep {
        let mut sweep = amplitude_sweep(&cands);
        evaluate(&base, &mut sweep, rate);
        cands.extend(sweep);
    }
    // The winner among full-torque candidates, its bound at the scenario's own rate.
    let mut chosen = cands
        .iter()
        .find(|c| c.amplitude_fraction == 1.0)
        .cloned()
        .ok_or(PlanError::NothingBounded)?;
    let final_rate = if opts.exact {
        base.sample_rate_hz.min((FINAL_SAMPLES / d).max(rate))
    } else {
        rate
    };
    if final_rate != rate {
        let cs = with_maneuver(&base, &chosen.maneuver);
        let b = if final_rate >= base.sample_rate_hz {
            maneuver_bound_on(&cs, Threads::available())
        } else {
            crlb_at_rate(&cs, final_rate)
        };
        set_bound(&base, &mut chosen, b, final_rate);
    }
    let shortfall = (chosen.worst_ratio.is_nan() || chosen.worst_ratio > 1.0)
        .then(|| infeasible(&base, &chosen));
    Ok(Plan {
        shortfall,
        chosen,
        candidates: cands,
        search_rate_hz: rate,
        duration_s: d,
        elapsed_s: t0.elapsed().as_secs_f64(),
        best_by_schedule,
    })
}

/// The shortest window [s] whose plan meets every requirement with `margin` on the
/// bound (worst CRLB / requirement ≤ 1 / margin), to 2 %: a scan up in factors of 2,
/// then bisection in log duration on the search bound, then the exact bound checked
/// (stepping up 5 % while it misses).
pub fn min_duration(s: &Scenario, margin: f64) -> Result<Plan, PlanError> {
    if !(margin.is_finite() && margin >= 1.0) {
        return Err(PlanError::Margin { margin });
    }
    let max = crate::sim::scenario::MAX_DURATION_S;
    let meets = |d: f64, exact: bool| -> Option<Plan> {
        let p = plan(
            s,
            &PlanOptions {
                duration_s: Some(d),
                amplitude_sweep: false,
                exact,
            },
        )
        .ok()?;
        (p.shortfall.is_none() && p.chosen.worst_ratio * margin <= 1.0).then_some(p)
    };
    let mut lo = 100.0f64;
    let mut hi = lo;
    while meets(hi, false).is_none() {
        lo = hi;
        hi *= 2.0;
        if hi > max {
            return Err(PlanError::NoWindow { max_s: max, margin });
        }
    }
    while hi / lo > 1.02 {
        let mid = (lo * hi).sqrt();
        if meets(mid, false).is_some() {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    // Whole tens of seconds, then the exact bound.
    let mut d = (hi / 10.0).ceil() * 10.0;
    loop {
        if let Some(p) = meets(d, true) {
            return Ok(p);
        }
        d = ((d * 1.05) / 10.0).ceil() * 10.0;
        if d > max {
            return Err(PlanError::NoExactWindow { max_s: max, margin });
        }
    }
}

/// `s` with its maneuver planned if it has none; what the plan was when one was made.
/// A plan of the same scenario made before by the same code comes from the cache.
pub fn resolve(s: Scenario) -> Result<(Scenario, Option<PlanInfo>), PlanError> {
    if !s.plan_pending {
        return Ok((s, None));
    }
    if let Some((m, info)) = cache::load(&s) {
        let mut out = s.clone();
        out.maneuver = m;
        out.plan_pending = false;
        if let Ok(out) = out.validated() {
            warn_shortfall(&info);
            return Ok((out, Some(info)));
        }
    }
    // The run computes the exact bound itself: the search's ranks the plan.
    let opts = PlanOptions {
        exact: false,
        ..PlanOptions::default()
    };
    let p = plan(&s, &opts).map_err(|e| PlanError::Planning(Box::new(e)))?;
    let info = PlanInfo::from(&p);
    warn_shortfall(&info);
    let mut out = s.clone();
    out.maneuver = p.chosen.maneuver.clone();
    out.plan_pending = false;
    let out = out.validated().map_err(PlanError::PlannedInvalid)?;
    cache::store(&s, &out.maneuver, &info);
    Ok((out, Some(info)))
}

/// Once, through `log` (every binary shows warnings by default; `RUST_LOG` can silence
/// it): a second `eprintln!` printed the same line twice.
fn warn_shortfall(info: &PlanInfo) {
    if let Some(why) = &info.shortfall {
        log::warn!("flying the best maneuver found, but {why}");
    }
}

/// The chosen maneuver as a `[maneuver]` TOML table.
pub fn maneuver_toml(m: &Maneuver) -> String {
    #[derive(Serialize)]
    struct Wrap<'a> {
        maneuver: &'a Maneuver,
    }
    toml::to_string(&Wrap { maneuver: m }).unwrap_or_default()
}

pub mod cache;
mod describe;
mod search;
pub use describe::{bounds, describe, maneuver_bound, ManeuverReport};
use search::{
    amplitude_sweep, best_first, coarse_candidates, evaluate, finer_counts, infeasible, set_bound,
    variants_of, with_maneuver,
};
mod output;
pub use output::write;
