//! `taiji-estimator`: the calibration filters on the sensor stream. Resumes from its
//! checkpoint when restarted; allocates nothing in its loop (it counts and reports it).

use super::{Exit, Link, StageArgs};
use crate::alloc_count;
use crate::bus;
use crate::checkpoint::{self, Checkpointer};
use crate::estimate::Estimator;
use crate::msg::{EstimateMsg, SensorSample, PROC_ESTIMATOR, STATE_DONE, STATE_RUNNING};
use crate::timing::monotonic_ns;
use std::time::Duration;

/// Checkpoint every this many ticks (100 s at 10 Hz): at most this much is replayed
/// after a restart. Must stay below `fee::RING − bus::WINDOW`.
pub const CHECKPOINT_EVERY: u64 = 1000;

/// File name of the checkpoint in the run directory.
pub const CHECKPOINT_FILE: &str = "estimator.ckpt";

/// Fault injection: `TAIJI_FAULT_CHECKPOINT_DELAY_MS` holds back every checkpoint write
/// (a slow disk), so tests can show that the set neither stalls nor loses a sample.
pub const FAULT_CHECKPOINT_DELAY: &str = "TAIJI_FAULT_CHECKPOINT_DELAY_MS";

fn fault_checkpoint_delay() -> Result<Duration, String> {
    match std::env::var(FAULT_CHECKPOINT_DELAY) {
        Err(_) => Ok(Duration::ZERO),
        Ok(v) => match v.trim().parse::<u64>() {
            Ok(ms) if ms <= 60_000 => {
                log::warn!("taiji-estimator: fault injection: every checkpoint write held {ms} ms");
                Ok(Duration::from_millis(ms))
            }
            _ => Err(format!(
                "{FAULT_CHECKPOINT_DELAY} must be a whole number of milliseconds up to 60000, not {v:?}"
            )),
        },
    }
}

pub fn run(args: &StageArgs) -> Result<Exit, String> {
    let s = args.scenario()?;
    let method = args.method()?;
    let period = args.period_ns(&s)?;
    std::fs::create_dir_all(&args.run_dir)
        .map_err(|e| format!("cannot create {}: {e}", args.run_dir.display()))?;
    let ckpt_path = args.run_dir.join(CHECKPOINT_FILE);
    let (mut est, mut next) = match checkpoint::load(&ckpt_path)? {
        Some((est, next)) => {
            log::warn!("taiji-estimator: resuming from checkpoint at tick {next}");
            (est, next)
        }
        None => (Estimator::new(method, s.estimator_config(&s.priors())), 0),
    };
    let mut ckpt = Checkpointer::with_write_delay(&ckpt_path, &est, fault_checkpoint_delay()?)?;
    let mut link = Link::new(
        "taiji-estimator",
        PROC_ESTIMATOR,
        "estimator",
        Some("fee"),
        None,
        args,
    )?;
    let input = bus::subscriber::<SensorSample>(&link.node, bus::SVC_SENSOR)?;
    let out = bus::publisher::<EstimateMsg>(&link.node, bus::SVC_ESTIMATE)?;
    let n = s.n_samples();
    link.progress.next_tick = next;
    link.progress.resume_tick = next;
    link.beat()?;

    // The loop runs without touching the heap once connected: allocations are
    // counted from the first sample on (iceoryx2 allocates while it connects ports).
    let mut allocs_before = None;
    let mut done = false;
    let exit = loop {
        if let Some(e) = link.poll()? {
            break e;
        }
        // The front-end keeps every sample from the newest checkpoint on disk. The
        // writer may finish while this loop waits for samples, and the front-end may be
        // waiting for exactly this news (its ring full), so look on every pass.
        if let Some(w) = ckpt.written() {
            if w != link.progress.resume_tick {
                link.progress.resume_tick = w;
                link.beat()?;
            }
        }
        let Some(sample) = bus::receive(&input)? else {
            if let Some(e) = link.idle(super::IDLE) {
                break e;
            }
            continue;
        };
        // Sent before the front-end noticed this instance (a restart): it resends
        // everything from our checkpoint, addressed to us.
        if sample.header.epoch != link.progress.incarnation {
            continue;
        }
        if allocs_before.is_none() {
            allocs_before = alloc_count::allocations();
        }
        link.progress.state = STATE_RUNNING;
        let received = monotonic_ns();
        link.hop
            .record(received.saturating_sub(sample.header.publish_ns));
        let mut e = est.step(&sample);
        e.header.origin_ns = sample.header.origin_ns;
        let now = monotonic_ns();
        e.header.publish_ns = now;
        bus::publish(&out, e)?;
        link.e2e.record(now.saturating_sub(sample.header.origin_ns));
        // The tick's deadline: its estimate out within one period of the tick's due
        // time, whichever stage was late (a lost plant tick carries no due time).
        let due = sample.header.due_ns;
        if period > 0 && due > 0 && now > due + period {
            link.progress.missed_deadlines += 1;
        }
        // Duplicates, late and garbage ticks are the estimator's to judge (and count).
        let advanced = est.next_tick() > next;
        next = est.next_tick();
        link.progress.next_tick = next;
        link.progress.samples_lost = e.rejected_by_cause[crate::msg::CAUSE_TICK_MISSING];
        if advanced && next % CHECKPOINT_EVERY == 0 {
            ckpt.save(&est, next)?;
        }
        if next == n && !done {
            let mut f = est.finish();
            f.header.origin_ns = sample.header.origin_ns;
            f.header.publish_ns = monotonic_ns();
            bus::publish(&out, f)?;
            done = true;
            link.progress.state = STATE_DONE;
        }
        if next % 32 == 0 || done {
            if let Some(a) = allocs_before {
                link.progress.loop_allocations = alloc_count::allocations().unwrap_or(a) - a;
            }
            link.beat()?;
        }
    };
    match allocs_before {
        Some(a) => log::info!(
            "taiji-estimator: heap allocations in the filter loop: {}",
            alloc_count::allocations().unwrap_or(a) - a
        ),
        None => log::info!("taiji-estimator: allocation counting not installed"),
    }
    link.beat()?;
    Ok(exit)
}
