//! `taiji-estimator`: the calibration filters on the sensor stream. Resumes from its
//! checkpoint when restarted; allocates nothing in its loop (it counts and reports it).

use super::{BusArgs, Exit, Link};
use crate::alloc_count;
use crate::bus;
use crate::checkpoint::{self, Checkpointer};
use crate::estimate::{Estimator, EstimatorConfig};
use crate::msg::{SensorSample, STATE_DONE, STATE_RUNNING};
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

/// Fault injection: `TAIJI_FAULT_DROP_FINAL=1` does not send the first final estimate,
/// as if the link broke as it crossed, so tests can show the run still ends cleanly.
pub const FAULT_DROP_FINAL: &str = "TAIJI_FAULT_DROP_FINAL";

/// Everything the estimator process is given: the estimator's table (priors, known
/// geometry, noise levels — `EstimatorConfig` has no field for a truth) and the length
/// of the campaign. The supervisor writes it from the scenario (`TABLE_FILE`); the
/// process never sees the scenario itself.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub struct EstimatorTable {
    pub config: EstimatorConfig,
    /// Samples in the campaign (the final estimate follows the last).
    pub n_samples: u64,
}

/// File name of the table in the run directory.
pub const TABLE_FILE: &str = "estimator_table.json";

impl EstimatorTable {
    pub fn of(s: &crate::scenario::Scenario) -> Self {
        EstimatorTable {
            config: s.estimator_config(&s.priors()),
            n_samples: s.n_samples(),
        }
    }

    pub fn write(&self, path: &std::path::Path) -> Result<(), String> {
        let text = serde_json::to_string_pretty(self).map_err(|e| e.to_string())?;
        std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
    }

    pub fn load(path: &std::path::Path) -> Result<Self, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("cannot read the estimator table {}: {e}", path.display()))?;
        let t: Self = serde_json::from_str(&text)
            .map_err(|e| format!("{}: not an estimator table: {e}", path.display()))?;
        t.config
            .check()
            .map_err(|e| format!("{}: estimator table refused: {e:?}", path.display()))?;
        Ok(t)
    }
}

/// The estimator process's arguments: the bus's and its table — no scenario.
#[derive(Debug, Clone, clap::Args)]
pub struct EstimatorArgs {
    /// The estimator's table (JSON; the supervisor writes it to the run directory).
    #[arg(long)]
    pub table: std::path::PathBuf,
    /// Sets across hosts: after this long without a sample [ms] (samples lost on the
    /// link), ask the front-end to resend from the next tick (0: never).
    #[arg(long, default_value_t = 0)]
    pub resync_after_ms: u64,
    #[command(flatten)]
    pub bus: BusArgs,
}

pub fn run(args: &EstimatorArgs) -> Result<Exit, String> {
    let table = EstimatorTable::load(&args.table)?;
    let resync_ns = args.resync_after_ms.saturating_mul(1_000_000);
    let args = &args.bus;
    let method = args.method()?;
    let period = args.period_ns(table.config.fs)?;
    std::fs::create_dir_all(&args.run_dir)
        .map_err(|e| format!("cannot create {}: {e}", args.run_dir.display()))?;
    let ckpt_path = args.run_dir.join(CHECKPOINT_FILE);
    let (mut est, mut next) = match checkpoint::load(&ckpt_path)? {
        Some((est, next)) => {
            log::warn!("taiji-estimator: resuming from checkpoint at tick {next}");
            (est, next)
        }
        None => (Estimator::new(method, table.config), 0),
    };
    let mut ckpt = Checkpointer::with_write_delay(&ckpt_path, &est, fault_checkpoint_delay()?)?;
    let mut link = Link::new("taiji-estimator", args)?;
    let input = bus::subscriber::<SensorSample>(&link.node, bus::SVC_SENSOR)?;
    // Estimates leave through their own thread (see `outbox`).
    let mut out = super::outbox::Outbox::start(&args.bus_prefix)?;
    let n = table.n_samples;
    link.progress.next_tick = next;
    link.progress.resume_tick = next;
    link.beat()?;

    // The loop runs without touching the heap once connected: allocations are
    // counted from the first sample on (iceoryx2 allocates while it connects ports).
    let mut allocs_before = None;
    let mut done = false;
    let mut last_input = monotonic_ns();
    // The final estimate, kept to be sent again (sets over hosts), and when it last was.
    let mut final_msg = None;
    let mut final_sent = 0u64;
    let mut drop_final = super::fault_count(FAULT_DROP_FINAL, 1)?;
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
            // Starved mid-campaign: samples were lost on a link between hosts. A new
            // incarnation makes the front-end resend from `next`, and what is still in
            // flight under the old one is dropped (below): nothing lost, nothing twice.
            let now = monotonic_ns();
            if resync_ns > 0 && allocs_before.is_some() && !done && now > last_input + resync_ns {
                super::warn_without_alloc(format_args!(
                    "taiji-estimator: no sample for {} ms; asking the front-end to resend from tick {next}",
                    resync_ns / 1_000_000
                ));
                link.progress.incarnation = now;
                link.beat()?;
                last_input = now;
            }
            // Done, and still no stop: the final estimate may have been lost on the
            // link (cut as it crossed). Resend it (same seq: receivers keep the first)
            // until the supervisor in charge, having it, says stop.
            if let Some(f) = final_msg.filter(|_| resync_ns > 0 && now > final_sent + resync_ns) {
                super::warn_without_alloc(format_args!(
                    "taiji-estimator: no stop {} ms after the final estimate; sending it again",
                    resync_ns / 1_000_000
                ));
                out.send(f)?;
                final_sent = now;
            }
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
        last_input = monotonic_ns();
        if allocs_before.is_none() {
            allocs_before = alloc_count::thread_allocations();
        }
        link.progress.state = STATE_RUNNING;
        let received = monotonic_ns();
        link.hop
            .record(received.saturating_sub(sample.header.publish_ns));
        let mut e = est.step(&sample);
        e.header.origin_ns = sample.header.origin_ns;
        let now = monotonic_ns();
        e.header.publish_ns = now;
        out.send(e)?;
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
            if drop_final > 0 {
                drop_final -= 1;
                super::warn_without_alloc(format_args!(
                    "taiji-estimator: fault injection: the final estimate is not sent"
                ));
            } else {
                out.send(f)?;
            }
            final_msg = Some(f);
            final_sent = monotonic_ns();
            done = true;
            link.progress.state = STATE_DONE;
        }
        if next % 32 == 0 || done {
            if let Some(a) = allocs_before {
                link.progress.loop_allocations = alloc_count::thread_allocations().unwrap_or(a) - a;
            }
            link.beat()?;
        }
    };
    match allocs_before {
        Some(a) => log::info!(
            "taiji-estimator: heap allocations in the filter loop: {}",
            alloc_count::thread_allocations().unwrap_or(a) - a
        ),
        None => log::info!("taiji-estimator: allocation counting not installed"),
    }
    out.finish()?;
    link.beat()?;
    Ok(exit)
}
