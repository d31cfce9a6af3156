//! `taiji-fee`: the only subscriber of the truth; turns it into IS drive voltages and
//! star-tracker samples. Keeps every sample since the estimator's last checkpoint in a
//! ring, so a restarted estimator catches up without a lost sample.

use super::{Exit, Link, StageArgs};
use crate::bus;
use crate::faults::Delivery;
use crate::fee::FrontEnd;
use crate::msg::{SensorSample, TruthState, STATE_DONE, STATE_RUNNING};
use crate::timing::monotonic_ns;

/// Samples retained for a restarted estimator; must exceed the estimator's checkpoint
/// interval plus the flow-control window.
pub const RING: u64 = 8192;

pub fn run(args: &StageArgs) -> Result<Exit, String> {
    let s = args.scenario()?;
    let seed = args.seed(&s);
    let mut link = Link::new("taiji-fee", args)?;
    let input = bus::subscriber::<TruthState>(&link.node, bus::SVC_TRUTH)?;
    let out = bus::publisher::<SensorSample>(&link.node, bus::SVC_SENSOR)?;
    let mut fee = FrontEnd::new(&s, seed, true);
    // `[faults]`: sample faults go into the ring (a resend repeats them), bus faults
    // are applied per tick as the ring is sent (a pure function of the tick).
    let mut inj = crate::faults::Injector::new(&s, seed);
    let mut ring = vec![SensorSample::default(); RING as usize];
    link.beat()?;
    let n = s.n_samples();
    let (mut produced, mut sent) = (0u64, 0u64);
    let mut estimator = 0u64;
    loop {
        if let Some(e) = link.poll()? {
            return Ok(e);
        }
        let est = link.downstream;
        if est.heard && est.incarnation != estimator {
            if estimator != 0 {
                log::warn!(
                    "taiji-fee: estimator restarted; resending from tick {}",
                    est.next_tick
                );
            }
            if est.next_tick + RING < produced || est.next_tick > produced {
                return Err(format!(
                    "the estimator resumed at tick {} but the front-end holds ticks {}..{}",
                    est.next_tick,
                    produced.saturating_sub(RING),
                    produced
                ));
            }
            estimator = est.incarnation;
            sent = est.next_tick;
        }
        let mut busy = false;
        while sent < produced && est.credit(sent) {
            let this = ring[(sent % RING) as usize];
            for d in inj.deliveries(sent) {
                let mut m = match d {
                    Delivery::This => this,
                    Delivery::Previous => ring[(sent.wrapping_sub(1) % RING) as usize],
                    Delivery::Garbage => inj.garbage(&this),
                };
                m.header.publish_ns = monotonic_ns();
                // Addressed to this estimator instance: what it receives from before the
                // front-end noticed a restart carries the old one's and is dropped.
                m.header.epoch = est.incarnation;
                bus::publish(&out, m)?;
            }
            link.sent(args.realtime);
            sent += 1;
            busy = true;
        }
        // Produce while the ring keeps everything since the estimator's checkpoint.
        let keep_from = if est.heard { est.resume_tick } else { 0 };
        if produced < n && produced < keep_from + RING && sent == produced {
            if let Some(truth) = bus::receive(&input)? {
                link.progress.state = STATE_RUNNING;
                let now = monotonic_ns();
                link.hop.record(now.saturating_sub(truth.header.publish_ns));
                let tick = truth.header.tick;
                if tick > produced {
                    link.progress.samples_lost += tick - produced;
                }
                if tick >= produced {
                    let mut m = fee.step(&truth);
                    inj.corrupt(&mut m, &mut |_| {});
                    m.header.origin_ns = truth.header.origin_ns;
                    m.header.due_ns = truth.header.due_ns;
                    ring[(tick % RING) as usize] = m;
                    produced = tick + 1;
                    link.progress.next_tick = produced;
                    link.progress.resume_tick = produced;
                    if produced % 32 == 0 {
                        link.beat()?;
                    }
                }
                busy = true;
            }
        }
        // Done, but stay responsive until the supervisor's stop: an estimator that
        // restarts now still needs the samples since its checkpoint.
        if produced == n && est.next_tick >= n && link.progress.state != STATE_DONE {
            link.progress.state = STATE_DONE;
            link.beat()?;
        }
        if !busy {
            if let Some(e) = link.idle(super::IDLE) {
                return Ok(e);
            }
        }
    }
}
