//! The set of child processes one host runs: the supervisor's arguments, each
//! member's process and its last heartbeat, and the watch that restarts what died by
//! its policy. The supervisor (one host) and the hosts module (a set over hosts) both
//! drive it.

use crate::bus;
use crate::launch::{ProcessSpec, Restart};
use crate::msg::Progress;
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
    pub graph: Option<crate::topology::GraphFormat>,
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
    #[arg(long, default_value = bus::DEFAULT_PREFIX)]
    pub bus_prefix: String,
    /// Start the recorder too: every stream to OUT/telemetry.h5.
    #[arg(long)]
    pub record: bool,
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
    pub(crate) bar: crate::progress::Bar,
}

/// What [`Set::reap`] found among this host's processes.
pub(crate) enum Reap {
    /// None exited for good (any that died were restarted by policy).
    Running,
    /// One was stopped by SIGINT/SIGTERM: the user is stopping the set.
    Interrupted,
    /// One exited and may not be restarted: its name, how it ended, and why not.
    Stopped(String),
}

impl Set {
    /// Watch this host's processes: restart what died by its policy (after its delay,
    /// releasing the dead node's shared memory first); the first that may not be
    /// restarted ends the watch. `who` prefixes the log lines ("host sim: ").
    pub(crate) fn reap(&mut self, who: &str) -> Result<Reap, String> {
        for i in 0..self.members.len() {
            let Some(child) = self.members[i].child.as_mut() else {
                continue;
            };
            let status = match child.try_wait() {
                Ok(Some(st)) => st,
                Ok(None) => continue,
                Err(e) => return Err(format!("cannot watch {}: {e}", self.members[i].spec.name)),
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
                if let Ok(sv) = bus::cleanup_stale(&self.prefix) {
                    log::info!("{who}removed {} dead node(s)", sv.removed_dead);
                }
                let child = self.spawn(&spec)?;
                let m = &mut self.members[i];
                m.child = Some(child);
                m.restarts += 1;
                m.last_seen = Instant::now();
                continue;
            }
            let why = match m.spec.restart {
                Restart::Never => format!(
                    "{name} is not restartable (restart = \"never\" in the launch description)"
                ),
                Restart::OnFailure if status.success() => {
                    format!("{name} exited before the campaign ended")
                }
                Restart::OnFailure => {
                    format!("{name} exhausted its {} restarts", m.spec.max_restarts)
                }
            };
            return Ok(Reap::Stopped(format!(
                "{name} died ({}); {why}",
                describe(status)
            )));
        }
        Ok(Reap::Running)
    }
}

impl Set {
    pub(crate) fn spawn(&self, spec: &ProcessSpec) -> Result<Child, String> {
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
            .map_err(|e| format!("cannot start {}: {e}", exe.display()))
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
    User(String),
    Set(String),
}
