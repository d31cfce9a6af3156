//! `taiji-supervisor`: starts the set from a launch description, waits until every
//! process is ready, starts the campaign, watches liveness (child exit and progress
//! heartbeats), restarts what may be restarted, stops everything cleanly, and writes
//! the report.

use crate::analysis::report::Report;
use crate::bus::timing::monotonic_ns;
use crate::bus::wiring::{self, BusError};
use crate::runtime::launch::{LaunchDescription, ProcessSpec, Restart};
use crate::runtime::process::estimator::{EstimatorTable, CHECKPOINT_FILE, TABLE_FILE};
pub use crate::runtime::process::set::SupervisorArgs;
use crate::runtime::process::set::{Member, Reap, Set, SupervisorError};
pub use crate::runtime::process::set::{SetError, SpawnError, UserError};
use crate::runtime::process::status::StatusBoard;
use crate::runtime::process::timing_report::{timing_json, MemberSummary};
use crate::sim::files::FileError;
use crate::sim::msg::{
    Control, EstimateMsg, Header, Progress, CMD_START, CMD_STOP, EST_FINAL, PROC_ESTIMATOR,
    PROC_RECORDER, SET_FINISHED, SET_RUNNING, SET_STARTING, SET_STOPPING, STATE_DONE,
};
use crate::sim::scenario::Scenario;
use serde_json::json;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How a supervised run ended, with its process exit code.
#[derive(Debug)]
pub enum Outcome {
    /// The campaign completed; `met` says whether the requirements were met.
    Completed { report: Box<Report>, met: bool },
    /// Bad arguments, scenario or launch description (exit 2).
    UserError(UserError),
    /// A process of the set failed and could not be restarted (exit 3).
    SetFailed(SetError),
    /// SIGINT / SIGTERM (exit 130).
    Interrupted,
    /// A host that is not in charge: its processes ran until the one in charge said
    /// stop (exit 0).
    HostStopped(String),
}

impl Outcome {
    pub fn exit_code(&self) -> u8 {
        match self {
            Outcome::Completed { met: true, .. } => 0,
            Outcome::Completed { met: false, .. } => 1,
            Outcome::UserError(_) => 2,
            Outcome::SetFailed(_) => 3,
            Outcome::Interrupted => 130,
            Outcome::HostStopped(_) => 0,
        }
    }
}

/// The scenario every stage is given, in the run folder: the user's, with its
/// maneuver planned when it had none.
pub const PLANNED_SCENARIO_FILE: &str = "scenario.toml";

/// Points of the bound's curve the status interpolates between (`crlb::bound_at`).
const BOUND_POINTS: usize = 64;

/// Run the campaign through the process set.
pub fn run(args: &SupervisorArgs) -> Outcome {
    let s = match Scenario::load_or_default(args.scenario.as_deref()) {
        Ok(s) => s,
        Err(e) => return Outcome::UserError(e.into()),
    };
    let (s, plan) = match crate::analysis::plan::resolve(s) {
        Ok(x) => x,
        Err(e) => return Outcome::UserError(e.into()),
    };
    // `--seed` is the scenario's seed from here on: every noise stream and the priors'
    // ground-calibration draw, as `run` and the Monte Carlo's run of that seed (the
    // maneuver stays the one planned for the file).
    let s = Scenario {
        seed: args.seed.unwrap_or(s.seed),
        ..s
    };
    let launch = match LaunchDescription::load_or_default(args.launch.as_deref()) {
        Ok(l) => l,
        Err(e) => return Outcome::UserError(e.into()),
    };
    if let Err(e) = super::parse_method(&args.method) {
        return Outcome::UserError(e.into());
    }
    if args.realtime && !(args.time_scale.is_finite() && args.time_scale > 0.0) {
        return Outcome::UserError(
            super::ProcessError::TimeScale {
                time_scale: args.time_scale,
            }
            .into(),
        );
    }
    let me = match super::hosts::my_host(args, &launch) {
        Ok(m) => m,
        Err(e) => return Outcome::UserError(e.into()),
    };
    if me.is_some() && args.record {
        return Outcome::UserError(UserError::RecordOverHosts);
    }
    // The bound as the campaign goes, for monitors; its last point is the report's.
    // At the run's seed: a campaign that loses data has the bound of its losses. Beside
    // it the maneuver's bound (its motion alone), for the maneuver's line and the
    // prediction before the run.
    let (curve, maneuver) = std::thread::scope(|sc| {
        let m = sc.spawn(|| crate::analysis::plan::maneuver_bound(&s));
        let curve = crate::analysis::crlb::crlb_curve(
            &s,
            BOUND_POINTS,
            crate::analysis::campaign::Threads::available(),
        );
        (
            curve,
            m.join().unwrap_or_else(|e| std::panic::resume_unwind(e)),
        )
    });
    let Some(crlb) = curve.last().and_then(|(_, c)| *c) else {
        return Outcome::UserError(UserError::SingularFisher);
    };
    match supervise(args, &s, &launch, me.as_deref(), curve) {
        Ok(Supervised::HostStopped(m)) => Outcome::HostStopped(m),
        Ok(Supervised::Done(final_est, members, wall, hosts)) => {
            let bounds = crate::analysis::crlb::Bounds {
                run: crlb,
                maneuver,
            };
            let mut report = Report::with_bounds(
                &s,
                s.seed,
                "multi-process",
                &args.method,
                &final_est,
                &bounds,
            );
            if let (Some(m), Some(p)) = (report.maneuver.as_mut(), &plan) {
                m.search = Some(p.search_json());
            }
            report.wall_time_s = Some(wall);
            let mut timing = timing_json(args, &s, &members);
            if let (Some(h), Some(t)) = (&hosts, timing.as_object_mut()) {
                t.insert("tunnel_hop_us".into(), h["tunnel_hop_us"].clone());
                t.insert("clocks".into(), h["clocks"].clone());
            }
            report.timing = Some(timing);
            report.hosts = hosts;
            let restarts: BTreeMap<String, u32> = members
                .iter()
                .filter(|m| m.spec.restart != Restart::Never)
                .map(|m| (m.spec.name.clone(), m.restarts))
                .collect();
            report.restarts = Some(json!(restarts));
            report.estimator_loop_allocations = members
                .iter()
                .find(|m| m.id == PROC_ESTIMATOR)
                .and_then(|m| m.last)
                .map(|p| p.loop_allocations);
            // With `[faults]` and a recording, the recorder's fault log scores detection.
            if args.record && s.faults.any() {
                let path = args
                    .out
                    .join(crate::runtime::process::recorder::TELEMETRY_FILE);
                match crate::telemetry::read::fault_log(&path) {
                    Ok((records, detected)) => {
                        report.faults = Some(
                            crate::sim::faults::FaultScore::from_log(&s, records, detected)
                                .summary(),
                        );
                    }
                    Err(e) => log::warn!("taiji-supervisor: no fault score: {e}"),
                }
            }
            let met = report.requirements.met && report.requirements.verified;
            Outcome::Completed {
                report: Box::new(report),
                met,
            }
        }
        Ok(Supervised::Interrupted) => Outcome::Interrupted,
        Err(SupervisorError::User(e)) => Outcome::UserError(*e),
        Err(SupervisorError::Set(e)) => Outcome::SetFailed(e),
    }
}

enum Supervised {
    /// The final estimate, every member, the wall time [s], and (sets over hosts) the
    /// report's `hosts`.
    Done(
        Box<EstimateMsg>,
        Vec<MemberSummary>,
        f64,
        Option<serde_json::Value>,
    ),
    Interrupted,
    HostStopped(String),
}

/// Sweeps the run's shared memory for objects abandoned half-made by a killed stage
/// (`wiring::sweep_abandoned`) while the set runs: a live stage connecting to the killed
/// one would otherwise wait on such an object forever. Stops when dropped.
struct Janitor {
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Janitor {
    fn start(prefix: &str) -> Result<Self, SetError> {
        let stop = Arc::new(AtomicBool::new(false));
        let (flag, prefix) = (Arc::clone(&stop), prefix.to_string());
        let thread = std::thread::Builder::new()
            .name("shm-janitor".into())
            .spawn(move || {
                while !flag.load(Ordering::Relaxed) {
                    wiring::sweep_abandoned(&prefix, wiring::ABANDONED_AFTER);
                    std::thread::park_timeout(Duration::from_millis(250));
                }
            })
            .map_err(SetError::Janitor)?;
        Ok(Janitor {
            stop,
            thread: Some(thread),
        })
    }
}

impl Drop for Janitor {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            t.thread().unpark();
            let _ = t.join();
        }
    }
}

/// The refusal of a run on a prefix in use, naming its supervisor (when known) and
/// its live nodes.
fn another_run(prefix: &str, pid: Option<u32>, alive: Vec<String>) -> SupervisorError {
    SupervisorError::user(UserError::AnotherRun {
        prefix: prefix.to_string(),
        pid,
        alive,
    })
}

/// The run's hold on its bus prefix. Dropped last, when every process of the set has
/// exited and the supervisor's node is gone: removes what the run left on the bus
/// (`wiring::release`: dead nodes, then the prefix's global object), then frees the prefix.
struct PrefixHold {
    prefix: String,
    _lock: wiring::PidLock,
    /// The run's hold on its `--out` folder (dropped with the prefix's).
    _out: Option<wiring::PidLock>,
}

impl Drop for PrefixHold {
    fn drop(&mut self) {
        match wiring::release(&self.prefix) {
            Ok(r) => log::info!(
                "bus prefix {:?} released: {} dead node(s), {} global object(s) removed",
                self.prefix,
                r.dead_nodes,
                r.global_mgmt
            ),
            Err(e) => log::warn!("bus prefix {:?}: {e}", self.prefix),
        }
    }
}

/// The lock file a running supervisor holds in its `--out` folder (`wiring::PidLock`): a
/// second run into the same folder (on any bus prefix) is refused instead of mixing its
/// files in. Removed when the run ends.
const OUT_LOCK_FILE: &str = ".taiji-run.lock";

/// Take `out`'s lock, or say which run holds it.
fn lock_out(out: &std::path::Path) -> Result<wiring::PidLock, SupervisorError> {
    match wiring::lock_pid_file(out.join(OUT_LOCK_FILE)) {
        Ok(wiring::Claim::Won(lock)) => Ok(lock),
        Ok(wiring::Claim::Held { pid }) => Err(SupervisorError::user(UserError::OutBusy {
            path: out.to_path_buf(),
            pid,
        })),
        Err(BusError::Io { path, source, .. }) => Err(SupervisorError::user(UserError::from(
            FileError::create(path, source),
        ))),
        Err(e) => Err(SupervisorError::Set(e.into())),
    }
}

fn supervise(
    args: &SupervisorArgs,
    s: &Scenario,
    launch: &LaunchDescription,
    me: Option<&str>,
    bound: Vec<(u64, Option<crate::analysis::crlb::Crlb>)>,
) -> Result<Supervised, SupervisorError> {
    let set_err = |e: BusError| SupervisorError::Set(e.into());
    let t_start = Instant::now();
    // Declared before every port and node of the run, so dropped after them.
    let _hold = claim(args)?;
    let _janitor = Janitor::start(&args.bus_prefix).map_err(SupervisorError::Set)?;
    let ckpt = fresh_checkpoint(args)?;
    let node = wiring::node("taiji-supervisor", &args.bus_prefix).map_err(set_err)?;
    let progress = wiring::subscriber::<Progress>(&node, wiring::SVC_PROGRESS).map_err(set_err)?;
    let estimates =
        wiring::subscriber::<EstimateMsg>(&node, wiring::SVC_ESTIMATE).map_err(set_err)?;
    let control = wiring::publisher::<Control>(&node, wiring::SVC_CONTROL).map_err(set_err)?;
    let send = |command: u32, seq: u64| {
        wiring::publish(
            &control,
            Control {
                header: Header {
                    seq,
                    publish_ns: monotonic_ns(),
                    ..Default::default()
                },
                command,
                _pad: 0,
            },
        )
    };
    let mut set = new_set(args, s)?;
    // Sets over hosts: this host's tunnel; the one in charge also watches the others.
    let in_charge_host = launch.host.first().map(|h| h.name.as_str());
    let agent = me.is_some() && me != in_charge_host;
    let mut hosts = match me {
        Some(_) if !agent => Some(
            super::hosts::InCharge::start(args, launch, &node, &set.bin_dir)
                .map_err(|e| SupervisorError::user(e.into()))?,
        ),
        _ => None,
    };
    spawn_members(&mut set, launch.processes(args.record), launch, me, agent)?;
    let result = match me {
        Some(m) if agent => super::hosts::agent_watch(&node, &progress, &mut set, launch, m, args)
            .map_err(SupervisorError::Set)
            .map(|stopped| {
                stopped.map(|tick| EstimateMsg {
                    header: Header {
                        tick,
                        ..Default::default()
                    },
                    ..Default::default()
                })
            }),
        _ => {
            let ports = Ports {
                node: &node,
                progress: &progress,
                estimates: &estimates,
                send: &send,
            };
            let mut board = StatusBoard::new(&node, args, s, launch, bound).map_err(set_err)?;
            let r =
                Watch::new(launch, s.n_samples()).run(&ports, &mut set, hosts.as_mut(), &mut board);
            let state = match r {
                Ok(Some(_)) => SET_FINISHED,
                _ => SET_STOPPING,
            };
            board.publish(&set, state, true);
            r
        }
    };
    set.bar.finish();
    // Whatever happened: stop everyone. What they left on the bus goes when `_hold` is
    // dropped, after this supervisor's node.
    match hosts.as_mut() {
        // Over hosts: repeated until every other host acknowledged it.
        Some(h) => h.stop_hosts(&node, &progress, &send),
        None => {
            let _ = send(CMD_STOP, 1);
        }
    }
    set.stop_all(Duration::from_secs_f64(launch.stop_timeout_s));
    let wall = t_start.elapsed().as_secs_f64();
    let result = settle_checkpoint(result, &ckpt);
    let hosts_json = hosts.as_ref().map(|h| {
        let placed: Vec<(String, String)> = set
            .members
            .iter()
            .map(|m| (m.spec.name.clone(), m.host.clone()))
            .chain([("taiji-supervisor".to_string(), h.me.clone())])
            .collect();
        h.report(&placed)
    });
    let members = set
        .members
        .into_iter()
        .map(|m| MemberSummary {
            spec: m.spec,
            id: m.id,
            restarts: m.restarts,
            last: m.last,
        })
        .collect();
    match result {
        Ok(Some(est)) if agent => Ok(Supervised::HostStopped(format!(
            "host {}: stopped by the supervisor in charge (last estimate tick {})",
            me.unwrap_or_default(),
            est.header.tick
        ))),
        Ok(Some(est)) => Ok(Supervised::Done(Box::new(est), members, wall, hosts_json)),
        Ok(None) => Ok(Supervised::Interrupted),
        Err(e) => Err(e),
    }
}

/// Take the bus prefix for this run: the output folder made, the prefix usable and
/// not another run's, the shared memory of dead processes of an earlier run removed.
fn claim(args: &SupervisorArgs) -> Result<PrefixHold, SupervisorError> {
    let user = SupervisorError::user;
    let set_err = |e: BusError| SupervisorError::Set(e.into());
    // An output folder that cannot be made (a path through a file) is the user's to fix,
    // before the campaign runs; nothing is created before the prefix is won.
    out_makeable(&args.out).map_err(|source| {
        user(UserError::OutFolder {
            path: args.out.clone(),
            source,
        })
    })?;
    // A prefix iceoryx2 cannot use as a file name is the user's to fix.
    wiring::config(&args.bus_prefix).map_err(|e| user(UserError::BusPrefix(e)))?;
    // One supervisor per prefix: the lock, not the live-node check below, decides.
    let lock = match wiring::claim_prefix(&args.bus_prefix).map_err(set_err)? {
        wiring::Claim::Won(lock) => lock,
        wiring::Claim::Held { pid } => {
            let alive = wiring::live_nodes(&args.bus_prefix);
            return Err(another_run(&args.bus_prefix, pid, alive));
        }
    };
    let mut hold = PrefixHold {
        prefix: args.bus_prefix.clone(),
        _lock: lock,
        _out: None,
    };
    let survey = wiring::cleanup_stale(&args.bus_prefix).map_err(set_err)?;
    if survey.removed_dead > 0 {
        log::warn!(
            "removed the stale shared memory of {} dead process(es) of an earlier run",
            survey.removed_dead
        );
    }
    // Live nodes without a supervisor: the set of a supervisor killed a moment ago
    // (a monitor still attached is none of it: it reads the next run as well).
    let mut alive = survey.alive;
    alive.retain(|n| n != wiring::MONITOR_NODE);
    if !alive.is_empty() {
        return Err(another_run(&args.bus_prefix, None, alive));
    }
    // Only now the folder: a refused run creates none.
    std::fs::create_dir_all(&args.out).map_err(|source| {
        user(UserError::OutFolder {
            path: args.out.clone(),
            source,
        })
    })?;
    hold._out = Some(lock_out(&args.out)?);
    Ok(hold)
}

/// Can `out` be made (or is it a folder already)? Its nearest existing ancestor must be
/// a folder; nothing is created.
fn out_makeable(out: &std::path::Path) -> std::io::Result<()> {
    let mut p = out;
    loop {
        match std::fs::metadata(p) {
            Ok(m) if m.is_dir() => return Ok(()),
            Ok(_) => {
                return Err(std::io::Error::other(format!(
                    "{} is not a folder",
                    p.display()
                )))
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => match p.parent() {
                Some(q) if !q.as_os_str().is_empty() => p = q,
                _ => return Ok(()),
            },
            Err(e) => return Err(e),
        }
    }
}

/// The estimator's checkpoint path in the run folder, with an earlier run's removed
/// (a checkpoint only serves restarts within its own run).
fn fresh_checkpoint(args: &SupervisorArgs) -> Result<PathBuf, SupervisorError> {
    let user = SupervisorError::user;
    std::fs::create_dir_all(&args.out)
        .map_err(|source| user(UserError::from(FileError::create(args.out.clone(), source))))?;
    let ckpt = args.out.join(CHECKPOINT_FILE);
    if ckpt.exists() {
        std::fs::remove_file(&ckpt).map_err(|source| {
            user(UserError::RemoveCheckpoint {
                path: ckpt.clone(),
                source,
            })
        })?;
    }
    Ok(ckpt)
}

/// A run that ended is cleared of its checkpoint; a failed set keeps it for diagnosis
/// and says so.
fn settle_checkpoint<T>(
    result: Result<T, SupervisorError>,
    ckpt: &std::path::Path,
) -> Result<T, SupervisorError> {
    match result {
        Err(SupervisorError::Set(e)) if ckpt.exists() => {
            Err(SupervisorError::Set(SetError::CheckpointKept {
                error: Box::new(e),
                checkpoint: ckpt.to_path_buf(),
            }))
        }
        r => {
            remove_checkpoint(ckpt);
            r
        }
    }
}

/// The set to start: its binaries, the arguments every member gets, and the files the
/// members read from the run folder (the resolved scenario, the estimator's table).
fn new_set(args: &SupervisorArgs, s: &Scenario) -> Result<Set, SupervisorError> {
    let user = SupervisorError::user;
    let bin_dir = match &args.bin_dir {
        Some(d) => d.clone(),
        None => std::env::current_exe()
            .ok()
            .and_then(|p| p.parent().map(|d| d.to_path_buf()))
            .ok_or(user(UserError::NoBinDir))?,
    };
    let mut common: Vec<String> = vec![
        "--bus-prefix".into(),
        args.bus_prefix.clone(),
        "--run-dir".into(),
        args.out.display().to_string(),
        "--method".into(),
        args.method.clone(),
    ];
    // Every stage flies the same maneuver: the scenario as resolved here (its
    // maneuver planned when the file gave none), written into the run folder.
    let resolved = args.out.join(PLANNED_SCENARIO_FILE);
    let text = toml::to_string(s).map_err(|e| user(UserError::ScenarioToml(e)))?;
    std::fs::write(&resolved, text)
        .map_err(|source| user(UserError::from(FileError::write(resolved.clone(), source))))?;
    let mut scenario_args: Vec<String> = vec!["--scenario".into(), resolved.display().to_string()];
    if let Some(seed) = args.seed {
        scenario_args.extend(["--seed".into(), seed.to_string()]);
    }
    // The estimator process is given its table, never the scenario (truths).
    let table = args.out.join(TABLE_FILE);
    EstimatorTable::of(s)
        .write(&table)
        .map_err(|e| user(e.into()))?;
    let table_args = vec!["--table".into(), table.display().to_string()];
    if args.record {
        common.push("--record".into());
        scenario_args.extend([
            "--record-compression".into(),
            args.record_compression.to_string(),
        ]);
    }
    if args.realtime {
        common.extend([
            "--realtime".into(),
            "--time-scale".into(),
            args.time_scale.to_string(),
        ]);
    }
    Ok(Set {
        members: Vec::new(),
        prefix: args.bus_prefix.clone(),
        common,
        scenario_args,
        table_args,
        realtime: args.realtime,
        bin_dir,
        bar: crate::analysis::progress::Bar::new(s.n_samples(), "process set"),
    })
}

/// Start this host's members of the set (all of them on one host). A host that is
/// not in charge (`agent`) lists only its own.
fn spawn_members<'a>(
    set: &mut Set,
    specs: impl IntoIterator<Item = &'a ProcessSpec>,
    launch: &LaunchDescription,
    me: Option<&str>,
    agent: bool,
) -> Result<(), SupervisorError> {
    for spec in specs {
        let host = launch.host_of(spec).to_string();
        let local = me.is_none_or(|m| m == host);
        if agent && !local {
            continue;
        }
        let child = if local {
            set.spawn(spec).map(Some)
        } else {
            Ok(None)
        };
        match child {
            Ok(child) => set.members.push(Member {
                spec: spec.clone(),
                // The launch description's names were checked against the table.
                id: crate::bus::topology::stage(&spec.name).map_or(0, |st| st.id),
                child,
                host,
                restarts: 0,
                last_seen: Instant::now(),
                last: None,
            }),
            Err(e) => {
                set.stop_all(Duration::from_secs_f64(launch.stop_timeout_s));
                return Err(SupervisorError::user(e.into()));
            }
        }
    }
    Ok(())
}

/// Remove the estimator's checkpoint and the temporary file a killed writer may leave.
fn remove_checkpoint(ckpt: &std::path::Path) {
    let mut tmp = ckpt.as_os_str().to_owned();
    tmp.push(".tmp");
    for p in [ckpt.to_path_buf(), PathBuf::from(tmp)] {
        if let Err(e) = std::fs::remove_file(&p) {
            if e.kind() != std::io::ErrorKind::NotFound {
                log::warn!("cannot remove {}: {e}", p.display());
            }
        }
    }
}

/// The supervisor's ports the watch reads and writes.
struct Ports<'a> {
    node: &'a iceoryx2::prelude::Node<iceoryx2::prelude::ipc::Service>,
    progress: &'a wiring::Sub<Progress>,
    estimates: &'a wiring::Sub<EstimateMsg>,
    send: &'a dyn Fn(u32, u64) -> Result<(), BusError>,
}

/// What the supervisor in charge knows while it watches the set.
struct Watch {
    heartbeat: Duration,
    heartbeat_s: f64,
    ready_timeout: Duration,
    ready_timeout_s: f64,
    t_ready: Instant,
    started: bool,
    final_est: Option<EstimateMsg>,
    n: u64,
    /// Stall watch: alive processes whose ticks do not advance are a failure too.
    ticks_seen: u64,
    last_advance: Instant,
}

impl Watch {
    fn new(launch: &LaunchDescription, n: u64) -> Self {
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
    fn run(
        mut self,
        ports: &Ports,
        set: &mut Set,
        mut hosts: Option<&mut super::hosts::InCharge>,
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
        mut hosts: Option<&mut super::hosts::InCharge>,
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
