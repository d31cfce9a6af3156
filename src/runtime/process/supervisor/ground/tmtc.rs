//! The TMTC process as the ground supervisor keeps it: started once, restarted by its
//! launch-description policy when it dies or its heartbeats stop, stopped last.

use super::{GroundError, Up};
use crate::bus::wiring;
use crate::runtime::launch::{ProcessSpec, Restart};
use crate::runtime::process::set::{describe, interrupted, SupervisorArgs};
use crate::sim::msg::Progress;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The binary's name.
pub const PROCESS: &str = "taiji-tmtc";

/// What the watch of the TMTC process found.
pub(super) enum Health {
    Up,
    /// It was restarted.
    Restarted,
    /// SIGINT / SIGTERM: the operator is stopping the set.
    Interrupted,
    /// Dead and out of restarts (why).
    Lost(String),
}

pub(super) struct Tmtc {
    exe: PathBuf,
    args: Vec<String>,
    spec: ProcessSpec,
    child: Option<Child>,
    pub restarts: u32,
    /// Heard from its current incarnation since it was (re)started.
    pub heard: bool,
    incarnation: u64,
    last_seen: Instant,
    heartbeat_timeout: Duration,
    prefix: String,
}

impl Tmtc {
    pub(super) fn start(args: &SupervisorArgs, up: &Up) -> Result<Tmtc, GroundError> {
        let bin_dir = match &args.bin_dir {
            Some(d) => d.clone(),
            None => std::env::current_exe()
                .ok()
                .and_then(|p| p.parent().map(|d| d.to_path_buf()))
                .unwrap_or_default(),
        };
        let exe = bin_dir.join(PROCESS);
        if !exe.is_file() {
            return Err(GroundError::NoTmtc(exe));
        }
        let launch = &up.prepared.launch;
        let spec = launch
            .ground_process()
            .cloned()
            .unwrap_or_else(default_spec);
        let mut a: Vec<String> = vec![
            "--bus-prefix".into(),
            args.bus_prefix.clone(),
            "--run-dir".into(),
            args.out.display().to_string(),
            "--method".into(),
            args.method.clone(),
            "--ground".into(),
            up.addr.to_string(),
            "--ground-key".into(),
            up.key.display().to_string(),
            "--state-dir".into(),
            args.out.display().to_string(),
        ];
        if args.ground_remote {
            a.push("--ground-remote".into());
        }
        a.extend(spec.args.iter().cloned());
        let mut t = Tmtc {
            exe,
            args: a,
            spec,
            child: None,
            restarts: 0,
            heard: false,
            incarnation: 0,
            last_seen: Instant::now(),
            heartbeat_timeout: Duration::from_secs_f64(launch.heartbeat_timeout_s),
            prefix: args.bus_prefix.clone(),
        };
        t.spawn().map_err(GroundError::TmtcSpawn)?;
        Ok(t)
    }

    fn spawn(&mut self) -> Result<(), String> {
        let child = Command::new(&self.exe)
            .args(&self.args)
            .stdin(Stdio::null())
            .spawn()
            .map_err(|e| format!("{}: {e}", self.exe.display()))?;
        self.child = Some(child);
        self.heard = false;
        self.last_seen = Instant::now();
        Ok(())
    }

    /// A heartbeat of the TMTC process. Returns true when it is the first of a new
    /// incarnation (notes held for it can go now).
    pub(super) fn heard(&mut self, p: &Progress) -> bool {
        self.last_seen = Instant::now();
        let new = !self.heard || p.incarnation != self.incarnation;
        self.heard = true;
        self.incarnation = p.incarnation;
        new
    }

    /// Restart it when it died or fell silent, by its policy.
    pub(super) fn watch(&mut self) -> Health {
        let Some(child) = self.child.as_mut() else {
            return Health::Lost("not running".into());
        };
        let why = match child.try_wait() {
            Ok(Some(st)) if interrupted(st) => return Health::Interrupted,
            Ok(Some(st)) => format!("died ({})", describe(st)),
            Ok(None) if self.last_seen.elapsed() > self.heartbeat_timeout => {
                let _ = child.kill();
                let _ = child.wait();
                format!(
                    "sent no heartbeat for {:.0} s (heartbeat_timeout_s); killed",
                    self.heartbeat_timeout.as_secs_f64()
                )
            }
            Ok(None) => return Health::Up,
            Err(e) => format!("cannot be watched ({e})"),
        };
        if self.spec.restart == Restart::Never || self.restarts >= self.spec.max_restarts {
            return Health::Lost(format!(
                "{PROCESS} {why}; no restart left ({} of at most {})",
                self.restarts, self.spec.max_restarts
            ));
        }
        log::warn!(
            "{PROCESS} {why}; restarting it ({} of at most {})",
            self.restarts + 1,
            self.spec.max_restarts
        );
        std::thread::sleep(Duration::from_millis(self.spec.restart_delay_ms));
        if let Ok(sv) = wiring::cleanup_stale(&self.prefix) {
            log::info!("removed {} dead node(s)", sv.removed_dead);
        }
        match self.spawn() {
            Ok(()) => {
                self.restarts += 1;
                Health::Restarted
            }
            Err(e) => Health::Lost(format!("{PROCESS} {why}; cannot restart it: {e}")),
        }
    }

    /// SIGTERM, then SIGKILL after `timeout`.
    pub(super) fn stop(&mut self, timeout: Duration) {
        let Some(mut c) = self.child.take() else {
            return;
        };
        // SAFETY: kill with the pid of our own child, not yet reaped.
        unsafe { libc::kill(c.id() as i32, libc::SIGTERM) };
        let t0 = Instant::now();
        while t0.elapsed() < timeout {
            if let Ok(Some(_)) = c.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        log::warn!("{PROCESS} did not stop; killing it");
        let _ = c.kill();
        let _ = c.wait();
    }
}

/// The TMTC process's policy when the launch description lists none.
fn default_spec() -> ProcessSpec {
    ProcessSpec {
        name: PROCESS.into(),
        args: Vec::new(),
        restart: Restart::OnFailure,
        max_restarts: 5,
        restart_delay_ms: 100,
        record_only: false,
        ground_only: true,
        rt_priority: 0,
        cpu: None,
        host: None,
    }
}
