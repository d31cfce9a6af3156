//! A mission (`taiji-calib timeline`, docs/mission.md): campaign after campaign at
//! their epochs, each a whole in-process campaign (`campaign_report::run`, as
//! `taiji-calib run`) with that epoch's truths (`[drift]`), its priors the values in
//! use onboard; each result applied by function 3's rules (`report::table_values`) and
//! taken into the trend filters (`sim::trend`), whose predictions are the values in use
//! between campaigns; with `campaigns = "auto"` the next campaign falls when the
//! requirements would lapse (`schedule`). Campaigns depend on each other through the
//! table, so they run one after the other; each runs its simulation, its estimator,
//! its bound's noise-free twin and its maneuver's bound on threads of their own.

pub mod figures;
pub mod output;
pub mod schedule;

use crate::analysis::campaign::Threads;
use crate::analysis::report::{Report, REQ_COM_M, REQ_SCALE_FACTOR_REL};
use crate::sim::drift::{History, Truths, DAY_S};
use crate::sim::estimate::Method;
use crate::sim::msg::TableValues;
use crate::sim::scenario::{CampaignDays, MissionTimeline, Scenario};
use crate::sim::trend::{self, Grid, Trends};
use serde::Serialize;

/// The parameter groups, as `daily` names them.
pub const GROUPS: [&str; 3] = ["beta", "k", "com_offset"];
/// The axes, as `daily` names them.
pub const AXES: [&str; 3] = ["x", "y", "z"];
/// Most campaigns one mission flies (a schedule that cannot keep the requirements
/// would otherwise never end).
pub const MAX_CAMPAIGNS: usize = 1000;

/// The seed of campaign `n` of the mission of seed `seed` (SplitMix64 of both, its top
/// bit cleared: a scenario file's seed is a TOML integer, at most 2⁶³ − 1, and the
/// process set passes its scenario as a file): every campaign its own noise, the same
/// for the same mission.
pub fn campaign_seed(seed: u64, n: usize) -> u64 {
    let mut z = seed.wrapping_add((n as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    (z ^ (z >> 31)) & (i64::MAX as u64)
}

/// One campaign of the mission.
#[derive(Debug, Clone, Serialize)]
pub struct CampaignRecord {
    /// Mission day it started.
    pub day: f64,
    pub seed: u64,
    /// Its result became the table (function 3 accepted it).
    pub applied: bool,
    /// Why function 3 refused it, or why it did not fly.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refused: Option<String>,
    /// Its report (as report.json), when it flew.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub report: Option<Report>,
}

/// One parameter on one day.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct DailyRow {
    pub day: f64,
    /// 1 or 2.
    pub is: usize,
    pub param: &'static str,
    pub axis: &'static str,
    pub truth: f64,
    pub in_use: f64,
    /// Predicted σ of in_use − truth.
    pub sigma: f64,
}

/// A campaign result beyond [`trend::MISFIT_SIGMA`] of its prediction.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Misfit {
    pub day: f64,
    pub is: usize,
    pub param: &'static str,
    pub axis: &'static str,
    pub innovation_sigma: f64,
}

/// Per group, over every parameter-day.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct GroupSummary {
    pub param: &'static str,
    /// Share of parameter-days whose error meets the requirement.
    pub requirement_met_share: f64,
    /// Mean (err/σ)² (1: the predicted σ is honest).
    pub mean_z2: f64,
    pub parameter_days: usize,
}

/// The whole mission.
#[derive(Debug, Clone, Serialize)]
pub struct Mission {
    pub scenario: String,
    pub seed: u64,
    pub days: f64,
    pub confidence: f64,
    pub schedule: &'static str,
    pub campaigns: Vec<CampaignRecord>,
    pub daily: Vec<DailyRow>,
    pub model_misfits: Vec<Misfit>,
    pub summary: Vec<GroupSummary>,
    /// Campaign time over mission time.
    pub science_time_fraction: f64,
    /// What the user should know (the schedule could not keep the requirements, …).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wall_time_s: Option<f64>,
}

/// The values in use from one time on: the ground calibration, or the trends.
#[derive(Debug, Clone)]
enum InUse {
    /// Value and σ.
    Ground(Box<(Grid<f64>, Grid<f64>)>),
    Trends(Box<Trends>),
}

impl InUse {
    /// Value and σ of (IS i, group g, axis a) at `day`.
    fn at(&self, i: usize, g: usize, a: usize, day: f64) -> (f64, f64) {
        match self {
            InUse::Ground(vs) => (vs.0[i][g][a], vs.1[i][g][a]),
            InUse::Trends(t) => t[i][g][a].map_or((f64::NAN, f64::NAN), |t| t.predict(day)),
        }
    }
}

/// The requirement on (group g) for a value `v` [its unit].
fn requirement(g: usize, v: f64) -> f64 {
    if g == 2 {
        REQ_COM_M
    } else {
        REQ_SCALE_FACTOR_REL * v.abs()
    }
}

/// The truths of the mission at `day`.
fn truths(s: &Scenario, history: Option<&History>, day: f64) -> Truths {
    match history {
        Some(h) => h.at(day),
        None => s.truths(),
    }
}

/// Fly the mission of `s` (its maneuver resolved: `plan::resolve`) at mission seed
/// `seed`; `progress` hears of each campaign as it ends.
pub fn run(
    s: &Scenario,
    seed: u64,
    method: Method,
    threads: Threads,
    mut progress: impl FnMut(&CampaignRecord),
) -> Mission {
    let t0 = std::time::Instant::now();
    let tl = s.timeline.clone().unwrap_or_default();
    let campaign_days = s.duration_s / DAY_S;
    let base = Scenario {
        mission_seed: Some(seed),
        ..s.clone()
    };
    let history = History::of(&base, tl.days + campaign_days);
    let n_is = s.inertial_sensor.len();
    let z = schedule::two_sided_quantile(tl.confidence);
    let mut campaigns: Vec<CampaignRecord> = Vec::new();
    let mut misfits = Vec::new();
    let mut warnings = Vec::new();
    // The values in use, from each time on (the first: the ground calibration).
    let mut in_use: Vec<(f64, InUse)> = vec![(0.0, ground(&base, seed))];
    let mut trends: Trends = [[[None; 3]; 3]; 2];
    let mut next = match &tl.campaigns {
        CampaignDays::Auto => Some(0.0),
        CampaignDays::Days(d) => d.first().copied(),
    };
    while let Some(day) = next.filter(|d| d + campaign_days <= tl.days) {
        if campaigns.len() >= MAX_CAMPAIGNS {
            warnings.push(format!("stopped after {MAX_CAMPAIGNS} campaigns"));
            break;
        }
        let n = campaigns.len();
        let (record, result) = fly(&base, seed, n, day, &in_use, method, threads);
        let end = day + campaign_days;
        if let Some(result) = result {
            let mid = trend::campaign_middle(day, s.duration_s);
            for m in trend::take_in(&mut trends, s, &result, mid) {
                misfits.push(Misfit {
                    day,
                    is: m.is + 1,
                    param: GROUPS[m.group],
                    axis: AXES[m.axis],
                    innovation_sigma: m.innovation_sigma,
                });
            }
            in_use.push((end, InUse::Trends(Box::new(trends))));
        }
        progress(&record);
        campaigns.push(record);
        next = match &tl.campaigns {
            CampaignDays::Days(d) => d.get(n + 1).copied(),
            CampaignDays::Auto => Some(next_auto(
                &in_use,
                n_is,
                z,
                end,
                &tl,
                campaign_days,
                &mut warnings,
            )),
        };
    }
    let daily = daily_rows(&base, history.as_ref(), &in_use, &campaigns, &tl);
    let summary = summarize(&daily);
    let flown = campaigns.iter().filter(|c| c.report.is_some()).count();
    Mission {
        scenario: s.name.clone(),
        seed,
        days: tl.days,
        confidence: tl.confidence,
        schedule: match tl.campaigns {
            CampaignDays::Auto => "auto",
            CampaignDays::Days(_) => "list",
        },
        campaigns,
        daily,
        model_misfits: misfits,
        summary,
        science_time_fraction: flown as f64 * campaign_days / tl.days,
        warnings,
        wall_time_s: Some(t0.elapsed().as_secs_f64()),
    }
}

/// The ground calibration as the values in use before the first campaign: the
/// scenario's priors (drawn at the first campaign's seed) with the stated errors.
fn ground(base: &Scenario, seed: u64) -> InUse {
    let s0 = Scenario {
        seed: campaign_seed(seed, 0),
        ..base.clone()
    };
    let gc = &s0.ground_calibration;
    let mut value = [[[0.0; 3]; 3]; 2];
    let mut sigma = [[[0.0; 3]; 3]; 2];
    for (i, (p, is)) in s0.priors().iter().zip(&s0.inertial_sensor).enumerate() {
        let k = crate::sim::scenario::k_from_beta(&is.geometry_m, &p.beta);
        for a in 0..3 {
            value[i][0][a] = p.beta[a];
            value[i][1][a] = k[a];
            value[i][2][a] = p.com_offset_m[a];
            sigma[i][0][a] = gc.beta_rel_error * p.beta[a].abs();
            sigma[i][1][a] = gc.beta_rel_error * k[a].abs();
            sigma[i][2][a] = gc.com_offset_error_m;
        }
    }
    InUse::Ground(Box::new((value, sigma)))
}

/// Campaign `n` on `day`: its scenario (epoch, seed, priors from the values in use
/// after the first), flown and judged by function 3; its result when applied.
fn fly(
    base: &Scenario,
    seed: u64,
    n: usize,
    day: f64,
    in_use: &[(f64, InUse)],
    method: Method,
    threads: Threads,
) -> (CampaignRecord, Option<TableValues>) {
    let mut sc = Scenario {
        epoch_day: day,
        seed: campaign_seed(seed, n),
        ..base.clone()
    };
    let mut record = CampaignRecord {
        day,
        seed: sc.seed,
        applied: false,
        refused: None,
        report: None,
    };
    if let Some((_, InUse::Trends(t))) = in_use.last() {
        let table = trend::predicted(t, day);
        match sc.with_onboard_priors(&table).validated() {
            Ok(v) => sc = v,
            Err(e) => {
                record.refused = Some(format!("not flown: {e}"));
                return (record, None);
            }
        }
    }
    let mut result = None;
    match crate::analysis::campaign_report::run(&sc, sc.seed, method, threads, |_| {}) {
        Ok(report) => {
            match crate::analysis::report::table_values(&report) {
                Ok(v) => {
                    record.applied = true;
                    result = Some(v);
                }
                Err(f) => record.refused = Some(format!("function 3 refused it: {f:?}")),
            }
            record.report = Some(report);
        }
        Err(e) => record.refused = Some(e.to_string()),
    }
    (record, result)
}

/// With "auto": the day of the next campaign after one ending at `end`.
fn next_auto(
    in_use: &[(f64, InUse)],
    n_is: usize,
    z: f64,
    end: f64,
    tl: &MissionTimeline,
    campaign_days: f64,
    warnings: &mut Vec<String>,
) -> f64 {
    let mut ts = Vec::new();
    if let Some((_, InUse::Trends(t))) = in_use.last() {
        for tg in t.iter().take(n_is) {
            for (g, ta) in tg.iter().enumerate() {
                for t in ta.iter().flatten() {
                    ts.push((*t, requirement(g, t.value)));
                }
            }
        }
    }
    // Nothing applied yet: the ground calibration does not meet them; fly again.
    if ts.is_empty() {
        return end.ceil().max(end);
    }
    let lapse = schedule::requirement_lapses(&ts, z, end, tl.days + 1.0);
    if lapse <= end + campaign_days && warnings.is_empty() {
        warnings.push(format!(
            "the requirements lapse at day {lapse:.2}, before a campaign started after the one ending on day {end:.2} could end: the values in use cannot keep them with confidence {} between campaigns",
            tl.confidence
        ));
    }
    let cap = end - campaign_days + tl.max_interval_days;
    schedule::next_campaign(lapse.min(cap + campaign_days), campaign_days, end.ceil())
}

/// Every whole day from the end of the first campaign to the mission's end: each
/// parameter's truth, value in use and σ.
fn daily_rows(
    s: &Scenario,
    history: Option<&History>,
    in_use: &[(f64, InUse)],
    campaigns: &[CampaignRecord],
    tl: &MissionTimeline,
) -> Vec<DailyRow> {
    let Some(first) = campaigns.first() else {
        return Vec::new();
    };
    let start = (first.day + s.duration_s / DAY_S).ceil() as usize;
    let mut out = Vec::new();
    for d in start..=tl.days.floor() as usize {
        let day = d as f64;
        let Some((_, u)) = in_use.iter().rev().find(|(from, _)| *from <= day) else {
            continue;
        };
        let t = truths(s, history, day);
        for i in 0..s.inertial_sensor.len() {
            for (g, param) in GROUPS.iter().enumerate() {
                for (a, axis) in AXES.iter().enumerate() {
                    let truth = [t.beta, t.k, t.com_offset_m][g][i][a];
                    let (in_use, sigma) = u.at(i, g, a, day);
                    out.push(DailyRow {
                        day,
                        is: i + 1,
                        param,
                        axis,
                        truth,
                        in_use,
                        sigma,
                    });
                }
            }
        }
    }
    out
}

/// Per group: the share of parameter-days that meet the requirement, mean (err/σ)².
pub fn summarize(daily: &[DailyRow]) -> Vec<GroupSummary> {
    GROUPS
        .iter()
        .enumerate()
        .map(|(g, param)| {
            let rows: Vec<&DailyRow> = daily.iter().filter(|r| r.param == *param).collect();
            let n = rows.len().max(1) as f64;
            let met = rows
                .iter()
                .filter(|r| (r.in_use - r.truth).abs() < requirement(g, r.truth))
                .count();
            let z2: f64 = rows
                .iter()
                .map(|r| ((r.in_use - r.truth) / r.sigma).powi(2))
                .sum();
            GroupSummary {
                param,
                requirement_met_share: met as f64 / n,
                mean_z2: z2 / n,
                parameter_days: rows.len(),
            }
        })
        .collect()
}
