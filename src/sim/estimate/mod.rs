//! The estimators as a stage of the simulation and the process set. The estimators
//! themselves are the flight core's (`taiji_core::estimate`), re-exported here; this
//! layer adds the one stage type that holds either (the fuzz harness, which drives the
//! simulation, is `crate::analysis::fuzz`).
pub use taiji_core::estimate::*;

use crate::sim::msg::{EstimateMsg, SensorSample, EST_FINAL};

/// Either estimator behind one stage interface (no dynamic dispatch; boxed because the
/// joint estimator's state is ~50 KB).
#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub enum Estimator {
    Joint(Box<JointEstimator>),
    Paper(Box<paper::PaperEstimator>),
}

impl Estimator {
    pub fn new(method: Method, cfg: EstimatorConfig) -> Self {
        match method {
            Method::Joint => Estimator::Joint(Box::new(JointEstimator::new(cfg))),
            Method::Paper => Estimator::Paper(Box::new(paper::PaperEstimator::new(cfg))),
        }
    }

    /// One sample in, the current estimate out.
    pub fn step(&mut self, s: &SensorSample) -> EstimateMsg {
        match self {
            Estimator::Joint(e) => e.step(s),
            Estimator::Paper(e) => e.step(s),
        }
    }

    /// Every tick below this one has been taken (processed, bridged or skipped).
    pub fn next_tick(&self) -> u64 {
        match self {
            Estimator::Joint(e) => e.next_tick(),
            Estimator::Paper(e) => e.next_tick(),
        }
    }

    /// Final estimate at the end of the campaign.
    pub fn finish(&mut self) -> EstimateMsg {
        let mut m = match self {
            Estimator::Joint(e) => e.finish(),
            Estimator::Paper(e) => e.finish(),
        };
        m.flags |= EST_FINAL;
        m
    }
}
