//! iceoryx2 wiring shared by every process: service names, queue depths, the
//! flow-control window, and construction of nodes and ports. All data services are
//! zero-copy publish–subscribe of the fixed-size `msg` types.
//!
//! Which process publishes and subscribes to which service is the set's table,
//! `crate::bus::topology` (`tools/launch --graph` draws it); the payloads' bus names are
//! `Payload::TYPE_NAME`.

use crate::sim::msg::{
    Control, EstimateMsg, GroundNote, GroundRequest, GroundState, Progress, Request, SensorSample,
    SetStatus, TorqueCommand, TruthState,
};
use iceoryx2::node::NodeView;
use iceoryx2::node::{NodeCreationFailure, NodeListFailure};
use iceoryx2::port::listener::ListenerCreateError;
use iceoryx2::port::notifier::NotifierCreateError;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::publisher::PublisherCreateError;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::port::subscriber::SubscriberCreateError;
use iceoryx2::port::{LoanError, ReceiveError, SendError};
use iceoryx2::prelude::*;
use iceoryx2::service::builder::event::EventOpenOrCreateError;
use iceoryx2::service::builder::publish_subscribe::{
    PublishSubscribeOpenError, PublishSubscribeOpenOrCreateError,
};
use iceoryx2::service::service_name::ServiceNameError;
use std::fmt::Debug;
use std::path::PathBuf;
use std::time::Duration;

pub const SVC_TORQUE: &str = "taiji/torque_cmd";
pub const SVC_TRUTH: &str = "taiji/truth";
pub const SVC_SENSOR: &str = "taiji/sensor";
pub const SVC_ESTIMATE: &str = "taiji/estimate";
pub const SVC_PROGRESS: &str = "taiji/progress";
pub const SVC_CONTROL: &str = "taiji/control";
/// The supervisor in charge's view of the set, for outside monitors (`SetStatus`).
pub const SVC_STATUS: &str = "taiji/status";
/// Operators' requests to the supervisor in charge (`Request`): the monitor's way to
/// act on a run without publishing where a stage listens.
pub const SVC_REQUEST: &str = "taiji/request";
/// The TMTC process's accepted functions, to the supervisor (`GroundRequest`).
pub const SVC_GROUND_REQUEST: &str = "taiji/ground_request";
/// The supervisor's answers and events, to the TMTC process (`GroundNote`).
pub const SVC_GROUND_NOTE: &str = "taiji/ground_note";
/// The supervisor's mode, campaigns and table, to the TMTC process (`GroundState`).
pub const SVC_GROUND_STATE: &str = "taiji/ground_state";
/// The TMTC process's heartbeats, to the supervisor alone (`Progress`): on
/// `SVC_PROGRESS` every campaign's stages would connect to it.
pub const SVC_GROUND_BEAT: &str = "taiji/ground_beat";

/// Node name of outside monitors (`taiji-calib monitor`): a live one is no stage of a
/// crashed run, so a new supervisor does not refuse the prefix for it.
pub const MONITOR_NODE: &str = "taiji-monitor";

/// Default prefix of every iceoryx2 resource of a run (files in /dev/shm and /tmp/iceoryx2).
pub const DEFAULT_PREFIX: &str = "taiji_";

/// Subscriber queue depth of the data streams [samples].
pub const QUEUE: usize = 512;
/// Flow-control window [ticks]: a stage publishes tick t only when its downstream has
/// consumed every tick below t − WINDOW, so a queue never overflows and no sample is lost.
pub const WINDOW: u64 = 256;
/// Recorder's credit window [ticks]: with recording on, the commander publishes tick t
/// only while t < (every tick below it recorded) + RECORDER_WINDOW. Wider than the
/// three stage windows together, so the recorder never throttles a healthy set.
pub const RECORDER_WINDOW: u64 = 4 * WINDOW;
/// Recorder's subscriber queue depth: more than any stream can be ahead of it.
pub const RECORDER_QUEUE: usize = 2 * RECORDER_WINDOW as usize;
/// Queue depth of the progress and control services (only the latest matters).
pub const SMALL_QUEUE: usize = 64;

/// Upper bounds of every service (same everywhere so any process may create it).
const MAX_PUBLISHERS: usize = 8;
const MAX_SUBSCRIBERS: usize = 8;
const MAX_NODES: usize = 16;

/// A message as it travels on the bus: the same bytes (`repr(transparent)`), under the
/// versioned type name iceoryx2 compares between peers. The flight core's messages
/// cannot name iceoryx2, so the bus layer gives them their names here.
#[derive(Debug, Clone, Copy)]
#[repr(transparent)]
pub struct Wire<T>(pub T);

/// A fixed-size `#[repr(C)]` message that may travel on the bus, with its versioned
/// type name (`taiji::v1::EstimateMsg`: outside clients use the same names).
pub trait Payload: Debug + Copy + 'static {
    const TYPE_NAME: &'static str;
}

// SAFETY: `Wire<T>` is `repr(transparent)` over a `Payload`, and every `Payload` is a
// `#[repr(C)]` struct of integers, floats and arrays of them: no pointers, no
// references, the same layout in every process of one layout version (whose number is
// in the name, so peers of other layouts refuse each other).
unsafe impl<T: Payload> ZeroCopySend for Wire<T> {
    unsafe fn type_name() -> &'static str {
        T::TYPE_NAME
    }
}

macro_rules! payloads {
    ($($t:ident),*) => {
        $(impl Payload for $t {
            const TYPE_NAME: &'static str = concat!("taiji::v1::", stringify!($t));
        })*
    };
}
payloads!(
    TorqueCommand,
    TruthState,
    SensorSample,
    EstimateMsg,
    Progress,
    Control,
    SetStatus,
    Request,
    GroundRequest,
    GroundNote,
    GroundState
);

/// What went wrong on the bus. The variants met on every tick (`Loan`, `Send`,
/// `Receive`) carry iceoryx2's own small `Copy` error values, so building them
/// allocates nothing (the text is made only when displayed); the others name the
/// prefix, node or service concerned.
#[derive(Debug, thiserror::Error)]
pub enum BusError {
    #[error("invalid bus prefix {prefix:?}: {cause:?}")]
    Prefix {
        prefix: String,
        cause: SemanticStringError,
    },
    #[error("invalid node name {name}: {cause:?}")]
    NodeName {
        name: String,
        cause: SemanticStringError,
    },
    #[error("cannot create iceoryx2 node {name}: {cause:?}")]
    Node {
        name: String,
        cause: NodeCreationFailure,
    },
    #[error("invalid service name {service}: {cause:?}")]
    ServiceName {
        service: String,
        cause: ServiceNameError,
    },
    /// The service exists with another payload type: a peer of another build or layout.
    #[error(
        "cannot open service {service}: its payload type differs from this build's \
         ({type_name}, message layout version {}): a process of another build (or an \
         outside client with another layout) holds the bus; use the same \
         build everywhere or another --bus-prefix",
        crate::sim::msg::LAYOUT_VERSION
    )]
    IncompatiblePayload {
        service: String,
        type_name: &'static str,
    },
    #[error("cannot open service {service}: {cause:?}")]
    Service {
        service: String,
        cause: PublishSubscribeOpenOrCreateError,
    },
    #[error("cannot open event service {service}: {cause:?}")]
    EventService {
        service: String,
        cause: EventOpenOrCreateError,
    },
    #[error("cannot create publisher on {service}: {cause:?}")]
    Publisher {
        service: String,
        cause: PublisherCreateError,
    },
    #[error("cannot create subscriber on {service}: {cause:?}")]
    Subscriber {
        service: String,
        cause: SubscriberCreateError,
    },
    #[error("cannot create listener on {service}: {cause:?}")]
    Listener {
        service: String,
        cause: ListenerCreateError,
    },
    #[error("cannot create notifier on {service}: {cause:?}")]
    Notifier {
        service: String,
        cause: NotifierCreateError,
    },
    #[error("loan failed: {0:?}")]
    Loan(LoanError),
    #[error("send failed: {0:?}")]
    Send(SendError),
    #[error("receive failed: {0:?}")]
    Receive(ReceiveError),
    #[error("cannot list iceoryx2 nodes: {0:?}")]
    ListNodes(NodeListFailure),
    #[error("cannot start the shared-memory cleanup: {0}")]
    CleanupThread(#[source] std::io::Error),
    #[error(
        "the cleanup of stale shared memory (prefix {prefix:?}) did not finish in {timeout_s} s"
    )]
    CleanupTimeout { prefix: String, timeout_s: u64 },
    #[error("the shared-memory cleanup thread failed")]
    CleanupDied,
    /// The prefix's lock file (`action`: create its folder, open or lock it).
    #[error("cannot {action} {}: {source}", path.display())]
    Io {
        action: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

pub type Pub<T> = Publisher<ipc::Service, Wire<T>, ()>;
pub type Sub<T> = Subscriber<ipc::Service, Wire<T>, ()>;

/// iceoryx2 configuration of a run: the default with our resource prefix.
pub fn config(prefix: &str) -> Result<Config, BusError> {
    let mut c = Config::default();
    c.global.prefix = FileName::new(prefix.as_bytes()).map_err(|cause| BusError::Prefix {
        prefix: prefix.to_string(),
        cause,
    })?;
    // Dead nodes are cleaned by the supervisor alone (at start, before a restart and at
    // the end), not by every process as it starts or stops: concurrent cleaners race.
    c.global.node.cleanup_dead_nodes_on_creation = false;
    c.global.node.cleanup_dead_nodes_on_destruction = false;
    Ok(c)
}

/// A node named after the process, in the run's prefix. SIGINT/SIGTERM make
/// `Node::wait` return an error, which the loops treat as a stop request.
pub fn node(name: &str, prefix: &str) -> Result<Node<ipc::Service>, BusError> {
    let cfg = config(prefix)?;
    let node_name = NodeName::new(name).map_err(|cause| BusError::NodeName {
        name: name.to_string(),
        cause,
    })?;
    NodeBuilder::new()
        .name(&node_name)
        .config(&cfg)
        .create::<ipc::Service>()
        .map_err(|cause| BusError::Node {
            name: name.to_string(),
            cause,
        })
}

fn service<T: Payload>(
    node: &Node<ipc::Service>,
    name: &str,
    queue: usize,
) -> Result<
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, Wire<T>, ()>,
    BusError,
> {
    let sn = service_name(name)?;
    node.service_builder(&sn)
        .publish_subscribe::<Wire<T>>()
        .max_publishers(MAX_PUBLISHERS)
        .max_subscribers(MAX_SUBSCRIBERS)
        .max_nodes(MAX_NODES)
        .subscriber_max_buffer_size(queue)
        .history_size(0)
        .open_or_create()
        .map_err(|cause| match cause {
            PublishSubscribeOpenOrCreateError::PublishSubscribeOpenError(
                PublishSubscribeOpenError::IncompatibleTypes,
            ) => BusError::IncompatiblePayload {
                service: name.to_string(),
                type_name: T::TYPE_NAME,
            },
            cause => BusError::Service {
                service: name.to_string(),
                cause,
            },
        })
}

fn service_name(name: &str) -> Result<ServiceName, BusError> {
    name.try_into().map_err(|cause| BusError::ServiceName {
        service: name.to_string(),
        cause,
    })
}

fn is_small(name: &str) -> bool {
    [
        SVC_PROGRESS,
        SVC_CONTROL,
        SVC_STATUS,
        SVC_REQUEST,
        SVC_GROUND_REQUEST,
        SVC_GROUND_NOTE,
        SVC_GROUND_STATE,
        SVC_GROUND_BEAT,
    ]
    .contains(&name)
}

/// Default subscriber queue depth of a service.
fn queue_of(name: &str) -> usize {
    if is_small(name) {
        SMALL_QUEUE
    } else {
        QUEUE
    }
}

/// Deepest subscriber queue a service allows (the recorder's, on data services).
fn max_queue_of(name: &str) -> usize {
    if is_small(name) {
        SMALL_QUEUE
    } else {
        RECORDER_QUEUE
    }
}

pub fn publisher<T: Payload>(node: &Node<ipc::Service>, name: &str) -> Result<Pub<T>, BusError> {
    service::<T>(node, name, max_queue_of(name))?
        .publisher_builder()
        .create()
        .map_err(|cause| BusError::Publisher {
            service: name.to_string(),
            cause,
        })
}

pub fn subscriber<T: Payload>(node: &Node<ipc::Service>, name: &str) -> Result<Sub<T>, BusError> {
    subscriber_with_queue(node, name, queue_of(name))
}

/// A subscriber with its own queue depth (the recorder's is deeper).
pub fn subscriber_with_queue<T: Payload>(
    node: &Node<ipc::Service>,
    name: &str,
    q: usize,
) -> Result<Sub<T>, BusError> {
    service::<T>(node, name, max_queue_of(name))?
        .subscriber_builder()
        .buffer_size(q)
        .create()
        .map_err(|cause| BusError::Subscriber {
            service: name.to_string(),
            cause,
        })
}

/// Publish one message by value into a loaned shared-memory sample (no heap
/// allocation, failure included: the error is iceoryx2's value).
pub fn publish<T: Payload>(p: &Pub<T>, value: T) -> Result<(), BusError> {
    let sample = p.loan_uninit().map_err(BusError::Loan)?;
    sample
        .write_payload(Wire(value))
        .send()
        .map(|_| ())
        .map_err(BusError::Send)
}

/// Receive the next message by value, if any (no heap allocation, failure included).
pub fn receive<T: Payload>(s: &Sub<T>) -> Result<Option<T>, BusError> {
    match s.receive() {
        Ok(Some(sample)) => Ok(Some(sample.payload().0)),
        Ok(None) => Ok(None),
        Err(e) => Err(BusError::Receive(e)),
    }
}

/// Nodes found on the bus at start-up.
#[derive(Debug, Default)]
pub struct BusSurvey {
    /// Stale nodes of crashed processes whose resources were removed.
    pub removed_dead: usize,
    /// Names of nodes still alive in this prefix (another run in progress).
    pub alive: Vec<String>,
}

/// Where POSIX shared memory lives on Linux.
const SHM_DIR: &str = "/dev/shm";

/// A shared-memory object of the run still empty and unreadable this long after it was
/// made was abandoned: its creator was killed between creating and sizing it (a window
/// of microseconds otherwise).
pub const ABANDONED_AFTER: Duration = Duration::from_secs(1);

/// The stale-resource cleanup gives up after this long.
const CLEANUP_TIMEOUT: Duration = Duration::from_secs(20);

/// Remove this prefix's shared-memory objects abandoned half-made (see
/// `ABANDONED_AFTER`); returns how many. iceoryx2 0.9.3 opens such an object in an
/// endless retry (a zero-size mapping is taken for one still being made; as root the
/// missing read permission does not stop it), which would hang any process that opens
/// the connection of a peer `kill -9`ed while connecting, and the stale-node cleanup.
/// Once the object is gone, the opener gets "does not exist" and carries on.
pub fn sweep_abandoned(prefix: &str, min_age: Duration) -> usize {
    // Never everyone's objects: an empty prefix would match every name.
    if prefix.is_empty() {
        return 0;
    }
    let Ok(dir) = std::fs::read_dir(SHM_DIR) else {
        return 0;
    };
    let now = std::time::SystemTime::now();
    let mut removed = 0;
    for entry in dir.flatten() {
        if !entry.file_name().to_string_lossy().starts_with(prefix) {
            continue;
        }
        let Ok(meta) = entry.metadata() else { continue };
        use std::os::unix::fs::PermissionsExt;
        let unreadable = meta.permissions().mode() & 0o444 == 0;
        let old = meta
            .modified()
            .ok()
            .and_then(|m| now.duration_since(m).ok())
            .is_some_and(|age| age >= min_age);
        let empty = meta.is_file() && meta.len() == 0;
        if empty && unreadable && old && std::fs::remove_file(entry.path()).is_ok() {
            log::warn!(
                "removed shared memory {} abandoned half-made by a killed process",
                entry.file_name().to_string_lossy()
            );
            removed += 1;
        }
    }
    removed
}

/// Remove the shared-memory resources of dead nodes in this prefix (left by a crashed
/// earlier run or a killed stage) and list the nodes still alive. Runs iceoryx2's
/// cleanup on a thread while sweeping abandoned half-made objects, which would
/// otherwise hang it.
pub fn cleanup_stale(prefix: &str) -> Result<BusSurvey, BusError> {
    let (tx, rx) = std::sync::mpsc::channel();
    let p = prefix.to_string();
    std::thread::Builder::new()
        .name("bus-cleanup".into())
        .spawn(move || {
            let _ = tx.send(cleanup_dead_nodes(&p));
        })
        .map_err(BusError::CleanupThread)?;
    let t0 = std::time::Instant::now();
    loop {
        match rx.recv_timeout(Duration::from_millis(100)) {
            Ok(r) => return r,
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                sweep_abandoned(prefix, ABANDONED_AFTER);
                if t0.elapsed() > CLEANUP_TIMEOUT {
                    return Err(BusError::CleanupTimeout {
                        prefix: prefix.to_string(),
                        timeout_s: CLEANUP_TIMEOUT.as_secs(),
                    });
                }
            }
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                return Err(BusError::CleanupDied)
            }
        }
    }
}

/// Names of the live nodes in this prefix (none when they cannot be listed); removes
/// nothing.
pub fn live_nodes(prefix: &str) -> Vec<String> {
    let Ok(cfg) = config(prefix) else {
        return Vec::new();
    };
    let mut alive = Vec::new();
    let _ = Node::<ipc::Service>::list(&cfg, |state| {
        if let NodeState::Alive(view) = state {
            alive.push(node_name(&view));
        }
        CallbackProgression::Continue
    });
    alive
}

fn node_name(view: &impl NodeView) -> String {
    view.details()
        .as_ref()
        .map(|d| d.name().as_str().to_string())
        .unwrap_or_default()
}

fn cleanup_dead_nodes(prefix: &str) -> Result<BusSurvey, BusError> {
    let cfg = config(prefix)?;
    let mut survey = BusSurvey::default();
    let mut dead = Vec::new();
    Node::<ipc::Service>::list(&cfg, |state| {
        match state {
            NodeState::Alive(view) => survey.alive.push(node_name(&view)),
            NodeState::Dead(view) => dead.push(view),
            _ => {}
        }
        CallbackProgression::Continue
    })
    .map_err(BusError::ListNodes)?;
    for view in dead {
        if view.try_remove_stale_resources().is_ok() {
            survey.removed_dead += 1;
        }
    }
    Ok(survey)
}

/// Who may run a process set on a bus prefix (or write into a run folder). Two
/// supervisors started together both found no live node and both ran, overflowing
/// every service; the lock makes the check and the start one step.
pub enum Claim {
    /// This supervisor has it until the lock is dropped.
    Won(PidLock),
    /// Another supervisor holds it (its pid, once it has written it).
    Held { pid: Option<u32> },
}

/// An exclusive flock(2) on a file holding its owner's pid: for a bus prefix,
/// `<iceoryx2 root>/<prefix>supervisor.lock` (`claim_prefix`); for a run folder, its
/// lock file (the supervisor). The kernel releases it when its holder dies, however it
/// dies, so a crashed run never blocks the next (a PID file alone would). Dropping it
/// unlinks the file, then releases.
#[derive(Debug)]
pub struct PidLock {
    path: std::path::PathBuf,
    /// Holds the lock; closed after the file is unlinked (field drop follows `drop`).
    _file: std::fs::File,
}

impl Drop for PidLock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

/// The lock file of a prefix, in the iceoryx2 root of its configuration.
pub fn lock_path(prefix: &str) -> Result<std::path::PathBuf, BusError> {
    let cfg = config(prefix)?;
    Ok(std::path::PathBuf::from(cfg.global.root_path().to_string())
        .join(format!("{prefix}supervisor.lock")))
}

/// Take the prefix without waiting, or say who has it.
pub fn claim_prefix(prefix: &str) -> Result<Claim, BusError> {
    let path = lock_path(prefix)?;
    if let Some(dir) = path.parent() {
        // With the permissions iceoryx2 gives the directories it makes there.
        use std::os::unix::fs::DirBuilderExt;
        std::fs::DirBuilder::new()
            .recursive(true)
            .mode(0o750)
            .create(dir)
            .map_err(|source| BusError::Io {
                action: "create",
                path: dir.to_path_buf(),
                source,
            })?;
    }
    lock_pid_file(path)
}

/// Take the lock on the pid file at `path` (created if missing; its folder must exist)
/// without waiting, or say who holds it.
pub fn lock_pid_file(path: std::path::PathBuf) -> Result<Claim, BusError> {
    use std::io::{Read, Write};
    use std::os::fd::AsRawFd;
    use std::os::unix::fs::MetadataExt;
    loop {
        let mut file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(|source| BusError::Io {
                action: "open",
                path: path.clone(),
                source,
            })?;
        // SAFETY: flock on a descriptor this function owns.
        if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } != 0 {
            let e = std::io::Error::last_os_error();
            match e.raw_os_error() {
                Some(libc::EWOULDBLOCK) => {
                    let mut text = String::new();
                    let _ = file.read_to_string(&mut text);
                    return Ok(Claim::Held {
                        pid: text.trim().parse().ok(),
                    });
                }
                Some(libc::EINTR) => continue,
                _ => {
                    return Err(BusError::Io {
                        action: "lock",
                        path,
                        source: e,
                    })
                }
            }
        }
        // The holder before us unlinks the file before releasing it: a lock won on a file
        // no longer at `path` guards nothing, so take the one there now.
        let ours = file.metadata().map(|m| (m.dev(), m.ino()));
        let there = std::fs::metadata(&path).map(|m| (m.dev(), m.ino()));
        if !matches!((ours, there), (Ok(a), Ok(b)) if a == b) {
            continue;
        }
        // Only for the message of a refused supervisor: who holds it.
        let _ = file.set_len(0);
        let _ = write!(file, "{}", std::process::id());
        return Ok(Claim::Won(PidLock { path, _file: file }));
    }
}

/// The global management object iceoryx2 0.9.3 makes per prefix in /dev/shm (its node
/// counter, `<prefix><40 hex>_node.<version><global_mgmt_suffix>`), never removed by it.
fn is_global_mgmt(name: &str, prefix: &str, suffix: &str) -> bool {
    let Some(rest) = name.strip_prefix(prefix) else {
        return false;
    };
    rest.len() > 40
        && rest.as_bytes()[..40].iter().all(u8::is_ascii_hexdigit)
        && rest[40..].starts_with("_node.")
        && rest.ends_with(suffix)
}

/// What `release` removed.
#[derive(Debug, Default)]
pub struct Released {
    /// Dead nodes whose resources were removed.
    pub dead_nodes: usize,
    /// Global management objects removed (0 while a node of the prefix remains).
    pub global_mgmt: usize,
}

/// Once a run has ended (every process of it exited, the caller holding the prefix's
/// lock): remove the resources of its dead nodes, then, when no node of the prefix is
/// left at all, its global management object. Live nodes and anything of another
/// prefix are never touched.
pub fn release(prefix: &str) -> Result<Released, BusError> {
    if prefix.is_empty() {
        return Ok(Released::default());
    }
    let survey = cleanup_stale(prefix)?;
    let mut released = Released {
        dead_nodes: survey.removed_dead,
        global_mgmt: 0,
    };
    let cfg = config(prefix)?;
    remove_empty_node_dirs(&cfg);
    let mut left = 0usize;
    Node::<ipc::Service>::list(&cfg, |_| {
        left += 1;
        CallbackProgression::Continue
    })
    .map_err(BusError::ListNodes)?;
    if left > 0 {
        return Ok(released);
    }
    let suffix = cfg.global.node.global_mgmt_suffix.to_string();
    let Ok(dir) = std::fs::read_dir(SHM_DIR) else {
        return Ok(released);
    };
    for entry in dir.flatten() {
        let name = entry.file_name().to_string_lossy().to_string();
        if is_global_mgmt(&name, prefix, &suffix) && std::fs::remove_file(entry.path()).is_ok() {
            released.global_mgmt += 1;
        }
    }
    Ok(released)
}

/// Does publish–subscribe service `name` exist on this prefix? Reads the service
/// folder only: no node, so an outside client that waits for a run leaves nothing in
/// /dev/shm while none comes. False when it cannot be told.
pub fn service_exists(prefix: &str, name: &str) -> bool {
    use iceoryx2::service::Service as _;
    let (Ok(cfg), Ok(sn)) = (config(prefix), service_name(name)) else {
        return false;
    };
    ipc::Service::does_exist(&sn, &cfg, MessagingPattern::PublishSubscribe).unwrap_or(false)
}

/// For an outside client that detached (its node dropped): when no node of the prefix
/// is left at all (the run ended while it was attached, so the supervisor had to leave
/// them), remove the prefix's global object and the empty node folders. Never touches
/// dead nodes' resources: those are the supervisor's to clean (concurrent cleaners race).
pub fn release_if_unused(prefix: &str) -> usize {
    let Ok(cfg) = config(prefix) else {
        return 0;
    };
    if prefix.is_empty() {
        return 0;
    }
    let mut left = 0usize;
    if Node::<ipc::Service>::list(&cfg, |_| {
        left += 1;
        CallbackProgression::Continue
    })
    .is_err()
        || left > 0
    {
        return 0;
    }
    remove_empty_node_dirs(&cfg);
    let suffix = cfg.global.node.global_mgmt_suffix.to_string();
    let Ok(dir) = std::fs::read_dir(SHM_DIR) else {
        return 0;
    };
    let mut removed = 0;
    for entry in dir.flatten() {
        let name = entry.file_name().to_string_lossy().to_string();
        if is_global_mgmt(&name, prefix, &suffix) && std::fs::remove_file(entry.path()).is_ok() {
            removed += 1;
        }
    }
    removed
}

/// Removes the empty folders under iceoryx2's node directory. iceoryx2 0.9.3 removes a
/// released node's files, then its folder only if nothing else is in it at that moment
/// (a port still being dropped, a cleanup running beside it), so empty folders pile up.
/// A live node's folder always holds its files, and removing a folder that is not
/// empty fails, so only leftovers go (any prefix's: the folders are named by node id).
fn remove_empty_node_dirs(cfg: &Config) {
    let root = std::path::PathBuf::from(cfg.global.root_path().to_string());
    let nodes = root.join(cfg.global.node.directory.to_string());
    let Ok(dir) = std::fs::read_dir(&nodes) else {
        return;
    };
    for entry in dir.flatten() {
        if entry.file_type().is_ok_and(|t| t.is_dir()) {
            let _ = std::fs::remove_dir(entry.path());
        }
    }
}

/// Wake-up event of a stage: its upstream notifies it after publishing data, its
/// downstream after granting credit, so no stage polls.
pub fn wake_service(stage: &str) -> String {
    format!("taiji/wake/{stage}")
}

pub type Listener = iceoryx2::port::listener::Listener<ipc::Service>;
pub type Notifier = iceoryx2::port::notifier::Notifier<ipc::Service>;

fn event_service(
    node: &Node<ipc::Service>,
    name: &str,
) -> Result<iceoryx2::service::port_factory::event::PortFactory<ipc::Service>, BusError> {
    let sn = service_name(name)?;
    node.service_builder(&sn)
        .event()
        .max_nodes(MAX_NODES)
        .max_listeners(MAX_SUBSCRIBERS)
        .max_notifiers(MAX_PUBLISHERS)
        .open_or_create()
        .map_err(|cause| BusError::EventService {
            service: name.to_string(),
            cause,
        })
}

pub fn listener(node: &Node<ipc::Service>, name: &str) -> Result<Listener, BusError> {
    event_service(node, name)?
        .listener_builder()
        .create()
        .map_err(|cause| BusError::Listener {
            service: name.to_string(),
            cause,
        })
}

pub fn notifier(node: &Node<ipc::Service>, name: &str) -> Result<Notifier, BusError> {
    event_service(node, name)?
        .notifier_builder()
        .create()
        .map_err(|cause| BusError::Notifier {
            service: name.to_string(),
            cause,
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_global_object_is_recognised_by_prefix_hash_and_suffix() {
        let hash = "9204dd183d1c4d8e1ff592a30766ffa6765aa8b5";
        let name = format!("taiji_{hash}_node.0_9_3.global_mgmt");
        assert!(is_global_mgmt(&name, "taiji_", ".global_mgmt"));
        // Another prefix that merely starts like ours, or another object of ours: no.
        let longer = format!("taiji_x_{hash}_node.0_9_3.global_mgmt");
        assert!(!is_global_mgmt(&longer, "taiji_", ".global_mgmt"));
        assert!(!is_global_mgmt(&name, "taij_", ".global_mgmt"));
        let dynamic = format!("taiji_{hash}_{hash}.dynamic");
        assert!(!is_global_mgmt(&dynamic, "taiji_", ".global_mgmt"));
    }

    #[test]
    fn every_bus_type_name_carries_the_layout_version() {
        let v = format!("taiji::v{}::", crate::sim::msg::LAYOUT_VERSION);
        for name in [
            TorqueCommand::TYPE_NAME,
            TruthState::TYPE_NAME,
            SensorSample::TYPE_NAME,
            EstimateMsg::TYPE_NAME,
            Progress::TYPE_NAME,
            Control::TYPE_NAME,
            SetStatus::TYPE_NAME,
            Request::TYPE_NAME,
            GroundRequest::TYPE_NAME,
            GroundNote::TYPE_NAME,
            GroundState::TYPE_NAME,
        ] {
            assert!(name.starts_with(&v), "{name} lacks {v}");
        }
        // iceoryx2 sees the versioned name, and the wire type has the message's layout.
        // SAFETY: type_name only returns a string.
        assert_eq!(
            unsafe { <Wire<EstimateMsg> as ZeroCopySend>::type_name() },
            EstimateMsg::TYPE_NAME
        );
        assert_eq!(
            std::mem::size_of::<Wire<SensorSample>>(),
            std::mem::size_of::<SensorSample>()
        );
    }

    /// The ground's request has no implicit padding: the header, token, function,
    /// `_pad`, seed, duration and epoch, in that order (the epoch added last).
    #[test]
    fn the_ground_request_is_packed_as_declared() {
        use std::mem::{offset_of, size_of};
        let h = size_of::<crate::sim::msg::Header>();
        assert_eq!(offset_of!(GroundRequest, token), h);
        assert_eq!(offset_of!(GroundRequest, seed), h + 16);
        assert_eq!(offset_of!(GroundRequest, duration_s), h + 24);
        assert_eq!(offset_of!(GroundRequest, epoch_day), h + 32);
        assert_eq!(size_of::<GroundRequest>(), h + 40);
        assert_eq!(size_of::<Wire<GroundRequest>>(), size_of::<GroundRequest>());
    }
}
