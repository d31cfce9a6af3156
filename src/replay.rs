//! Replay: the estimator alone on a recording's star-tracker and IS channels (never
//! truth). On our own recordings it reproduces the live estimates bit for bit, since
//! it feeds the same samples, in the same order, to the same estimator.

use crate::estimate::{Estimator, Method};
use crate::msg::EstimateMsg;
use crate::telemetry::read::Recording;
use crate::telemetry::Telemetry;

/// The final estimate and the estimate rows a live recording would hold.
pub struct Replayed {
    pub estimate: EstimateMsg,
    pub rows: Vec<EstimateMsg>,
    /// Detection of the recording's own fault log (`/faults`; bus faults are not in a
    /// recording's samples, so they are left out).
    pub faults: Option<crate::faults::FaultScore>,
}

pub fn run(rec: &Recording, method: Method, mut progress: impl FnMut(f64)) -> Replayed {
    let s = &rec.scenario;
    let mut est = Estimator::new(method, s.estimator_config(&s.priors()));
    let mut rows = Telemetry::new(s.inertial_sensor.len(), s.sample_rate_hz, 0);
    let n = rec.samples.len();
    let mut score = (!rec.faults.is_empty()).then(|| {
        let mut sc = crate::faults::FaultScore::new(s);
        for r in rec
            .faults
            .iter()
            .filter(|r| r.field != crate::faults::FIELD_HEADER)
        {
            sc.push(*r);
        }
        sc
    });
    for (i, sample) in rec.samples.iter().enumerate() {
        let e = est.step(sample);
        if let Some(sc) = score.as_mut() {
            sc.observe(
                sample.header.tick,
                crate::faults::Delivery::This,
                false,
                e.tick_rejections,
            );
        }
        rows.record_estimate(&e);
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
        faults: score,
    }
}
