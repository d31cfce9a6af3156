//! `taiji-fee`: the only subscriber of the truth; turns it into IS drive voltages and
//! star-tracker samples. Keeps every sample since the estimator's last checkpoint in a
//! ring, so a restarted estimator catches up without a lost sample.

use super::driver::{self, Service, Turn};
use super::{Exit, Link, ProcessError, StageArgs};
use crate::bus::timing::monotonic_ns;
use crate::bus::wiring;
use crate::sim::fee::FrontEnd;
use crate::sim::msg::{SensorSample, TruthState, STATE_DONE, STATE_RUNNING};
use crate::sim::stage::Stage;

/// Samples retained for a restarted estimator; must exceed the estimator's checkpoint
/// interval plus the flow-control window.
pub const RING: u64 = 8192;

pub fn run(args: &StageArgs) -> Result<Exit, ProcessError> {
    let s = args.scenario()?;
    let seed = s.seed;
    let mut link = Link::new(<FrontEnd as Stage>::PROCESS, args)?;
    let mut service = FeeService {
        input: wiring::subscriber::<TruthState>(&link.node, wiring::SVC_TRUTH)?,
        out: wiring::publisher::<SensorSample>(&link.node, wiring::SVC_SENSOR)?,
        fee: FrontEnd::new(&s, seed, true),
        // `[faults]`: sample faults go into the ring (a resend repeats them), bus faults
        // are applied per tick as the ring is sent (a pure function of the tick).
        inj: crate::sim::faults::Injector::new(&s, seed),
        ring: vec![SensorSample::default(); RING as usize],
        n: s.n_samples(),
        produced: 0,
        sent: 0,
        estimator: 0,
        realtime: args.realtime,
    };
    driver::drive(&mut link, &mut service)
}

struct FeeService {
    input: wiring::Sub<TruthState>,
    out: wiring::Pub<SensorSample>,
    fee: FrontEnd,
    inj: crate::sim::faults::Injector,
    /// Every sample since the estimator's checkpoint, by tick modulo `RING`.
    ring: Vec<SensorSample>,
    n: u64,
    /// Ticks produced into the ring, and sent from it.
    produced: u64,
    sent: u64,
    /// The estimator instance being served (its incarnation; 0 before the first).
    estimator: u64,
    realtime: bool,
}

impl FeeService {
    /// A new estimator instance (a restart): resend from its checkpoint.
    fn follow(&mut self, est: &super::Downstream) -> Result<(), ProcessError> {
        if !est.heard || est.incarnation == self.estimator {
            return Ok(());
        }
        if self.estimator != 0 {
            log::warn!(
                "taiji-fee: estimator restarted; resending from tick {}",
                est.next_tick
            );
        }
        if est.next_tick + RING < self.produced || est.next_tick > self.produced {
            return Err(ProcessError::ResumeOutsideRing {
                resumed: est.next_tick,
                from: self.produced.saturating_sub(RING),
                to: self.produced,
            });
        }
        self.estimator = est.incarnation;
        self.sent = est.next_tick;
        Ok(())
    }

    /// Send from the ring what the estimator's credit allows; true if anything went.
    fn send(&mut self, link: &mut Link, est: &super::Downstream) -> Result<bool, wiring::BusError> {
        let mut busy = false;
        while self.sent < self.produced && est.credit(self.sent) {
            let sent = self.sent;
            let this = self.ring[(sent % RING) as usize];
            for d in self.inj.deliveries(sent) {
                let prev = &self.ring[(sent.wrapping_sub(1) % RING) as usize];
                let mut m = self.inj.delivered(d, &this, Some(prev));
                m.header.publish_ns = monotonic_ns();
                // Addressed to this estimator instance: what it receives from before the
                // front-end noticed a restart carries the old one's and is dropped.
                m.header.epoch = est.incarnation;
                wiring::publish(&self.out, m)?;
            }
            link.sent(self.realtime);
            self.sent += 1;
            busy = true;
        }
        Ok(busy)
    }

    /// Turn one truth into a sample in the ring, while the ring keeps everything since
    /// the estimator's checkpoint; true if a truth was taken.
    fn produce(
        &mut self,
        link: &mut Link,
        est: &super::Downstream,
    ) -> Result<bool, wiring::BusError> {
        let keep_from = if est.heard { est.resume_tick } else { 0 };
        let room = self.produced < self.n && self.produced < keep_from + RING;
        if !(room && self.sent == self.produced) {
            return Ok(false);
        }
        let Some(truth) = wiring::receive(&self.input)? else {
            return Ok(false);
        };
        link.progress.state = STATE_RUNNING;
        link.hop
            .record(monotonic_ns().saturating_sub(truth.header.publish_ns));
        let tick = truth.header.tick;
        if tick > self.produced {
            link.progress.samples_lost += tick - self.produced;
        }
        if tick >= self.produced {
            let mut m = self.fee.process(tick, &truth);
            self.inj.corrupt(&mut m, &mut |_| {});
            m.header.origin_ns = truth.header.origin_ns;
            m.header.due_ns = truth.header.due_ns;
            self.ring[(tick % RING) as usize] = m;
            self.produced = tick + 1;
            link.progress.next_tick = self.produced;
            link.progress.resume_tick = self.produced;
        }
        Ok(true)
    }
}

impl Service for FeeService {
    fn turn(&mut self, link: &mut Link) -> Result<Turn, ProcessError> {
        let est = link.downstream;
        self.follow(&est)?;
        let sent = self.send(link, &est)?;
        let produced = self.produce(link, &est)?;
        // Done, but stay responsive until the supervisor's stop: an estimator that
        // restarts now still needs the samples since its checkpoint.
        if self.produced == self.n && est.next_tick >= self.n && link.progress.state != STATE_DONE {
            link.progress.state = STATE_DONE;
            link.beat()?;
        }
        Ok(if sent || produced {
            Turn::Busy
        } else {
            Turn::Idle(super::IDLE)
        })
    }
}
