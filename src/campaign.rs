//! The whole campaign in one process: commander → plant → front-end → estimator,
//! the same stage types the process set wires over shared memory.

use crate::commander::Commander;
use crate::estimate::{Estimator, Method};
use crate::faults::{Delivery, FaultScore, Injector};
use crate::fee::FrontEnd;
use crate::model::plant::{Plant, PlantNoise};
use crate::msg::EstimateMsg;
use crate::scenario::Scenario;
use crate::telemetry::{Sink, Telemetry};

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
            estimator: Estimator::new(method, s.estimator_config(&priors)),
        }
    }
}

/// Result of a campaign: the final estimate, and with `[faults]` how the estimator
/// fared against the injected faults.
pub struct CampaignResult {
    pub estimate: EstimateMsg,
    pub faults: Option<FaultScore>,
}

/// Run the campaign; `progress` is called with the fraction done now and then.
pub fn run(s: &Scenario, seed: u64, method: Method, progress: impl FnMut(f64)) -> CampaignResult {
    match run_with(s, seed, method, progress, None) {
        Ok(r) => r,
        Err(e) => unreachable!("a campaign that records nothing cannot fail: {e}"),
    }
}

/// Run the campaign and record every stream in memory (figures, tests). Recording only
/// copies the stages' outputs: the estimates are those of [`run`], bit for bit.
pub fn run_recorded(
    s: &Scenario,
    seed: u64,
    method: Method,
    progress: impl FnMut(f64),
) -> (CampaignResult, Telemetry) {
    let mut tel = Telemetry::new(s.inertial_sensor.len(), s.sample_rate_hz, s.n_samples());
    let res = match run_with(s, seed, method, progress, Some(&mut tel)) {
        Ok(r) => r,
        Err(e) => unreachable!("recording to memory cannot fail: {e}"),
    };
    if let Some(sc) = &res.faults {
        tel.faults = sc.records.clone();
        tel.faults_detected = sc.detected.clone();
    }
    (res, tel)
}

/// Run the campaign recording every stream into `sink` as it goes (a
/// [`crate::telemetry::Writer`] streams it to `telemetry.h5`); the fault log, if any,
/// is in the result. The estimates are those of [`run`], bit for bit.
pub fn run_into(
    s: &Scenario,
    seed: u64,
    method: Method,
    progress: impl FnMut(f64),
    sink: &mut dyn Sink,
) -> Result<CampaignResult, String> {
    run_with(s, seed, method, progress, Some(sink))
}

fn run_with(
    s: &Scenario,
    seed: u64,
    method: Method,
    mut progress: impl FnMut(f64),
    mut rec: Option<&mut dyn Sink>,
) -> Result<CampaignResult, String> {
    let mut st = Stages::new(s, seed, method);
    let mut inj = Injector::new(s, seed);
    let mut score = inj.enabled().then(|| FaultScore::new(s));
    let n = s.n_samples();
    let mut prev = None;
    for tick in 0..n {
        let cmd = st.commander.step(tick);
        let truth = st.plant.step(tick, &cmd.torque_cmd_b);
        let mut sample = st.fee.step(&truth);
        if let Some(sc) = score.as_mut() {
            inj.corrupt(&mut sample, &mut |r| sc.push(r));
            inj.bus_records(tick, &mut |r| sc.push(r));
        }
        // What the bus delivers this tick (just the sample without bus faults).
        for (d, of, second) in inj.annotated_deliveries(tick) {
            let m = match d {
                Delivery::This => sample,
                Delivery::Previous => prev.unwrap_or(sample),
                Delivery::Garbage => inj.garbage(&sample),
            };
            let est = st.estimator.step(&m);
            if let Some(sc) = score.as_mut() {
                sc.observe(of, d, second, est.tick_rejections);
            }
            if let Some(t) = rec.as_deref_mut() {
                t.record_estimate(&est)?;
            }
        }
        if let Some(t) = rec.as_deref_mut() {
            t.record(&truth, &sample)?;
        }
        prev = Some(sample);
        if tick % 10_000 == 0 {
            progress(tick as f64 / n as f64);
        }
    }
    let estimate = st.estimator.finish();
    if let Some(t) = rec {
        t.record_estimate(&estimate)?;
    }
    progress(1.0);
    Ok(CampaignResult {
        estimate,
        faults: score,
    })
}
