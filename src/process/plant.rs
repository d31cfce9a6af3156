//! `taiji-plant`: steps the spacecraft and test masses one tick per torque command and
//! publishes the truth (to the front-end electronics only).

use super::{Exit, Link, StageArgs};
use crate::bus;
use crate::model::plant::{Plant, PlantNoise};
use crate::msg::{TorqueCommand, TruthState, STATE_DONE, STATE_RUNNING};
use crate::timing::monotonic_ns;

pub fn run(args: &StageArgs) -> Result<Exit, String> {
    let s = args.scenario()?;
    let seed = args.seed(&s);
    let realtime = args.realtime;
    let mut link = Link::new("taiji-plant", args)?;
    let input = bus::subscriber::<TorqueCommand>(&link.node, bus::SVC_TORQUE)?;
    let out = bus::publisher::<TruthState>(&link.node, bus::SVC_TRUTH)?;
    let mut plant = Plant::new(&s, seed, PlantNoise::ALL);
    link.beat()?;
    let n = s.n_samples();
    let mut next = 0;
    let mut held = [0.0; 3];
    while next < n {
        if let Some(e) = link.poll()? {
            return Ok(e);
        }
        // Consume only what can be passed on: the credit propagates upstream.
        if !link.downstream.credit(next) {
            if let Some(e) = link.idle(super::IDLE) {
                return Ok(e);
            }
            continue;
        }
        let Some(cmd) = bus::receive(&input)? else {
            if let Some(e) = link.idle(super::IDLE) {
                return Ok(e);
            }
            continue;
        };
        link.progress.state = STATE_RUNNING;
        let now = monotonic_ns();
        link.hop.record(now.saturating_sub(cmd.header.publish_ns));
        let tick = cmd.header.tick;
        if tick < next {
            continue;
        }
        // A lost command: the thrusters hold the last one (zero-order hold), as on board.
        while next < tick && next < n {
            link.progress.samples_lost += 1;
            publish_truth(&out, plant.step(next, &held), 0)?;
            next += 1;
        }
        held = cmd.torque_cmd_b;
        publish_truth(&out, plant.step(tick, &held), cmd.header.due_ns)?;
        link.sent(realtime);
        next = tick + 1;
        link.progress.next_tick = next;
        link.progress.resume_tick = next;
        if next % 32 == 0 {
            link.beat()?;
        }
    }
    link.linger(STATE_DONE)
}

fn publish_truth(out: &bus::Pub<TruthState>, mut t: TruthState, due_ns: u64) -> Result<(), String> {
    let now = monotonic_ns();
    t.header.publish_ns = now;
    t.header.origin_ns = now;
    t.header.due_ns = due_ns;
    bus::publish(out, t)
}
