//! The whole campaign in one process: commander → plant → front-end → estimator,
//! the same stage types the process set wires over shared memory.

use crate::commander::Commander;
use crate::estimate::{Estimator, EstimatorConfig, Method};
use crate::fee::FrontEnd;
use crate::model::plant::{Plant, PlantNoise};
use crate::msg::EstimateMsg;
use crate::scenario::Scenario;

/// The stages of one campaign, built from a scenario and seed.
pub struct Stages {
    pub commander: Commander,
    pub plant: Plant,
    pub fee: FrontEnd,
    pub estimator: Estimator,
}

impl Stages {
    pub fn new(s: &Scenario, seed: u64, method: Method) -> Self {
        let priors = s.priors();
        Stages {
            commander: Commander::new(s),
            plant: Plant::new(s, seed, PlantNoise::ALL),
            fee: FrontEnd::new(s, seed, true),
            estimator: Estimator::new(method, EstimatorConfig::from_scenario(s, &priors)),
        }
    }
}

/// Result of a campaign: the final estimate and the estimates at every solve.
pub struct CampaignResult {
    pub estimate: EstimateMsg,
    pub history: Vec<EstimateMsg>,
}

/// Run the campaign; `progress` is called with the fraction done now and then.
pub fn run(
    s: &Scenario,
    seed: u64,
    method: Method,
    mut progress: impl FnMut(f64),
) -> CampaignResult {
    let mut st = Stages::new(s, seed, method);
    let n = s.n_samples();
    let mut history = Vec::new();
    let mut last_solved = u64::MAX;
    for tick in 0..n {
        let cmd = st.commander.step(tick);
        let truth = st.plant.step(tick, &cmd.torque_cmd_b);
        let sample = st.fee.step(&truth);
        let est = st.estimator.step(&sample);
        if est.solved_tick != last_solved && method == Method::Joint {
            last_solved = est.solved_tick;
            history.push(est);
        }
        if tick % 10_000 == 0 {
            progress(tick as f64 / n as f64);
        }
    }
    let estimate = st.estimator.finish();
    history.push(estimate);
    progress(1.0);
    CampaignResult { estimate, history }
}
