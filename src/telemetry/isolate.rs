//! libhdf5 is C, and the 1.10 series crashes or loops for ever on some corrupt files: a
//! corrupt global heap collection (where variable-length strings live) makes it copy
//! past a buffer or walk its objects without end (`fuzz/known/`). Nothing that calls it
//! can recover from that in the same process. So before this process reads a
//! recording, a forked child makes the same reads — `read::open` every sample window,
//! `truth::fault_log` the fault log, `truth::full` every stream — and only when that
//! child ends normally within a time limit does this process read the file itself (the
//! same calls, on the same bytes). A crash or a hang is then the child's, and the caller
//! gets [`TelemetryError::Hdf5Failed`] naming the file and what libhdf5 did.
//!
//! A file checked once is not checked again while its size, times and inode stay the
//! same. A recording followed while it is written (`replay --follow`) is ours and still
//! growing: it is not checked.

use super::TelemetryError;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::Duration;

/// Set in the child: its own reads are not checked again.
static IN_CHILD: AtomicBool = AtomicBool::new(false);

/// The time limit's fixed part, in ms ([`set_time_limit`]).
static BASE_MS: AtomicU64 = AtomicU64::new(DEFAULT_BASE_MS);
const DEFAULT_BASE_MS: u64 = 10_000;
/// The limit grows by 1 s per MB of file: a normal read takes about 10 ms per MB here.
const MS_PER_MB: u64 = 1_000;

/// Files checked already: (device, inode, length, modification and change time in ns,
/// and what was read: a file read one way is not proven for another).
type Key = (u64, u64, u64, i128, i128, &'static str);
/// What each gave (a file libhdf5 hung on is not waited for twice).
static CHECKED: Mutex<Vec<(Key, Result<(), Failure>)>> = Mutex::new(Vec::new());
const REMEMBERED: usize = 32;

/// Set the fixed part of the time the child may take (default 10 s; 1 s per MB of
/// file is added). A fuzzer sets it low to cut hangs short.
pub fn set_time_limit(base: Duration) {
    BASE_MS.store(base.as_millis().max(1) as u64, Ordering::Relaxed);
}

/// How the child ended, when not normally.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Failure {
    /// Killed by a signal (SIGSEGV, SIGBUS, SIGABRT, ...).
    Signal(i32),
    /// Exited with a status other than 0 (a sanitizer's report ends that way).
    Exit(i32),
    /// Still running at the time limit; killed.
    Hung(Duration),
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Failure::Signal(s) => write!(f, "crashed ({}) while reading it", signal_name(s)),
            Failure::Exit(c) => write!(f, "failed abnormally (exit status {c}) while reading it"),
            Failure::Hung(t) => write!(
                f,
                "did not finish reading it in {:.1} s (an endless loop in its decoder)",
                t.as_secs_f64()
            ),
        }
    }
}

fn signal_name(s: i32) -> String {
    let name = match s {
        libc::SIGSEGV => "SIGSEGV",
        libc::SIGBUS => "SIGBUS",
        libc::SIGABRT => "SIGABRT",
        libc::SIGFPE => "SIGFPE",
        libc::SIGILL => "SIGILL",
        libc::SIGKILL => "SIGKILL",
        libc::SIGTRAP => "SIGTRAP",
        _ => return format!("signal {s}"),
    };
    format!("signal {s}, {name}")
}

/// Check that `read` (the caller's own reading of `path`, its errors ignored) ends
/// normally in a child process, unless this file (same inode, size and times) was
/// checked already for `what` (its outcome is kept) or this is the child.
pub(super) fn check(
    path: &Path,
    what: &'static str,
    read: fn(&Path),
) -> Result<(), TelemetryError> {
    if IN_CHILD.load(Ordering::Relaxed) {
        return Ok(());
    }
    let Some(key) = key(path, what) else {
        return Ok(()); // unreadable: opening it reports why
    };
    let outcome = match remembered(&key) {
        Some(outcome) => outcome,
        None => {
            let limit = Duration::from_millis(
                BASE_MS
                    .load(Ordering::Relaxed)
                    .saturating_add(key.2 / 1_000_000 * MS_PER_MB),
            );
            let o = in_child(path, read, limit);
            remember(key, o);
            o
        }
    };
    outcome.map_err(|how| TelemetryError::Hdf5Failed {
        path: path.to_path_buf(),
        how,
    })
}

fn key(path: &Path, what: &'static str) -> Option<Key> {
    use std::os::unix::fs::MetadataExt;
    let m = std::fs::metadata(path).ok()?;
    let ns = |s: i64, n: i64| i128::from(s) * 1_000_000_000 + i128::from(n);
    Some((
        m.dev(),
        m.ino(),
        m.len(),
        ns(m.mtime(), m.mtime_nsec()),
        ns(m.ctime(), m.ctime_nsec()),
        what,
    ))
}

fn remembered(key: &Key) -> Option<Result<(), Failure>> {
    let c = CHECKED.lock().ok()?;
    c.iter().find(|(k, _)| k == key).map(|&(_, o)| o)
}

fn remember(key: Key, outcome: Result<(), Failure>) {
    if let Ok(mut c) = CHECKED.lock() {
        if c.len() >= REMEMBERED {
            let _ = c.remove(0);
        }
        c.push((key, outcome));
    }
}

/// Fork, `read` in the child, wait for it at most `limit`.
fn in_child(path: &Path, read: fn(&Path), limit: Duration) -> Result<(), Failure> {
    // Forked while holding the binding's lock on libhdf5, so that no other thread of
    // this process is inside libhdf5 (or holds that lock) at the fork: the child's one
    // thread owns the lock and re-enters it.
    // SAFETY: fork has no memory-safety preconditions; the child only reads the file
    // (allocating: glibc's malloc is fork-safe), then leaves with _exit.
    let pid = hdf5::sync::sync(|| unsafe { libc::fork() });
    match pid {
        0 => child(path, read),
        p if p < 0 => {
            // No process to spare: read in this process, as before the check existed.
            log::warn!(
                "{}: could not fork to check the file first ({}); reading it here",
                path.display(),
                std::io::Error::last_os_error()
            );
            Ok(())
        }
        p => wait(p, limit),
    }
}

fn child(path: &Path, read: fn(&Path)) -> ! {
    IN_CHILD.store(true, Ordering::Relaxed);
    // SAFETY: plain libc calls in the child's only thread: default actions for the
    // crash signals (no handler of the parent's — a sanitizer's, a fuzzer's — runs
    // here), and stdout and stderr to /dev/null (the parent reports).
    unsafe {
        for s in [
            libc::SIGSEGV,
            libc::SIGBUS,
            libc::SIGABRT,
            libc::SIGFPE,
            libc::SIGILL,
            libc::SIGTRAP,
        ] {
            libc::signal(s, libc::SIG_DFL);
        }
        let null = libc::open(c"/dev/null".as_ptr(), libc::O_WRONLY);
        if null >= 0 {
            libc::dup2(null, 1);
            libc::dup2(null, 2);
        }
        no_sanitizer_death_callback();
    }
    let _ = std::panic::catch_unwind(|| read(path));
    // SAFETY: ends the child at once, running no exit handler of the parent's.
    unsafe { libc::_exit(0) }
}

/// Under a sanitizer, a fuzzer may have registered a callback that saves the current
/// input when the process dies: the child's death is not the fuzzer's finding.
///
/// # Safety
/// Call only in the forked child.
unsafe fn no_sanitizer_death_callback() {
    let f = libc::dlsym(
        libc::RTLD_DEFAULT,
        c"__sanitizer_set_death_callback".as_ptr(),
    );
    if !f.is_null() {
        // SAFETY: the sanitizer runtime's interface: void (*)(void (*)(void)).
        let set: unsafe extern "C" fn(Option<unsafe extern "C" fn()>) = std::mem::transmute(f);
        set(None);
    }
}

fn wait(pid: libc::pid_t, limit: Duration) -> Result<(), Failure> {
    let start = std::time::Instant::now();
    let mut nap = Duration::from_micros(100);
    loop {
        let mut status = 0;
        // SAFETY: waits for this process's own child.
        let r = unsafe { libc::waitpid(pid, &mut status, libc::WNOHANG) };
        if r == pid {
            return ended(status);
        }
        if r < 0 {
            if std::io::Error::last_os_error().raw_os_error() == Some(libc::EINTR) {
                continue;
            }
            // Reaped by someone else (SIGCHLD ignored): its end is unknown; the
            // parent's own read decides.
            return Ok(());
        }
        let waited = start.elapsed();
        if waited >= limit {
            // SAFETY: kill and reap this process's own child.
            unsafe {
                libc::kill(pid, libc::SIGKILL);
                libc::waitpid(pid, &mut status, 0);
            }
            return Err(Failure::Hung(waited));
        }
        std::thread::sleep(nap);
        nap = (nap * 2).min(Duration::from_millis(20));
    }
}

fn ended(status: libc::c_int) -> Result<(), Failure> {
    if libc::WIFSIGNALED(status) {
        Err(Failure::Signal(libc::WTERMSIG(status)))
    } else if libc::WIFEXITED(status) && libc::WEXITSTATUS(status) != 0 {
        Err(Failure::Exit(libc::WEXITSTATUS(status)))
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_child_killed_by_a_signal_or_exiting_nonzero_is_a_failure() {
        // SAFETY: fork in a test; each child ends at once by the means under test.
        unsafe {
            let p = libc::fork();
            if p == 0 {
                libc::signal(libc::SIGSEGV, libc::SIG_DFL);
                libc::raise(libc::SIGSEGV);
                libc::_exit(0);
            }
            assert_eq!(
                wait(p, Duration::from_secs(30)),
                Err(Failure::Signal(libc::SIGSEGV))
            );
            let p = libc::fork();
            if p == 0 {
                libc::_exit(1);
            }
            assert_eq!(wait(p, Duration::from_secs(30)), Err(Failure::Exit(1)));
            let p = libc::fork();
            if p == 0 {
                libc::_exit(0);
            }
            assert_eq!(wait(p, Duration::from_secs(30)), Ok(()));
        }
    }

    #[test]
    fn a_child_past_its_limit_is_killed_and_reported_hung() {
        // SAFETY: fork in a test; the child sleeps until killed.
        let p = unsafe { libc::fork() };
        if p == 0 {
            loop {
                // SAFETY: sleeping in the child.
                unsafe { libc::pause() };
            }
        }
        let t = std::time::Instant::now();
        let r = wait(p, Duration::from_millis(200));
        assert!(matches!(r, Err(Failure::Hung(d)) if d >= Duration::from_millis(200)));
        assert!(t.elapsed() < Duration::from_secs(20));
        let msg = r.unwrap_err().to_string();
        assert!(msg.contains("did not finish"), "{msg}");
    }
}
