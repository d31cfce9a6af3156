//! What the monitor knows of a run, built from the estimates and the supervisor's
//! status as they arrive, and the snapshot the screen and `--json` show. Rates and the
//! end-to-end latency are over a sliding window of wall-clock time; the stages' hop
//! latencies are their own figures since they started (a stage keeps no window).

use super::feed::Stream;
use crate::sim::msg::Header;
use crate::sim::msg::{
    status_text, EstimateMsg, SetStatus, CAUSE_NAMES, EST_FINAL, GROUP_NAMES, N_CAUSES,
    PROC_ESTIMATOR, PROC_FEE, PROC_PLANT, SET_FINISHED, SET_RUNNING, SET_STARTING, SET_STOPPING,
    STATE_DONE, STATE_READY, STATE_RUNNING,
};
use serde::Serialize;
use std::collections::{BTreeMap, VecDeque};
use std::time::{Duration, Instant};

/// Sliding window of the rates and the end-to-end latency [s of wall-clock time].
pub const WINDOW: Duration = Duration::from_secs(10);
/// Points kept per parameter for the convergence plot (spread over the campaign).
const HISTORY: usize = 400;
/// End-to-end latencies kept at most (the window at ×1000 real time and more).
const LATENCIES: usize = 50_000;
/// Ticks of publish times kept to pair a stage's input with its output.
const PAIRING_TICKS: u64 = 4096;
/// The stages' segments of the end-to-end latency, each from one stage's publish to the
/// next one's (its input hop and its processing): names, in order.
pub const SEGMENTS: [&str; 3] = ["commander->plant", "plant->fee", "fee->estimator"];

/// Parameter groups, in row order: name, unit of the raw value.
pub const GROUPS: [(&str, &str); 3] = [("beta", "rad s^-2 V^-1"), ("k", "m s^-2 V^-1"), ("r", "m")];
pub const AXES: [&str; 3] = ["x", "y", "z"];
/// Rows of the parameter table: 2 IS × 3 groups × 3 axes.
pub const ROWS: usize = 18;

/// The truth of a scenario the monitor was given (never read from the bus).
#[derive(Debug, Clone, Copy)]
pub struct Truth {
    pub values: [f64; ROWS],
    pub n_is: usize,
}

impl Truth {
    pub fn of(s: &crate::sim::scenario::Scenario) -> Self {
        let mut values = [f64::NAN; ROWS];
        for (i, is) in s.inertial_sensor.iter().enumerate().take(2) {
            let k = is.k();
            for a in 0..3 {
                values[row(i, 0, a)] = is.beta[a];
                values[row(i, 1, a)] = k[a];
                values[row(i, 2, a)] = is.com_offset_m[a];
            }
        }
        Truth {
            values,
            n_is: s.inertial_sensor.len().min(2),
        }
    }
}

/// Row of IS `is`, group `g` (`GROUPS`), axis `a`.
pub fn row(is: usize, g: usize, a: usize) -> usize {
    is * 9 + g * 3 + a
}

fn values_of(m: &EstimateMsg) -> ([f64; ROWS], [f64; ROWS]) {
    let mut v = [0.0; ROWS];
    let mut s = [0.0; ROWS];
    for i in 0..2 {
        for a in 0..3 {
            v[row(i, 0, a)] = m.beta[i][a];
            s[row(i, 0, a)] = m.beta_sigma[i][a];
            v[row(i, 1, a)] = m.k[i][a];
            s[row(i, 1, a)] = m.k_sigma[i][a];
            v[row(i, 2, a)] = m.r_b[i][a];
            s[row(i, 2, a)] = m.r_sigma[i][a];
        }
    }
    (v, s)
}

fn bound_of(st: &SetStatus) -> [f64; ROWS] {
    let mut b = [f64::NAN; ROWS];
    for i in 0..2 {
        for a in 0..3 {
            b[row(i, 0, a)] = st.bound_beta[i][a];
            b[row(i, 1, a)] = st.bound_k[i][a];
            b[row(i, 2, a)] = st.bound_r[i][a];
        }
    }
    b
}

/// One point of the convergence plot.
#[derive(Debug, Clone, Copy)]
pub struct Point {
    pub tick: u64,
    pub sigma: [f64; ROWS],
    pub value: [f64; ROWS],
    pub bound: [f64; ROWS],
}

/// The run as seen so far.
pub struct Tracker {
    pub truth: Option<Truth>,
    pub latest: Option<EstimateMsg>,
    pub status: Option<SetStatus>,
    pub status_at: Option<Instant>,
    pub estimates_seen: u64,
    pub history: Vec<Point>,
    /// (when, rejections by cause, ticks used + rejected) at each estimate batch.
    counts: VecDeque<(Instant, [u64; N_CAUSES], u64)>,
    /// (when, estimator's missed deadlines) at each status.
    missed: VecDeque<(Instant, u64)>,
    /// (when, plant publish → estimate published [ns]).
    e2e: VecDeque<(Instant, u64)>,
    /// (when, segment [ns]) per `SEGMENTS`.
    segments: [VecDeque<(Instant, u64)>; 3],
    /// Recent publish times by tick [ns]: commands; samples (plant's, front end's);
    /// estimates.
    torque_at: BTreeMap<u64, u64>,
    sensor_at: BTreeMap<u64, (u64, u64)>,
    estimate_at: BTreeMap<u64, u64>,
}

impl Tracker {
    pub fn new(truth: Option<Truth>) -> Self {
        Tracker {
            truth,
            latest: None,
            status: None,
            status_at: None,
            estimates_seen: 0,
            history: Vec::new(),
            counts: VecDeque::new(),
            missed: VecDeque::new(),
            e2e: VecDeque::new(),
            segments: Default::default(),
            torque_at: BTreeMap::new(),
            sensor_at: BTreeMap::new(),
            estimate_at: BTreeMap::new(),
        }
    }

    fn segment(&mut self, k: usize, from_ns: u64, to_ns: u64, now: Instant) {
        if from_ns > 0 && to_ns >= from_ns {
            let w = &mut self.segments[k];
            w.push_back((now, to_ns - from_ns));
            if w.len() > LATENCIES {
                w.pop_front();
            }
        }
    }

    /// A command's or sample's header: pair it with the other side of its segment.
    pub fn stream(&mut self, k: Stream, h: &Header, now: Instant) {
        let tick = h.tick;
        match k {
            Stream::Torque => {
                self.torque_at.insert(tick, h.publish_ns);
                if let Some(&(origin, _)) = self.sensor_at.get(&tick) {
                    self.segment(0, h.publish_ns, origin, now);
                }
            }
            Stream::Sensor => {
                self.sensor_at.insert(tick, (h.origin_ns, h.publish_ns));
                if let Some(&cmd) = self.torque_at.get(&tick) {
                    self.segment(0, cmd, h.origin_ns, now);
                }
                self.segment(1, h.origin_ns, h.publish_ns, now);
                if let Some(&est) = self.estimate_at.get(&tick) {
                    self.segment(2, h.publish_ns, est, now);
                }
            }
        }
    }

    pub fn estimate(&mut self, m: &EstimateMsg, now: Instant) {
        self.estimates_seen += 1;
        // The final estimate is sent again over hosts (same seq): keep the first.
        if self.latest.is_some_and(|l| l.flags & EST_FINAL != 0) {
            return;
        }
        let tick = m.header.tick;
        self.estimate_at.insert(tick, m.header.publish_ns);
        if let Some(&(_, fee)) = self.sensor_at.get(&tick) {
            self.segment(2, fee, m.header.publish_ns, now);
        }
        if m.header.origin_ns > 0 && m.header.publish_ns >= m.header.origin_ns {
            self.e2e
                .push_back((now, m.header.publish_ns - m.header.origin_ns));
            if self.e2e.len() > LATENCIES {
                self.e2e.pop_front();
            }
        }
        self.latest = Some(*m);
    }

    pub fn status(&mut self, st: &SetStatus, now: Instant) {
        self.status = Some(*st);
        self.status_at = Some(now);
        if let Some(est) = st.members.iter().find(|m| m.process == PROC_ESTIMATOR) {
            self.missed.push_back((now, est.last.missed_deadlines));
        }
    }

    /// After a batch of messages: the window's bookkeeping and the plot's next point.
    pub fn settle(&mut self, now: Instant) {
        let horizon = now.checked_sub(WINDOW);
        let old = |t: &Instant| horizon.is_some_and(|h| *t < h);
        for w in std::iter::once(&mut self.e2e).chain(self.segments.iter_mut()) {
            while w.front().is_some_and(|(t, _)| old(t)) {
                w.pop_front();
            }
        }
        let newest = [&self.torque_at, &self.estimate_at]
            .iter()
            .filter_map(|m| m.keys().next_back().copied())
            .chain(self.sensor_at.keys().next_back().copied())
            .max()
            .unwrap_or(0);
        let keep = newest.saturating_sub(PAIRING_TICKS);
        self.torque_at = self.torque_at.split_off(&keep);
        self.sensor_at = self.sensor_at.split_off(&keep);
        self.estimate_at = self.estimate_at.split_off(&keep);
        // Keep one entry older than the window: rates span the whole of it.
        while self.counts.len() > 1 && self.counts.get(1).is_some_and(|(t, ..)| old(t)) {
            self.counts.pop_front();
        }
        while self.missed.len() > 1 && self.missed.get(1).is_some_and(|(t, _)| old(t)) {
            self.missed.pop_front();
        }
        let Some(m) = self.latest else { return };
        self.counts
            .push_back((now, m.rejected_by_cause, m.n_used + m.n_rejected));
        let n = self.status.map_or(0, |s| s.n_samples).max(1);
        let step = (n / HISTORY as u64).max(1);
        let tick = m.header.tick;
        if self
            .history
            .last()
            .is_none_or(|p| tick >= p.tick + step || (m.flags & EST_FINAL != 0 && tick > p.tick))
        {
            let (value, sigma) = values_of(&m);
            let bound = self.status.map_or([f64::NAN; ROWS], |s| bound_of(&s));
            self.history.push(Point {
                tick,
                sigma,
                value,
                bound,
            });
        }
    }

    /// Has the run ended (its final estimate in, or the supervisor stopping)?
    pub fn ended(&self) -> bool {
        self.status
            .is_some_and(|s| s.state == SET_FINISHED || s.state == SET_STOPPING)
    }

    pub fn snapshot(&self, prefix: &str, hosts: &super::HostNames, now: Instant) -> Snapshot {
        Snapshot {
            bus_prefix: Some(prefix.to_string()),
            ground: None,
            estimates_received: self.estimates_seen,
            status_age_s: self.status_at.map(|t| (now - t).as_secs_f64()),
            run: self.status.map(|s| run_of(&s)),
            estimate: self.latest.map(|m| self.estimate_of(&m, now)),
            latency: self.status.map(|s| self.latency_of(&s, now)),
            processes: self
                .status
                .map(|s| processes_of(&s, hosts))
                .unwrap_or_default(),
        }
    }

    fn estimate_of(&self, m: &EstimateMsg, now: Instant) -> EstimateView {
        let (value, sigma) = values_of(m);
        let bound = self.status.map_or([f64::NAN; ROWS], |s| bound_of(&s));
        let n_is = self.truth.map_or(2, |t| t.n_is);
        let mut parameters = Vec::new();
        for i in 0..n_is {
            for (g, (name, unit)) in GROUPS.iter().enumerate() {
                for a in 0..3 {
                    let k = row(i, g, a);
                    let truth = self.truth.map(|t| t.values[k]);
                    parameters.push(Parameter {
                        is: i + 1,
                        name,
                        axis: AXES[a],
                        unit,
                        estimate: value[k],
                        sigma: sigma[k],
                        bound: finite(bound[k]),
                        sigma_over_bound: finite(sigma[k] / bound[k]),
                        truth,
                        err_over_sigma: truth.and_then(|t| finite((value[k] - t) / sigma[k])),
                    });
                }
            }
        }
        let first = self.counts.front();
        let span = first.map_or(0.0, |(t, ..)| (now - *t).as_secs_f64());
        let rejections = (0..N_CAUSES)
            .map(|c| Rejection {
                cause: CAUSE_NAMES[c],
                count: m.rejected_by_cause[c],
                rate_per_s: first.filter(|_| span > 0.0).map_or(0.0, |(_, n0, _)| {
                    m.rejected_by_cause[c].saturating_sub(n0[c]) as f64 / span
                }),
            })
            .collect();
        let ticks_in_window = first.map_or(0, |(_, _, t0)| (m.n_used + m.n_rejected) - t0);
        EstimateView {
            tick: m.header.tick,
            solved_tick: m.solved_tick,
            is_final: m.flags & EST_FINAL != 0,
            status: status_text(m.status),
            status_word: m.status,
            chi2_per_dof: GROUP_NAMES
                .iter()
                .zip(m.chi2_per_dof)
                .map(|(g, v)| (g.to_string(), v))
                .collect(),
            sigma_inflation: Some(m.sigma_inflation),
            samples_used: m.n_used,
            samples_rejected: m.n_rejected,
            ticks_in_window,
            rejections: Some(rejections),
            parameters,
        }
    }

    fn latency_of(&self, st: &SetStatus, now: Instant) -> Latency {
        let member = |id: u32| st.members.iter().find(|m| m.process == id && m.heard != 0);
        let hop = |id: u32| {
            member(id).map(|m| Quantiles {
                p50: m.last.hop_latency_us[0],
                p99: m.last.hop_latency_us[1],
                max: m.last.hop_latency_us[2],
                count: Some(m.last.latency_count),
            })
        };
        let est = member(PROC_ESTIMATOR);
        let missed_window = match (self.missed.front(), est) {
            (Some((t, n0)), Some(e)) if now > *t => {
                Some(e.last.missed_deadlines - n0.min(&e.last.missed_deadlines))
            }
            _ => None,
        };
        Latency {
            realtime: Some(st.period_ns > 0),
            window_s: WINDOW.as_secs_f64(),
            end_to_end_us: Some(quantiles(&self.e2e)),
            segments_us: SEGMENTS
                .iter()
                .zip(&self.segments)
                .filter(|(_, w)| !w.is_empty())
                .map(|(n, w)| (n.to_string(), quantiles(w)))
                .collect(),
            end_to_end_since_start_us: est.map(|m| Quantiles {
                p50: m.last.e2e_latency_us[0],
                p99: m.last.e2e_latency_us[1],
                max: m.last.e2e_latency_us[2],
                count: Some(m.last.latency_count),
            }),
            hops_since_start_us: [
                ("commander->plant", hop(PROC_PLANT)),
                ("plant->fee", hop(PROC_FEE)),
                ("fee->estimator", hop(PROC_ESTIMATOR)),
            ]
            .into_iter()
            .filter_map(|(n, h)| h.map(|h| (n.to_string(), h)))
            .collect(),
            missed_deadlines: Some(est.map_or(0, |m| m.last.missed_deadlines)),
            missed_deadlines_in_window: missed_window,
            samples_lost: st
                .members
                .iter()
                .take(st.n_members as usize)
                .map(|m| m.last.samples_lost)
                .sum(),
        }
    }
}

/// p50, p99, max [µs] of a window of latencies [ns].
fn quantiles(w: &VecDeque<(Instant, u64)>) -> Quantiles {
    let mut v: Vec<f64> = w.iter().map(|(_, ns)| *ns as f64 / 1e3).collect();
    v.sort_by(f64::total_cmp);
    let q = |p: f64| {
        v.get(((p * v.len() as f64).ceil() as usize).saturating_sub(1))
            .copied()
            .unwrap_or(0.0)
    };
    Quantiles {
        p50: q(0.5),
        p99: q(0.99),
        max: v.last().copied().unwrap_or(0.0),
        count: Some(v.len() as u64),
    }
}

fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

fn run_of(s: &SetStatus) -> RunView {
    let est = s
        .members
        .iter()
        .find(|m| m.process == PROC_ESTIMATOR && m.heard != 0);
    let tick = est.map_or(0, |m| m.last.next_tick);
    let torque = s.maneuver_torque_nm;
    let axis = (0..3).find(|&a| torque[a] != 0.0);
    RunView {
        state: match s.state {
            SET_STARTING => "starting",
            SET_RUNNING => "running",
            SET_FINISHED => "finished",
            SET_STOPPING => "stopping",
            _ => "unknown",
        },
        campaign: None,
        supervisor_pid: Some(s.supervisor_pid),
        elapsed_s: Some(s.elapsed_ns as f64 / 1e9),
        pacing: Some(if s.period_ns > 0 {
            "realtime"
        } else {
            "accelerated"
        }),
        time_scale: (s.period_ns > 0).then_some(s.time_scale),
        period_us: (s.period_ns > 0).then_some(s.period_ns as f64 / 1e3),
        tick,
        n_samples: s.n_samples,
        progress: tick as f64 / s.n_samples.max(1) as f64,
        sim_time_s: tick as f64 / s.sample_rate_hz,
        maneuver: Some(Maneuver {
            axis: axis.map(|a| AXES[a]),
            torque_nm: axis.map_or(0.0, |a| torque[a]),
            axes_rocked: (0..3).filter(|&a| torque[a] != 0.0).count(),
        }),
        stop_requested_by: (s.stop_requested_by != 0).then_some(s.stop_requested_by),
    }
}

fn processes_of(s: &SetStatus, hosts: &super::HostNames) -> Vec<ProcessView> {
    s.members
        .iter()
        .take(s.n_members as usize)
        .map(|m| {
            let name = crate::bus::topology::STAGES
                .iter()
                .find(|st| st.id == m.process)
                .map_or("?", |st| st.process);
            ProcessView {
                name: name.to_string(),
                host: Some(hosts.name(s, m.host, name)),
                state: match (m.heard, m.last.state) {
                    (0, _) => "not heard",
                    (_, STATE_READY) => "ready",
                    (_, STATE_RUNNING) => "running",
                    (_, STATE_DONE) => "done",
                    _ => "unknown",
                },
                heartbeat_age_ms: Some(m.heartbeat_age_ns as f64 / 1e6),
                restarts: m.restarts,
                next_tick: Some(m.last.next_tick),
                samples_lost: m.last.samples_lost,
                loop_allocations: (m.process == PROC_ESTIMATOR).then_some(m.last.loop_allocations),
            }
        })
        .collect()
}

/// Everything shown, in SI units (`--json`; the screen draws the same).
#[derive(Debug, Clone, Serialize)]
pub struct Snapshot {
    /// The run's bus prefix (None: drawn from the ground link).
    pub bus_prefix: Option<String>,
    /// Drawn from the ground link's telemetry (`monitor --ground`), not the bus.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ground: Option<GroundView>,
    pub estimates_received: u64,
    /// Seconds since the supervisor's last status arrived (None: none yet).
    pub status_age_s: Option<f64>,
    pub run: Option<RunView>,
    pub estimate: Option<EstimateView>,
    pub latency: Option<Latency>,
    pub processes: Vec<ProcessView>,
}

/// The ground link a snapshot was drawn from (`monitor --ground`), and what its
/// health report says of the link itself; None before the first health report.
#[derive(Debug, Clone, Serialize)]
pub struct GroundView {
    /// The set's address.
    pub address: String,
    /// Seconds since the last datagram came (None: none yet).
    pub telemetry_age_s: Option<f64>,
    /// The set's mode as its number (0 standby, 1 running, 2 shutting down).
    pub mode: Option<u8>,
    pub campaign: Option<u32>,
    pub tmtc_restarts: Option<u32>,
    pub stage_restarts: Option<u32>,
    pub tc_accepted: Option<u32>,
    /// Telecommands refused, every failure code together.
    pub tc_refused: Option<u64>,
    pub datagrams: Option<u64>,
    pub tm_sent: Option<u64>,
    pub tm_send_errors: Option<u32>,
    /// The snapshot's figures the ground link does not carry (shown as unavailable).
    pub unavailable: Vec<&'static str>,
}

#[derive(Debug, Clone, Serialize)]
pub struct RunView {
    pub state: &'static str,
    /// The campaign's number (only over the ground link).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub campaign: Option<u32>,
    /// None: not known (over the ground link), as below.
    pub supervisor_pid: Option<u32>,
    pub elapsed_s: Option<f64>,
    pub pacing: Option<&'static str>,
    pub time_scale: Option<f64>,
    pub period_us: Option<f64>,
    /// The estimator's next tick.
    pub tick: u64,
    pub n_samples: u64,
    /// Fraction of the campaign the estimator has taken in.
    pub progress: f64,
    pub sim_time_s: f64,
    pub maneuver: Option<Maneuver>,
    pub stop_requested_by: Option<u32>,
}

/// The maneuver's phase at the estimator's tick.
#[derive(Debug, Clone, Serialize)]
pub struct Maneuver {
    /// The first axis rocked (None: quiet).
    pub axis: Option<&'static str>,
    /// Its commanded torque [N m] (the square wave's level).
    pub torque_nm: f64,
    pub axes_rocked: usize,
}

#[derive(Debug, Clone, Serialize)]
pub struct EstimateView {
    pub tick: u64,
    pub solved_tick: u64,
    pub is_final: bool,
    pub status: String,
    pub status_word: u64,
    /// Per residual group (1 when the noise model fits).
    pub chi2_per_dof: std::collections::BTreeMap<String, f64>,
    /// None: not known (over the ground link), as below.
    pub sigma_inflation: Option<f64>,
    pub samples_used: u64,
    pub samples_rejected: u64,
    /// Ticks the estimator took in during the window.
    pub ticks_in_window: u64,
    pub rejections: Option<Vec<Rejection>>,
    pub parameters: Vec<Parameter>,
}

#[derive(Debug, Clone, Serialize)]
pub struct Rejection {
    pub cause: &'static str,
    pub count: u64,
    /// Over the window [1/s of wall-clock time].
    pub rate_per_s: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Parameter {
    pub is: usize,
    pub name: &'static str,
    pub axis: &'static str,
    pub unit: &'static str,
    pub estimate: f64,
    pub sigma: f64,
    /// Cramér–Rao bound of the samples so far (None before every parameter is excited).
    pub bound: Option<f64>,
    pub sigma_over_bound: Option<f64>,
    /// Only when the monitor was given the scenario (`--scenario`).
    pub truth: Option<f64>,
    pub err_over_sigma: Option<f64>,
}

#[derive(Debug, Clone, Copy, Serialize)]
pub struct Quantiles {
    pub p50: f64,
    pub p99: f64,
    pub max: f64,
    /// Latencies behind the figures (None: not known, over the ground link).
    pub count: Option<u64>,
}

#[derive(Debug, Clone, Serialize)]
pub struct Latency {
    /// Real-time pacing (None: not known, over the ground link).
    pub realtime: Option<bool>,
    pub window_s: f64,
    /// Plant publish → estimate published, over the window [µs] (None over the
    /// ground link: the estimates' publish times do not cross it).
    pub end_to_end_us: Option<Quantiles>,
    /// Over the window, each stage's segment of it [µs]: from its upstream's publish to
    /// its own (input hop and processing), by `SEGMENTS` name; a stream that does not
    /// reach the monitor's host is left out.
    pub segments_us: std::collections::BTreeMap<String, Quantiles>,
    /// The estimator's own figure since it started [µs].
    pub end_to_end_since_start_us: Option<Quantiles>,
    /// Each stage's input hop since it started [µs].
    pub hops_since_start_us: std::collections::BTreeMap<String, Quantiles>,
    /// The estimator's missed deadlines (None: not known, over the ground link).
    pub missed_deadlines: Option<u64>,
    pub missed_deadlines_in_window: Option<u64>,
    pub samples_lost: u64,
}

#[derive(Debug, Clone, Serialize)]
pub struct ProcessView {
    pub name: String,
    /// None: not known (over the ground link), as below.
    pub host: Option<String>,
    pub state: &'static str,
    pub heartbeat_age_ms: Option<f64>,
    pub restarts: u32,
    pub next_tick: Option<u64>,
    pub samples_lost: u64,
    pub loop_allocations: Option<u64>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::msg::{MemberStatus, Progress, CAUSE_LINEAR_OUTLIER};

    fn status(missed: u64) -> SetStatus {
        let mut st = SetStatus {
            state: SET_RUNNING,
            n_samples: 1000,
            sample_rate_hz: 10.0,
            period_ns: 1_000_000,
            time_scale: 100.0,
            n_members: 1,
            ..Default::default()
        };
        st.members[0] = MemberStatus {
            process: PROC_ESTIMATOR,
            heard: 1,
            last: Progress {
                next_tick: 500,
                missed_deadlines: missed,
                ..Default::default()
            },
            ..Default::default()
        };
        st
    }

    fn estimate(tick: u64, latency_us: u64, rejected: u64) -> EstimateMsg {
        let mut m = EstimateMsg::default();
        m.header.tick = tick;
        m.header.origin_ns = 1_000_000;
        m.header.publish_ns = 1_000_000 + latency_us * 1000;
        m.beta_sigma = [[1.0; 3]; 2];
        m.rejected_by_cause[CAUSE_LINEAR_OUTLIER] = rejected;
        m.n_used = tick + 1 - rejected;
        m.n_rejected = rejected;
        m
    }

    #[test]
    fn rates_and_latency_are_over_the_window_and_old_entries_leave_it() {
        let t0 = Instant::now();
        let hosts = crate::runtime::monitor::HostNames(None);
        let mut t = Tracker::new(None);
        t.status(&status(2), t0);
        for us in 1..=100 {
            t.estimate(&estimate(us, us, 0), t0);
        }
        t.settle(t0);
        let t1 = t0 + Duration::from_secs(2);
        t.status(&status(7), t1);
        t.estimate(&estimate(200, 50, 10), t1);
        t.settle(t1);
        let s = t.snapshot("p_", &hosts, t1);
        let l = s.latency.unwrap();
        let e2e = l.end_to_end_us.unwrap();
        assert_eq!(e2e.count, Some(101));
        assert_eq!(e2e.p50, 50.0);
        assert_eq!(e2e.p99, 99.0);
        assert_eq!(e2e.max, 100.0);
        assert_eq!(l.missed_deadlines, Some(7));
        assert_eq!(l.missed_deadlines_in_window, Some(5));
        let e = s.estimate.unwrap();
        let outlier = &e.rejections.unwrap()[CAUSE_LINEAR_OUTLIER];
        assert_eq!((outlier.count, outlier.rate_per_s), (10, 5.0));
        assert_eq!(e.parameters.len(), 18);
        assert!(e
            .parameters
            .iter()
            .all(|p| p.truth.is_none() && p.bound.is_none()));
        // Past the window, the old latencies and counts no longer count.
        let t2 = t1 + WINDOW + Duration::from_secs(1);
        t.settle(t2);
        let s = t.snapshot("p_", &hosts, t2);
        assert_eq!(s.latency.unwrap().end_to_end_us.unwrap().count, Some(0));
        assert_eq!(
            s.estimate.unwrap().rejections.unwrap()[CAUSE_LINEAR_OUTLIER].rate_per_s,
            0.0
        );
    }

    #[test]
    fn the_plot_keeps_one_point_per_step_and_the_final_estimate_stays() {
        let t0 = Instant::now();
        let mut t = Tracker::new(None);
        t.status(&status(0), t0);
        // 1000 samples, 400 points at most: a point every 2 ticks.
        for tick in 0..10 {
            t.estimate(&estimate(tick, 10, 0), t0);
            t.settle(t0);
        }
        let ticks: Vec<u64> = t.history.iter().map(|p| p.tick).collect();
        assert_eq!(ticks, [0, 2, 4, 6, 8]);
        let mut last = estimate(999, 10, 0);
        last.flags = EST_FINAL;
        t.estimate(&last, t0);
        // Sent again over hosts: the first final estimate is kept.
        t.estimate(&estimate(5, 10, 0), t0);
        assert_eq!(t.latest.unwrap().header.tick, 999);
    }

    #[test]
    fn each_stages_segment_pairs_its_input_and_output_by_tick_in_any_order() {
        let t0 = Instant::now();
        let hosts = crate::runtime::monitor::HostNames(None);
        let mut t = Tracker::new(None);
        t.status(&status(0), t0);
        let head = |tick, origin_ns, publish_ns| Header {
            tick,
            origin_ns,
            publish_ns,
            ..Default::default()
        };
        // Tick 1 in publish order; tick 2's estimate before its sample (another batch).
        t.stream(Stream::Torque, &head(1, 0, 1_000), t0);
        t.stream(Stream::Sensor, &head(1, 3_000, 7_000), t0);
        let mut e = estimate(1, 0, 0);
        (e.header.origin_ns, e.header.publish_ns) = (3_000, 12_000);
        t.estimate(&e, t0);
        let mut e = estimate(2, 0, 0);
        (e.header.origin_ns, e.header.publish_ns) = (23_000, 32_000);
        t.estimate(&e, t0);
        t.stream(Stream::Sensor, &head(2, 23_000, 27_000), t0);
        t.stream(Stream::Torque, &head(2, 0, 21_000), t0);
        t.settle(t0);
        let l = t.snapshot("p_", &hosts, t0).latency.unwrap();
        let seg = |n: &str| {
            let q = l.segments_us[n];
            (q.count, q.max)
        };
        assert_eq!(seg("commander->plant"), (Some(2), 2.0));
        assert_eq!(seg("plant->fee"), (Some(2), 4.0));
        assert_eq!(seg("fee->estimator"), (Some(2), 5.0));
        let e2e = l.end_to_end_us.unwrap();
        assert_eq!((e2e.count, e2e.max), (Some(2), 9.0));
    }
}
