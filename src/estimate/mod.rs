//! Estimators: the joint angle-domain estimator that reaches the CRLB, the paper's
//! route for comparison, and the static-state Kalman filter both build on.
pub mod config;
#[cfg(feature = "std")]
pub mod fuzz;
pub mod integrity;
pub mod joint;
pub mod kalman;
pub mod paper;
pub mod snapshot;

pub use config::EstimatorConfig;
pub use joint::JointEstimator;

#[cfg(feature = "std")]
use crate::msg::{EstimateMsg, SensorSample, EST_FINAL};

/// Which estimator a run uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// Joint angle-domain estimation of β, r1, r2 with the SRP whitened (default).
    #[default]
    Joint,
    /// The paper's route: double differentiation, 0.05 Hz low-pass, static KF, CoM KF.
    Paper,
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::Joint => "joint",
            Method::Paper => "paper",
        }
    }
}

/// Either estimator behind one stage interface (no dynamic dispatch; boxed because the
/// joint estimator's state is ~50 KB).
#[cfg(feature = "std")]
#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub enum Estimator {
    Joint(Box<JointEstimator>),
    Paper(Box<paper::PaperEstimator>),
}

#[cfg(feature = "std")]
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
