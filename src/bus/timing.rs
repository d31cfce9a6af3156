//! Timing as a product feature: a system-wide monotonic clock shared by all processes,
//! and a fixed-size latency histogram (no allocation when recording) from which
//! p50/p99/max are read.

use serde::{Deserialize, Serialize};

/// The real-time scheduling the calling thread asked for was refused.
#[derive(Debug, thiserror::Error)]
pub enum TimingError {
    /// The system call failed (permissions, limits).
    #[error("{0}")]
    Os(#[source] std::io::Error),
    /// No such CPU: this machine has CPUs 0 to `last`.
    #[error("this machine has CPUs 0–{last}")]
    NoSuchCpu { cpu: usize, last: usize },
}

/// CLOCK_MONOTONIC in ns. The same clock in every process on the host, so a publish
/// timestamp written by one process can be subtracted from a receive time in another.
/// Switch the calling thread (and the threads it starts afterwards) to `SCHED_FIFO` at
/// `priority` (1–99), as flight software runs its real-time tasks. Needs CAP_SYS_NICE
/// or an RLIMIT_RTPRIO allowance; the error says why it was refused. (Locking memory
/// with mlockall made no measurable difference here, so it is not done.)
pub fn enter_fifo(priority: u8) -> Result<(), TimingError> {
    let p = libc::sched_param {
        sched_priority: priority as libc::c_int,
    };
    // SAFETY: plain syscall on the calling thread with a valid parameter struct.
    if unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &p) } == 0 {
        Ok(())
    } else {
        Err(TimingError::Os(std::io::Error::last_os_error()))
    }
}

/// Pin the calling thread (and the threads it starts afterwards) to one CPU: the
/// real-time chain shares a core, so each stage's wake-up of the next (higher-priority)
/// one is a same-core preemption instead of a cross-core interrupt.
pub fn pin_to_cpu(cpu: usize) -> Result<(), TimingError> {
    let n = std::thread::available_parallelism().map_or(1, |n| n.get());
    if cpu >= n || cpu >= libc::CPU_SETSIZE as usize {
        return Err(TimingError::NoSuchCpu { cpu, last: n - 1 });
    }
    // SAFETY: a zeroed cpu_set_t is a valid empty set; CPU_SET stays within it.
    let r = unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_SET(cpu, &mut set);
        libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set)
    };
    if r == 0 {
        Ok(())
    } else {
        Err(TimingError::Os(std::io::Error::last_os_error()))
    }
}

pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; CLOCK_MONOTONIC always exists on Linux.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// Bins per decade of the latency histogram: 2.4 % relative resolution.
const PER_DECADE: usize = 96;
/// Decades covered, from 100 ns to 10 s.
const DECADES: usize = 8;
const LOWEST_NS: f64 = 100.0;
const BINS: usize = PER_DECADE * DECADES;

/// Summary of a latency distribution [µs].
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct LatencySummary {
    pub count: u64,
    pub p50: f64,
    pub p99: f64,
    pub max: f64,
}

/// Log-binned latency histogram: records in O(1) without allocating; quantiles are
/// read at the geometric centre of their bin.
#[derive(Debug, Clone, Copy)]
pub struct LatencyHistogram {
    bins: [u32; BINS],
    below: u64,
    count: u64,
    max_ns: u64,
}

impl Default for LatencyHistogram {
    fn default() -> Self {
        LatencyHistogram {
            bins: [0; BINS],
            below: 0,
            count: 0,
            max_ns: 0,
        }
    }
}

impl LatencyHistogram {
    /// Record one latency [ns].
    pub fn record(&mut self, ns: u64) {
        self.count += 1;
        self.max_ns = self.max_ns.max(ns);
        let x = ns as f64 / LOWEST_NS;
        if x < 1.0 {
            self.below += 1;
            return;
        }
        let i = ((x.log10() * PER_DECADE as f64) as usize).min(BINS - 1);
        self.bins[i] = self.bins[i].saturating_add(1);
    }

    pub fn count(&self) -> u64 {
        self.count
    }

    /// Latency [ns] below which a fraction `q` of the records lie.
    pub fn quantile_ns(&self, q: f64) -> f64 {
        if self.count == 0 {
            return 0.0;
        }
        let target = (q * self.count as f64).ceil().max(1.0) as u64;
        let mut seen = self.below;
        if seen >= target {
            return LOWEST_NS;
        }
        for (i, &n) in self.bins.iter().enumerate() {
            seen += n as u64;
            if seen >= target {
                let centre = LOWEST_NS * 10f64.powf((i as f64 + 0.5) / PER_DECADE as f64);
                return centre.min(self.max_ns as f64);
            }
        }
        self.max_ns as f64
    }

    pub fn summary_us(&self) -> LatencySummary {
        LatencySummary {
            count: self.count,
            p50: self.quantile_ns(0.5) / 1e3,
            p99: self.quantile_ns(0.99) / 1e3,
            max: self.max_ns as f64 / 1e3,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_of_a_uniform_spread_are_within_bin_resolution() {
        let mut h = LatencyHistogram::default();
        for us in 1..=1000u64 {
            h.record(us * 1000);
        }
        let s = h.summary_us();
        assert_eq!(s.count, 1000);
        assert!((s.p50 / 500.0 - 1.0).abs() < 0.03, "{s:?}");
        assert!((s.p99 / 990.0 - 1.0).abs() < 0.03, "{s:?}");
        assert_eq!(s.max, 1000.0);
    }

    #[test]
    fn empty_histogram_reads_zero_and_tiny_values_do_not_panic() {
        let mut h = LatencyHistogram::default();
        assert_eq!(h.summary_us(), LatencySummary::default());
        h.record(0);
        h.record(u64::MAX / 2);
        assert_eq!(h.count(), 2);
        assert!(h.quantile_ns(0.5) > 0.0);
    }

    #[test]
    fn monotonic_clock_advances() {
        let a = monotonic_ns();
        std::thread::sleep(std::time::Duration::from_millis(2));
        assert!(monotonic_ns() >= a + 1_000_000);
    }
}
