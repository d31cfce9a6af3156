//! The supervisor in charge's side of outside monitors (`taiji-calib monitor`): it
//! publishes what only it knows — every process's heartbeat age, restarts and host,
//! the maneuver's phase — as a `SetStatus` every `STATUS_EVERY`, and takes operators'
//! requests (`Request`) on a service of its own. A monitor thus never opens a port on a
//! service a stage's loop publishes or reads: a stage's publisher connects to a new
//! subscriber inside its next send, which allocates, and the estimator's loop must not.

use super::set::{Set, SupervisorArgs};
use crate::analysis::crlb::Crlb;
use crate::bus::timing::monotonic_ns;
use crate::bus::wiring::{self, BusError};
use crate::runtime::launch::LaunchDescription;
use crate::sim::commander::Commander;
use crate::sim::msg::{
    Header, MemberStatus, Request, SetStatus, MAX_HOSTS, MAX_MEMBERS, PROC_ESTIMATOR, REQ_STOP,
};
use crate::sim::scenario::Scenario;
use std::time::{Duration, Instant};

/// Status period: a monitor redraws at about this rate, and a process's heartbeat age
/// is shown this fresh.
pub const STATUS_EVERY: Duration = Duration::from_millis(100);

pub(crate) struct StatusBoard {
    publisher: wiring::Pub<SetStatus>,
    requests: wiring::Sub<Request>,
    /// The fields that never change during the run.
    fixed: SetStatus,
    /// The launch description's host names, in order (one host: none).
    hosts: Vec<String>,
    commander: Commander,
    /// The bound as the campaign goes (`crlb::crlb_curve`).
    bound: Vec<(u64, Option<Crlb>)>,
    t0: Instant,
    next: Instant,
    seq: u64,
    stop_requested_by: u32,
    /// A bus failure was logged (once: the monitors' side never fails the run).
    warned: bool,
}

impl StatusBoard {
    pub(crate) fn new(
        node: &iceoryx2::prelude::Node<iceoryx2::prelude::ipc::Service>,
        args: &SupervisorArgs,
        s: &Scenario,
        launch: &LaunchDescription,
        bound: Vec<(u64, Option<Crlb>)>,
    ) -> Result<Self, BusError> {
        let publisher = wiring::publisher::<SetStatus>(node, wiring::SVC_STATUS)?;
        let requests = wiring::subscriber::<Request>(node, wiring::SVC_REQUEST)?;
        let mut fixed = SetStatus {
            supervisor_pid: std::process::id(),
            n_samples: s.n_samples(),
            sample_rate_hz: s.sample_rate_hz,
            ..Default::default()
        };
        if args.realtime {
            fixed.time_scale = args.time_scale;
            fixed.period_ns = (1e9 / (s.sample_rate_hz * args.time_scale)).round() as u64;
        }
        let hosts: Vec<String> = launch.host.iter().map(|h| h.name.clone()).collect();
        for (i, h) in hosts.iter().take(MAX_HOSTS).enumerate() {
            fixed.set_host_name(i, h);
        }
        fixed.n_hosts = hosts.len().min(MAX_HOSTS) as u32;
        Ok(StatusBoard {
            publisher,
            requests,
            fixed,
            hosts,
            commander: Commander::new(s),
            bound,
            t0: Instant::now(),
            next: Instant::now(),
            seq: 0,
            stop_requested_by: 0,
            warned: false,
        })
    }

    /// Publish the set's status (`SET_*` `state`) when one is due, or at once (`now`).
    /// A failure is logged once and changes nothing in the run.
    pub(crate) fn publish(&mut self, set: &Set, state: u32, now: bool) {
        if !now && Instant::now() < self.next {
            return;
        }
        if let Err(e) = self.send(set, state) {
            self.warn(e);
        }
    }

    fn warn(&mut self, e: BusError) {
        if !self.warned {
            self.warned = true;
            log::warn!("the status for monitors failed ({e}); the run goes on");
        }
    }

    fn send(&mut self, set: &Set, state: u32) -> Result<(), BusError> {
        self.next = Instant::now() + STATUS_EVERY;
        let mut st = self.fixed;
        st.header = Header {
            seq: self.seq,
            publish_ns: monotonic_ns(),
            ..Default::default()
        };
        self.seq += 1;
        st.state = state;
        st.elapsed_ns = self.t0.elapsed().as_nanos() as u64;
        st.stop_requested_by = self.stop_requested_by;
        for (slot, m) in st.members.iter_mut().zip(&set.members) {
            *slot = MemberStatus {
                process: m.id,
                host: self.hosts.iter().position(|h| *h == m.host).unwrap_or(0) as u32,
                restarts: m.restarts,
                heard: m.last.is_some() as u32,
                heartbeat_age_ns: m.last_seen.elapsed().as_nanos() as u64,
                last: m.last.unwrap_or_default(),
            };
        }
        st.n_members = set.members.len().min(MAX_MEMBERS) as u32;
        let tick = set
            .members
            .iter()
            .find(|m| m.id == PROC_ESTIMATOR)
            .and_then(|m| m.last)
            .map_or(0, |p| p.next_tick);
        st.maneuver_tick = tick;
        st.maneuver_torque_nm = self.commander.torque(tick);
        if let Some(b) = crate::analysis::crlb::bound_at(&self.bound, tick) {
            (st.bound_beta, st.bound_k, st.bound_r) = (b.beta, b.k, b.com_offset_m);
        }
        wiring::publish(&self.publisher, st)
    }

    /// The process id of a monitor that asked to stop the run (the first one; it is
    /// then named in every status until the end).
    pub(crate) fn stop_request(&mut self) -> Option<u32> {
        loop {
            match wiring::receive(&self.requests) {
                Ok(Some(r)) => {
                    if r.command == REQ_STOP && self.stop_requested_by == 0 {
                        self.stop_requested_by = r.requester_pid.max(1);
                    }
                }
                Ok(None) => break,
                Err(e) => {
                    self.warn(e);
                    break;
                }
            }
        }
        (self.stop_requested_by != 0).then_some(self.stop_requested_by)
    }
}
