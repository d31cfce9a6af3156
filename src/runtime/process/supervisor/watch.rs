//! The watch of the supervisor in charge: progress and estimates heard, the start
//! once every process is ready, the watchdog that kills a hung process for a restart,
//! the liveness check, and the end of the campaign.

use crate::bus::wiring::{self, BusError};
use crate::runtime::launch::{LaunchDescription, Restart};
pub use crate::runtime::process::set::SetError;
use crate::runtime::process::set::{Reap, Set, SupervisorError};
use crate::runtime::process::status::StatusBoard;
use crate::sim::msg::{
    EstimateMsg, Progress, CMD_START, EST_FINAL, PROC_ESTIMATOR, PROC_RECORDER, SET_FINISHED,
    SET_RUNNING, SET_STARTING, STATE_DONE,
};
use std::time::{Duration, Instant};

/// The supervisor's ports the watch reads and writes.
pub(super) struct Ports<'a> {
    pub(super) node: &'a iceoryx2::prelude::Node<iceoryx2::prelude::ipc::Service>,
    pub(super) progress: &'a wiring::Sub<Progress>,
    pub(super) estimates: &'a wiring::Sub<EstimateMsg>,
    pub(super) send: &'a dyn Fn(u32, u64) -> Result<(), BusError>,
    /// A campaign run from the ground: the estimates go on to the ground desk.
    pub(super) relay: Option<&'a Relay>,
}

/// The estimates a campaign run from the ground hands to the ground desk (another
/// thread of this supervisor), so no further port of the supervisor's subscribes to the
/// estimator's stream: the latest, and each one whose status word changed.
#[derive(Debug, Default)]
pub(crate) struct Relay {
    latest: std::sync::Mutex<Option<EstimateMsg>>,
    changed: std::sync::Mutex<Vec<EstimateMsg>>,
    status: std::sync::atomic::AtomicU64,
}

impl Relay {
    fn put(&self, e: &EstimateMsg) {
        use std::sync::atomic::Ordering::Relaxed;
        if self.status.swap(e.status, Relaxed) != e.status {
            if let Ok(mut c) = self.changed.lock() {
                c.push(*e);
            }
        }
        if let Ok(mut l) = self.latest.lock() {
            *l = Some(*e);
        }
    }

    /// The estimates whose status changed since the last call, then the latest.
    pub(crate) fn take(&self) -> (Vec<EstimateMsg>, Option<EstimateMsg>) {
        let changed = self
            .changed
            .lock()
            .map(|mut c| std::mem::take(&mut *c))
            .unwrap_or_default();
        let latest = self.latest.lock().ok().and_then(|mut l| l.take());
        (changed, latest)
    }
}

/// What the supervisor in charge knows while it watches the set.
pub(super) struct Watch {
    pub(super) heartbeat: Duration,
    pub(super) heartbeat_s: f64,
    pub(super) ready_timeout: Duration,
    pub(super) ready_timeout_s: f64,
    pub(super) t_ready: Instant,
    pub(super) started: bool,
    pub(super) final_est: Option<EstimateMsg>,
    pub(super) n: u64,
    /// Stall watch: alive processes whose ticks do not advance are a failure too.
    pub(super) ticks_seen: u64,
    pub(super) last_advance: Instant,
}

impl Watch {
    pub(super) fn new(launch: &LaunchDescription, n: u64) -> Self {
        Watch {
            heartbeat: Duration::from_secs_f64(launch.heartbeat_timeout_s),
            heartbeat_s: launch.heartbeat_timeout_s,
            ready_timeout: Duration::from_secs_f64(launch.ready_timeout_s),
            ready_timeout_s: launch.ready_timeout_s,
            t_ready: Instant::now(),
            started: false,
            final_est: None,
            n,
            ticks_seen: 0,
            last_advance: Instant::now(),
        }
    }

    /// Watch the set until the final estimate (Some), a termination request (None) or
    /// a failure.
    pub(super) fn run(
        mut self,
        ports: &Ports,
        set: &mut Set,
        mut hosts: Option<&mut crate::runtime::process::hosts::InCharge>,
        board: &mut StatusBoard,
    ) -> Result<Option<EstimateMsg>, SupervisorError> {
        let set_err = SupervisorError::Set;
        loop {
            if ports.node.wait(Duration::from_millis(1)).is_err() {
                return Ok(None);
            }
            let link_silent = self.hear(ports, set, hosts.as_deref_mut())?;
            let state = match (self.started, self.final_est.is_some()) {
                (_, true) => SET_FINISHED,
                (true, false) => SET_RUNNING,
                (false, false) => SET_STARTING,
            };
            board.publish(set, state, false);
            // An operator's stop from a monitor: as SIGINT would (exit 130).
            if let Some(pid) = board.stop_request() {
                log::warn!("stop requested from a monitor (pid {pid}); stopping the set");
                return Ok(None);
            }
            // Exits: restart what may be restarted, otherwise stop the set.
            match set.reap("").map_err(set_err)? {
                Reap::Running => {}
                Reap::Interrupted => return Ok(None),
                Reap::Stopped(ended) => return Err(set_err(SetError::Stopped(ended))),
            }
            if !self.started {
                self.start_when_ready(ports, set)?;
                continue;
            }
            if self.watchdog(set, link_silent) {
                continue;
            }
            self.check_liveness(set)?;
            if let Some(e) = self.finished(set) {
                return Ok(Some(e));
            }
        }
    }

    /// Take in every process's progress and the estimates. Returns whether a link
    /// between hosts is silent (it holds the verdicts on the processes behind it).
    fn hear(
        &mut self,
        ports: &Ports,
        set: &mut Set,
        mut hosts: Option<&mut crate::runtime::process::hosts::InCharge>,
    ) -> Result<bool, SupervisorError> {
        let set_err = |e: SetError| SupervisorError::Set(e);
        while let Some(p) = wiring::receive(ports.progress).map_err(|e| set_err(e.into()))? {
            if p.process == PROC_ESTIMATOR {
                set.bar.set(p.next_tick);
            }
            if let Some(h) = hosts.as_deref_mut() {
                let host = set.members.iter().find(|m| m.id == p.process);
                h.heard(&p, host.map(|m| m.host.as_str()));
            }
            if let Some(m) = set.members.iter_mut().find(|m| m.id == p.process) {
                m.last = Some(p);
                m.last_seen = Instant::now();
            }
        }
        let link_silent = match hosts {
            Some(h) => h.poll().map_err(|e| set_err(e.into()))?,
            None => false,
        };
        while let Some(e) = wiring::receive(ports.estimates).map_err(|e| set_err(e.into()))? {
            if let Some(r) = ports.relay {
                r.put(&e);
            }
            if e.flags & EST_FINAL != 0 {
                self.final_est = Some(e);
            }
        }
        Ok(link_silent)
    }

    /// Say start once every process has reported; fail after the ready timeout.
    fn start_when_ready(&mut self, ports: &Ports, set: &Set) -> Result<(), SupervisorError> {
        let set_err = SupervisorError::Set;
        if set.members.iter().all(|m| m.last.is_some()) {
            (ports.send)(CMD_START, 0).map_err(|e| set_err(e.into()))?;
            self.started = true;
            log::info!("all processes ready; campaign started");
        } else if self.t_ready.elapsed() > self.ready_timeout {
            let missing: Vec<String> = set
                .members
                .iter()
                .filter(|m| m.last.is_none())
                .map(|m| m.spec.name.clone())
                .collect();
            return Err(set_err(SetError::NotReady {
                timeout_s: self.ready_timeout_s,
                missing,
            }));
        }
        Ok(())
    }

    /// Watchdog: a restartable process that publishes no progress (hung, stopped) is
    /// killed; the exit handling restarts it on the next pass. True if one was killed.
    fn watchdog(&mut self, set: &mut Set, link_silent: bool) -> bool {
        if link_silent {
            let now = Instant::now();
            self.last_advance = now;
            for m in set.members.iter_mut().filter(|m| m.child.is_none()) {
                m.last_seen = now;
            }
        }
        let heartbeat = self.heartbeat;
        let Some(m) = set.members.iter_mut().find(|m| {
            m.last_seen.elapsed() > heartbeat
                && m.child.is_some()
                && m.spec.restart == Restart::OnFailure
                && m.restarts < m.spec.max_restarts
        }) else {
            return false;
        };
        log::warn!(
            "{} published no progress for {:.0} s (hung?); killing it to restart it",
            m.spec.name,
            self.heartbeat_s
        );
        if let Some(c) = m.child.as_mut() {
            let _ = c.kill();
        }
        m.last_seen = Instant::now();
        self.last_advance = Instant::now();
        true
    }

    /// Fail on a stalled set (no tick advanced for the heartbeat timeout) or a process
    /// that stopped reporting and cannot be restarted.
    fn check_liveness(&mut self, set: &Set) -> Result<(), SupervisorError> {
        let set_err = SupervisorError::Set;
        let ticks: u64 = set
            .members
            .iter()
            .filter_map(|m| m.last.map(|p| p.next_tick))
            .sum();
        if ticks != self.ticks_seen {
            self.ticks_seen = ticks;
            self.last_advance = Instant::now();
        } else if self.final_est.is_none() && self.last_advance.elapsed() > self.heartbeat {
            let ticks: Vec<(String, u64)> = set
                .members
                .iter()
                .filter_map(|m| m.last.map(|p| (m.spec.name.clone(), p.next_tick)))
                .collect();
            return Err(set_err(SetError::Stalled {
                heartbeat_s: self.heartbeat_s,
                ticks,
            }));
        }
        if let Some(m) = set
            .members
            .iter()
            .find(|m| m.last_seen.elapsed() > self.heartbeat)
        {
            return Err(set_err(SetError::Hung {
                name: m.spec.name.clone(),
                heartbeat_s: self.heartbeat_s,
            }));
        }
        Ok(())
    }

    /// The final estimate, once the estimator is done (and, when recording,
    /// telemetry.h5 is written too).
    fn finished(&self, set: &Set) -> Option<EstimateMsg> {
        let est_done = set
            .members
            .iter()
            .find(|m| m.id == PROC_ESTIMATOR)
            .and_then(|m| m.last)
            .is_some_and(|p| p.state == STATE_DONE && p.next_tick >= self.n);
        let recorded = set
            .members
            .iter()
            .filter(|m| m.id == PROC_RECORDER)
            .all(|m| m.last.is_some_and(|p| p.state == STATE_DONE));
        self.final_est.filter(|_| est_done && recorded)
    }
}
