//! `taiji-recorder`: subscribes to the truth and estimate streams and streams them to
//! `telemetry.h5` a chunk at a time (its memory does not grow with the campaign; if it
//! dies, the file holds every chunk but the last). It only reads: the estimates are those of
//! the set without it, bit for bit. Its credit paces the commander (never the
//! estimator directly), so no sample is dropped however the OS schedules it.
//!
//! The sensor channels it records are the front-end's, rebuilt from the truth with the
//! same seeded front-end and fault injector (deterministic, bit-identical): so the
//! recording holds each tick's sample once whatever the bus did to it (`[faults]`
//! duplicates, reorders, drops), and the fault log with each fault's before and after.
//! It pairs each estimate message with the bus delivery behind it to score detection.

use super::{Exit, Link, StageArgs};
use crate::bus;
use crate::faults::{FaultScore, Injector};
use crate::fee::FrontEnd;
use crate::msg::{EstimateMsg, TruthState, EST_FINAL, STATE_DONE, STATE_RUNNING};
use crate::telemetry::{Meta, Writer, CHUNK_ROWS};
use std::time::Duration;

/// File name of the recording in the run directory.
pub const TELEMETRY_FILE: &str = "telemetry.h5";

/// Next expected tick of one stream; duplicates (resent after an estimator restart)
/// are skipped, gaps counted.
#[derive(Default)]
struct Cursor {
    next: u64,
    lost: u64,
}

impl Cursor {
    /// Should the sample of `tick` be recorded?
    fn take(&mut self, tick: u64) -> bool {
        if tick < self.next {
            return false;
        }
        self.lost += tick - self.next;
        self.next = tick + 1;
        true
    }
}

pub fn run(args: &StageArgs) -> Result<Exit, String> {
    let s = args.scenario()?;
    let seed = args.seed(&s);
    let method = args.method()?;
    std::fs::create_dir_all(&args.run_dir)
        .map_err(|e| format!("cannot create {}: {e}", args.run_dir.display()))?;
    let path = args.run_dir.join(TELEMETRY_FILE);
    let mut link = Link::new("taiji-recorder", args)?;
    let q = bus::RECORDER_QUEUE;
    let truth = bus::subscriber_with_queue::<TruthState>(&link.node, bus::SVC_TRUTH, q)?;
    let estimate = bus::subscriber_with_queue::<EstimateMsg>(&link.node, bus::SVC_ESTIMATE, q)?;
    let n = s.n_samples();
    let meta = Meta::of(&s, seed, method.name(), "multi-process");
    let mut tel = Some(Writer::create(&path, &meta, n, CHUNK_ROWS)?);
    let mut fee = FrontEnd::new(&s, seed, true);
    let mut inj = Injector::new(&s, seed);
    let mut score = FaultScore::new(&s);
    let mut c_truth = Cursor::default();
    // Estimate messages in the estimator's sequence (a restarted estimator repeats
    // some), each paired with the bus delivery it answered.
    let mut next_seq = 0u64;
    let (mut turn, mut in_turn) = (0u64, 0usize);
    let mut pending = std::collections::VecDeque::<EstimateMsg>::with_capacity(4096);
    let mut final_seen = false;
    link.beat()?;
    loop {
        if let Some(e) = link.poll()? {
            if let Some(mut t) = tel.take() {
                // Stopped early: the file keeps every sample received.
                t.flush()?;
                log::warn!(
                    "taiji-recorder: stopped before {} was complete ({} samples)",
                    path.display(),
                    t.samples()
                );
            }
            return Ok(e);
        }
        let mut got = 0u64;
        if let Some(t) = tel.as_mut() {
            while let Some(m) = bus::receive(&truth)? {
                got += 1;
                if c_truth.take(m.header.tick) {
                    let mut smp = fee.step(&m);
                    inj.corrupt(&mut smp, &mut |r| score.push(r));
                    inj.bus_records(m.header.tick, &mut |r| score.push(r));
                    t.record(&m, &smp)?;
                }
            }
            while let Some(m) = bus::receive(&estimate)? {
                got += 1;
                pending.push_back(m);
            }
            // An estimate is scored once its tick's truth (hence its faults) is in.
            while let Some(m) = pending.front().copied() {
                if m.header.seq < next_seq {
                    pending.pop_front();
                    continue;
                }
                if m.flags & EST_FINAL != 0 {
                    pending.pop_front();
                    next_seq = m.header.seq + 1;
                    if !final_seen {
                        t.record_estimate(&m)?;
                        final_seen = true;
                    }
                    continue;
                }
                // The delivery this message answered (turns whose bus sent nothing
                // produced no message).
                let mut plan = inj.annotated_deliveries(turn);
                while in_turn >= plan.len() {
                    turn += 1;
                    in_turn = 0;
                    plan = inj.annotated_deliveries(turn);
                }
                if turn >= c_truth.next {
                    break;
                }
                pending.pop_front();
                next_seq = m.header.seq + 1;
                let (d, of, second) = plan[in_turn];
                score.observe(of, d, second, m.tick_rejections);
                in_turn += 1;
                t.record_estimate(&m)?;
            }
        }
        if got > 0 {
            link.progress.state = STATE_RUNNING;
            link.progress.next_tick = c_truth.next.min(turn);
            link.progress.resume_tick = link.progress.next_tick;
            link.progress.samples_lost = c_truth.lost;
            link.beat()?;
        }
        let complete = c_truth.next >= n && final_seen;
        if let Some(mut t) = tel.take_if(|_| complete) {
            if link.progress.samples_lost > 0 {
                t.flush()?;
                return Err(format!(
                    "{} samples never reached the recorder; {} is incomplete",
                    link.progress.samples_lost,
                    path.display()
                ));
            }
            let none: (&[_], &[_]) = (&[], &[]);
            let (records, detected) = match inj.enabled() {
                true => (&score.records[..], &score.detected[..]),
                false => none,
            };
            t.finish(records, detected)?;
            log::info!("taiji-recorder: wrote {}", path.display());
            return link.linger(STATE_DONE);
        }
        if got == 0 {
            if let Some(e) = link.idle(Duration::from_millis(1)) {
                return Ok(e);
            }
        }
    }
}
