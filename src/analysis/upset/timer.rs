//! A flip in the middle of a call: a one-shot POSIX timer on `CLOCK_MONOTONIC`,
//! signalled to the calling thread alone (`SIGEV_THREAD_ID`), whose handler flips one
//! bit of the state's memory wherever the call has got to. The handler flips only while
//! the call runs: a signal that comes before it starts (a delay shorter than the
//! syscall that arms the timer) or after it returned flips nothing, and the trial tries
//! the next call. The kernel's high-resolution timers fire within microseconds of the
//! delay; the call is interrupted at whatever instruction it is running.

use std::sync::atomic::{compiler_fence, AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::Once;

thread_local! {
    // Const-initialised atomics without destructors: the handler may use them.
    /// The word to flip (its address; 0: nothing armed) and the bit's mask.
    static ADDR: AtomicUsize = const { AtomicUsize::new(0) };
    static MASK: AtomicU64 = const { AtomicU64::new(0) };
    /// Set while the struck call runs.
    static IN_CALL: AtomicBool = const { AtomicBool::new(false) };
    /// Whether the armed flip happened (in the call).
    static FIRED: AtomicBool = const { AtomicBool::new(false) };
}

fn signal() -> libc::c_int {
    libc::SIGRTMIN() + 3
}

extern "C" fn on_signal(_: libc::c_int) {
    // Taken whether or not the call runs: a signal outside it disarms the flip.
    let addr = ADDR.with(|a| a.swap(0, Ordering::Relaxed));
    if addr != 0 && IN_CALL.with(|c| c.load(Ordering::Relaxed)) {
        let mask = MASK.with(|m| m.load(Ordering::Relaxed));
        // SAFETY: `strike`'s caller keeps the word alive and 8-aligned until it
        // returns, and the signal goes to this thread only.
        unsafe {
            let p = addr as *mut u64;
            p.write_volatile(p.read_volatile() ^ mask);
        }
        FIRED.with(|f| f.store(true, Ordering::Relaxed));
    }
}

/// This thread's timer.
pub(super) struct Timer(libc::timer_t);

/// Ends a strike however the call ends (a panic unwinding through it included): the
/// call is over, the timer stopped and nothing armed.
struct Disarm<'a>(&'a Timer);

impl Drop for Disarm<'_> {
    fn drop(&mut self) {
        compiler_fence(Ordering::SeqCst);
        IN_CALL.with(|c| c.store(false, Ordering::Relaxed));
        self.0.set(0);
        ADDR.with(|a| a.store(0, Ordering::Relaxed));
    }
}

impl Timer {
    pub(super) fn new() -> Timer {
        static HANDLER: Once = Once::new();
        HANDLER.call_once(|| {
            // SAFETY: a zeroed sigaction with a handler that only touches its
            // thread's atomics and the armed word.
            unsafe {
                let mut sa: libc::sigaction = std::mem::zeroed();
                sa.sa_sigaction = on_signal as *const () as usize;
                libc::sigemptyset(&mut sa.sa_mask);
                assert_eq!(libc::sigaction(signal(), &sa, std::ptr::null_mut()), 0);
            }
        });
        // SAFETY: a zeroed sigevent filled in for a signal to this thread.
        unsafe {
            let mut ev: libc::sigevent = std::mem::zeroed();
            ev.sigev_notify = libc::SIGEV_THREAD_ID;
            ev.sigev_signo = signal();
            ev.sigev_notify_thread_id = libc::gettid();
            let mut id: libc::timer_t = std::mem::zeroed();
            assert_eq!(
                libc::timer_create(libc::CLOCK_MONOTONIC, &mut ev, &mut id),
                0,
                "timer_create: {}",
                std::io::Error::last_os_error()
            );
            Timer(id)
        }
    }

    fn set(&self, ns: u64) {
        let spec = libc::itimerspec {
            it_interval: libc::timespec {
                tv_sec: 0,
                tv_nsec: 0,
            },
            it_value: libc::timespec {
                tv_sec: (ns / 1_000_000_000) as libc::time_t,
                tv_nsec: (ns % 1_000_000_000) as libc::c_long,
            },
        };
        // SAFETY: this thread's live timer and a valid spec.
        let rc = unsafe { libc::timer_settime(self.0, 0, &spec, std::ptr::null_mut()) };
        assert_eq!(rc, 0, "timer_settime: {}", std::io::Error::last_os_error());
    }

    /// Runs `call` with bit `bit` of `*word` set to flip `delay_ns` (at least 1 ns)
    /// from now, if the call is still running then. Returns the call's result and
    /// whether the bit flipped during it (else it did not flip at all).
    pub(super) fn strike<R>(
        &self,
        word: *mut u64,
        bit: u32,
        delay_ns: u64,
        call: impl FnOnce() -> R,
    ) -> (R, bool) {
        FIRED.with(|f| f.store(false, Ordering::Relaxed));
        MASK.with(|m| m.store(1u64 << (bit % 64), Ordering::Relaxed));
        ADDR.with(|a| a.store(word as usize, Ordering::Relaxed));
        let disarm = Disarm(self);
        self.set(delay_ns.max(1));
        IN_CALL.with(|c| c.store(true, Ordering::Relaxed));
        compiler_fence(Ordering::SeqCst);
        let r = call();
        drop(disarm);
        (r, FIRED.with(|f| f.load(Ordering::Relaxed)))
    }
}

impl Drop for Timer {
    fn drop(&mut self) {
        // SAFETY: this thread's live timer.
        unsafe { libc::timer_delete(self.0) };
    }
}
