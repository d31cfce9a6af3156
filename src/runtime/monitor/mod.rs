//! `taiji-calib monitor`: watch a running set live from outside it, on any host of
//! it, at any moment. It reads the estimates and the supervisor's status (`feed`),
//! keeps what it needs for rates, latency windows and plots (`model`), and draws a
//! terminal screen (`screen`) or prints one snapshot (`--once`, `--json`). It never
//! writes where a stage reads: the only thing it sends is an operator's request to
//! the supervisor (stop, after a y/n question), which alone commands the stages.
//! `--ground ADDR` draws the same screen from the ground link's telemetry instead
//! (`ground`), on any machine that reaches the set's address, with no shared memory.

pub mod feed;
pub mod ground;
pub mod model;
pub mod png;
pub mod screen;

use crate::bus::wiring::BusError;
use crate::runtime::launch::LaunchDescription;
use crate::sim::files::FileError;
use crate::sim::msg::SetStatus;
use model::{Snapshot, Tracker, Truth};
use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(Debug, Clone, clap::Args)]
pub struct MonitorArgs {
    /// Bus prefix of the run to watch.
    #[arg(long, default_value = crate::bus::wiring::DEFAULT_PREFIX)]
    pub bus_prefix: String,
    /// The set's launch description with its `[[host]]` tables (e.g.
    /// tools/two_hosts.toml): names each process's host from it (otherwise from the
    /// supervisor's status).
    #[arg(long)]
    pub hosts: Option<PathBuf>,
    /// The run's scenario (its folder's scenario.toml): shows the truth and err/σ.
    /// The monitor never reads truth from the bus.
    #[arg(long)]
    pub scenario: Option<PathBuf>,
    /// Print one snapshot and exit (text; with --json, JSON).
    #[arg(long)]
    pub once: bool,
    /// With --once: the snapshot as JSON.
    #[arg(long, requires = "once")]
    pub json: bool,
    /// With --once: watch this long [s] after the first status and estimate before the
    /// snapshot (rates and latency windows need time).
    #[arg(long, default_value_t = 1.0, requires = "once")]
    pub watch: f64,
    /// Give up after this long [s] without a run (0: wait forever in the terminal UI;
    /// with --ground, without both housekeeping structures, 0: wait forever).
    #[arg(long, default_value_t = 30.0)]
    pub timeout: f64,
    /// With --once: also draw the screen to this PNG (the README's screenshot).
    #[arg(long, requires = "once")]
    pub png: Option<PathBuf>,
    /// Draw the screen from the ground link's telemetry alone, no shared memory: the
    /// set's address (`tools/launch --ground ADDR`). Needs --key.
    #[arg(long, value_name = "ADDR", requires = "key", conflicts_with_all = ["hosts", "bus_prefix"], value_parser = address)]
    pub ground: Option<SocketAddr>,
    /// With --ground: the link's key file (readable by its owner only).
    #[arg(long, requires = "ground")]
    pub key: Option<PathBuf>,
    /// With --ground: the local address to receive on (default: an ephemeral port on
    /// the loopback, or on every interface when ADDR is not a loopback address).
    #[arg(long, requires = "ground", value_parser = address)]
    pub bind: Option<SocketAddr>,
    /// With --ground: ping every S seconds to keep the telemetry coming here (it goes
    /// to the sender of the last accepted telecommand); 0: only at start.
    #[arg(long, default_value_t = 5.0, value_name = "S")]
    pub keepalive: f64,
}

/// An address as `HOST:PORT`, the first it resolves to.
fn address(s: &str) -> Result<SocketAddr, String> {
    use std::net::ToSocketAddrs;
    s.to_socket_addrs()
        .map_err(|e| format!("{s:?} is not an address HOST:PORT ({e})"))?
        .next()
        .ok_or_else(|| format!("{s:?} resolves to no address"))
}

#[derive(Debug, thiserror::Error)]
pub enum MonitorError {
    #[error(transparent)]
    Bus(#[from] BusError),
    #[error(transparent)]
    Scenario(#[from] crate::sim::scenario::ScenarioError),
    #[error("--hosts: {0}")]
    Hosts(#[from] crate::runtime::launch::LaunchError),
    #[error("--watch and --timeout must be seconds ≥ 0, not {value}")]
    Seconds { value: f64 },
    /// No run came on the prefix (exit 1: nothing to show).
    #[error(
        "no run on bus prefix {prefix:?} after {timeout_s} s (no supervisor's status; start one with tools/launch, check --bus-prefix, or raise --timeout)"
    )]
    NoRun { prefix: String, timeout_s: f64 },
    /// The run ended (or stood still) before the monitor saw an estimate.
    #[error("the run on bus prefix {prefix:?} ended or sent no estimate before --timeout")]
    Ended { prefix: String },
    /// SIGINT or SIGTERM before the snapshot was taken.
    #[error("terminated before the snapshot")]
    Terminated,
    #[error("the terminal: {0}")]
    Terminal(#[source] std::io::Error),
    /// A file or folder that could not be read, created or written.
    #[error(transparent)]
    File(#[from] FileError),
    #[error("{0}")]
    Json(#[from] serde_json::Error),
    #[error(transparent)]
    Png(#[from] png::PngError),
    /// `--ground` without `--key` (clap asks for it; this is the library's own check).
    #[error("--ground needs --key")]
    NoKey,
    /// The ground link: the key, the sequence counter, the socket.
    #[error(transparent)]
    Link(#[from] crate::ground::client::ClientError),
    /// No telemetry came from the set (exit 1: nothing to show).
    #[error("no telemetry from {address} after {timeout_s} s{why}")]
    NoTelemetry {
        address: SocketAddr,
        timeout_s: f64,
        why: &'static str,
    },
    /// The set refused the monitor's ping.
    #[error("the set at {address} refused the monitor's ping: {why}")]
    Refused { address: SocketAddr, why: String },
}

impl MonitorError {
    /// 1 when there was nothing to watch, 2 for everything else.
    pub fn exit_code(&self) -> u8 {
        match self {
            MonitorError::NoRun { .. }
            | MonitorError::Ended { .. }
            | MonitorError::NoTelemetry { .. } => 1,
            _ => 2,
        }
    }
}

/// Where each process runs: the launch description given with `--hosts`, else the
/// names the supervisor's status carries ("local" on one host).
pub struct HostNames(Option<LaunchDescription>);

impl HostNames {
    pub fn name(&self, s: &SetStatus, index: u32, process: &str) -> String {
        if let Some(l) = &self.0 {
            if let Some(p) = l.process.iter().find(|p| p.name == process) {
                return l.host_of(p).to_string();
            }
        }
        match s.host_name(index) {
            n if n.is_empty() => "local".into(),
            n => n,
        }
    }
}

/// How often the monitor reads the bus and redraws.
const FRAME: Duration = Duration::from_millis(100);
/// A run whose supervisor is silent this long is taken as gone (it beats every 0.1 s).
const SILENT: Duration = Duration::from_secs(5);

fn seconds(v: f64) -> Result<Duration, MonitorError> {
    if v.is_finite() && v >= 0.0 {
        Ok(Duration::from_secs_f64(v))
    } else {
        Err(MonitorError::Seconds { value: v })
    }
}

/// Run the monitor; the exit code.
pub fn run(args: &MonitorArgs) -> Result<u8, MonitorError> {
    let truth = match &args.scenario {
        Some(p) => Some(Truth::of(&crate::sim::scenario::Scenario::load(p)?)),
        None => None,
    };
    let hosts = HostNames(match &args.hosts {
        Some(p) => Some(LaunchDescription::load_or_default(Some(p))?),
        None => None,
    });
    let timeout = seconds(args.timeout)?;
    let watch = seconds(args.watch)?;
    if let Some(to) = args.ground {
        return if args.once {
            once_ground(args, to, truth, timeout, watch)
        } else {
            ui::run_ground(args, to, truth, timeout)
        };
    }
    if args.once {
        once(args, truth, &hosts, timeout, watch)
    } else {
        ui::run(args, truth, &hosts, timeout)
    }
}

/// Wait for a run (without touching the bus) and attach.
fn attach(prefix: &str, timeout: Duration) -> Result<feed::Feed, MonitorError> {
    let t0 = Instant::now();
    loop {
        if let Some(f) = feed::Feed::attach(prefix)? {
            return Ok(f);
        }
        if timeout > Duration::ZERO && t0.elapsed() > timeout {
            return Err(MonitorError::NoRun {
                prefix: prefix.to_string(),
                timeout_s: timeout.as_secs_f64(),
            });
        }
        std::thread::sleep(FRAME);
    }
}

/// Read what arrived into the tracker.
fn pump(feed: &mut feed::Feed, t: &mut Tracker) -> Result<(), BusError> {
    let now = Instant::now();
    let mut est = Vec::new();
    let mut st = Vec::new();
    let mut heads = Vec::new();
    feed.drain(
        |e| est.push(*e),
        |s| st.push(*s),
        |k, h| heads.push((k, *h)),
    )?;
    for s in &st {
        t.status(s, now);
    }
    for (k, h) in &heads {
        t.stream(*k, h, now);
    }
    for e in &est {
        t.estimate(e, now);
    }
    t.settle(now);
    Ok(())
}

/// Detach: drop the ports and node, and when the run is over and nothing else is left
/// on the prefix, what iceoryx2 leaves of it.
fn detach(feed: feed::Feed, prefix: &str) {
    drop(feed);
    crate::bus::wiring::release_if_unused(prefix);
}

fn once(
    args: &MonitorArgs,
    truth: Option<Truth>,
    hosts: &HostNames,
    timeout: Duration,
    watch: Duration,
) -> Result<u8, MonitorError> {
    let mut feed = attach(&args.bus_prefix, timeout)?;
    let mut t = Tracker::new(truth);
    let mut since: Option<Instant> = None;
    let t0 = Instant::now();
    let result = loop {
        std::thread::sleep(FRAME);
        if feed.terminated() {
            break Err(MonitorError::Terminated);
        }
        if let Err(e) = pump(&mut feed, &mut t) {
            break Err(e.into());
        }
        if since.is_none() && t.latest.is_some() && t.status.is_some() {
            since = Some(Instant::now());
        }
        if since.is_some_and(|s| s.elapsed() >= watch) || (t.ended() && t.latest.is_some()) {
            break Ok(());
        }
        let silent = t.status_at.map_or(t0.elapsed(), |s| s.elapsed());
        // A run held still (no estimate comes) is given the same time as a run to come.
        let starved = since.is_none() && t0.elapsed() > SILENT.max(timeout);
        if silent > SILENT.max(timeout) || starved || (t.ended() && t.latest.is_none()) {
            break Err(MonitorError::Ended {
                prefix: args.bus_prefix.clone(),
            });
        }
    };
    detach(feed, &args.bus_prefix);
    result?;
    let snap = t.snapshot(&args.bus_prefix, hosts, Instant::now());
    print_snapshot(args, &snap, &t)
}

/// `--once --ground`: watch the telemetry until structures 1 and 2 have come and
/// `--watch` has passed, then print the snapshot.
fn once_ground(
    args: &MonitorArgs,
    to: SocketAddr,
    truth: Option<Truth>,
    timeout: Duration,
    watch: Duration,
) -> Result<u8, MonitorError> {
    let mut g = ground::GroundFeed::open(args, to)?;
    crate::ground::client::catch_termination();
    let mut t = Tracker::new(truth);
    let mut since: Option<Instant> = None;
    let t0 = Instant::now();
    loop {
        if crate::ground::client::terminated() {
            return Err(MonitorError::Terminated);
        }
        g.pump(&mut t, FRAME)?;
        if g.new_campaign {
            t = Tracker::new(t.truth);
            since = None;
        }
        if let Some(why) = g.refused.take() {
            return Err(MonitorError::Refused { address: to, why });
        }
        if since.is_none() && t.latest.is_some() && g.has_health() {
            since = Some(Instant::now());
        }
        if since.is_some_and(|s| s.elapsed() >= watch) {
            break;
        }
        if since.is_none() && !timeout.is_zero() && t0.elapsed() > timeout {
            return Err(MonitorError::NoTelemetry {
                address: to,
                timeout_s: timeout.as_secs_f64(),
                why: match (g.nothing_listens, g.heard_at) {
                    (true, _) => " (nothing listens there: is the set up with --ground?)",
                    (false, None) => " (is the set up, on this address, with this key?)",
                    (false, Some(_)) => " with both housekeeping structures (enable them with `ground hk-enable 1 2`)",
                },
            });
        }
    }
    let now = Instant::now();
    let mut snap = t.snapshot("", &HostNames(None), now);
    g.finish(&mut snap, now);
    print_snapshot(args, &snap, &t)
}

/// `--once`'s output: the PNG if asked for, then the JSON or the text.
fn print_snapshot(args: &MonitorArgs, snap: &Snapshot, t: &Tracker) -> Result<u8, MonitorError> {
    if let Some(path) = &args.png {
        png::write(snap, t, path)?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(snap)?);
    } else {
        print!("{}", text(snap, t));
    }
    Ok(0)
}

/// The screen as text lines (`--once` without `--json`), 150 columns wide.
pub fn text(snap: &Snapshot, t: &Tracker) -> String {
    let buf = render(snap, t, 150, 46);
    let mut out = String::new();
    for y in 0..buf.area.height {
        let line: String = (0..buf.area.width)
            .map(|x| buf[(x, y)].symbol().to_string())
            .collect();
        out.push_str(line.trim_end());
        out.push('\n');
    }
    out
}

/// The screen drawn into a buffer of `w` × `h` cells (ratatui's test backend).
pub fn render(snap: &Snapshot, t: &Tracker, w: u16, h: u16) -> ratatui::buffer::Buffer {
    let backend = ratatui::backend::TestBackend::new(w, h);
    // The test backend cannot fail to draw.
    let mut term = match ratatui::Terminal::new(backend) {
        Ok(term) => term,
        Err(_) => return ratatui::buffer::Buffer::empty(ratatui::layout::Rect::new(0, 0, w, h)),
    };
    let _ = term.draw(|f| screen::draw(f, &screen::View::of(t, snap)));
    term.backend().buffer().clone()
}

mod ui;
