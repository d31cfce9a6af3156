//! A process set spread over hosts that share no memory, only a network link (hardware
//! in the loop: the estimator on the flight computer, the simulation elsewhere).
//!
//! Each host runs a supervisor (`taiji-supervisor --host NAME`) that starts that host's
//! processes and a `taiji-tunnel` (the iceoryx2 Zenoh tunnel, library 0.9.3) relaying
//! the services that cross hosts. The first `[[host]]` of the launch description is in
//! charge: it starts the campaign, watches every process through the heartbeats that
//! cross the tunnel, and writes the report. Another host's supervisor (an agent)
//! restarts its own processes by their policy and obeys the control service.
//!
//! Heartbeats of the supervisors themselves reuse `Progress` (ids below): the one in
//! charge beats with `header.publish_ns` (its clock); an agent answers each beat with
//! `header.origin_ns` = that time and `header.due_ns` = how long it held it, so the
//! round trip is measured on one clock (hosts share none): hop ≈ round trip / 2.

pub use super::set::HostError;
use super::set::{Reap, Set, SetError, SupervisorArgs};
use crate::bus::timing::{monotonic_ns, LatencyHistogram};
use crate::bus::wiring::{self, BusError};
use crate::runtime::launch::LaunchDescription;
use crate::sim::msg::{Header, Progress, CMD_STOP, STATE_DONE, STATE_READY};
use serde_json::json;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// `Progress::process` of the supervisor in charge (its heartbeat to the agents).
pub const PROC_SUPERVISOR: u32 = 16;
/// `Progress::process` of a host's agent (its heartbeat and echo to the one in charge).
pub const PROC_AGENT: u32 = 17;
/// Heartbeat period of the supervisors across the link.
pub const BEAT: Duration = Duration::from_millis(100);
/// A host silent this long is reported as a link stall (logged, in the report); the
/// set stops only after the launch description's `link_timeout_s`.
pub const LINK_SUSPECT: Duration = Duration::from_secs(1);
/// An agent that acknowledged the stop ends once no repeat of it came for this long
/// (the one in charge repeats it every `BEAT` until acknowledged).
const ACK_QUIET: Duration = Duration::from_millis(300);

/// Fault injection: `TAIJI_FAULT_DROP_STOPS=N` makes the supervisor in charge not send
/// its first N stop commands, as if the link broke as they crossed, so tests can show
/// that the stop is repeated until the other hosts acknowledge it.
pub const FAULT_DROP_STOPS: &str = "TAIJI_FAULT_DROP_STOPS";

/// Services whose users run on more than one host, and on a set over hosts those of
/// outside monitors (which may run on any host): only these cross the link (the
/// truth, for one, never reaches the flight computer).
pub fn crossing_services(launch: &LaunchDescription, record: bool) -> Vec<String> {
    let in_charge = launch.host.first().map(|h| h.name.as_str()).unwrap_or("");
    let host_of = |user: &str| -> Option<&str> {
        if user == "supervisor" {
            return Some(in_charge);
        }
        launch
            .processes(record)
            .find(|p| p.name == user)
            .map(|p| launch.host_of(p))
    };
    let all = [
        wiring::SVC_TORQUE.to_string(),
        wiring::SVC_TRUTH.into(),
        wiring::SVC_SENSOR.into(),
        wiring::SVC_ESTIMATE.into(),
        wiring::SVC_PROGRESS.into(),
        wiring::SVC_CONTROL.into(),
        wiring::SVC_STATUS.into(),
        wiring::SVC_REQUEST.into(),
        wiring::wake_service("commander"),
        wiring::wake_service("plant"),
        wiring::wake_service("fee"),
        wiring::wake_service("estimator"),
    ];
    all.into_iter()
        .filter(|s| {
            let mut hosts: Vec<&str> = crate::bus::topology::users(s)
                .iter()
                .filter_map(|u| host_of(u))
                .collect();
            hosts.sort_unstable();
            hosts.dedup();
            hosts.len() > 1 || (launch.host.len() > 1 && crate::bus::topology::outside(s))
        })
        .collect()
}

/// This host's `taiji-tunnel`, restarted when it dies (it holds no state but what was
/// in flight, which the estimator's resync recovers).
pub struct TunnelChild {
    exe: std::path::PathBuf,
    args: Vec<String>,
    child: Child,
    pub restarts: u32,
}

impl TunnelChild {
    pub fn start(
        exe: &Path,
        prefix: &str,
        launch: &LaunchDescription,
        me: &str,
        record: bool,
    ) -> Result<Self, HostError> {
        let own =
            launch
                .host
                .iter()
                .find(|h| h.name == me)
                .ok_or_else(|| HostError::NoSuchHost {
                    host: me.to_string(),
                })?;
        let mut args = vec![
            "--bus-prefix".to_string(),
            prefix.to_string(),
            "--listen".into(),
            own.endpoint.clone(),
        ];
        // Every other host connects to the one in charge (zenoh retries until it answers).
        if launch.host[0].name != me {
            args.extend(["--connect".into(), launch.host[0].endpoint.clone()]);
        }
        for s in crossing_services(launch, record) {
            args.extend(["--service".into(), s]);
        }
        let child = spawn(exe, &args)?;
        Ok(TunnelChild {
            exe: exe.to_path_buf(),
            args,
            child,
            restarts: 0,
        })
    }

    /// Restart the tunnel if it died; how it ended, for the log and the report.
    pub fn check(&mut self) -> Result<Option<TunnelDied>, HostError> {
        match self.child.try_wait() {
            Ok(None) => Ok(None),
            Ok(Some(status)) => {
                self.child = spawn(&self.exe, &self.args)?;
                self.restarts += 1;
                Ok(Some(TunnelDied(status)))
            }
            Err(e) => Err(HostError::TunnelWatch(e)),
        }
    }
}

/// The tunnel died (its exit status) and was restarted.
#[derive(Debug, Clone, Copy)]
pub struct TunnelDied(pub std::process::ExitStatus);

impl std::fmt::Display for TunnelDied {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "the tunnel died ({}); restarted it", self.0)
    }
}

impl Drop for TunnelChild {
    fn drop(&mut self) {
        // SAFETY: kill with the pid of our own child (reaped below).
        unsafe { libc::kill(self.child.id() as i32, libc::SIGTERM) };
        let t0 = Instant::now();
        while matches!(self.child.try_wait(), Ok(None)) && t0.elapsed() < Duration::from_secs(3) {
            std::thread::sleep(Duration::from_millis(5));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn spawn(exe: &Path, args: &[String]) -> Result<Child, HostError> {
    Command::new(exe)
        .args(args)
        .stdin(Stdio::null())
        .spawn()
        .map_err(|source| HostError::TunnelSpawn {
            exe: exe.to_path_buf(),
            source,
        })
}

/// The tunnel binary: `--tunnel-bin`, else `taiji-tunnel` beside the stages.
fn tunnel_exe(args: &SupervisorArgs, bin_dir: &Path) -> std::path::PathBuf {
    args.tunnel_bin
        .clone()
        .unwrap_or_else(|| bin_dir.join("taiji-tunnel"))
}

/// A supervisor's heartbeat across the link.
pub fn beat(process: u32, origin_ns: u64, held_ns: u64, seq: u64) -> Progress {
    Progress {
        header: Header {
            seq,
            publish_ns: monotonic_ns(),
            origin_ns,
            due_ns: held_ns,
            ..Default::default()
        },
        process,
        state: STATE_READY,
        incarnation: 0,
        ..Default::default()
    }
}

/// A period in which a host's heartbeats did not cross the link.
#[derive(Debug, Clone)]
pub struct LinkEvent {
    pub host: String,
    /// Seconds since the supervisor started.
    pub silent_from_s: f64,
    /// How long no heartbeat crossed [s] (None: never came back).
    pub silent_for_s: Option<f64>,
}

/// The supervisor in charge's view of the other hosts: their liveness through the
/// link, the round trips of its heartbeats, and the tunnel it runs.
pub struct InCharge {
    pub me: String,
    pub tunnel: TunnelChild,
    pub remote: Vec<RemoteHost>,
    pub events: Vec<LinkEvent>,
    pub tunnel_deaths: Vec<String>,
    pub round_trip: LatencyHistogram,
    beat_pub: wiring::Pub<Progress>,
    next_beat: Instant,
    seq: u64,
    t0: Instant,
    link_timeout: Duration,
    /// A link stayed silent past the timeout (no stop can cross it).
    lost: bool,
    /// Stop commands still to drop (fault injection).
    drop_stops: u32,
}

pub struct RemoteHost {
    pub name: String,
    /// Last heartbeat (any process of the host, or its agent) that crossed the link.
    pub last_heard: Instant,
    /// Since when it is silent (a stall being waited out).
    pub silent_since: Option<Instant>,
    pub heard_once: bool,
    /// Its agent acknowledged the stop.
    pub stopped: bool,
}

impl InCharge {
    pub fn start(
        args: &SupervisorArgs,
        launch: &LaunchDescription,
        node: &iceoryx2::prelude::Node<iceoryx2::prelude::ipc::Service>,
        bin_dir: &Path,
    ) -> Result<Self, HostError> {
        let me = launch.host[0].name.clone();
        let exe = tunnel_exe(args, bin_dir);
        let tunnel = TunnelChild::start(&exe, &args.bus_prefix, launch, &me, args.record)?;
        let beat_pub = wiring::publisher::<Progress>(node, wiring::SVC_PROGRESS)?;
        let remote = launch.host[1..]
            .iter()
            .map(|h| RemoteHost {
                name: h.name.clone(),
                last_heard: Instant::now(),
                silent_since: None,
                heard_once: false,
                stopped: false,
            })
            .collect();
        Ok(InCharge {
            me,
            tunnel,
            remote,
            events: Vec::new(),
            tunnel_deaths: Vec::new(),
            round_trip: LatencyHistogram::default(),
            beat_pub,
            next_beat: Instant::now(),
            seq: 0,
            t0: Instant::now(),
            link_timeout: Duration::from_secs_f64(launch.link_timeout_s),
            lost: false,
            drop_stops: super::fault_count(FAULT_DROP_STOPS, 100)?,
        })
    }

    /// A progress message heard: a remote host is alive; an agent's echo gives a round
    /// trip. `host` is the host of its publisher (None: not a member, e.g. an agent).
    pub fn heard(&mut self, p: &Progress, host: Option<&str>) {
        if p.process == PROC_SUPERVISOR {
            return;
        }
        if p.process == PROC_AGENT {
            if p.header.origin_ns > 0 {
                let rt = monotonic_ns()
                    .saturating_sub(p.header.origin_ns)
                    .saturating_sub(p.header.due_ns);
                self.round_trip.record(rt);
            }
            // The agent's host rides in `tick` (its index in the launch description).
            if let Some(h) = self
                .remote
                .get_mut((p.header.tick as usize).wrapping_sub(1))
            {
                h.last_heard = Instant::now();
                h.heard_once = true;
                h.stopped |= p.state == STATE_DONE;
            }
            return;
        }
        if let Some(h) = host.and_then(|n| self.remote.iter_mut().find(|h| h.name == n)) {
            h.last_heard = Instant::now();
            h.heard_once = true;
        }
    }

    /// Beat, watch the tunnel and the links. Ok(true) while some link is silent (the
    /// caller holds its stall and heartbeat verdicts on that host's processes);
    /// Err once a host stayed silent for the link timeout.
    pub fn poll(&mut self) -> Result<bool, HostError> {
        if Instant::now() >= self.next_beat {
            self.next_beat = Instant::now() + BEAT;
            self.seq += 1;
            wiring::publish(&self.beat_pub, beat(PROC_SUPERVISOR, 0, 0, self.seq))?;
        }
        if let Some(why) = self.tunnel.check()? {
            log::warn!("host {}: {why}", self.me);
            self.tunnel_deaths.push(why.to_string());
        }
        let mut silent = false;
        for h in &mut self.remote {
            let quiet = h.last_heard.elapsed();
            if quiet > LINK_SUSPECT && h.heard_once {
                silent = true;
                if h.silent_since.is_none() {
                    h.silent_since = Some(h.last_heard);
                    log::warn!(
                        "link {} <-> {}: no heartbeat crossed it for {:.1} s (tunnel or link down); waiting up to {:.0} s",
                        self.me,
                        h.name,
                        quiet.as_secs_f64(),
                        self.link_timeout.as_secs_f64()
                    );
                    self.events.push(LinkEvent {
                        host: h.name.clone(),
                        silent_from_s: (h.last_heard - self.t0).as_secs_f64(),
                        silent_for_s: None,
                    });
                }
                if quiet > self.link_timeout {
                    self.lost = true;
                    return Err(HostError::LinkLost {
                        me: self.me.clone(),
                        host: h.name.clone(),
                        timeout_s: self.link_timeout.as_secs_f64(),
                    });
                }
            } else if let Some(since) = h.silent_since.take() {
                let gap = (h.last_heard - since).as_secs_f64();
                log::warn!(
                    "link {} <-> {}: heartbeats back after {gap:.1} s; the run resumes",
                    self.me,
                    h.name
                );
                if let Some(e) = self.events.iter_mut().rev().find(|e| e.host == h.name) {
                    e.silent_for_s = Some(gap);
                }
            }
        }
        Ok(silent)
    }

    /// End the run on every host: repeat the stop every `BEAT` until each other host's
    /// agent acknowledged it, for at most the link timeout — a stop lost on a link that
    /// breaks at that moment is sent again once it is back. A link already lost gets
    /// one stop (its host stops by itself: its own link timeout).
    pub fn stop_hosts(
        &mut self,
        node: &iceoryx2::prelude::Node<iceoryx2::prelude::ipc::Service>,
        progress: &wiring::Sub<Progress>,
        send: &dyn Fn(u32, u64) -> Result<(), BusError>,
    ) {
        let t0 = Instant::now();
        let mut next_stop = t0;
        let mut seq = 1;
        loop {
            if Instant::now() >= next_stop {
                next_stop = Instant::now() + BEAT;
                if self.drop_stops > 0 {
                    self.drop_stops -= 1;
                    log::warn!("fault injection: stop command {seq} not sent");
                } else if let Err(e) = send(CMD_STOP, seq) {
                    log::warn!("cannot send the stop: {e}");
                }
                seq += 1;
            }
            if self.lost {
                return;
            }
            while let Ok(Some(p)) = wiring::receive(progress) {
                self.heard(&p, None);
            }
            if self.remote.iter().all(|h| h.stopped) {
                return;
            }
            if let Err(e) = self.poll() {
                log::warn!("host {}: {e}", self.me);
                return;
            }
            if t0.elapsed() > self.link_timeout {
                let silent: Vec<&str> = self
                    .remote
                    .iter()
                    .filter(|h| !h.stopped)
                    .map(|h| h.name.as_str())
                    .collect();
                log::warn!(
                    "host {}: no acknowledgement of the stop from host(s) {} in {:.0} s (link_timeout_s); they stop by themselves once the link has been silent that long",
                    self.me,
                    silent.join(", "),
                    self.link_timeout.as_secs_f64()
                );
                return;
            }
            if node.wait(Duration::from_millis(1)).is_err() {
                return;
            }
        }
    }

    /// The report's `hosts`: where each process ran, the tunnel, the link events.
    pub fn report(&self, processes: &[(String, String)]) -> serde_json::Value {
        let rt = self.round_trip.summary_us();
        json!({
            "in_charge": self.me,
            "processes": processes
                .iter()
                .map(|(p, h)| (p.clone(), json!(h)))
                .collect::<serde_json::Map<_, _>>(),
            "tunnel": {
                "implementation": "iceoryx2-services-tunnel 0.9.3 + iceoryx2-integrations-zenoh-tunnel-backend 0.9.3 (zenoh 1.9.0), taiji-tunnel",
                "restarts": self.tunnel.restarts,
                "deaths": self.tunnel_deaths,
            },
            "link_round_trip_us": {"p50": rt.p50, "p99": rt.p99, "max": rt.max, "count": rt.count},
            "tunnel_hop_us": {"p50": rt.p50 / 2.0, "p99": rt.p99 / 2.0, "max": rt.max / 2.0},
            "clocks": "one monotonic clock per host: the tunnel hop is half the supervisors' heartbeat round trip, measured on the in-charge host's clock (the agent's holding time subtracted). One-way latencies that cross hosts (fee->estimator hop, end to end) compare two hosts' clocks: exact only when the hosts share one (network namespaces on one machine do), meaningless between real machines.",
            "link_events": self.events.iter().map(|e| json!({
                "host": e.host,
                "silent_from_s": e.silent_from_s,
                "silent_for_s": e.silent_for_s,
            })).collect::<Vec<_>>(),
        })
    }
}

/// Does the set span hosts, and which one is this?
pub fn my_host(
    args: &SupervisorArgs,
    launch: &LaunchDescription,
) -> Result<Option<String>, HostError> {
    match (&args.host, launch.in_charge()) {
        (None, None) => Ok(None),
        (Some(h), None) => Err(HostError::NoHosts { host: h.clone() }),
        (None, Some(first)) => Ok(Some(first.name.clone())),
        (Some(h), Some(_)) => {
            if launch.host.iter().any(|x| &x.name == h) {
                Ok(Some(h.clone()))
            } else {
                Err(HostError::UnknownHost {
                    host: h.clone(),
                    hosts: launch.host.iter().map(|x| x.name.clone()).collect(),
                })
            }
        }
    }
}

/// A host that is not in charge: run its tunnel and processes (restarting them by
/// their policy), answer the heartbeats of the one in charge, and end when it says
/// stop — Some(the estimator's next tick, when it runs here) — or when it stayed
/// silent for the link timeout (Err: exit 3; the estimator's checkpoint is kept).
pub(crate) fn agent_watch(
    node: &iceoryx2::prelude::Node<iceoryx2::prelude::ipc::Service>,
    progress: &wiring::Sub<Progress>,
    set: &mut Set,
    launch: &LaunchDescription,
    me: &str,
    args: &SupervisorArgs,
) -> Result<Option<u64>, SetError> {
    use crate::sim::msg::{Control, PROC_ESTIMATOR};
    let index = launch.host.iter().position(|h| h.name == me).unwrap_or(0) as u64;
    let boss = launch.host[0].name.clone();
    let exe = tunnel_exe(args, &set.bin_dir);
    let mut tunnel = TunnelChild::start(&exe, &args.bus_prefix, launch, me, false)?;
    let control = wiring::subscriber::<Control>(node, wiring::SVC_CONTROL)?;
    let beat_pub = wiring::publisher::<Progress>(node, wiring::SVC_PROGRESS)?;
    let link_timeout = Duration::from_secs_f64(launch.link_timeout_s);
    let heartbeat = Duration::from_secs_f64(launch.heartbeat_timeout_s);
    let mut seq = 0u64;
    let mut next_beat = Instant::now();
    let mut boss_heard: Option<Instant> = None;
    let mut boss_link = BossLink {
        me,
        boss: &boss,
        link_timeout,
        ready_timeout: Duration::from_secs_f64(launch.ready_timeout_s),
        t_start: Instant::now(),
        silent_logged: false,
    };
    let tick_of_estimator = |set: &Set| {
        set.members
            .iter()
            .find(|m| m.id == PROC_ESTIMATOR)
            .and_then(|m| m.last)
            .map_or(0, |p| p.next_tick)
    };
    log::info!("host {me}: processes started; the supervisor in charge is on host {boss}");
    loop {
        // A short wait: the echo's holding time is subtracted, the poll delay is not.
        if node.wait(Duration::from_micros(200)).is_err() {
            return Ok(None);
        }
        while let Some(p) = wiring::receive(progress)? {
            if p.process == PROC_SUPERVISOR {
                let got = monotonic_ns();
                boss_heard = Some(Instant::now());
                seq += 1;
                let mut echo = beat(PROC_AGENT, p.header.publish_ns, 0, seq);
                echo.header.tick = index;
                echo.header.due_ns = monotonic_ns().saturating_sub(got);
                wiring::publish(&beat_pub, echo)?;
                continue;
            }
            if let Some(m) = set.members.iter_mut().find(|m| m.id == p.process) {
                m.last = Some(p);
                m.last_seen = Instant::now();
            }
        }
        while let Some(c) = wiring::receive(&control)? {
            if c.command == CMD_STOP {
                log::info!("host {me}: the supervisor in charge said stop");
                let tick = tick_of_estimator(set);
                acknowledge_stop(node, &control, &beat_pub, index, &mut seq, link_timeout)?;
                return Ok(Some(tick));
            }
        }
        if Instant::now() >= next_beat {
            next_beat = Instant::now() + BEAT;
            seq += 1;
            let mut b = beat(PROC_AGENT, 0, 0, seq);
            b.header.tick = index;
            wiring::publish(&beat_pub, b)?;
        }
        if let Some(why) = tunnel.check()? {
            log::warn!("host {me}: {why}");
        }
        // The one in charge: silent for the link timeout ends this host's part.
        boss_link.check(boss_heard)?;
        // This host's processes: restart by policy, like the supervisor in charge.
        match set.reap(&format!("host {me}: "))? {
            Reap::Running => {}
            Reap::Interrupted => return Ok(None),
            Reap::Stopped(ended) => {
                return Err(SetError::HostStopped {
                    host: me.to_string(),
                    ended,
                })
            }
        }
        // A restartable process silent on its own host is hung: kill it (restarted above).
        kill_hung(set, heartbeat, me);
    }
}

/// Kill a restartable process of this host that published no progress for
/// `heartbeat` (hung); the exit handling restarts it.
fn kill_hung(set: &mut Set, heartbeat: Duration, me: &str) {
    use crate::runtime::launch::Restart;
    if let Some(m) = set.members.iter_mut().find(|m| {
        m.last.is_some()
            && m.last_seen.elapsed() > heartbeat
            && m.spec.restart == Restart::OnFailure
            && m.restarts < m.spec.max_restarts
    }) {
        log::warn!(
            "host {me}: {} published no progress for {:.0} s (hung?); killing it to restart it",
            m.spec.name,
            heartbeat.as_secs_f64()
        );
        if let Some(c) = m.child.as_mut() {
            let _ = c.kill();
        }
        m.last_seen = Instant::now();
    }
}

/// An agent's view of its link to the supervisor in charge: how long it has been
/// silent, warned about once when suspect, fatal after the link timeout.
struct BossLink<'a> {
    me: &'a str,
    boss: &'a str,
    link_timeout: Duration,
    ready_timeout: Duration,
    t_start: Instant,
    silent_logged: bool,
}

impl BossLink<'_> {
    /// `heard`: when the one in charge was last heard (None: not yet).
    fn check(&mut self, heard: Option<Instant>) -> Result<(), HostError> {
        let (me, boss) = (self.me, self.boss);
        let quiet = heard.map_or(self.t_start.elapsed(), |t| t.elapsed());
        let limit = match heard {
            Some(_) => self.link_timeout,
            // Before its first heartbeat: it may still be starting.
            None => self.link_timeout + self.ready_timeout,
        };
        if quiet > limit {
            return Err(HostError::BossLost {
                me: me.to_string(),
                boss: boss.to_string(),
                quiet_s: quiet.as_secs_f64(),
            });
        }
        if heard.is_some() && quiet > LINK_SUSPECT {
            if !self.silent_logged {
                self.silent_logged = true;
                log::warn!(
                    "link {me} <-> {boss}: no heartbeat crossed it for {:.1} s (tunnel or link down); waiting up to {:.0} s",
                    quiet.as_secs_f64(),
                    self.link_timeout.as_secs_f64()
                );
            }
        } else if self.silent_logged {
            self.silent_logged = false;
            log::warn!("link {me} <-> {boss}: heartbeats back");
        }
        Ok(())
    }
}

/// An agent told to stop: acknowledge it (an agent beat in `STATE_DONE`), and again on
/// every repeat of the stop — the one in charge repeats it until an acknowledgement
/// crosses — until no repeat came for `ACK_QUIET` (at most `limit`). Its tunnel runs
/// meanwhile; its processes, told to stop too, end by themselves.
fn acknowledge_stop(
    node: &iceoryx2::prelude::Node<iceoryx2::prelude::ipc::Service>,
    control: &wiring::Sub<crate::sim::msg::Control>,
    beat_pub: &wiring::Pub<Progress>,
    index: u64,
    seq: &mut u64,
    limit: Duration,
) -> Result<(), BusError> {
    let t0 = Instant::now();
    let mut last_stop = t0;
    let mut ack = true;
    while last_stop.elapsed() < ACK_QUIET && t0.elapsed() < limit {
        if ack {
            ack = false;
            *seq += 1;
            let mut b = beat(PROC_AGENT, 0, 0, *seq);
            b.header.tick = index;
            b.state = STATE_DONE;
            wiring::publish(beat_pub, b)?;
        }
        while let Some(c) = wiring::receive(control)? {
            if c.command == CMD_STOP {
                last_stop = Instant::now();
                ack = true;
            }
        }
        if node.wait(Duration::from_millis(1)).is_err() {
            break;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const TWO_HOSTS: &str = include_str!("../../../tools/two_hosts.toml");

    #[test]
    fn only_the_services_between_the_hosts_cross_the_link() {
        let d = LaunchDescription::parse(TWO_HOSTS, "two_hosts.toml").unwrap();
        assert_eq!(
            crossing_services(&d, false),
            [
                "taiji/sensor",
                "taiji/estimate",
                "taiji/progress",
                "taiji/control",
                "taiji/status",
                "taiji/request",
                "taiji/wake/fee",
                "taiji/wake/estimator"
            ]
        );
        // The truth never reaches the flight computer.
        assert!(!crossing_services(&d, false).contains(&wiring::SVC_TRUTH.to_string()));
        // Everything on one host: nothing crosses.
        let one = LaunchDescription::parse(crate::runtime::launch::DEFAULT, "x").unwrap();
        assert!(crossing_services(&one, false).is_empty());
    }

    #[test]
    fn hosts_in_the_launch_description_are_checked() {
        let d = LaunchDescription::parse(TWO_HOSTS, "x").unwrap();
        assert_eq!(d.in_charge().unwrap().name, "sim");
        let est = d
            .process
            .iter()
            .find(|p| p.name == "taiji-estimator")
            .unwrap();
        assert_eq!(d.host_of(est), "flight");
        let e = LaunchDescription::parse(
            &TWO_HOSTS.replace("host = \"flight\"", "host = \"moon\""),
            "x",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("taiji-estimator runs on host \"moon\""), "{e}");
        let e = LaunchDescription::parse(
            &TWO_HOSTS.replace("name = \"flight\"", "name = \"sim\""),
            "x",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("listed twice"), "{e}");
        let e = LaunchDescription::parse(
            &TWO_HOSTS.replace("link_timeout_s = 20.0", "link_timeout_s = 0.0"),
            "x",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("link_timeout_s"), "{e}");
    }
}
