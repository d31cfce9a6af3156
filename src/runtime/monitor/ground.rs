//! `monitor --ground ADDR`: the same screen drawn from the ground link's telemetry
//! alone, for an operator on another machine, with no shared memory. The monitor claims
//! the telemetry as `ground listen` does (a ping at start and every `--keepalive`
//! seconds), reads housekeeping structure 1 back into the estimator's `EstimateMsg` and
//! structure 2 into a `SetStatus` of the set's health, and feeds the same tracker and
//! screen. What only the shared memory carries (the Cramér–Rao bound, the maneuver's
//! phase, the pacing, σ inflation, rejections by cause, the latency window and hops,
//! missed deadlines, hosts) shows as unavailable.

use super::model::{GroundView, ProcessView, Quantiles, Snapshot, Tracker};
use super::{MonitorArgs, MonitorError};
use crate::ground::client::{Link, LinkConfig, Received};
use crate::ground::describe::describe;
use crate::ground::dictionary::{Mode, APID};
use crate::ground::exchange::{Keepalive, Outcome};
use crate::ground::health::Health;
use crate::ground::packet::decode_tm;
use crate::ground::readback;
use crate::sim::msg::{
    MemberStatus, Progress, SetStatus, PROC_COMMANDER, PROC_ESTIMATOR, PROC_FEE, PROC_PLANT,
    PROC_RECORDER, SET_RUNNING, SET_STARTING, SET_STOPPING, STATE_RUNNING,
};
use std::net::SocketAddr;
use std::time::{Duration, Instant};

/// The stages in structure 2's order (`health::STAGE_NAMES`).
const STAGES: [u32; 5] = [
    PROC_COMMANDER,
    PROC_PLANT,
    PROC_FEE,
    PROC_ESTIMATOR,
    PROC_RECORDER,
];

/// What the ground link does not carry, by the snapshot's names.
pub const UNAVAILABLE: [&str; 11] = [
    "bound",
    "maneuver",
    "pacing",
    "supervisor_pid",
    "elapsed_s",
    "sigma_inflation",
    "rejections",
    "end_to_end_us (window)",
    "hops_since_start_us",
    "missed_deadlines",
    "host",
];

/// The set's health as a supervisor's status, for the tracker.
pub fn status_of(h: &Health) -> SetStatus {
    let state = match h.mode {
        m if m == Mode::Running as u8 => SET_RUNNING,
        m if m == Mode::ShuttingDown as u8 => SET_STOPPING,
        _ => SET_STARTING,
    };
    let mut st = SetStatus {
        state,
        n_samples: h.n_samples,
        sample_rate_hz: f64::NAN,
        n_members: STAGES.len() as u32,
        ..SetStatus::default()
    };
    for (i, &process) in STAGES.iter().enumerate() {
        let age = h.heartbeat_age_ms[i];
        let up = age.is_finite();
        let estimator = process == PROC_ESTIMATOR;
        st.members[i] = MemberStatus {
            process,
            restarts: h.restarts[i],
            heard: u32::from(up),
            heartbeat_age_ns: if up { (age.max(0.0) * 1e6) as u64 } else { 0 },
            last: Progress {
                process,
                state: if up { STATE_RUNNING } else { 0 },
                next_tick: if estimator { h.campaign_tick } else { 0 },
                samples_lost: h.samples_lost[i],
                e2e_latency_us: if estimator {
                    h.e2e_latency_us
                } else {
                    [0.0; 3]
                },
                ..Progress::default()
            },
            ..MemberStatus::default()
        };
    }
    st
}

/// The monitor's end of the ground link.
pub struct GroundFeed {
    link: Link,
    keep: Keepalive,
    pub address: SocketAddr,
    /// The last health, its packet's time [s of the set's clock], when it came.
    health: Option<(Health, f64, Instant)>,
    /// When the last datagram came.
    pub heard_at: Option<Instant>,
    /// The set refused the ping (a failure code's name and meaning).
    pub refused: Option<String>,
    /// The address refused a datagram: nothing listens there (yet).
    pub nothing_listens: bool,
    /// A new campaign began since the last call to `pump` (the tracker starts over).
    pub new_campaign: bool,
}

impl GroundFeed {
    pub fn open(args: &MonitorArgs, to: SocketAddr) -> Result<GroundFeed, MonitorError> {
        let key = args.key.clone().ok_or(MonitorError::NoKey)?;
        let cfg = LinkConfig {
            to,
            bind: args.bind,
            key,
            seq: None,
        };
        Ok(GroundFeed {
            link: Link::open(&cfg)?,
            keep: Keepalive::new(super::seconds(args.keepalive)?),
            address: to,
            health: None,
            heard_at: None,
            refused: None,
            nothing_listens: false,
            new_campaign: false,
        })
    }

    /// Pings when it is time, then takes what arrives for up to `wait` into `t`.
    pub fn pump(&mut self, t: &mut Tracker, wait: Duration) -> Result<(), MonitorError> {
        let end = Instant::now() + wait;
        self.new_campaign = false;
        loop {
            self.keep.tick(&mut self.link)?;
            match self.link.receive_until(end)? {
                Received::Datagram(d) => self.take(&d, t),
                Received::Refused => self.nothing_listens = true,
                Received::Nothing => break,
            }
        }
        t.settle(Instant::now());
        Ok(())
    }

    fn take(&mut self, d: &[u8], t: &mut Tracker) {
        let now = Instant::now();
        self.heard_at = Some(now);
        self.nothing_listens = false;
        let Ok(tm) = decode_tm(d, APID) else { return };
        let (service, subtype) = (tm.header.service, tm.header.subtype);
        let data = tm.source_data;
        if (service, subtype) == (3, 25) && readback::is_estimate(data) {
            if let Some((e, _mode)) = readback::estimate(data) {
                t.estimate(&e, now);
            }
        } else if (service, subtype) == (3, 25) {
            if let Some(h) = readback::health(data) {
                let campaign = self.health.as_ref().map(|(old, ..)| old.campaign);
                if campaign.is_some_and(|c| c != h.campaign) {
                    self.new_campaign = true;
                }
                t.status(&status_of(&h), now);
                let time_s = tm.header.time.to_ns() as f64 / 1e9;
                self.health = Some((h, time_s, now));
            }
        } else if service == 1 {
            if let Some(Outcome::Failed {
                code,
                name,
                meaning,
                ..
            }) = self.keep.refusal(&describe(d))
            {
                self.refused = Some(format!("failure {code} {name}: {meaning}"));
            }
        }
    }

    /// Has structure 2 come yet?
    pub fn has_health(&self) -> bool {
        self.health.is_some()
    }

    /// The snapshot as the ground link shows it: what it does not carry unavailable.
    pub fn finish(&self, snap: &mut Snapshot, now: Instant) {
        snap.bus_prefix = None;
        let Some((h, time_s, _)) = &self.health else {
            snap.ground = Some(self.view(None, now));
            return;
        };
        let mode = Mode::ALL
            .iter()
            .find(|m| **m as u8 == h.mode)
            .map_or("unknown", |m| m.name());
        if let Some(run) = snap.run.as_mut() {
            run.state = mode;
            run.campaign = Some(h.campaign);
            run.supervisor_pid = None;
            run.elapsed_s = None;
            run.pacing = None;
            run.tick = h.campaign_tick;
            run.progress = h.campaign_tick as f64 / h.n_samples.max(1) as f64;
            run.sim_time_s = *time_s;
            run.maneuver = None;
        }
        if let Some(e) = snap.estimate.as_mut() {
            e.sigma_inflation = None;
            e.rejections = None;
        }
        if let Some(l) = snap.latency.as_mut() {
            l.realtime = None;
            l.end_to_end_us = None;
            l.segments_us.clear();
            l.hops_since_start_us.clear();
            l.missed_deadlines = None;
            l.missed_deadlines_in_window = None;
            let [p50, p99, max] = h.e2e_latency_us;
            l.end_to_end_since_start_us = p50.is_finite().then_some(Quantiles {
                p50,
                p99,
                max,
                count: None,
            });
        }
        for p in snap.processes.iter_mut() {
            let up = p.state == "running";
            p.host = None;
            p.state = if up { "running" } else { "down" };
            p.heartbeat_age_ms = p.heartbeat_age_ms.filter(|_| up);
            if p.name != "taiji-estimator" {
                p.next_tick = None;
            }
            p.loop_allocations = None;
        }
        snap.processes.push(ProcessView {
            name: "taiji-tmtc".into(),
            host: None,
            state: "running",
            heartbeat_age_ms: None,
            restarts: h.tmtc_restarts,
            next_tick: None,
            samples_lost: 0,
            loop_allocations: None,
        });
        snap.ground = Some(self.view(Some(h), now));
    }

    fn view(&self, h: Option<&Health>, now: Instant) -> GroundView {
        GroundView {
            address: self.address.to_string(),
            telemetry_age_s: self.heard_at.map(|t| (now - t).as_secs_f64()),
            mode: h.map(|h| h.mode),
            campaign: h.map(|h| h.campaign),
            tmtc_restarts: h.map(|h| h.tmtc_restarts),
            stage_restarts: h.map(|h| h.stage_restarts),
            tc_accepted: h.map(|h| h.tc_accepted),
            tc_refused: h.map(|h| h.tc_refused.iter().map(|&n| u64::from(n)).sum()),
            datagrams: h.map(|h| h.datagrams),
            tm_sent: h.map(|h| h.tm_sent),
            tm_send_errors: h.map(|h| h.tm_send_errors),
            unavailable: UNAVAILABLE.to_vec(),
        }
    }
}
