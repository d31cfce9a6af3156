//! The run's holds: its bus prefix and its `--out` folder, each locked against a
//! second run, and the janitor that sweeps what killed stages leave on the prefix.

use crate::bus::wiring::{self, BusError};
pub use crate::runtime::process::set::SupervisorArgs;
use crate::runtime::process::set::SupervisorError;
pub use crate::runtime::process::set::{SetError, UserError};
use crate::sim::files::FileError;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// The refusal of a run on a prefix in use, naming its supervisor (when known) and
/// its live nodes.
pub(super) fn another_run(prefix: &str, pid: Option<u32>, alive: Vec<String>) -> SupervisorError {
    SupervisorError::user(UserError::AnotherRun {
        prefix: prefix.to_string(),
        pid,
        alive,
    })
}

/// The run's hold on its bus prefix. Dropped last, when every process of the set has
/// exited and the supervisor's node is gone: removes what the run left on the bus
/// (`wiring::release`: dead nodes, then the prefix's global object), then frees the prefix.
pub(super) struct PrefixHold {
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
pub(super) const OUT_LOCK_FILE: &str = ".taiji-run.lock";

/// Take `out`'s lock, or say which run holds it.
pub(super) fn lock_out(out: &std::path::Path) -> Result<wiring::PidLock, SupervisorError> {
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

/// Take the bus prefix for this run: the output folder made, the prefix usable and
/// not another run's, the shared memory of dead processes of an earlier run removed.
pub(super) fn claim(args: &SupervisorArgs) -> Result<PrefixHold, SupervisorError> {
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
pub(super) fn out_makeable(out: &std::path::Path) -> std::io::Result<()> {
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

/// Sweeps the run's shared memory for objects abandoned half-made by a killed stage
/// (`wiring::sweep_abandoned`) while the set runs: a live stage connecting to the killed
/// one would otherwise wait on such an object forever. Stops when dropped.
pub(super) struct Janitor {
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Janitor {
    pub(super) fn start(prefix: &str) -> Result<Self, SetError> {
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
