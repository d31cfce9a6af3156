//! `taiji-tmtc`: the ground link's process (`--ground` sets only, docs/ground.md). It
//! listens for telecommands on a UDP socket and runs them through the onboard logic
//! (`ground::onboard`), whose telemetry it sends to the sender of the last accepted
//! telecommand; inside the set it speaks iceoryx2: it reads the estimates, the
//! supervisor's set status, ground state and notes, and publishes the accepted
//! functions of service 8 (`GroundRequest`) and its heartbeats (`Progress`, process
//! `PROC_TMTC`).
//!
//! It lives across campaigns: no `Control` reaches it. It ends on SIGINT/SIGTERM (exit
//! 130), when the supervisor's `GroundState` has been silent for `SUPERVISOR_SILENCE`
//! after it was heard (exit 0: the supervisor is gone), and at start on a bad argument
//! or key (exit 2). What a restart must not lose is on disk in `--state-dir`: the
//! anti-replay state (`tc-sequence.state`) and the telemetry's destination
//! (`tm-destination`).
//!
//! Its loop waits in `ppoll` on the socket (at most `POLL`), then drains the socket and
//! the bus, feeds the onboard logic, sends its telemetry with non-blocking `send_to`
//! (a refusal is counted, never fatal) and beats. After its warm-up it allocates
//! nothing: `Progress::loop_allocations` counts the heap allocations of the loop's
//! thread since then (`bus::alloc_count`, installed by the binary).

use super::{BusArgs, Exit, ProcessError};
use crate::bus::alloc_count;
use crate::bus::timing::monotonic_ns;
use crate::bus::wiring::{self, Pub, Sub};
use crate::ground::auth::{Key, KeyError};
use crate::ground::downlink::TM_MAX;
use crate::ground::onboard::Onboard;
use crate::ground::packet::MAX_PACKET_LEN;
use crate::ground::replay::{ReplayError, ReplayGuard};
use crate::sim::msg::{
    GroundNote, GroundRequest, GroundState, Header, Progress, PROC_TMTC, STATE_READY, STATE_RUNNING,
};
use iceoryx2::prelude::*;
use std::ffi::CString;
use std::net::{SocketAddr, UdpSocket};
use std::os::fd::AsRawFd;
use std::os::unix::ffi::OsStrExt;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The anti-replay state's file in `--state-dir`.
pub const SEQUENCE_FILE: &str = "tc-sequence.state";
/// The telemetry destination's file in `--state-dir`.
pub const DESTINATION_FILE: &str = "tm-destination";
/// Longest wait in `ppoll` for a datagram.
pub const POLL: Duration = Duration::from_millis(10);
/// Heartbeat period (the supervisor wants one at least every 50 ms).
pub const BEAT: Duration = Duration::from_millis(25);
/// The supervisor is gone when its `GroundState` has been silent this long.
pub const SUPERVISOR_SILENCE: Duration = Duration::from_secs(5);
/// Datagrams taken per loop turn at most (the bus is served between batches).
const BATCH: usize = 256;
/// Loop turns after the supervisor is first heard before allocations count (its
/// publishers' connections are set up in these).
const WARM_UP_TURNS: u32 = 20;

/// Arguments of `taiji-tmtc`: the common ones the supervisor passes every process, and
/// the ground link's.
#[derive(Debug, Clone, clap::Args)]
pub struct TmtcArgs {
    #[command(flatten)]
    pub bus: BusArgs,
    /// UDP address to listen on for telecommands, e.g. 127.0.0.1:7301.
    #[arg(long, value_name = "ADDR")]
    pub ground: SocketAddr,
    /// The telecommand key file (64 hexadecimal characters; refused when group or others
    /// can read it).
    #[arg(long, value_name = "FILE")]
    pub ground_key: PathBuf,
    /// Folder of the state that survives a restart (default: --run-dir).
    #[arg(long, value_name = "DIR")]
    pub state_dir: Option<PathBuf>,
    /// Allow --ground to be an address that is not loopback.
    #[arg(long)]
    pub ground_remote: bool,
}

/// Why `taiji-tmtc` could not start or run.
#[derive(Debug, thiserror::Error)]
pub enum TmtcError {
    #[error("--ground {addr} is not a loopback address: pass --ground-remote to listen on it")]
    NotLoopback { addr: SocketAddr },
    #[error(transparent)]
    Key(#[from] KeyError),
    #[error(transparent)]
    Replay(#[from] ReplayError),
    #[error("--state-dir {}: {source}", path.display())]
    StateDir {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("--ground {addr}: cannot listen ({source})")]
    Bind {
        addr: SocketAddr,
        source: std::io::Error,
    },
}

/// The telemetry's destination on disk: written (a temporary file renamed over it)
/// when an accepted telecommand changes it, read back at start. Writing touches no heap:
/// the paths are made ready when it is opened.
struct DestinationFile {
    path: CString,
    tmp: CString,
}

impl DestinationFile {
    fn new(dir: &Path) -> Option<DestinationFile> {
        let c = |p: PathBuf| CString::new(p.as_os_str().as_bytes()).ok();
        Some(DestinationFile {
            path: c(dir.join(DESTINATION_FILE))?,
            tmp: c(dir.join(format!("{DESTINATION_FILE}.tmp")))?,
        })
    }

    /// The destination kept by a previous incarnation, if any.
    fn load(dir: &Path) -> Option<SocketAddr> {
        let text = std::fs::read_to_string(dir.join(DESTINATION_FILE)).ok()?;
        text.trim().parse().ok()
    }

    /// Keeps `dest`; false when it could not be written.
    fn save(&self, dest: SocketAddr) -> bool {
        use std::io::Write;
        let mut buf = [0u8; 64];
        let mut cur = std::io::Cursor::new(&mut buf[..]);
        if writeln!(cur, "{dest}").is_err() {
            return false;
        }
        let n = cur.position() as usize;
        // SAFETY: NUL-terminated paths that outlive the calls; `buf` is valid for `n`
        // bytes; the descriptor is closed once.
        unsafe {
            let fd = libc::open(
                self.tmp.as_ptr(),
                libc::O_WRONLY | libc::O_CREAT | libc::O_TRUNC | libc::O_CLOEXEC,
                0o600 as libc::c_uint,
            );
            if fd < 0 {
                return false;
            }
            let w = libc::write(fd, buf.as_ptr().cast(), n);
            let closed = libc::close(fd);
            w == n as isize
                && closed == 0
                && libc::rename(self.tmp.as_ptr(), self.path.as_ptr()) == 0
        }
    }
}

/// The process's ports.
struct Ports {
    note: Sub<GroundNote>,
    state: Sub<GroundState>,
    request: Pub<GroundRequest>,
    progress: Pub<Progress>,
    /// Last field: iceoryx2 0.9.3 removes a node's folder only when it is dropped last.
    node: Node<ipc::Service>,
}

impl Ports {
    fn open(prefix: &str) -> Result<Ports, ProcessError> {
        let node = wiring::node("taiji-tmtc", prefix)?;
        Ok(Ports {
            note: wiring::subscriber(&node, wiring::SVC_GROUND_NOTE)?,
            state: wiring::subscriber(&node, wiring::SVC_GROUND_STATE)?,
            request: wiring::publisher(&node, wiring::SVC_GROUND_REQUEST)?,
            progress: wiring::publisher(&node, wiring::SVC_GROUND_BEAT)?,
            node,
        })
    }
}

/// Checks the arguments, reads the key and the state, binds the socket and opens the
/// ports; then runs the loop.
pub fn run(args: &TmtcArgs) -> Result<Exit, ProcessError> {
    if !args.ground.ip().is_loopback() && !args.ground_remote {
        return Err(TmtcError::NotLoopback { addr: args.ground }.into());
    }
    let key = Key::load(&args.ground_key).map_err(TmtcError::from)?;
    let dir = args.state_dir.clone().unwrap_or(args.bus.run_dir.clone());
    std::fs::create_dir_all(&dir).map_err(|source| TmtcError::StateDir {
        path: dir.clone(),
        source,
    })?;
    let guard = ReplayGuard::open(&dir.join(SEQUENCE_FILE)).map_err(TmtcError::from)?;
    let dest_file = DestinationFile::new(&dir).ok_or_else(|| TmtcError::StateDir {
        path: dir.clone(),
        source: std::io::Error::from(std::io::ErrorKind::InvalidInput),
    })?;
    let socket = UdpSocket::bind(args.ground)
        .and_then(|s| s.set_nonblocking(true).map(|_| s))
        .map_err(|source| TmtcError::Bind {
            addr: args.ground,
            source,
        })?;
    let incarnation = monotonic_ns();
    // Tokens of this incarnation start far from the last one's.
    let mut onboard = Onboard::new(key, guard, incarnation << 16);
    if let Some(d) = DestinationFile::load(&dir) {
        log::info!("taiji-tmtc: telemetry goes to {d} (kept from before a restart)");
        onboard.set_destination(d);
    }
    let ports = Ports::open(&args.bus.bus_prefix)?;
    log::info!("taiji-tmtc: listening on {}", args.ground);
    let mut l = Loop {
        onboard,
        ports,
        socket,
        dest_file,
        progress: Progress {
            process: PROC_TMTC,
            state: STATE_READY,
            incarnation,
            next_tick: 0,
            ..Progress::default()
        },
        rx: vec![0u8; MAX_PACKET_LEN].into_boxed_slice(),
        beat_seq: 0,
        last_beat_ns: 0,
        state_heard_ns: None,
        allocs_before: None,
        turns_heard: 0,
        last_estimate: Header::default(),
    };
    l.run()
}

/// The loop's state.
struct Loop {
    onboard: Onboard,
    ports: Ports,
    socket: UdpSocket,
    dest_file: DestinationFile,
    progress: Progress,
    /// A datagram's buffer: the longest space packet fits.
    rx: Box<[u8]>,
    beat_seq: u64,
    last_beat_ns: u64,
    /// When the supervisor's `GroundState` was last heard.
    state_heard_ns: Option<u64>,
    /// The thread's allocations when the warm-up ended.
    allocs_before: Option<u64>,
    turns_heard: u32,
    /// The header of the last estimate relayed (a repeat is not taken again).
    last_estimate: Header,
}

impl Loop {
    fn run(&mut self) -> Result<Exit, ProcessError> {
        self.beat()?;
        let exit = loop {
            if let Some(e) = self.turn()? {
                break e;
            }
        };
        alloc_count::trace_stop();
        if let Some(a) = self.allocs_before {
            log::info!(
                "taiji-tmtc: heap allocations in the loop: {}",
                alloc_count::thread_allocations().unwrap_or(a) - a
            );
        }
        Ok(exit)
    }

    /// One turn: wait, datagrams, bus, reports, heartbeat.
    fn turn(&mut self) -> Result<Option<Exit>, ProcessError> {
        if self.wait() {
            return Ok(Some(Exit::Terminated));
        }
        self.datagrams()?;
        self.bus()?;
        let now = monotonic_ns();
        self.onboard.tick(now);
        self.send();
        if let Some(t) = self.state_heard_ns {
            if now.saturating_sub(t) > SUPERVISOR_SILENCE.as_nanos() as u64 {
                super::warn_without_alloc(format_args!(
                    "taiji-tmtc: the supervisor has been silent for {} s: exiting",
                    SUPERVISOR_SILENCE.as_secs()
                ));
                return Ok(Some(Exit::Stopped));
            }
            self.warm_up();
        }
        if now.saturating_sub(self.last_beat_ns) >= BEAT.as_nanos() as u64 {
            self.beat()?;
        }
        Ok(None)
    }

    /// Counting starts once the supervisor has been heard for a few turns.
    fn warm_up(&mut self) {
        if self.allocs_before.is_some() {
            return;
        }
        self.turns_heard += 1;
        if self.turns_heard >= WARM_UP_TURNS {
            alloc_count::trace_from_here();
            self.allocs_before = alloc_count::thread_allocations();
        }
    }

    /// Waits for a datagram (at most `POLL`); true on SIGINT/SIGTERM.
    fn wait(&mut self) -> bool {
        let mut fds = libc::pollfd {
            fd: self.socket.as_raw_fd(),
            events: libc::POLLIN,
            revents: 0,
        };
        let ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: POLL.as_nanos() as libc::c_long,
        };
        // SAFETY: one valid pollfd, a valid timespec, no signal mask change. ppoll, not
        // iceoryx2's timed wait, which formats (allocates) on every call in 0.9.3.
        unsafe { libc::ppoll(&mut fds, 1, &ts, std::ptr::null()) };
        self.ports.node.wait(Duration::ZERO).is_err()
    }

    /// Takes the datagrams waiting (a batch at most).
    fn datagrams(&mut self) -> Result<(), ProcessError> {
        for _ in 0..BATCH {
            let (n, from) = match self.socket.recv_from(&mut self.rx) {
                Ok(r) => r,
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => break,
                // ICMP errors of earlier sends and the like: nothing to take.
                Err(_) => break,
            };
            let now = monotonic_ns();
            if let Some(r) = self.onboard.datagram(&self.rx[..n], from, now) {
                wiring::publish(&self.ports.request, r)?;
            }
            if let Some(d) = self.onboard.take_destination_change() {
                if !self.dest_file.save(d) {
                    super::warn_without_alloc(format_args!(
                        "taiji-tmtc: cannot keep the telemetry destination {d} in --state-dir"
                    ));
                }
            }
            self.send();
        }
        Ok(())
    }

    /// Reads what the set published since the last turn.
    fn bus(&mut self) -> Result<(), ProcessError> {
        let now = monotonic_ns();
        // The campaign's estimate and status come relayed in the supervisor's state:
        // this process connects to no port of a campaign's processes.
        while let Some(g) = wiring::receive(&self.ports.state)? {
            // A campaign's estimate (published, so its time is set), once.
            if g.estimate.header.publish_ns != 0 && g.estimate.header != self.last_estimate {
                self.onboard.on_estimate(&g.estimate);
                self.progress.next_tick = g.estimate.header.tick + 1;
                self.last_estimate = g.estimate.header;
            }
            if g.set.state != 0 {
                self.onboard.on_set_status(&g.set, now);
            }
            self.onboard.on_ground_state(&g);
            self.state_heard_ns = Some(now);
            self.progress.state = STATE_RUNNING;
        }
        while let Some(n) = wiring::receive(&self.ports.note)? {
            self.onboard.on_note(&n);
        }
        Ok(())
    }

    /// Sends the telemetry waiting to the destination.
    fn send(&mut self) {
        let n = self.onboard.outbox_len();
        if n == 0 {
            return;
        }
        if let Some(dest) = self.onboard.destination() {
            for i in 0..n {
                let ok = match self.onboard.outbox_packet(i) {
                    Some(p) => {
                        debug_assert!(p.len() <= TM_MAX);
                        self.socket.send_to(p, dest).is_ok_and(|k| k == p.len())
                    }
                    None => false,
                };
                self.onboard.sent(ok);
            }
        }
        self.onboard.clear_outbox();
    }

    /// Publishes a heartbeat.
    fn beat(&mut self) -> Result<(), ProcessError> {
        let now = monotonic_ns();
        if let Some(a) = self.allocs_before {
            self.progress.loop_allocations = alloc_count::thread_allocations().unwrap_or(a) - a;
        }
        self.progress.header = Header {
            seq: self.beat_seq,
            tick: self.progress.next_tick,
            publish_ns: now,
            ..Header::default()
        };
        self.progress.resume_tick = self.progress.next_tick;
        self.beat_seq += 1;
        self.last_beat_ns = now;
        wiring::publish(&self.ports.progress, self.progress)?;
        Ok(())
    }
}
