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

use super::driver::{self, Service, Turn};
use super::{Exit, Link, ProcessError, StageArgs};
use crate::bus::wiring;
use crate::sim::faults::{FaultScore, Injector};
use crate::sim::fee::FrontEnd;
use crate::sim::files::FileError;
use crate::sim::msg::{EstimateMsg, TruthState, EST_FINAL, STATE_RUNNING};
use crate::sim::stage::Stage;
use crate::telemetry::{Meta, Writer, CHUNK_ROWS};
use std::time::Duration;

/// The longest a received row waits in memory while the recorder idles: what a live
/// reader of the file (h5py with `swmr=True`, `replay --follow`) lags behind the run.
const LIVE_FLUSH: Duration = Duration::from_secs(2);

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

pub fn run(args: &StageArgs) -> Result<Exit, ProcessError> {
    let s = args.scenario()?;
    let seed = s.seed;
    let method = args.method()?;
    std::fs::create_dir_all(&args.run_dir)
        .map_err(|source| ProcessError::from(FileError::create(args.run_dir.clone(), source)))?;
    let path = args.run_dir.join(TELEMETRY_FILE);
    let mut link = Link::new("taiji-recorder", args)?;
    let q = wiring::RECORDER_QUEUE;
    let n = s.n_samples();
    let meta = Meta::of(&s, seed, method.name(), "multi-process");
    let mut service = RecorderService {
        truth: wiring::subscriber_with_queue::<TruthState>(&link.node, wiring::SVC_TRUTH, q)?,
        estimate: wiring::subscriber_with_queue::<EstimateMsg>(
            &link.node,
            wiring::SVC_ESTIMATE,
            q,
        )?,
        tel: Some(Writer::create_with(
            &path,
            &meta,
            n,
            CHUNK_ROWS,
            args.record_compression,
        )?),
        path,
        n,
        fee: FrontEnd::new(&s, seed, true),
        inj: Injector::new(&s, seed),
        score: FaultScore::new(&s),
        c_truth: Cursor::default(),
        next_seq: 0,
        turn: 0,
        in_turn: 0,
        pending: std::collections::VecDeque::with_capacity(4096),
        final_seen: false,
    };
    driver::drive(&mut link, &mut service)
}

struct RecorderService {
    truth: wiring::Sub<TruthState>,
    estimate: wiring::Sub<EstimateMsg>,
    /// The file being written; `None` once complete.
    tel: Option<Writer>,
    path: std::path::PathBuf,
    n: u64,
    /// The front end and fault injector rebuilt from the truth (see the module doc).
    fee: FrontEnd,
    inj: Injector,
    score: FaultScore,
    c_truth: Cursor,
    /// Estimate messages in the estimator's sequence (a restarted estimator repeats
    /// some), each paired with the bus delivery it answered: the next expected seq,
    /// and the delivery (`turn`, `in_turn`) the next one answers.
    next_seq: u64,
    turn: u64,
    in_turn: usize,
    pending: std::collections::VecDeque<EstimateMsg>,
    final_seen: bool,
}

impl RecorderService {
    /// Record every truth that has arrived, with its sample rebuilt; returns how many.
    fn take_truths(&mut self) -> Result<u64, ProcessError> {
        let Some(t) = self.tel.as_mut() else {
            return Ok(0);
        };
        let mut got = 0;
        while let Some(m) = wiring::receive(&self.truth)? {
            got += 1;
            if self.c_truth.take(m.header.tick) {
                let mut smp = self.fee.process(m.header.tick, &m);
                let score = &mut self.score;
                self.inj.corrupt(&mut smp, &mut |r| score.push(r));
                self.inj.bus_records(m.header.tick, &mut |r| score.push(r));
                t.record(&m, &smp)?;
            }
        }
        Ok(got)
    }

    /// Record the estimates that have arrived, each scored once its tick's truth (hence
    /// its faults) is in; returns how many arrived.
    fn take_estimates(&mut self) -> Result<u64, ProcessError> {
        let Some(t) = self.tel.as_mut() else {
            return Ok(0);
        };
        let mut got = 0;
        while let Some(m) = wiring::receive(&self.estimate)? {
            got += 1;
            self.pending.push_back(m);
        }
        while let Some(m) = self.pending.front().copied() {
            if m.header.seq < self.next_seq {
                self.pending.pop_front();
                continue;
            }
            if m.flags & EST_FINAL != 0 {
                self.pending.pop_front();
                self.next_seq = m.header.seq + 1;
                if !self.final_seen {
                    t.record_estimate(&m)?;
                    self.final_seen = true;
                }
                continue;
            }
            // The delivery this message answered (turns whose bus sent nothing
            // produced no message).
            let mut plan = self.inj.annotated_deliveries(self.turn);
            while self.in_turn >= plan.len() {
                self.turn += 1;
                self.in_turn = 0;
                plan = self.inj.annotated_deliveries(self.turn);
            }
            if self.turn >= self.c_truth.next {
                break;
            }
            self.pending.pop_front();
            self.next_seq = m.header.seq + 1;
            let (d, of, second) = plan[self.in_turn];
            self.score.observe(of, d, second, m.tick_rejections);
            self.in_turn += 1;
            t.record_estimate(&m)?;
        }
        Ok(got)
    }

    /// Everything is in: close the file with the fault log and its scores.
    fn complete(&mut self, mut t: Writer, lost: u64) -> Result<(), ProcessError> {
        if lost > 0 {
            t.flush()?;
            return Err(ProcessError::IncompleteRecording {
                lost,
                path: self.path.clone(),
            });
        }
        let none: (&[_], &[_]) = (&[], &[]);
        let (records, detected) = match self.inj.enabled() {
            true => (&self.score.records[..], &self.score.detected[..]),
            false => none,
        };
        t.finish(records, detected)?;
        log::info!("taiji-recorder: wrote {}", self.path.display());
        Ok(())
    }
}

impl Service for RecorderService {
    fn turn(&mut self, link: &mut Link) -> Result<Turn, ProcessError> {
        let got = self.take_truths()? + self.take_estimates()?;
        if got > 0 {
            link.progress.state = STATE_RUNNING;
            link.progress.next_tick = self.c_truth.next.min(self.turn);
            link.progress.resume_tick = link.progress.next_tick;
            link.progress.samples_lost = self.c_truth.lost;
            link.beat()?;
        }
        let complete = self.c_truth.next >= self.n && self.final_seen;
        if let Some(t) = self.tel.take_if(|_| complete) {
            self.complete(t, link.progress.samples_lost)?;
            return Ok(Turn::Done);
        }
        let Some(t) = self.tel.as_mut() else {
            return Ok(Turn::Done);
        };
        if got == 0 {
            // Idle: rows waiting reach live readers (SWMR) within LIVE_FLUSH.
            t.flush_if_older(LIVE_FLUSH)?;
        }
        Ok(match got {
            0 => Turn::Idle(Duration::from_millis(1)),
            _ => Turn::Busy,
        })
    }

    fn stop(&mut self, _link: &mut Link, _exit: Exit) -> Result<(), ProcessError> {
        if let Some(mut t) = self.tel.take() {
            // Stopped early: the file keeps every sample received.
            t.flush()?;
            log::warn!(
                "taiji-recorder: stopped before {} was complete ({} samples)",
                self.path.display(),
                t.samples()
            );
        }
        Ok(())
    }
}
