//! One campaign in this process and its report: what `taiji-calib run` does when it
//! records nothing (and what each campaign of `taiji-calib timeline` is). The
//! maneuver's bound runs on a thread beside the campaign, whose simulation and
//! estimator take two more (`campaign::Threads::Two`).

use crate::analysis::campaign::Threads;
use crate::analysis::crlb::{run_with_bound, Bounds};
use crate::analysis::report::Report;
use crate::sim::estimate::Method;
use crate::sim::scenario::Scenario;

/// The campaign's data left a parameter without information (no bound).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("the campaign's data left a parameter without information (no Cramér–Rao bound)")]
pub struct Unexcited;

/// Run `s` at `seed` in this process and build its report (faults scored, wall time
/// not set); `progress` gets the fraction done now and then.
pub fn run(
    s: &Scenario,
    seed: u64,
    method: Method,
    threads: Threads,
    progress: impl FnMut(f64),
) -> Result<Report, Unexcited> {
    let (res, run_bound, maneuver) = std::thread::scope(|sc| {
        // The maneuver's bound (its motion alone) beside the campaign; the run's (at
        // its seed) from the campaign's own simulation.
        let maneuver = sc.spawn(|| crate::analysis::plan::maneuver_bound(s));
        let (res, bound) = run_with_bound(s, seed, method, threads, progress, None)
            .unwrap_or_else(|e| unreachable!("a campaign that records nothing cannot fail: {e}"));
        let maneuver = maneuver
            .join()
            .unwrap_or_else(|e| std::panic::resume_unwind(e));
        (res, bound, maneuver)
    });
    let bounds = Bounds {
        run: run_bound.ok_or(Unexcited)?,
        maneuver,
    };
    let mut report =
        Report::with_bounds(s, seed, "in-process", method.name(), &res.estimate, &bounds);
    report.faults = res.faults.map(|f| f.summary());
    Ok(report)
}
