//! The run report (every key: docs/report.md) and the result table printed like the
//! paper's Tables 2–3.

mod build;
mod onboard;
mod table;
#[cfg(test)]
mod tests;

use crate::sim::files::FileError;
pub use crate::sim::requirements::{REQ_COM_M, REQ_SCALE_FACTOR_REL};
pub use crate::sim::scenario::PriorsSource;
use build::bound_with_prior;
pub use onboard::table_values;
use serde::{Deserialize, Serialize};
pub use table::{fault_line, prediction_line, scheduling_line, Row};

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Quantity {
    pub truth: [f64; 3],
    pub estimate: [f64; 3],
    pub sigma: [f64; 3],
    /// The bound of the data alone (the Cramér–Rao bound of the maneuver flown).
    pub crlb: [f64; 3],
    /// The prior the estimator started from (β and r: the scenario's or the onboard
    /// table's, `Report::priors_source`; k: from β's through the geometry, k = G β).
    #[serde(default)]
    pub prior: [f64; 3],
    /// 1σ of the estimator's own prior (joint: 5 % of β's prior, 5 cm for r).
    #[serde(default)]
    pub prior_sigma: [f64; 3],
    /// The bound with that prior: 1/√(1/crlb² + 1/prior_sigma²).
    #[serde(default)]
    pub crlb_with_prior: [f64; 3],
    /// How much of the information behind σ came from the data, 1 − (σ/prior_sigma)²:
    /// 0 where the estimate is its prior, 1 where the prior did not matter.
    #[serde(default)]
    pub data_share: [f64; 3],
}

impl Quantity {
    fn new(truth: [f64; 3], estimate: [f64; 3], sigma: [f64; 3], crlb: [f64; 3]) -> Self {
        Quantity {
            truth,
            estimate,
            sigma,
            crlb,
            prior: [f64::NAN; 3],
            prior_sigma: [f64::NAN; 3],
            crlb_with_prior: [f64::NAN; 3],
            data_share: [f64::NAN; 3],
        }
    }

    /// Set the estimator's prior σ, and what follows from it.
    fn with_prior(mut self, prior_sigma: [f64; 3]) -> Self {
        self.prior_sigma = prior_sigma;
        for a in 0..3 {
            let (c, p) = (self.crlb[a], prior_sigma[a]);
            self.crlb_with_prior[a] = bound_with_prior(c, p);
            self.data_share[a] = (1.0 - (self.sigma[a] / p).powi(2)).clamp(0.0, 1.0);
        }
        self
    }
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct IsReport {
    pub id: usize,
    pub beta: Quantity,
    pub k: Quantity,
    pub com_offset: Quantity,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Requirements {
    pub scale_factor_rel: f64,
    pub com_offset_m: f64,
    /// Every error within its requirement (judged against the scenario's truths).
    pub met: bool,
    /// The estimator vouches for its own result (no solve failure, converged, every
    /// residual group consistent with its noise model): what onboard software knows.
    #[serde(default = "yes")]
    pub verified: bool,
}

fn yes() -> bool {
    true
}

/// What the estimator says of its own result (`EstimateMsg::status`).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct EstimatorStatus {
    /// `ST_*` bits and their names ("ok" when none).
    pub bits: u64,
    pub text: String,
    /// χ²/dof of the whitened residuals per group at the final solve (1: the noise
    /// model fits).
    pub chi2_per_dof: std::collections::BTreeMap<String, f64>,
    /// Factor the σ were inflated by for inconsistent groups (1: none).
    pub sigma_inflation: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Report {
    pub scenario: String,
    pub seed: u64,
    pub duration_s: f64,
    pub mode: String,
    pub method: String,
    /// Where the priors came from: "scenario", or "onboard_table" for a campaign that
    /// started from the onboard calibration table (`Scenario::with_onboard_priors`).
    #[serde(default)]
    pub priors_source: PriorsSource,
    pub inertial_sensors: Vec<IsReport>,
    pub requirements: Requirements,
    /// Samples the estimator used and rejected (non-finite, saturated, invalid).
    pub samples_used: u64,
    pub samples_rejected: u64,
    /// Rejections by cause (a sample may count under several; see docs/integrity.md).
    #[serde(default)]
    pub samples_rejected_by_cause: std::collections::BTreeMap<String, u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub estimator_status: Option<EstimatorStatus>,
    /// Injected faults and how many the estimator detected, by kind (with `[faults]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub faults: Option<serde_json::Value>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wall_time_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub timing: Option<serde_json::Value>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub restarts: Option<serde_json::Value>,
    /// Sets spread over hosts: where each process ran, the tunnel, link events.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hosts: Option<serde_json::Value>,
    /// Heap allocations the estimator process made in its filter loop (multi-process).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub estimator_loop_allocations: Option<u64>,
    /// The maneuver flown: waveform, schedule, whether planned, envelope, bound.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub maneuver: Option<crate::analysis::plan::ManeuverReport>,
    /// Probability of meeting every requirement that the bound with the estimator's
    /// prior predicts (β and r of each IS, each error normal with that σ): before
    /// the run, from the maneuver and the noise model alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub predicted_probability_requirements_met: Option<f64>,
    /// The same if the errors were one common error (the smallest probability of one
    /// parameter): the bound gives each σ, not how the errors go together, so the
    /// probability lies between this and the product above (β's six errors are
    /// mostly one common scale error, which puts it nearer this one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub predicted_probability_requirements_met_upper: Option<f64>,
    /// Both from the run's bound (its thrusters' random motion at this seed
    /// included, which can calibrate what the maneuver alone cannot), [product,
    /// smallest]: known after the run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub probability_requirements_met_run_bound: Option<[f64; 2]>,
    /// Parameters whose estimate is mostly the estimator's prior (data share < 50 %).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub prior_dominated: Vec<String>,
    /// Parameters the data calibrated no better than the ground calibration claims
    /// (σ at or above `ground_calibration`'s error): its value is the one to keep.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub ground_better: Vec<String>,
    /// What the user should know before trusting the result (also printed).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

/// A report that could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A file or folder that could not be read, created or written.
    #[error(transparent)]
    File(#[from] FileError),
    #[error("{0}")]
    Json(#[from] serde_json::Error),
}

/// Write `DIR/report.json` (creating DIR).
pub fn write(out: &std::path::Path, report: &Report) -> Result<(), ReportError> {
    std::fs::create_dir_all(out)
        .map_err(|source| ReportError::from(FileError::create(out, source)))?;
    let path = out.join("report.json");
    let text = serde_json::to_string_pretty(report)?;
    std::fs::write(&path, text + "\n")
        .map_err(|source| ReportError::from(FileError::write(path, source)))
}
