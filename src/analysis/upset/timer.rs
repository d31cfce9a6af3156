//! A flip in the middle of a call: a one-shot POSIX timer on `CLOCK_MONOTONIC`,
//! signalled to the calling thread alone (`SIGEV_THREAD_ID`), whose handler flips one
//! bit of the state's memory wherever the call has got to. The kernel's high-resolution
//! timers fire within microseconds of the delay; the call is interrupted at whatever
//! instruction it is running, as an upset strikes.

use std::cell::Cell;
use std::sync::Once;

thread_local! {
    /// The word to flip (its address) and the bit's mask; 0: nothing armed.
    /// Const-initialised without a destructor, so the handler may read it.
    static TARGET: Cell<(usize, u64)> = const { Cell::new((0, 0)) };
    /// Whether the armed flip has happened.
    static FIRED: Cell<bool> = const { Cell::new(false) };
}

fn signal() -> libc::c_int {
    libc::SIGRTMIN() + 3
}

extern "C" fn on_signal(_: libc::c_int) {
    let (addr, mask) = TARGET.with(|t| t.replace((0, 0)));
    if addr != 0 {
        // SAFETY: `arm`'s caller keeps the word alive and 8-aligned until `disarm`,
        // and the signal goes to this thread only.
        unsafe {
            let p = addr as *mut u64;
            p.write_volatile(p.read_volatile() ^ mask);
        }
        FIRED.with(|f| f.set(true));
    }
}

/// This thread's timer.
pub(super) struct Timer(libc::timer_t);

impl Timer {
    pub(super) fn new() -> Timer {
        static HANDLER: Once = Once::new();
        HANDLER.call_once(|| {
            // SAFETY: a zeroed sigaction with a handler that only touches its
            // thread's locals and the armed word.
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

    /// Flips bit `bit` of `*word` in `delay_ns` (at least 1 ns) from now.
    pub(super) fn arm(&self, word: *mut u64, bit: u32, delay_ns: u64) {
        FIRED.with(|f| f.set(false));
        TARGET.with(|t| t.set((word as usize, 1u64 << (bit % 64))));
        self.set(delay_ns.max(1));
    }

    /// Right after the call: whether the flip happened during it. The timer is
    /// stopped; a flip that landed after the call returned (between this thread's
    /// reading of the flag and the timer's stop) is undone, so nothing lands outside.
    pub(super) fn landed_in_call(&self) -> bool {
        // The target before the flag: a flip between the two reads counts as during.
        let armed = TARGET.with(|t| t.get());
        let during = FIRED.with(|f| f.get());
        self.set(0);
        TARGET.with(|t| t.set((0, 0)));
        if !during && FIRED.with(|f| f.get()) {
            // SAFETY: the word `arm` was given, still alive (the caller holds it).
            unsafe {
                let p = armed.0 as *mut u64;
                p.write_volatile(p.read_volatile() ^ armed.1);
            }
        }
        during
    }
}

impl Drop for Timer {
    fn drop(&mut self) {
        // SAFETY: this thread's live timer.
        unsafe { libc::timer_delete(self.0) };
    }
}
