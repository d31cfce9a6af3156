//! One lifecycle for the four stages of the chain, in the spirit of copper's tasks
//! and F Prime's components: fixed-size input and output per tick, `start` before the
//! first tick, `process` once a tick, `stop` after the last (the estimator's final
//! estimate). The in-process campaign drives the chain through it
//! (`campaign::Chain`); each stage's process loop (`process::*`) calls the same
//! `process`. Which process runs which stage is `topology::STAGES`.

use crate::sim::commander::Commander;
use crate::sim::estimate::Estimator;
use crate::sim::fee::FrontEnd;
use crate::sim::model::plant::Plant;
use crate::sim::msg::{EstimateMsg, SensorSample, TorqueCommand, TruthState};

/// A stage of the chain commander → plant → front end → estimator.
pub trait Stage {
    /// What one tick consumes (the upstream stage's output; `()` at the head).
    type Input: Copy;
    /// What one tick produces: a fixed-size message.
    type Output: Copy;
    /// The binary that runs it (`topology::STAGES`).
    const PROCESS: &'static str;

    /// Before the first tick.
    fn start(&mut self) {}

    /// One tick.
    fn process(&mut self, tick: u64, input: &Self::Input) -> Self::Output;

    /// After the last tick: a final output, if the stage has one.
    fn stop(&mut self) -> Option<Self::Output> {
        None
    }
}

impl Stage for Commander {
    type Input = ();
    type Output = TorqueCommand;
    const PROCESS: &'static str = "taiji-commander";

    fn process(&mut self, tick: u64, _: &()) -> TorqueCommand {
        self.step(tick)
    }
}

impl Stage for Plant {
    type Input = TorqueCommand;
    type Output = TruthState;
    const PROCESS: &'static str = "taiji-plant";

    fn process(&mut self, tick: u64, cmd: &TorqueCommand) -> TruthState {
        self.step(tick, &cmd.torque_cmd_b)
    }
}

impl Stage for FrontEnd {
    type Input = TruthState;
    type Output = SensorSample;
    const PROCESS: &'static str = "taiji-fee";

    fn process(&mut self, _tick: u64, truth: &TruthState) -> SensorSample {
        self.step(truth)
    }
}

impl Stage for Estimator {
    type Input = SensorSample;
    type Output = EstimateMsg;
    const PROCESS: &'static str = "taiji-estimator";

    fn process(&mut self, _tick: u64, sample: &SensorSample) -> EstimateMsg {
        self.step(sample)
    }

    fn stop(&mut self) -> Option<EstimateMsg> {
        Some(self.finish())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_stage_names_a_process_of_the_topology() {
        for p in [
            <Commander as Stage>::PROCESS,
            <Plant as Stage>::PROCESS,
            <FrontEnd as Stage>::PROCESS,
            <Estimator as Stage>::PROCESS,
        ] {
            assert!(crate::bus::topology::stage(p).is_some(), "{p}");
        }
    }
}
