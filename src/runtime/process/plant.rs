//! `taiji-plant`: steps the spacecraft and test masses one tick per torque command and
//! publishes the truth (to the front-end electronics only).

use super::driver::{self, Service, Turn};
use super::{Exit, Link, ProcessError, StageArgs};
use crate::bus::timing::monotonic_ns;
use crate::bus::wiring;
use crate::sim::model::plant::{Plant, PlantNoise};
use crate::sim::msg::{TorqueCommand, TruthState, STATE_RUNNING};
use crate::sim::stage::Stage;

pub fn run(args: &StageArgs) -> Result<Exit, ProcessError> {
    let s = args.scenario()?;
    let seed = s.seed;
    let mut link = Link::new(<Plant as Stage>::PROCESS, args)?;
    let mut service = PlantService {
        input: wiring::subscriber::<TorqueCommand>(&link.node, wiring::SVC_TORQUE)?,
        out: wiring::publisher::<TruthState>(&link.node, wiring::SVC_TRUTH)?,
        plant: Plant::new(&s, seed, PlantNoise::ALL),
        n: s.n_samples(),
        next: 0,
        held: TorqueCommand::default(),
        realtime: args.realtime,
    };
    driver::drive(&mut link, &mut service)
}

struct PlantService {
    input: wiring::Sub<TorqueCommand>,
    out: wiring::Pub<TruthState>,
    plant: Plant,
    n: u64,
    /// Next tick to step.
    next: u64,
    /// The command in force: a lost one is replaced by it (zero-order hold, as on board).
    held: TorqueCommand,
    realtime: bool,
}

impl Service for PlantService {
    fn turn(&mut self, link: &mut Link) -> Result<Turn, ProcessError> {
        if self.next >= self.n {
            return Ok(Turn::Done);
        }
        // Consume only what can be passed on: the credit propagates upstream.
        if !link.downstream.credit(self.next) {
            return Ok(Turn::Idle(super::IDLE));
        }
        let Some(cmd) = wiring::receive(&self.input)? else {
            return Ok(Turn::Idle(super::IDLE));
        };
        link.progress.state = STATE_RUNNING;
        link.hop
            .record(monotonic_ns().saturating_sub(cmd.header.publish_ns));
        let tick = cmd.header.tick;
        if tick < self.next {
            return Ok(Turn::Busy);
        }
        while self.next < tick && self.next < self.n {
            link.progress.samples_lost += 1;
            let t = self.plant.process(self.next, &self.held);
            publish_truth(&self.out, t, 0)?;
            self.next += 1;
        }
        self.held = cmd;
        let t = self.plant.process(tick, &cmd);
        publish_truth(&self.out, t, cmd.header.due_ns)?;
        link.sent(self.realtime);
        self.next = tick + 1;
        link.progress.next_tick = self.next;
        link.progress.resume_tick = self.next;
        Ok(Turn::Busy)
    }
}

fn publish_truth(
    out: &wiring::Pub<TruthState>,
    mut t: TruthState,
    due_ns: u64,
) -> Result<(), wiring::BusError> {
    let now = monotonic_ns();
    t.header.publish_ns = now;
    t.header.origin_ns = now;
    t.header.due_ns = due_ns;
    wiring::publish(out, t)
}
