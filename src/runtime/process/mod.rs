//! The process set: each stage's loop, wired to iceoryx2, and the supervisor. The
//! binaries in `processes/` only parse arguments and call `run` here.
//!
//! Flow control is by credit: every stage publishes `Progress::next_tick` (ticks it has
//! consumed); its upstream publishes tick t only once it has heard from it and
//! t < next_tick + `wiring::WINDOW`. Queues therefore never overflow, nothing is dropped,
//! and a run is lock-step deterministic however the OS schedules the processes.

pub mod commander;
pub mod driver;
pub mod estimator;
pub mod fee;
pub mod hosts;
pub mod outbox;
pub mod plant;
pub mod recorder;
pub mod set;
pub mod status;
pub mod supervisor;
pub mod timing_report;
pub mod tmtc;

use crate::bus::timing::{monotonic_ns, LatencyHistogram};
use crate::bus::wiring::{self, BusError, Pub, Sub};
use crate::sim::estimate::Method;
use crate::sim::files::FileError;
use crate::sim::msg::{Control, Header, Progress, CMD_START, CMD_STOP, PROC_RECORDER, STATE_READY};
use crate::sim::scenario::Scenario;
use iceoryx2::prelude::*;
use std::path::PathBuf;
use std::time::Duration;

/// Why a stage process (or a helper of the supervisor's) failed. Wraps the error
/// enums of the modules it uses; the variants of the filter loop (`Bus`,
/// `Checkpoint`, the outbox's) allocate nothing until displayed.
#[derive(Debug, thiserror::Error)]
pub enum ProcessError {
    #[error(transparent)]
    Bus(#[from] BusError),
    #[error(transparent)]
    Scenario(#[from] crate::sim::scenario::ScenarioError),
    #[error(transparent)]
    Plan(#[from] crate::analysis::plan::PlanError),
    #[error(transparent)]
    Checkpoint(#[from] crate::analysis::checkpoint::CheckpointError),
    #[error(transparent)]
    Telemetry(#[from] crate::telemetry::TelemetryError),
    #[error(transparent)]
    FaultVar(#[from] FaultVarError),
    /// The ground link's process (`taiji-tmtc`) could not start.
    #[error(transparent)]
    Tmtc(#[from] tmtc::TmtcError),
    /// `Link::new` for a binary that is no stage of `topology::STAGES`.
    #[error("{process} is no stage of the set (topology::STAGES)")]
    NotAStage { process: String },
    #[error("--time-scale must be a positive number, not {time_scale}")]
    TimeScale { time_scale: f64 },
    #[error("--method must be joint or paper, not {method:?}")]
    Method { method: String },
    /// `TAIJI_FAULT_HOLD` is not TICK:PATH.
    #[error("{} must be TICK:PATH, not {value:?}", commander::FAULT_HOLD)]
    FaultHold { value: String },
    /// `TAIJI_FAULT_CHECKPOINT_DELAY_MS` is not a number of milliseconds up to 60000.
    #[error(
        "{} must be a whole number of milliseconds up to 60000, not {value:?}",
        estimator::FAULT_CHECKPOINT_DELAY
    )]
    FaultCheckpointDelay { value: String },
    /// A file or folder that could not be read, created or written.
    #[error(transparent)]
    File(#[from] FileError),
    /// The estimator's table could not be serialised.
    #[error("{0}")]
    TableJson(#[source] serde_json::Error),
    #[error("cannot read the estimator table {}: {source}", path.display())]
    TableRead {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: not an estimator table: {source}", path.display())]
    TableParse {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error("{}: estimator table refused: {problem:?}", path.display())]
    TableRefused {
        path: PathBuf,
        problem: crate::sim::estimate::config::ConfigError,
    },
    /// A (restarted) estimator asked for ticks the front end's ring no longer holds.
    #[error("the estimator resumed at tick {resumed} but the front-end holds ticks {from}..{to}")]
    ResumeOutsideRing { resumed: u64, from: u64, to: u64 },
    /// Samples never reached the recorder: its file lacks them.
    #[error("{lost} samples never reached the recorder; {} is incomplete", path.display())]
    IncompleteRecording { lost: u64, path: PathBuf },
    #[error("cannot start the estimate publisher thread: {0}")]
    OutboxSpawn(#[source] std::io::Error),
    #[error("the estimate publisher thread died at start")]
    OutboxDiedAtStart,
    /// The estimate publisher thread failed on the bus.
    #[error("estimate publisher: {0}")]
    Outbox(#[source] BusError),
    #[error("the estimate publisher thread panicked")]
    OutboxPanicked,
    #[error("the estimate publisher stopped")]
    OutboxStopped,
}

/// A fault-injection environment variable that is not a whole number in range.
#[derive(Debug, thiserror::Error)]
#[error("{var} must be a whole number from 0 to {max}, not {value:?}")]
pub struct FaultVarError {
    pub var: &'static str,
    pub max: u32,
    pub value: String,
}

/// Arguments of the stages that simulate (commander, plant, front-end, recorder): the
/// bus arguments and the scenario, truths included.
#[derive(Debug, Clone, clap::Args)]
pub struct StageArgs {
    /// Scenario TOML (default: the paper's case).
    #[arg(long)]
    pub scenario: Option<PathBuf>,
    /// Seed (default: the scenario's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// The campaign's epoch [mission day] (default 0): with `[drift]` the truths are
    /// that day's on (the supervisor passes a ground campaign's `campaign_epoch_day`).
    #[arg(long)]
    pub epoch_day: Option<f64>,
    /// Seed of the truths' history (`[drift]`'s walks; default: the seed).
    #[arg(long)]
    pub mission_seed: Option<u64>,
    /// The recorder's compression: each chunk shuffled and deflated at this level
    /// (1–9), or `none`.
    #[arg(long, default_value_t = crate::telemetry::Compression::DEFAULT, value_name = "none|N")]
    pub record_compression: crate::telemetry::Compression,
    #[command(flatten)]
    pub bus: BusArgs,
}

impl std::ops::Deref for StageArgs {
    type Target = BusArgs;
    fn deref(&self) -> &BusArgs {
        &self.bus
    }
}

/// Arguments every stage process takes (the supervisor passes them); no scenario: the
/// estimator gets only these and its table (`estimator::EstimatorArgs`).
#[derive(Debug, Clone, clap::Args)]
pub struct BusArgs {
    /// Prefix of the run's iceoryx2 resources.
    #[arg(long, default_value = wiring::DEFAULT_PREFIX)]
    pub bus_prefix: String,
    /// Pace at the sample rate (divided by --time-scale) instead of as fast as possible.
    #[arg(long)]
    pub realtime: bool,
    /// Real-time speed-up: simulated seconds per wall-clock second.
    #[arg(long, default_value_t = 1.0)]
    pub time_scale: f64,
    /// Run directory (the estimator keeps its checkpoint here).
    #[arg(long, default_value = "out")]
    pub run_dir: PathBuf,
    /// Estimator: joint (default) or paper.
    #[arg(long, default_value = "joint")]
    pub method: String,
    /// A recorder runs in the set: the commander also obeys its credit.
    #[arg(long)]
    pub record: bool,
    /// With --realtime: run under SCHED_FIFO at this priority (1–99; 0 = normal
    /// scheduling). Refused permission is logged and the stage runs on normally.
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u8).range(0..=99))]
    pub rt_priority: u8,
    /// With --realtime: pin the stage to this CPU.
    #[arg(long)]
    pub cpu: Option<usize>,
}

impl StageArgs {
    /// The stage's scenario. The supervisor hands every stage the scenario with its
    /// maneuver planned (`PLANNED_SCENARIO_FILE`); a stage started by hand on a
    /// scenario without one plans it itself (deterministic: the same plan). `--seed`
    /// is its seed then, as everywhere; `--epoch-day` and `--mission-seed` its epoch and
    /// its truths' history (checked as the supervisor checked them).
    pub fn scenario(&self) -> Result<Scenario, ProcessError> {
        let s = Scenario::load_or_default(self.scenario.as_deref())?;
        let (s, _) = crate::analysis::plan::resolve(s)?;
        let s = Scenario {
            seed: self.seed.unwrap_or(s.seed),
            epoch_day: self.epoch_day.unwrap_or(s.epoch_day),
            mission_seed: self.mission_seed.or(s.mission_seed),
            ..s
        };
        if self.epoch_day.is_some() {
            if !s.epoch_day.is_finite() || s.epoch_day < 0.0 {
                return Err(crate::sim::scenario::ScenarioError::Key {
                    key: "--epoch-day".into(),
                    msg: format!("must be a mission day ≥ 0, got {}", s.epoch_day),
                }
                .into());
            }
            return Ok(s.validated()?);
        }
        Ok(s)
    }

    /// Real-time tick period [ns] (0 in accelerated mode).
    pub fn period_ns(&self, s: &Scenario) -> Result<u64, ProcessError> {
        self.bus.period_ns(s.sample_rate_hz)
    }
}

impl BusArgs {
    pub fn method(&self) -> Result<Method, ProcessError> {
        parse_method(&self.method)
    }

    /// Real-time tick period [ns] at sample rate `fs` [Hz] (0 in accelerated mode).
    pub fn period_ns(&self, fs: f64) -> Result<u64, ProcessError> {
        if !self.realtime {
            return Ok(0);
        }
        if !(self.time_scale.is_finite() && self.time_scale > 0.0) {
            return Err(ProcessError::TimeScale {
                time_scale: self.time_scale,
            });
        }
        Ok((1e9 / (fs * self.time_scale)).round().max(1.0) as u64)
    }
}

/// Why a stage loop ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Exit {
    /// The supervisor said stop after the campaign.
    Stopped,
    /// SIGINT / SIGTERM, or the supervisor disappeared.
    Terminated,
}

/// What a stage knows of its downstream neighbour.
#[derive(Debug, Clone, Copy, Default)]
pub struct Downstream {
    pub heard: bool,
    pub incarnation: u64,
    pub next_tick: u64,
    pub resume_tick: u64,
    pub state: u32,
    /// It and every stage below it can take samples.
    pub primed: bool,
}

impl Downstream {
    /// May tick `t` be published now?
    pub fn credit(&self, t: u64) -> bool {
        self.heard && t < self.next_tick + wiring::WINDOW
    }
}

/// A stage's connection to the rest of the set: its node, its progress (heartbeat and
/// credit) publisher, the control stream, and its downstream's progress.
pub struct Link {
    wake: wiring::Listener,
    wake_up: Option<wiring::Notifier>,
    wake_down: Option<wiring::Notifier>,
    downstream_id: Option<u32>,
    progress_pub: Pub<Progress>,
    progress_sub: Sub<Progress>,
    control_sub: Sub<Control>,
    pub progress: Progress,
    pub downstream: Downstream,
    /// The recorder's progress (the commander obeys its credit when recording).
    pub recorder: Downstream,
    pub hop: LatencyHistogram,
    pub e2e: LatencyHistogram,
    last_beat_ns: u64,
    parent: i32,
    started: bool,
    stop: bool,
    seq: u64,
    /// Data published since the downstream was last woken.
    pending_wake: bool,
    /// Last field, so dropped after every port: iceoryx2 0.9.3 removes a node's
    /// directory only when the node itself is released last (else it stays, empty).
    pub node: Node<ipc::Service>,
}

/// Longest sleep when there is nothing to do; a neighbour's wake-up ends it sooner.
pub const IDLE: Duration = Duration::from_millis(20);

impl Link {
    /// The link of the stage run by binary `process`: its wake-up event, and its
    /// neighbours' from the set's table (`topology::STAGES`; it obeys the credit of
    /// its downstream).
    pub fn new(process: &str, args: &BusArgs) -> Result<Self, ProcessError> {
        let stage =
            crate::bus::topology::stage(process).ok_or_else(|| ProcessError::NotAStage {
                process: process.to_string(),
            })?;
        let name = stage.process;
        let downstream = stage.downstream.and_then(crate::bus::topology::stage_named);
        let node = wiring::node(name, &args.bus_prefix)?;
        let wake = wiring::listener(&node, &wiring::wake_service(stage.name))?;
        let wake_up = match stage.upstream {
            Some(u) => Some(wiring::notifier(&node, &wiring::wake_service(u))?),
            None => None,
        };
        let wake_down = match downstream {
            Some(d) => Some(wiring::notifier(&node, &wiring::wake_service(d.name))?),
            None => None,
        };
        let downstream_id = downstream.map(|d| d.id);
        let process = stage.id;
        let progress_pub = wiring::publisher::<Progress>(&node, wiring::SVC_PROGRESS)?;
        let progress_sub = wiring::subscriber::<Progress>(&node, wiring::SVC_PROGRESS)?;
        let control_sub = wiring::subscriber::<Control>(&node, wiring::SVC_CONTROL)?;
        // Real-time stages run under SCHED_FIFO when allowed; threads started before
        // this point (the estimator's checkpoint writer) stay at normal priority.
        let mut rt_priority = 0;
        let mut cpu = -1;
        if let (true, Some(c)) = (args.realtime, args.cpu) {
            match crate::bus::timing::pin_to_cpu(c) {
                Ok(()) => cpu = c as i32,
                Err(e) => log::warn!("{name}: cannot pin to CPU {c} ({e}); running unpinned"),
            }
        }
        if args.realtime && args.rt_priority > 0 {
            match crate::bus::timing::enter_fifo(args.rt_priority) {
                Ok(()) => rt_priority = args.rt_priority as u32,
                Err(e) => log::warn!(
                    "{name}: SCHED_FIFO priority {} refused ({e}); running with normal scheduling",
                    args.rt_priority
                ),
            }
        }
        let progress = Progress {
            process,
            state: STATE_READY,
            incarnation: monotonic_ns(),
            rt_priority,
            cpu,
            ..Default::default()
        };
        Ok(Link {
            node,
            wake,
            wake_up,
            wake_down,
            downstream_id,
            progress_pub,
            progress_sub,
            control_sub,
            progress,
            downstream: Downstream::default(),
            recorder: Downstream::default(),
            hop: LatencyHistogram::default(),
            e2e: LatencyHistogram::default(),
            last_beat_ns: 0,
            // SAFETY: getppid has no preconditions.
            parent: unsafe { libc::getppid() },
            started: false,
            stop: false,
            seq: 0,
            pending_wake: false,
        })
    }

    /// Publish progress now.
    pub fn beat(&mut self) -> Result<(), BusError> {
        let now = monotonic_ns();
        self.progress.primed = self.primed() as u32;
        let p = &mut self.progress;
        p.header = Header {
            seq: self.seq,
            tick: p.next_tick,
            sim_time_ns: 0,
            publish_ns: now,
            origin_ns: 0,
            due_ns: 0,
            epoch: 0,
        };
        let h = self.hop.summary_us();
        p.hop_latency_us = [h.p50, h.p99, h.max];
        let e = self.e2e.summary_us();
        p.e2e_latency_us = [e.p50, e.p99, e.max];
        p.latency_count = h.count.max(e.count);
        self.seq += 1;
        self.last_beat_ns = now;
        self.flush_wake();
        wiring::publish(&self.progress_pub, self.progress)?;
        // New credit: wake the upstream stage if it waits for it. A failed wake-up is
        // harmless (everyone also wakes on its heartbeat period).
        if let Some(n) = &self.wake_up {
            let _ = n.notify();
        }
        Ok(())
    }

    /// Note that data was published; the downstream is woken before this stage
    /// sleeps or beats, or at once in real-time mode (`now`).
    pub fn sent(&mut self, now: bool) {
        self.pending_wake = true;
        if now {
            self.flush_wake();
        }
    }

    fn flush_wake(&mut self) {
        if self.pending_wake {
            self.pending_wake = false;
            if let Some(n) = &self.wake_down {
                let _ = n.notify();
            }
        }
    }

    /// Read control and downstream progress; publish a heartbeat when one is due.
    /// Returns `Some(exit)` when the stage must stop.
    pub fn poll(&mut self) -> Result<Option<Exit>, BusError> {
        // Drain wake-ups: their data is already visible (publish precedes notify), and a
        // full socket would make the neighbour's notify fail (which allocates).
        let _ = self.wake.try_wait_all(|_| {});
        while let Some(c) = wiring::receive(&self.control_sub)? {
            match c.command {
                CMD_START => {
                    self.started = true;
                    // Neighbours may have started after our first heartbeat: grant credit now.
                    self.beat()?;
                }
                CMD_STOP => self.stop = true,
                _ => {}
            }
        }
        let was_primed = self.primed();
        while let Some(p) = wiring::receive(&self.progress_sub)? {
            let heard = Downstream {
                heard: true,
                incarnation: p.incarnation,
                next_tick: p.next_tick,
                resume_tick: p.resume_tick,
                state: p.state,
                primed: p.primed != 0,
            };
            if Some(p.process) == self.downstream_id {
                self.downstream = heard;
            } else if p.process == PROC_RECORDER {
                self.recorder = heard;
            }
        }
        if self.stop {
            return Ok(Some(Exit::Stopped));
        }
        // Tell the upstream at once when the chain below became ready.
        if self.primed() != was_primed
            || monotonic_ns() > self.last_beat_ns + crate::tuning::BEAT_NS
        {
            // SAFETY: getppid has no preconditions.
            if unsafe { libc::getppid() } != self.parent {
                return Ok(Some(Exit::Terminated));
            }
            self.beat()?;
        }
        Ok(None)
    }

    /// Can this stage and every stage downstream of it take samples?
    pub fn primed(&self) -> bool {
        self.downstream_id.is_none() || self.downstream.primed
    }

    /// Has the supervisor said start?
    pub fn started(&self) -> bool {
        self.started
    }

    /// Sleep until woken by a neighbour or `d` has passed; `Some(Terminated)` on
    /// SIGINT/SIGTERM.
    pub fn idle(&mut self, d: Duration) -> Option<Exit> {
        self.flush_wake();
        // ppoll on the listener's socket, then drain it without blocking: iceoryx2
        // 0.9.3's own timed wait formats an error string (allocates) on every call.
        // SAFETY: the descriptor stays owned by the listener, which outlives this call.
        let fd = unsafe { self.wake.file_descriptor().native_handle() };
        let mut fds = libc::pollfd {
            fd,
            events: libc::POLLIN,
            revents: 0,
        };
        let ts = libc::timespec {
            tv_sec: d.as_secs() as libc::time_t,
            tv_nsec: d.subsec_nanos() as libc::c_long,
        };
        // SAFETY: one valid pollfd, a valid timespec, no signal mask change.
        unsafe { libc::ppoll(&mut fds, 1, &ts, std::ptr::null()) };
        let _ = self.wake.try_wait_all(|_| {});
        match self.node.wait(Duration::ZERO) {
            Ok(()) => None,
            Err(_) => Some(Exit::Terminated),
        }
    }

    /// Sleep precisely (nanosleep), e.g. until a real-time tick is due.
    pub fn sleep(&mut self, d: Duration) -> Option<Exit> {
        self.flush_wake();
        match self.node.wait(d) {
            Ok(()) => None,
            Err(_) => Some(Exit::Terminated),
        }
    }

    /// After the last tick: report done and wait for the supervisor's stop.
    pub fn linger(&mut self, state: u32) -> Result<Exit, BusError> {
        self.progress.state = state;
        self.beat()?;
        loop {
            if let Some(e) = self.poll()? {
                return Ok(e);
            }
            if let Some(e) = self.idle(Duration::from_millis(1)) {
                return Ok(e);
            }
        }
    }
}

/// `--method` of the stages and the supervisor.
pub fn parse_method(name: &str) -> Result<Method, ProcessError> {
    match name {
        "joint" => Ok(Method::Joint),
        "paper" => Ok(Method::Paper),
        m => Err(ProcessError::Method {
            method: m.to_string(),
        }),
    }
}

/// A warning from a loop that must not touch the heap. The logger allocates on every
/// record (its colour probe reads environment variables), so when warnings are enabled
/// the line is formatted on the stack, in the logger's layout, and written to stderr
/// (cut at 255 bytes).
pub fn warn_without_alloc(args: std::fmt::Arguments<'_>) {
    use std::io::Write;
    if !log::log_enabled!(log::Level::Warn) {
        return;
    }
    let mut line = heapless::Vec::<u8, 256>::new();
    let mut w = Truncating(&mut line);
    let _ = write!(w, "[WARN ] {args}");
    if line.len() == line.capacity() {
        line.pop();
    }
    let _ = line.push(b'\n');
    let _ = std::io::stderr().write_all(&line);
}

/// Writes what fits, drops the rest.
struct Truncating<'a>(&'a mut heapless::Vec<u8, 256>);

impl std::io::Write for Truncating<'_> {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        let room = self.0.capacity() - self.0.len();
        let _ = self.0.extend_from_slice(&b[..b.len().min(room)]);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// `log` through env_logger (`RUST_LOG`, default warn); iceoryx2's own log at error
/// unless `IOX2_LOG_LEVEL` says otherwise (its warnings about a dead peer's socket are
/// expected during a restart).
pub fn init_logging() {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn"))
        .format_target(false)
        .init();
    iceoryx2::prelude::set_log_level_from_env_or(iceoryx2::prelude::LogLevel::Error);
}

/// Common `main` of a stage binary: logging, run, exit code (0 done, 2 error, 130 signal).
pub fn main_of(
    name: &str,
    run: impl FnOnce() -> Result<Exit, ProcessError>,
) -> std::process::ExitCode {
    init_logging();
    match run() {
        Ok(Exit::Stopped) => std::process::ExitCode::SUCCESS,
        Ok(Exit::Terminated) => {
            log::info!("{name}: terminated");
            std::process::ExitCode::from(130)
        }
        Err(e) => {
            eprintln!("{name}: error: {e}");
            std::process::ExitCode::from(2)
        }
    }
}

/// A fault-injection count from the environment variable `var` (unset: 0), at most
/// `max`; anything else is a user error naming the variable.
pub(crate) fn fault_count(var: &'static str, max: u32) -> Result<u32, FaultVarError> {
    match std::env::var(var) {
        Err(_) => Ok(0),
        Ok(v) => match v.trim().parse::<u32>() {
            Ok(k) if k <= max => Ok(k),
            _ => Err(FaultVarError { var, max, value: v }),
        },
    }
}
