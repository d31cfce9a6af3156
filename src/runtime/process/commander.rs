//! `taiji-commander`: publishes the maneuver's torque command per tick, paced by the
//! downstream credit (accelerated) or by the clock (real-time).

use super::driver::{self, Service, Turn};
use super::{Exit, Link, ProcessError, StageArgs};
use crate::bus::timing::monotonic_ns;
use crate::bus::wiring;
use crate::sim::commander::Commander;
use crate::sim::msg::{TorqueCommand, STATE_RUNNING};
use crate::sim::stage::Stage;
use std::time::Duration;

/// Fault injection for tests: `TAIJI_FAULT_HOLD=TICK:PATH` holds the campaign before
/// tick TICK while the file PATH exists, so a test can act mid-run (cut a link, kill a
/// tunnel) however fast or slow the machine, then let the run go on.
pub const FAULT_HOLD: &str = "TAIJI_FAULT_HOLD";

fn fault_hold() -> Result<Option<(u64, std::path::PathBuf)>, ProcessError> {
    let Ok(v) = std::env::var(FAULT_HOLD) else {
        return Ok(None);
    };
    match v.split_once(':') {
        Some((t, p)) if !p.is_empty() => {
            match t.trim().parse::<u64>() {
                Ok(t) => {
                    log::warn!("taiji-commander: fault injection: holding before tick {t} while {p} exists");
                    Ok(Some((t, p.into())))
                }
                Err(_) => Err(ProcessError::FaultHold { value: v }),
            }
        }
        _ => Err(ProcessError::FaultHold { value: v }),
    }
}

pub fn run(args: &StageArgs) -> Result<Exit, ProcessError> {
    let hold = fault_hold()?;
    let s = args.scenario()?;
    let period = args.period_ns(&s)?;
    let mut link = Link::new(<Commander as Stage>::PROCESS, args)?;
    let mut service = CommanderService {
        out: wiring::publisher::<TorqueCommand>(&link.node, wiring::SVC_TORQUE)?,
        commander: Commander::new(&s),
        n: s.n_samples(),
        period,
        record: args.record,
        hold,
        t0: None,
        t: 0,
    };
    driver::drive(&mut link, &mut service)
}

struct CommanderService {
    out: wiring::Pub<TorqueCommand>,
    commander: Commander,
    n: u64,
    /// Real-time tick period [ns] (0: accelerated, paced by the credit alone).
    period: u64,
    /// A recorder runs in the set: obey its credit too.
    record: bool,
    hold: Option<(u64, std::path::PathBuf)>,
    /// When tick 0 was due [ns]; `None` until the whole chain can take samples.
    t0: Option<u64>,
    /// Next tick to publish.
    t: u64,
}

impl CommanderService {
    /// Is the fault-injection hold in force before tick `t`?
    fn held(&mut self, t: u64) -> bool {
        match &self.hold {
            Some((at, path)) if t >= *at => {
                if path.exists() {
                    return true;
                }
                self.hold = None;
                false
            }
            _ => false,
        }
    }
}

impl Service for CommanderService {
    fn turn(&mut self, link: &mut Link) -> Result<Turn, ProcessError> {
        // Start the clock only once the whole chain can take samples: tick 0 is due now.
        let Some(t0) = self.t0 else {
            if link.started() && link.downstream.primed && (!self.record || link.recorder.heard) {
                link.progress.state = STATE_RUNNING;
                self.t0 = Some(monotonic_ns());
                return Ok(Turn::Busy);
            }
            return Ok(Turn::Idle(Duration::from_millis(1)));
        };
        let t = self.t;
        if t >= self.n {
            return Ok(Turn::Done);
        }
        let due = t0 + t * self.period;
        if self.period > 0 {
            let now = monotonic_ns();
            if now < due {
                return Ok(Turn::Wait(Duration::from_nanos((due - now).min(1_000_000))));
            }
        }
        if self.held(t) {
            return Ok(Turn::Idle(Duration::from_millis(2)));
        }
        let recorder_credit = !self.record
            || (link.recorder.heard && t < link.recorder.next_tick + wiring::RECORDER_WINDOW);
        if !(link.downstream.credit(t) && recorder_credit) {
            return Ok(Turn::Idle(super::IDLE));
        }
        let mut m = self.commander.process(t, &());
        m.header.publish_ns = monotonic_ns();
        if self.period > 0 {
            m.header.due_ns = due;
            if m.header.publish_ns > due + self.period {
                link.progress.missed_deadlines += 1;
            }
        }
        wiring::publish(&self.out, m)?;
        link.sent(self.period > 0);
        self.t = t + 1;
        link.progress.next_tick = self.t;
        link.progress.resume_tick = self.t;
        Ok(Turn::Busy)
    }
}
