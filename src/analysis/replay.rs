//! Replay: the estimator alone on a recording's star-tracker and IS channels (never
//! truth). On our own recordings it reproduces the live estimates bit for bit, since
//! it feeds the same samples, in the same order, to the same estimator. A recording
//! holds each tick's sample once; where its scenario injected bus faults (duplicates,
//! reorders, missing samples, garbage headers), replay delivers the samples as that
//! bus did, from the same seeded injector: the deliveries depend on the seed and the
//! tick alone. The samples are read from the file a window at a time, so memory does
//! not grow with its length.

use crate::sim::estimate::{Estimator, Method};
use crate::sim::faults::Injector;
use crate::sim::msg::{EstimateMsg, SensorSample};
use crate::telemetry::read::Recording;
use crate::telemetry::{RowGate, TelemetryError};

/// The final estimate of a replay.
pub struct Replayed {
    pub estimate: EstimateMsg,
    /// Detection of the recording's own fault log (`/faults`).
    pub faults: Option<crate::sim::faults::FaultScore>,
}

pub fn run(
    rec: &Recording,
    method: Method,
    progress: impl FnMut(f64),
) -> Result<Replayed, TelemetryError> {
    run_with_rows(rec, method, progress, |_| {})
}

/// [`run`], handing `row` each estimate row a live recording would hold, in order.
pub fn run_with_rows(
    rec: &Recording,
    method: Method,
    mut progress: impl FnMut(f64),
    mut row: impl FnMut(&EstimateMsg),
) -> Result<Replayed, TelemetryError> {
    let s = &rec.scenario;
    let mut est = Estimator::new(method, s.estimator_config(&s.priors()));
    let mut gate = RowGate::default();
    let fs = s.sample_rate_hz;
    let n = rec.expected;
    let mut score = (!rec.faults.is_empty()).then(|| {
        let mut sc = crate::sim::faults::FaultScore::new(s);
        for r in &rec.faults {
            sc.push(*r);
        }
        sc
    });
    // The bus of the live run (none without `[faults]`: each sample once).
    let bus = Injector::new(s, rec.seed);
    let mut prev: Option<SensorSample> = None;
    for (i, sample) in rec.samples().enumerate() {
        let sample = sample?;
        for (d, of, second) in bus.annotated_deliveries(sample.header.tick) {
            let e = est.step(&bus.delivered(d, &sample, prev.as_ref()));
            if let Some(sc) = score.as_mut() {
                sc.observe(of, d, second, e.tick_rejections);
            }
            if gate.due(&e, fs) {
                row(&e);
            }
        }
        prev = Some(sample);
        if i % 10_000 == 0 {
            progress((i as f64 / n as f64).min(1.0));
        }
    }
    let estimate = est.finish();
    if gate.due(&estimate, fs) {
        row(&estimate);
    }
    progress(1.0);
    Ok(Replayed {
        estimate,
        faults: score,
    })
}
