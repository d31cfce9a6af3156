//! Replay: the estimator alone on a recording's star-tracker and IS channels (never
//! truth). On our own recordings it reproduces the live estimates bit for bit, since
//! it feeds the same samples, in the same order, to the same estimator.

use crate::estimate::{Estimator, EstimatorConfig, Method};
use crate::msg::EstimateMsg;
use crate::telemetry::read::Recording;
use crate::telemetry::Telemetry;

/// The final estimate and the estimate rows a live recording would hold.
pub struct Replayed {
    pub estimate: EstimateMsg,
    pub rows: Vec<EstimateMsg>,
}

pub fn run(rec: &Recording, method: Method, mut progress: impl FnMut(f64)) -> Replayed {
    let s = &rec.scenario;
    let mut est = Estimator::new(method, EstimatorConfig::from_scenario(s, &s.priors()));
    let mut rows = Telemetry::new(s.inertial_sensor.len(), s.sample_rate_hz, 0);
    let n = rec.samples.len();
    for (i, sample) in rec.samples.iter().enumerate() {
        rows.record_estimate(&est.step(sample));
        if i % 10_000 == 0 {
            progress(i as f64 / n as f64);
        }
    }
    let estimate = est.finish();
    rows.record_estimate(&estimate);
    progress(1.0);
    Replayed {
        estimate,
        rows: rows.estimates,
    }
}
