//! Estimators: the joint angle-domain estimator that reaches the CRLB, the paper's
//! route for comparison, and the static-state Kalman filter both build on.
pub mod config;
pub mod integrity;
pub mod joint;
pub mod kalman;
pub mod paper;
pub mod snapshot;

pub use config::EstimatorConfig;
pub use joint::{JointEstimator, SolveWork};

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
