//! `taiji-estimator`: the calibration filters on the sensor stream. Resumes from its
//! checkpoint when restarted; allocates nothing in its loop (it counts and reports it).

use super::driver::{self, Service, Turn};
use super::{BusArgs, Exit, Link, ProcessError};
use crate::analysis::checkpoint::{self, Checkpointer};
use crate::bus::alloc_count;
use crate::bus::timing::monotonic_ns;
use crate::bus::wiring;
use crate::sim::estimate::{Estimator, EstimatorConfig};
use crate::sim::files::FileError;
use crate::sim::msg::{EstimateMsg, SensorSample, STATE_DONE, STATE_RUNNING};
use crate::sim::stage::Stage;
use std::time::Duration;

/// The checkpoint interval in ticks at sample rate `fs` [Hz]: `CHECKPOINT_EVERY_S` of
/// samples (1000 ticks at 10 Hz), at most what the front end's ring keeps beyond the
/// flow-control window (`fee::RING − 2 wiring::WINDOW`: 102 s at 75 Hz, less above).
pub fn checkpoint_every(fs: f64) -> u64 {
    let most = super::fee::RING - 2 * crate::bus::wiring::WINDOW;
    ((crate::tuning::CHECKPOINT_EVERY_S * fs).round() as u64).clamp(1, most)
}

/// File name of the checkpoint in the run directory.
pub const CHECKPOINT_FILE: &str = "estimator.ckpt";

/// Fault injection: `TAIJI_FAULT_CHECKPOINT_DELAY_MS` holds back every checkpoint write
/// (a slow disk), so tests can show that the set neither stalls nor loses a sample.
pub const FAULT_CHECKPOINT_DELAY: &str = "TAIJI_FAULT_CHECKPOINT_DELAY_MS";

fn fault_checkpoint_delay() -> Result<Duration, ProcessError> {
    match std::env::var(FAULT_CHECKPOINT_DELAY) {
        Err(_) => Ok(Duration::ZERO),
        Ok(v) => match v.trim().parse::<u64>() {
            Ok(ms) if ms <= 60_000 => {
                log::warn!("taiji-estimator: fault injection: every checkpoint write held {ms} ms");
                Ok(Duration::from_millis(ms))
            }
            _ => Err(ProcessError::FaultCheckpointDelay { value: v }),
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
    pub fn of(s: &crate::sim::scenario::Scenario) -> Self {
        EstimatorTable {
            config: s.estimator_config(&s.priors()),
            n_samples: s.n_samples(),
        }
    }

    pub fn write(&self, path: &std::path::Path) -> Result<(), ProcessError> {
        let text = serde_json::to_string_pretty(self).map_err(ProcessError::TableJson)?;
        std::fs::write(path, text)
            .map_err(|source| ProcessError::from(FileError::write(path, source)))
    }

    pub fn load(path: &std::path::Path) -> Result<Self, ProcessError> {
        let text = std::fs::read_to_string(path).map_err(|source| ProcessError::TableRead {
            path: path.to_path_buf(),
            source,
        })?;
        let t: Self = serde_json::from_str(&text).map_err(|source| ProcessError::TableParse {
            path: path.to_path_buf(),
            source,
        })?;
        t.config
            .check()
            .map_err(|problem| ProcessError::TableRefused {
                path: path.to_path_buf(),
                problem,
            })?;
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

pub fn run(args: &EstimatorArgs) -> Result<Exit, ProcessError> {
    let table = EstimatorTable::load(&args.table)?;
    let resync_ns = args.resync_after_ms.saturating_mul(1_000_000);
    let args = &args.bus;
    let method = args.method()?;
    let period = args.period_ns(table.config.fs)?;
    std::fs::create_dir_all(&args.run_dir)
        .map_err(|source| ProcessError::from(FileError::create(args.run_dir.clone(), source)))?;
    let ckpt_path = args.run_dir.join(CHECKPOINT_FILE);
    let (est, next) = match checkpoint::load(&ckpt_path)? {
        Some((est, next)) => {
            log::warn!("taiji-estimator: resuming from checkpoint at tick {next}");
            (est, next)
        }
        None => (Estimator::new(method, table.config), 0),
    };
    let ckpt = Checkpointer::with_write_delay(&ckpt_path, &est, fault_checkpoint_delay()?)?;
    let mut link = Link::new(<Estimator as Stage>::PROCESS, args)?;
    let input = wiring::subscriber::<SensorSample>(&link.node, wiring::SVC_SENSOR)?;
    link.progress.next_tick = next;
    link.progress.resume_tick = next;
    let mut service = EstimatorService {
        input,
        // Estimates leave through their own thread (see `outbox`).
        out: super::outbox::Outbox::start(&args.bus_prefix)?,
        est,
        ckpt,
        n: table.n_samples,
        next,
        period,
        checkpoint_every: checkpoint_every(table.config.fs),
        resync_ns,
        allocs_before: None,
        last_input: monotonic_ns(),
        final_msg: None,
        final_sent: 0,
        drop_final: super::fault_count(FAULT_DROP_FINAL, 1)?,
    };
    driver::drive(&mut link, &mut service)
}

struct EstimatorService {
    input: wiring::Sub<SensorSample>,
    out: super::outbox::Outbox,
    est: Estimator,
    ckpt: Checkpointer,
    /// Samples in the campaign.
    n: u64,
    /// Next tick the estimator expects.
    next: u64,
    /// Real-time tick period [ns] (0: accelerated).
    period: u64,
    /// Ticks between checkpoints (`checkpoint_every`).
    checkpoint_every: u64,
    /// Ask for a resend after this long without a sample [ns] (0: never).
    resync_ns: u64,
    /// The thread's allocation count at the first sample: the loop runs without
    /// touching the heap once connected (iceoryx2 allocates while it connects ports).
    allocs_before: Option<u64>,
    last_input: u64,
    /// The final estimate, kept to be sent again (sets over hosts), and when it last was.
    final_msg: Option<EstimateMsg>,
    final_sent: u64,
    drop_final: u32,
}

impl EstimatorService {
    /// No sample: starved mid-campaign (samples lost on a link between hosts), or done
    /// and still no stop (the final estimate lost as it crossed).
    fn starved(&mut self, link: &mut Link) -> Result<Turn, ProcessError> {
        // A new incarnation makes the front-end resend from `next`, and what is still in
        // flight under the old one is dropped (`turn`): nothing lost, nothing twice.
        let now = monotonic_ns();
        // Before the first sample too: between hosts the first window can go out
        // before the link's far side has subscribed, and the set then stalled at tick 0
        // (a new incarnation before any sample only makes the front-end start again).
        let resync = self.resync_ns > 0 && now > self.last_input + self.resync_ns;
        if resync && self.final_msg.is_none() {
            super::warn_without_alloc(format_args!(
                "taiji-estimator: no sample for {} ms; asking the front-end to resend from tick {}",
                self.resync_ns / 1_000_000,
                self.next
            ));
            link.progress.incarnation = now;
            link.beat()?;
            self.last_input = now;
        }
        // Resend the final estimate (same seq: receivers keep the first) until the
        // supervisor in charge, having it, says stop.
        let due = self.resync_ns > 0 && now > self.final_sent + self.resync_ns;
        if let Some(f) = self.final_msg.filter(|_| due) {
            super::warn_without_alloc(format_args!(
                "taiji-estimator: no stop {} ms after the final estimate; sending it again",
                self.resync_ns / 1_000_000
            ));
            self.out.send(f)?;
            self.final_sent = now;
        }
        Ok(Turn::Idle(super::IDLE))
    }

    /// The campaign's last sample is in: the final estimate.
    fn finish(&mut self, link: &mut Link, origin_ns: u64) -> Result<(), ProcessError> {
        let mut f = self.est.stop().unwrap_or_default();
        f.header.origin_ns = origin_ns;
        f.header.publish_ns = monotonic_ns();
        if self.drop_final > 0 {
            self.drop_final -= 1;
            super::warn_without_alloc(format_args!(
                "taiji-estimator: fault injection: the final estimate is not sent"
            ));
        } else {
            self.out.send(f)?;
        }
        self.final_msg = Some(f);
        self.final_sent = monotonic_ns();
        link.progress.state = STATE_DONE;
        self.count_allocations(link);
        Ok(link.beat()?)
    }

    fn count_allocations(&self, link: &mut Link) {
        if let Some(a) = self.allocs_before {
            link.progress.loop_allocations = alloc_count::thread_allocations().unwrap_or(a) - a;
        }
    }
}

impl Service for EstimatorService {
    fn turn(&mut self, link: &mut Link) -> Result<Turn, ProcessError> {
        let Some(sample) = wiring::receive(&self.input)? else {
            return self.starved(link);
        };
        // Sent before the front-end noticed this instance (a restart): it resends
        // everything from our checkpoint, addressed to us.
        if sample.header.epoch != link.progress.incarnation {
            return Ok(Turn::Busy);
        }
        self.last_input = monotonic_ns();
        if self.allocs_before.is_none() {
            alloc_count::trace_from_here();
            self.allocs_before = alloc_count::thread_allocations();
        }
        link.progress.state = STATE_RUNNING;
        link.hop
            .record(monotonic_ns().saturating_sub(sample.header.publish_ns));
        let mut e = self.est.process(sample.header.tick, &sample);
        e.header.origin_ns = sample.header.origin_ns;
        let now = monotonic_ns();
        e.header.publish_ns = now;
        self.out.send(e)?;
        link.e2e.record(now.saturating_sub(sample.header.origin_ns));
        // The tick's deadline: its estimate out within one period of the tick's due
        // time, whichever stage was late (a lost plant tick carries no due time).
        let due = sample.header.due_ns;
        if self.period > 0 && due > 0 && now > due + self.period {
            link.progress.missed_deadlines += 1;
        }
        // Duplicates, late and garbage ticks are the estimator's to judge (and count).
        let advanced = self.est.next_tick() > self.next;
        self.next = self.est.next_tick();
        link.progress.next_tick = self.next;
        link.progress.samples_lost = e.rejected_by_cause[crate::sim::msg::CAUSE_TICK_MISSING];
        if advanced && self.next % self.checkpoint_every == 0 {
            self.ckpt.save(&self.est, self.next)?;
        }
        if self.next % crate::tuning::BEAT_TICKS == 0 {
            self.count_allocations(link);
        }
        if self.next == self.n && self.final_msg.is_none() {
            self.finish(link, sample.header.origin_ns)?;
        }
        Ok(Turn::Busy)
    }

    fn resume_tick(&mut self) -> Option<u64> {
        // The front-end keeps every sample from the newest checkpoint on disk.
        self.ckpt.written()
    }

    fn stop(&mut self, link: &mut Link, _exit: Exit) -> Result<(), ProcessError> {
        alloc_count::trace_stop();
        match self.allocs_before {
            Some(a) => log::info!(
                "taiji-estimator: heap allocations in the filter loop: {}",
                alloc_count::thread_allocations().unwrap_or(a) - a
            ),
            None => log::info!("taiji-estimator: allocation counting not installed"),
        }
        self.out.finish()?;
        Ok(link.beat()?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_checkpoint_interval_is_100_s_of_samples_within_the_ring() {
        assert_eq!(checkpoint_every(10.0), 1000);
        assert_eq!(checkpoint_every(1.0), 100);
        assert_eq!(checkpoint_every(0.01), 1);
        let most = super::super::fee::RING - 2 * crate::bus::wiring::WINDOW;
        assert_eq!(checkpoint_every(1000.0), most);
    }
}
