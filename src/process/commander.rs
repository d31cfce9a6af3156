//! `taiji-commander`: publishes the maneuver's torque command per tick, paced by the
//! downstream credit (accelerated) or by the clock (real-time).

use super::{Exit, Link, StageArgs};
use crate::bus;
use crate::commander::Commander;
use crate::msg::{TorqueCommand, STATE_DONE, STATE_RUNNING};
use crate::timing::monotonic_ns;
use std::time::Duration;

/// Fault injection for tests: `TAIJI_FAULT_HOLD=TICK:PATH` holds the campaign before
/// tick TICK while the file PATH exists, so a test can act mid-run (cut a link, kill a
/// tunnel) however fast or slow the machine, then let the run go on.
pub const FAULT_HOLD: &str = "TAIJI_FAULT_HOLD";

fn fault_hold() -> Result<Option<(u64, std::path::PathBuf)>, String> {
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
                Err(_) => Err(format!("{FAULT_HOLD} must be TICK:PATH, not {v:?}")),
            }
        }
        _ => Err(format!("{FAULT_HOLD} must be TICK:PATH, not {v:?}")),
    }
}

pub fn run(args: &StageArgs) -> Result<Exit, String> {
    let mut hold = fault_hold()?;
    let s = args.scenario()?;
    let period = args.period_ns(&s)?;
    let mut link = Link::new("taiji-commander", args)?;
    let out = bus::publisher::<TorqueCommand>(&link.node, bus::SVC_TORQUE)?;
    let mut commander = Commander::new(&s);
    link.beat()?;
    // Start the clock only once the whole chain can take samples: tick 0 is due now.
    while !(link.started() && link.downstream.primed && (!args.record || link.recorder.heard)) {
        if let Some(e) = link.poll()?.or_else(|| link.idle(Duration::from_millis(1))) {
            return Ok(e);
        }
    }
    link.progress.state = STATE_RUNNING;
    let n = s.n_samples();
    let t0 = monotonic_ns();
    let mut t = 0;
    while t < n {
        if let Some(e) = link.poll()? {
            return Ok(e);
        }
        let due = t0 + t * period;
        if period > 0 {
            let now = monotonic_ns();
            if now < due {
                let wait = Duration::from_nanos((due - now).min(1_000_000));
                if let Some(e) = link.sleep(wait) {
                    return Ok(e);
                }
                continue;
            }
        }
        if let Some((at, path)) = &hold {
            if t >= *at {
                if !path.exists() {
                    hold = None;
                } else if let Some(e) = link.idle(Duration::from_millis(2)) {
                    return Ok(e);
                }
                continue;
            }
        }
        let recorder_credit = !args.record
            || (link.recorder.heard && t < link.recorder.next_tick + bus::RECORDER_WINDOW);
        if !(link.downstream.credit(t) && recorder_credit) {
            if let Some(e) = link.idle(super::IDLE) {
                return Ok(e);
            }
            continue;
        }
        let mut m = commander.step(t);
        m.header.publish_ns = monotonic_ns();
        if period > 0 {
            m.header.due_ns = due;
            if m.header.publish_ns > due + period {
                link.progress.missed_deadlines += 1;
            }
        }
        bus::publish(&out, m)?;
        link.sent(period > 0);
        t += 1;
        link.progress.next_tick = t;
        link.progress.resume_tick = t;
        if t % 32 == 0 {
            link.beat()?;
        }
    }
    link.linger(STATE_DONE)
}
