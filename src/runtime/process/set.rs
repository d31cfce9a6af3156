//! The set of child processes one host runs: the supervisor's arguments, each
//! member's process and its last heartbeat, and the watch that restarts what died by
//! its policy. The supervisor (one host) and the hosts module (a set over hosts) both
//! drive it.

use super::ProcessError;
use crate::bus::wiring::{self, BusError};
use crate::runtime::launch::{ProcessSpec, Restart};
use crate::sim::files::FileError;
use crate::sim::msg::Progress;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

#[derive(Debug, Clone, clap::Parser)]
#[command(
    name = "taiji-supervisor",
    version,
    about = "Run the calibration campaign through the iceoryx2 process set"
)]
pub struct SupervisorArgs {
    /// Print the process set (processes, services and their payloads, the credit
    /// chain) from its table as a Mermaid or DOT graph, and exit.
    #[arg(long, value_enum)]
    pub graph: Option<crate::bus::topology::GraphFormat>,
    /// Launch description (default: the built-in one, identical to tools/launch.toml).
    #[arg(long)]
    pub launch: Option<PathBuf>,
    /// Scenario TOML (default: the paper's case).
    #[arg(long)]
    pub scenario: Option<PathBuf>,
    /// Seed (default: the scenario's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Output directory: report.json (and, while the set runs, the estimator's checkpoint).
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Write report.json, report.md and report.html here instead of --out (a set over
    /// hosts: the folder above the hosts' own, as `tools/launch --two-hosts` passes).
    #[arg(long)]
    pub report_dir: Option<PathBuf>,
    /// Pace the set at the sample rate divided by --time-scale.
    #[arg(long)]
    pub realtime: bool,
    /// Real-time speed-up (simulated seconds per wall-clock second).
    #[arg(long, default_value_t = 1.0, requires = "realtime")]
    pub time_scale: f64,
    /// Estimator method: joint or paper.
    #[arg(long, default_value = "joint")]
    pub method: String,
    /// Prefix of this run's iceoryx2 resources (runs in parallel need different ones).
    #[arg(long, default_value = wiring::DEFAULT_PREFIX)]
    pub bus_prefix: String,
    /// Start the recorder too: every stream to OUT/telemetry.h5.
    #[arg(long)]
    pub record: bool,
    /// With --record: each chunk shuffled and deflated at this level (1–9), or `none`.
    #[arg(long, default_value_t = crate::telemetry::Compression::DEFAULT, value_name = "none|N")]
    pub record_compression: crate::telemetry::Compression,
    /// Draw the figures from the recording to OUT/plots/ (implies --record).
    #[arg(long)]
    pub plots: bool,
    /// Directory holding the process binaries (default: beside this executable).
    #[arg(long)]
    pub bin_dir: Option<PathBuf>,
    /// Sets over hosts (`[[host]]` in the launch description): the host this supervisor
    /// runs on (default: the first, in charge); it starts that host's processes only.
    #[arg(long)]
    pub host: Option<String>,
    /// Sets over hosts: the `taiji-tunnel` binary (crate `tools/tunnel`; default:
    /// beside this executable).
    #[arg(long)]
    pub tunnel_bin: Option<PathBuf>,
    /// Operate the set from the ground (docs/ground.md): come up in standby with the
    /// TMTC process listening for telecommands on this UDP address (e.g.
    /// 127.0.0.1:7301); each start runs a campaign into OUT/campaign-N; function 5 or
    /// SIGTERM ends the set.
    #[arg(long, value_name = "ADDR")]
    pub ground: Option<String>,
    /// With --ground: the telecommand key (64 hex characters, mode 0600). Default:
    /// OUT/ground.key, created when missing.
    #[arg(long, value_name = "FILE", requires = "ground")]
    pub ground_key: Option<PathBuf>,
    /// With --ground: allow an address that is not loopback.
    #[arg(long, requires = "ground")]
    pub ground_remote: bool,
}

pub(crate) struct Member {
    pub(crate) spec: ProcessSpec,
    pub(crate) id: u32,
    /// None: it runs on another host (watched through its heartbeats only).
    pub(crate) child: Option<Child>,
    /// Host it runs on ("" in a single-host set).
    pub(crate) host: String,
    pub(crate) restarts: u32,
    /// When it was (re)started or last heard from.
    pub(crate) last_seen: Instant,
    pub(crate) last: Option<Progress>,
}

pub(crate) struct Set {
    pub(crate) members: Vec<Member>,
    /// Bus prefix of the run (for cleaning a dead member's resources).
    pub(crate) prefix: String,
    pub(crate) common: Vec<String>,
    /// Arguments of the simulating stages only (the scenario, the seed); the estimator
    /// gets its table instead.
    pub(crate) scenario_args: Vec<String>,
    pub(crate) table_args: Vec<String>,
    /// Real-time run: stages get their launch-description SCHED_FIFO priority.
    pub(crate) realtime: bool,
    pub(crate) bin_dir: PathBuf,
    /// Progress of the campaign (the estimator's tick), on a terminal only.
    pub(crate) bar: crate::analysis::progress::Bar,
}

/// What [`Set::reap`] found among this host's processes.
pub(crate) enum Reap {
    /// None exited for good (any that died were restarted by policy).
    Running,
    /// One was stopped by SIGINT/SIGTERM: the user is stopping the set.
    Interrupted,
    /// One exited and may not be restarted: its name, how it ended, and why not.
    Stopped(Ended),
}

/// A member that exited and may not be restarted.
#[derive(Debug)]
pub struct Ended {
    pub name: String,
    pub status: std::process::ExitStatus,
    pub restart: Restart,
    pub max_restarts: u32,
}

impl std::fmt::Display for Ended {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = &self.name;
        write!(f, "{name} died ({}); ", describe(self.status))?;
        match self.restart {
            Restart::Never => write!(
                f,
                "{name} is not restartable (restart = \"never\" in the launch description)"
            ),
            Restart::OnFailure if self.status.success() => {
                write!(f, "{name} exited before the campaign ended")
            }
            Restart::OnFailure => write!(f, "{name} exhausted its {} restarts", self.max_restarts),
        }
    }
}

/// A member's binary could not be started.
#[derive(Debug, thiserror::Error)]
#[error("cannot start {}: {source}", exe.display())]
pub struct SpawnError {
    pub exe: PathBuf,
    #[source]
    pub source: std::io::Error,
}

impl Set {
    /// Watch this host's processes: restart what died by its policy (after its delay,
    /// releasing the dead node's shared memory first); the first that may not be
    /// restarted ends the watch. `who` prefixes the log lines ("host sim: ").
    pub(crate) fn reap(&mut self, who: &str) -> Result<Reap, SetError> {
        for i in 0..self.members.len() {
            let Some(child) = self.members[i].child.as_mut() else {
                continue;
            };
            let status = match child.try_wait() {
                Ok(Some(st)) => st,
                Ok(None) => continue,
                Err(source) => {
                    return Err(SetError::Watch {
                        name: self.members[i].spec.name.clone(),
                        source,
                    })
                }
            };
            if interrupted(status) {
                return Ok(Reap::Interrupted);
            }
            let m = &self.members[i];
            let name = m.spec.name.clone();
            if m.spec.restart == Restart::OnFailure
                && !status.success()
                && m.restarts < m.spec.max_restarts
            {
                log::warn!(
                    "{who}{name} died ({}); restarting it ({} of at most {})",
                    describe(status),
                    m.restarts + 1,
                    m.spec.max_restarts
                );
                std::thread::sleep(Duration::from_millis(m.spec.restart_delay_ms));
                let spec = m.spec.clone();
                // Release the dead process's shared memory before its successor opens it.
                if let Ok(sv) = wiring::cleanup_stale(&self.prefix) {
                    log::info!("{who}removed {} dead node(s)", sv.removed_dead);
                }
                let child = self.spawn(&spec)?;
                let m = &mut self.members[i];
                m.child = Some(child);
                m.restarts += 1;
                m.last_seen = Instant::now();
                continue;
            }
            return Ok(Reap::Stopped(Ended {
                name,
                status,
                restart: m.spec.restart,
                max_restarts: m.spec.max_restarts,
            }));
        }
        Ok(Reap::Running)
    }
}

impl Set {
    pub(crate) fn spawn(&self, spec: &ProcessSpec) -> Result<Child, SpawnError> {
        let exe = self.bin_dir.join(&spec.name);
        let mut cmd = Command::new(&exe);
        cmd.args(&self.common);
        if spec.name == "taiji-estimator" {
            cmd.args(&self.table_args);
        } else {
            cmd.args(&self.scenario_args);
        }
        if self.realtime && spec.rt_priority > 0 {
            cmd.args(["--rt-priority", &spec.rt_priority.to_string()]);
        }
        if let (true, Some(c)) = (self.realtime, spec.cpu) {
            cmd.args(["--cpu", &c.to_string()]);
        }
        cmd.args(&spec.args)
            .stdin(Stdio::null())
            .spawn()
            .map_err(|source| SpawnError { exe, source })
    }

    /// After the stop command: wait for everyone to exit by themselves, then SIGTERM
    /// what is left, then SIGKILL after `timeout`.
    pub(crate) fn stop_all(&mut self, timeout: Duration) {
        let t0 = Instant::now();
        let mut termed = false;
        loop {
            let running: Vec<usize> = (0..self.members.len())
                .filter(|&i| {
                    let c = self.members[i].child.as_mut();
                    c.is_some_and(|c| matches!(c.try_wait(), Ok(None)))
                })
                .collect();
            if running.is_empty() {
                return;
            }
            let waited = t0.elapsed();
            if waited > timeout {
                for i in running {
                    let m = &mut self.members[i];
                    log::warn!("{} did not stop; killing it", m.spec.name);
                    if let Some(c) = m.child.as_mut() {
                        let _ = c.kill();
                        let _ = c.wait();
                    }
                }
                return;
            }
            if !termed && waited > timeout / 2 {
                termed = true;
                for i in running {
                    if let Some(c) = &self.members[i].child {
                        // SAFETY: kill with the pid of our own, still running child.
                        unsafe { libc::kill(c.id() as i32, libc::SIGTERM) };
                    }
                }
            }
            std::thread::sleep(Duration::from_millis(2));
        }
    }
}

pub(crate) fn describe(status: std::process::ExitStatus) -> String {
    use std::os::unix::process::ExitStatusExt;
    match (status.code(), status.signal()) {
        (Some(c), _) => format!("exit status {c}"),
        (None, Some(s)) => format!("signal {s}"),
        _ => "unknown status".into(),
    }
}

pub(crate) fn interrupted(status: std::process::ExitStatus) -> bool {
    use std::os::unix::process::ExitStatusExt;
    status.code() == Some(130) || matches!(status.signal(), Some(libc::SIGINT | libc::SIGTERM))
}

/// Why a supervised run stopped: the user's mistake (exit 2) or the set's failure (exit 3).
pub(crate) enum SupervisorError {
    /// Boxed: the scenario's and launch description's errors are large.
    User(Box<UserError>),
    Set(SetError),
}

impl SupervisorError {
    pub(crate) fn user(e: UserError) -> Self {
        SupervisorError::User(Box::new(e))
    }
}

/// What went wrong with the hosts of a set, their tunnel or the link between them.
#[derive(Debug, thiserror::Error)]
pub enum HostError {
    #[error(transparent)]
    Bus(#[from] BusError),
    #[error(transparent)]
    FaultVar(#[from] super::FaultVarError),
    #[error("--host {host}: no such [[host]] in the launch description")]
    NoSuchHost { host: String },
    #[error("--host {host}: the launch description names no hosts (add [[host]] tables, see tools/two_hosts.toml)")]
    NoHosts { host: String },
    #[error("--host {host}: the launch description's hosts are {}", hosts.join(", "))]
    UnknownHost { host: String, hosts: Vec<String> },
    #[error(
        "cannot start the tunnel {} ({source}); build it with `cargo build --release --manifest-path tools/tunnel/Cargo.toml` and pass --tunnel-bin",
        exe.display()
    )]
    TunnelSpawn {
        exe: std::path::PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot watch the tunnel: {0}")]
    TunnelWatch(#[source] std::io::Error),
    /// The supervisor in charge heard nothing from host `host` for the link timeout.
    #[error("link {me} <-> {host} lost: no heartbeat crossed it for {timeout_s:.0} s (link_timeout_s); stopping the set")]
    LinkLost {
        me: String,
        host: String,
        timeout_s: f64,
    },
    /// An agent heard nothing from the supervisor in charge (`boss`) for `quiet_s`.
    #[error("link {me} <-> {boss} lost: no heartbeat of the supervisor in charge crossed it for {quiet_s:.0} s; stopping host {me}'s processes")]
    BossLost {
        me: String,
        boss: String,
        quiet_s: f64,
    },
}

/// A supervised run refused: bad arguments, scenario, launch description or folders,
/// or a prefix in use (exit 2).
#[derive(Debug, thiserror::Error)]
pub enum UserError {
    #[error(transparent)]
    Scenario(#[from] crate::sim::scenario::ScenarioError),
    #[error(transparent)]
    Plan(#[from] crate::analysis::plan::PlanError),
    #[error(transparent)]
    Launch(#[from] crate::runtime::launch::LaunchError),
    /// `--method`, `--time-scale`, the estimator's table.
    #[error(transparent)]
    Process(#[from] ProcessError),
    /// `--host`, the tunnel.
    #[error(transparent)]
    Host(#[from] HostError),
    #[error(transparent)]
    Spawn(#[from] SpawnError),
    #[error("--record: recording a set spread over hosts is not supported (the recorder's streams would cross the link)")]
    RecordOverHosts,
    #[error("the Fisher information of this scenario is singular: the maneuver does not excite every parameter")]
    SingularFisher,
    /// `--out` cannot be made (a path through a file).
    #[error("--out {}: cannot create this folder ({source})", path.display())]
    OutFolder {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A prefix iceoryx2 cannot use as a file name.
    #[error("--bus-prefix: {0}")]
    BusPrefix(#[source] BusError),
    /// Another run holds the prefix: its supervisor (when known) and live nodes.
    #[error(
        "another run is active on bus prefix {prefix:?} ({}); stop it or pass a different --bus-prefix",
        holders(*pid, alive)
    )]
    AnotherRun {
        prefix: String,
        pid: Option<u32>,
        alive: Vec<String>,
    },
    /// Another run writes into this `--out` (its supervisor holds the folder's lock).
    #[error(
        "--out {}: in use by another run (supervisor pid {}); wait for it or pass another --out",
        path.display(),
        pid.map_or_else(|| "unknown".to_string(), |p| p.to_string())
    )]
    OutBusy { path: PathBuf, pid: Option<u32> },
    /// A file or folder that could not be read, created or written.
    #[error(transparent)]
    File(#[from] FileError),
    #[error("cannot remove old {}: {source}", path.display())]
    RemoveCheckpoint {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot find the directory of the supervisor's executable")]
    NoBinDir,
    #[error("cannot write the scenario: {0}")]
    ScenarioToml(#[source] toml::ser::Error),
}

/// Who holds a prefix: its supervisor's pid (when known), its live nodes.
fn holders(pid: Option<u32>, alive: &[String]) -> String {
    let mut who: Vec<String> = pid
        .map(|p| format!("supervisor pid {p}"))
        .into_iter()
        .collect();
    who.push(match alive {
        [] => "no live node yet".into(),
        _ => format!("live nodes: {}", alive.join(", ")),
    });
    who.join("; ")
}

/// The process set failed and could not go on (exit 3).
#[derive(Debug, thiserror::Error)]
pub enum SetError {
    #[error(transparent)]
    Bus(#[from] BusError),
    #[error(transparent)]
    Host(#[from] HostError),
    /// A restart could not start the member again.
    #[error(transparent)]
    Spawn(#[from] SpawnError),
    #[error("cannot start the shared-memory janitor: {0}")]
    Janitor(#[source] std::io::Error),
    #[error("cannot watch {name}: {source}")]
    Watch {
        name: String,
        #[source]
        source: std::io::Error,
    },
    /// A member exited and may not be restarted.
    #[error("{0}; stopping the set")]
    Stopped(Ended),
    /// A member exited and may not be restarted, on a host not in charge.
    #[error("host {host}: {ended}; stopping host {host}'s processes")]
    HostStopped { host: String, ended: Ended },
    #[error("not ready after {timeout_s:.0} s: {}", missing.join(", "))]
    NotReady {
        timeout_s: f64,
        missing: Vec<String>,
    },
    /// No tick advanced: each member's last tick.
    #[error(
        "the set stalled: no tick advanced for {heartbeat_s:.0} s ({}); stopping the set",
        ticks.iter().map(|(n, t)| format!("{n} at tick {t}")).collect::<Vec<_>>().join(", ")
    )]
    Stalled {
        heartbeat_s: f64,
        ticks: Vec<(String, u64)>,
    },
    #[error("{name} published no progress for {heartbeat_s:.0} s (hung?); stopping the set")]
    Hung { name: String, heartbeat_s: f64 },
    /// The failure, with the estimator's checkpoint kept for diagnosis.
    #[error("{error} (the estimator's last crash-restart checkpoint is kept: {})", checkpoint.display())]
    CheckpointKept {
        error: Box<SetError>,
        checkpoint: PathBuf,
    },
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::process::ExitStatusExt;

    /// The typed errors print what the `format!` strings they replaced printed.
    #[test]
    fn messages_are_those_of_the_string_errors_they_replaced() {
        let ended = Ended {
            name: "taiji-plant".into(),
            status: std::process::ExitStatus::from_raw(256),
            restart: Restart::OnFailure,
            max_restarts: 3,
        };
        assert_eq!(
            SetError::Stopped(ended).to_string(),
            "taiji-plant died (exit status 1); taiji-plant exhausted its 3 restarts; stopping the set"
        );
        let never = Ended {
            name: "taiji-fee".into(),
            status: std::process::ExitStatus::from_raw(9),
            restart: Restart::Never,
            max_restarts: 0,
        };
        assert_eq!(
            SetError::HostStopped {
                host: "sim".into(),
                ended: never
            }
            .to_string(),
            "host sim: taiji-fee died (signal 9); taiji-fee is not restartable (restart = \"never\" in the launch description); stopping host sim's processes"
        );
        let kept = SetError::CheckpointKept {
            error: Box::new(SetError::Stalled {
                heartbeat_s: 5.0,
                ticks: vec![("taiji-plant".into(), 7), ("taiji-fee".into(), 6)],
            }),
            checkpoint: "out/estimator.ckpt".into(),
        };
        assert_eq!(
            kept.to_string(),
            "the set stalled: no tick advanced for 5 s (taiji-plant at tick 7, taiji-fee at tick 6); stopping the set (the estimator's last crash-restart checkpoint is kept: out/estimator.ckpt)"
        );
        assert_eq!(
            UserError::AnotherRun {
                prefix: "taiji_".into(),
                pid: Some(42),
                alive: vec!["taiji-plant".into()]
            }
            .to_string(),
            "another run is active on bus prefix \"taiji_\" (supervisor pid 42; live nodes: taiji-plant); stop it or pass a different --bus-prefix"
        );
        assert_eq!(
            UserError::AnotherRun {
                prefix: "p_".into(),
                pid: None,
                alive: vec![]
            }
            .to_string(),
            "another run is active on bus prefix \"p_\" (no live node yet); stop it or pass a different --bus-prefix"
        );
        assert_eq!(
            HostError::UnknownHost {
                host: "moon".into(),
                hosts: vec!["sim".into(), "flight".into()]
            }
            .to_string(),
            "--host moon: the launch description's hosts are sim, flight"
        );
        assert_eq!(
            HostError::LinkLost {
                me: "sim".into(),
                host: "flight".into(),
                timeout_s: 20.0
            }
            .to_string(),
            "link sim <-> flight lost: no heartbeat crossed it for 20 s (link_timeout_s); stopping the set"
        );
        assert_eq!(
            ProcessError::FaultHold { value: "x".into() }.to_string(),
            "TAIJI_FAULT_HOLD must be TICK:PATH, not \"x\""
        );
        assert_eq!(
            ProcessError::ResumeOutsideRing {
                resumed: 1,
                from: 2,
                to: 3
            }
            .to_string(),
            "the estimator resumed at tick 1 but the front-end holds ticks 2..3"
        );
        assert_eq!(
            ProcessError::Outbox(BusError::Loan(iceoryx2::port::LoanError::OutOfMemory))
                .to_string(),
            "estimate publisher: loan failed: OutOfMemory"
        );
    }
}
