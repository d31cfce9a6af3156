//! The whole campaign in one process: commander → plant → front-end → estimator,
//! the same stage types the process set wires over shared memory. On two cores the
//! simulation runs a few batches ahead of the estimator on a thread of its own.

use crate::sim::commander::Commander;
use crate::sim::estimate::{Estimator, Method};
use crate::sim::faults::{Delivery, FaultRecord, FaultScore, Injector};
use crate::sim::fee::FrontEnd;
use crate::sim::model::plant::{Plant, PlantNoise};
use crate::sim::msg::{EstimateMsg, SensorSample, TruthState};
use crate::sim::scenario::Scenario;
use crate::sim::stage::Stage;
use crate::telemetry::{Sink, Telemetry, TelemetryError};
use std::sync::mpsc;

/// The stages of one campaign, built from a scenario and seed.
pub struct Stages {
    pub commander: Commander,
    pub plant: Plant,
    pub fee: FrontEnd,
    pub estimator: Estimator,
}

impl Stages {
    /// The sensor samples of `n` ticks from the commander, the plant and the front end,
    /// stepped in turn (no faults, no estimator).
    pub fn sensor_samples(&mut self, n: u64) -> Vec<SensorSample> {
        (0..n)
            .map(|t| {
                let cmd = self.commander.step(t);
                let truth = self.plant.step(t, &cmd.torque_cmd_b);
                self.fee.step(&truth)
            })
            .collect()
    }

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

/// How a campaign uses the machine's cores. Both give the same results, bit for bit:
/// the estimator takes the same messages in the same order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Threads {
    /// Simulation and estimator take turns on the calling thread (for campaigns that
    /// already run side by side, one per core: the Monte Carlo).
    One,
    /// The simulation (commander, plant, front-end, fault injection) on a thread of its
    /// own, up to [`POOL`] batches of [`BATCH`] ticks ahead of the estimator, which runs
    /// on the calling thread.
    Two,
}

impl Threads {
    /// `Two` when the machine has a second core, else `One`.
    pub fn available() -> Self {
        match std::thread::available_parallelism() {
            Ok(n) if n.get() >= 2 => Threads::Two,
            _ => Threads::One,
        }
    }
}

/// Ticks per batch the simulation hands to the estimator: enough that the hand-over
/// costs nothing per tick (~0.5 ms of work per batch), few enough to stay in cache.
pub const BATCH: usize = 256;
/// Batches in flight: how far the simulation may run ahead of the estimator.
pub const POOL: usize = 16;

/// Run the campaign; `progress` is called with the fraction done now and then.
pub fn run(s: &Scenario, seed: u64, method: Method, progress: impl FnMut(f64)) -> CampaignResult {
    run_on(s, seed, method, Threads::available(), progress)
}

/// [`run`] on the given threads.
pub fn run_on(
    s: &Scenario,
    seed: u64,
    method: Method,
    threads: Threads,
    progress: impl FnMut(f64),
) -> CampaignResult {
    match run_with(s, seed, method, threads, progress, None, None) {
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
    let threads = Threads::available();
    let res = match run_with(s, seed, method, threads, progress, Some(&mut tel), None) {
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
) -> Result<CampaignResult, TelemetryError> {
    run_with(
        s,
        seed,
        method,
        Threads::available(),
        progress,
        Some(sink),
        None,
    )
}

/// A run of consecutive ticks as the estimator's side takes them.
#[derive(Default)]
struct Batch {
    /// The first tick.
    first: u64,
    /// Per tick: messages the bus delivers, and fault records logged.
    counts: Vec<(usize, usize)>,
    /// The delivered messages, in order: message, tick it carries, delivery, second copy.
    delivered: Vec<(SensorSample, u64, Delivery, bool)>,
    records: Vec<FaultRecord>,
    /// Per tick, only when recording: the truth and the sample.
    truth: Vec<TruthState>,
    sample: Vec<SensorSample>,
    /// The noise-free twin's delivered samples (`Twin`), when there is one.
    twin: Vec<SensorSample>,
}

impl Batch {
    fn with_capacity() -> Self {
        Batch {
            first: 0,
            counts: Vec::with_capacity(BATCH),
            delivered: Vec::with_capacity(BATCH + 8),
            records: Vec::new(),
            truth: Vec::new(),
            sample: Vec::new(),
            twin: Vec::with_capacity(BATCH + 8),
        }
    }
}

/// Something that takes the noise-free twin's samples in tick order (the Cramér–Rao
/// bound's estimator pass, `crlb::run_with_bound`): with [`Threads::Two`] on a third
/// thread, beside the simulation and the run's estimator.
pub type TwinTake<'t> = &'t mut (dyn FnMut(&SensorSample) + Send);

/// The campaign's noise-free twin: the same motion (`Plant::noise_free_twin`) through a
/// noise-free front-end, losing what the run loses (`Injector::losses_only`): the
/// stream `samples` and `samples_losing` give the bound, without simulating the
/// motion a second time.
struct Twin {
    fee: FrontEnd,
    inj: Option<Injector>,
    prev: Option<SensorSample>,
}

/// The simulating side: commander, plant, front-end and the fault injector (none:
/// every tick delivers its sample once), and the noise-free twin if asked.
struct Sim {
    commander: Commander,
    plant: Plant,
    fee: FrontEnd,
    inj: Option<Injector>,
    faults: bool,
    record: bool,
    prev: Option<SensorSample>,
    next: u64,
    n: u64,
    twin: Option<Twin>,
}

impl Sim {
    /// The stages alone: no faults, nothing recorded.
    fn clean(commander: Commander, plant: Plant, fee: FrontEnd, n: u64) -> Self {
        Sim {
            commander,
            plant,
            fee,
            inj: None,
            faults: false,
            record: false,
            prev: None,
            next: 0,
            n,
            twin: None,
        }
    }

    /// Simulate the next [`BATCH`] ticks into `b`; false when none are left.
    fn fill(&mut self, b: &mut Batch) -> bool {
        b.first = self.next;
        b.counts.clear();
        b.delivered.clear();
        b.records.clear();
        b.truth.clear();
        b.sample.clear();
        b.twin.clear();
        let end = (self.next + BATCH as u64).min(self.n);
        for tick in self.next..end {
            // The chain, each stage through its one lifecycle (`stage::Stage`).
            let cmd = self.commander.process(tick, &());
            let truth = self.plant.process(tick, &cmd);
            if let Some(tw) = self.twin.as_mut() {
                tw.step(tick, &self.plant.noise_free_twin(&truth), &mut b.twin);
            }
            let mut sample = self.fee.process(tick, &truth);
            let (d0, r0) = (b.delivered.len(), b.records.len());
            let (records, delivered) = (&mut b.records, &mut b.delivered);
            bus_tick(
                self.inj.as_mut(),
                self.faults,
                tick,
                &mut sample,
                self.prev.as_ref(),
                &mut |r| records.push(r),
                &mut |m| delivered.push(m),
            );
            b.counts
                .push((b.delivered.len() - d0, b.records.len() - r0));
            if self.record {
                b.truth.push(truth);
                b.sample.push(sample);
            }
            self.prev = Some(sample);
        }
        self.next = end;
        !b.counts.is_empty()
    }
}

/// One tick on the bus: with `faults` the injector corrupts `sample` and logs its
/// records (to `log`), then each message the bus delivers this tick goes to `out`
/// (message, tick it carries, delivery, second copy); without an injector, the sample
/// once.
fn bus_tick(
    inj: Option<&mut Injector>,
    faults: bool,
    tick: u64,
    sample: &mut SensorSample,
    prev: Option<&SensorSample>,
    log: &mut impl FnMut(FaultRecord),
    out: &mut impl FnMut((SensorSample, u64, Delivery, bool)),
) {
    let Some(inj) = inj else {
        out((*sample, tick, Delivery::This, false));
        return;
    };
    if faults {
        inj.corrupt(sample, log);
        inj.bus_records(tick, log);
    }
    // What the bus delivers this tick (just the sample without bus faults).
    for (d, of, second) in inj.annotated_deliveries(tick) {
        out((inj.delivered(d, sample, prev), of, d, second));
    }
}

impl Twin {
    /// One tick of the twin: its sample, what the bus delivers of it, into `out` (as
    /// `Sim::fill` with `samples_losing`'s injector, or none).
    fn step(&mut self, tick: u64, truth: &TruthState, out: &mut Vec<SensorSample>) {
        let mut sample = self.fee.process(tick, truth);
        let inj = self.inj.as_mut();
        bus_tick(
            inj,
            true,
            tick,
            &mut sample,
            self.prev.as_ref(),
            &mut |_| {},
            &mut |m| out.push(m.0),
        );
        self.prev = Some(sample);
    }
}

/// The estimating side: the estimator, the fault score, the recording and progress.
struct Est<'a, P> {
    estimator: Estimator,
    score: Option<FaultScore>,
    rec: Option<&'a mut dyn Sink>,
    progress: P,
    n: u64,
}

impl<P: FnMut(f64)> Est<'_, P> {
    /// Take a batch's ticks in order; a recording error stops the campaign.
    fn take(&mut self, b: &Batch) -> Result<(), TelemetryError> {
        let (mut di, mut ri) = (0, 0);
        for (i, &(nd, nr)) in b.counts.iter().enumerate() {
            let tick = b.first + i as u64;
            if let Some(sc) = self.score.as_mut() {
                for r in &b.records[ri..ri + nr] {
                    sc.push(*r);
                }
            }
            ri += nr;
            for (m, of, d, second) in &b.delivered[di..di + nd] {
                let est = self.estimator.process(*of, m);
                if let Some(sc) = self.score.as_mut() {
                    sc.observe(*of, *d, *second, est.tick_rejections);
                }
                if let Some(t) = self.rec.as_deref_mut() {
                    t.record_estimate(&est)?;
                }
            }
            di += nd;
            if let Some(t) = self.rec.as_deref_mut() {
                t.record(&b.truth[i], &b.sample[i])?;
            }
            if tick % 10_000 == 0 {
                (self.progress)(tick as f64 / self.n as f64);
            }
        }
        Ok(())
    }
}

/// The sensor samples of a campaign without faults from these stages, handed to `take`
/// in tick order (the Cramér–Rao bound's noise-free stream).
pub fn samples(
    s: &Scenario,
    commander: Commander,
    plant: Plant,
    fee: FrontEnd,
    threads: Threads,
    take: impl FnMut(&SensorSample),
) {
    deliver(
        Sim::clean(commander, plant, fee, s.n_samples()),
        threads,
        take,
    );
}

/// [`samples`] with the data the campaign at `seed` loses: its IS and star-tracker
/// dropouts and the ticks the bus never delivers, the same ticks as its run loses
/// (`Injector::losses_only`).
pub fn samples_losing(
    s: &Scenario,
    seed: u64,
    commander: Commander,
    plant: Plant,
    fee: FrontEnd,
    threads: Threads,
    take: impl FnMut(&SensorSample),
) {
    let mut sim = Sim::clean(commander, plant, fee, s.n_samples());
    sim.inj = Some(Injector::new(s, seed).losses_only());
    sim.faults = true;
    deliver(sim, threads, take);
}

/// Every message `sim` delivers, handed to `take` in order (nothing is recorded, so
/// nothing can fail).
fn deliver(sim: Sim, threads: Threads, mut take: impl FnMut(&SensorSample)) {
    let all: Result<(), TelemetryError> = drive(
        threads,
        sim,
        |b| {
            b.delivered.iter().for_each(|(m, ..)| take(m));
            Ok(())
        },
        None,
    );
    debug_assert!(all.is_ok());
}

/// Simulate batch after batch and hand each to `take`, on the calling thread, until
/// the end or `take`'s first error; the twin's samples of each batch (if any) to
/// `twin`, in order, on a thread of their own with [`Threads::Two`].
fn drive(
    threads: Threads,
    mut sim: Sim,
    mut take: impl FnMut(&Batch) -> Result<(), TelemetryError>,
    mut twin: Option<TwinTake<'_>>,
) -> Result<(), TelemetryError> {
    match threads {
        Threads::One => {
            let mut b = Batch::with_capacity();
            while sim.fill(&mut b) {
                if let Some(t) = twin.as_deref_mut() {
                    b.twin.iter().for_each(&mut *t);
                }
                take(&b)?;
            }
            Ok(())
        }
        Threads::Two => {
            // Full batches to `take`, emptied ones back: a fixed pool, no allocation
            // once warm, and the simulation never more than POOL batches ahead. The
            // twin's samples go the same way to a third thread, in buffers of their own.
            let (full_tx, full_rx) = mpsc::sync_channel::<Batch>(POOL);
            let (free_tx, free_rx) = mpsc::sync_channel::<Batch>(POOL);
            for _ in 0..POOL {
                let _ = free_tx.send(Batch::with_capacity());
            }
            let (twin_full_tx, twin_full_rx) = mpsc::sync_channel::<Vec<SensorSample>>(POOL);
            let (twin_free_tx, twin_free_rx) = mpsc::sync_channel::<Vec<SensorSample>>(POOL);
            if twin.is_some() {
                for _ in 0..POOL {
                    let _ = twin_free_tx.send(Vec::with_capacity(BATCH + 8));
                }
            }
            let twin_on = twin.is_some();
            std::thread::scope(|sc| {
                sc.spawn(move || {
                    while let Ok(mut b) = free_rx.recv() {
                        if !sim.fill(&mut b) {
                            break;
                        }
                        if twin_on {
                            let Ok(mut empty) = twin_free_rx.recv() else {
                                break;
                            };
                            empty.clear();
                            std::mem::swap(&mut b.twin, &mut empty);
                            if twin_full_tx.send(empty).is_err() {
                                break;
                            }
                        }
                        if full_tx.send(b).is_err() {
                            break;
                        }
                    }
                });
                if let Some(t) = twin.take() {
                    sc.spawn(move || {
                        // Ends when the simulation is done (or stopped) and dropped its
                        // sender; a closed return channel is no error here.
                        while let Ok(v) = twin_full_rx.recv() {
                            v.iter().for_each(&mut *t);
                            let _ = twin_free_tx.send(v);
                        }
                    });
                }
                // Owned here, so that an error or a panic in `take` drops them and the
                // simulation, its channels closed, stops instead of waiting forever.
                let (full_rx, free_tx) = (full_rx, free_tx);
                // Ends when the simulation is done (or failed) and dropped its sender.
                while let Ok(b) = full_rx.recv() {
                    take(&b)?;
                    let _ = free_tx.send(b);
                }
                Ok(())
            })
        }
    }
}

/// The campaign, and with `twin_take` its noise-free twin: the twin's samples are
/// handed to it on the simulating thread (`crlb::run_with_bound`), the run's estimates
/// are those of [`run`] bit for bit, and it takes the stream `samples_losing` (or
/// `samples`) gives at `seed`.
pub fn run_with(
    s: &Scenario,
    seed: u64,
    method: Method,
    threads: Threads,
    progress: impl FnMut(f64),
    rec: Option<&mut dyn Sink>,
    twin_take: Option<TwinTake<'_>>,
) -> Result<CampaignResult, TelemetryError> {
    let twin = twin_take.is_some().then(|| Twin {
        fee: FrontEnd::new(s, seed, false),
        inj: s
            .faults
            .loses_data()
            .then(|| Injector::new(s, seed).losses_only()),
        prev: None,
    });
    let st = Stages::new(s, seed, method);
    let inj = Injector::new(s, seed);
    let n = s.n_samples();
    let sim = Sim {
        twin,
        commander: st.commander,
        plant: st.plant,
        fee: st.fee,
        faults: inj.enabled(),
        inj: Some(inj),
        record: rec.is_some(),
        prev: None,
        next: 0,
        n,
    };
    let mut est = Est {
        estimator: st.estimator,
        score: sim.faults.then(|| FaultScore::new(s)),
        rec,
        progress,
        n,
    };
    drive(threads, sim, |b| est.take(b), twin_take)?;
    let Est {
        mut estimator,
        score,
        rec,
        mut progress,
        ..
    } = est;
    // The estimator's stop is its final estimate (always there).
    let estimate = estimator.stop().unwrap_or_default();
    if let Some(t) = rec {
        t.record_estimate(&estimate)?;
    }
    progress(1.0);
    Ok(CampaignResult {
        estimate,
        faults: score,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// FNV-1a over 64-bit words.
    fn fnv(h: &mut u64, words: impl IntoIterator<Item = f64>) {
        for w in words {
            *h = (*h ^ w.to_bits()).wrapping_mul(0x100_0000_01b3);
        }
    }

    #[test]
    fn the_simulated_streams_are_those_of_the_reference_bit_for_bit() {
        // Default scenario, seed 7: truth attitude, rate, TM accelerations, both IS's
        // voltages and the star tracker, every tick, hashed in that order. The value is
        // that of the recording made before the simulation was sped up (the same words
        // of its telemetry.h5): a faster plant must not move a single bit. Changed
        // once since, on purpose: the tick's SRP became the attitude's mean over the
        // tick (`plant::tests`), which moves the IS voltages.
        let s = Scenario::default();
        let mut st = Stages::new(&s, 7, Method::Joint);
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        for tick in 0..s.n_samples() {
            let cmd = st.commander.step(tick);
            let t = st.plant.step(tick, &cmd.torque_cmd_b);
            let m = st.fee.step(&t);
            fnv(&mut h, t.q_bn);
            fnv(&mut h, t.omega_b);
            fnv(&mut h, t.a_tm_b.into_iter().flatten());
            for is in &m.is {
                fnv(&mut h, is.volts.into_iter().flatten());
            }
            fnv(&mut h, m.star.q_bn);
        }
        assert_eq!(h, 0xcf55_d172_4cdc_60a1, "{h:#x}");
    }

    #[test]
    fn a_failing_estimator_side_stops_the_simulation_thread() {
        let s = Scenario::default();
        let (done_tx, done_rx) = mpsc::channel();
        std::thread::spawn(move || {
            let st = Stages::new(&s, 1, Method::Joint);
            let sim = Sim::clean(st.commander, st.plant, st.fee, s.n_samples());
            let mut taken = 0;
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                drive(
                    Threads::Two,
                    sim,
                    |_| {
                        taken += 1;
                        assert!(taken < 3, "the estimator side fails");
                        Ok(())
                    },
                    None,
                )
            }));
            let _ = done_tx.send((r.is_err(), taken));
        });
        let got = done_rx.recv_timeout(std::time::Duration::from_secs(60));
        assert_eq!(got, Ok((true, 3)), "the campaign hung or did not fail");
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    #[test]
    fn one_thread_and_two_give_the_same_records_and_estimates() {
        // Faults of every kind, so batches carry duplicates, reorders, garbage and logs.
        let s = Scenario::from_toml_str(
            "duration_s = 2000.0\n[maneuver]\nfrequency_hz = 0.003\n[faults]\n\
             upset_rate = 1e-4\nstar_jumps = 3\noutliers = 1\nstuck_channels = 1\n\
             is_dropout_rate = 0.05\nduplicate_rate = 1e-3\nreorder_rate = 1e-3\n\
             missing_rate = 2e-4\ngarbage_headers = 5\n",
        )
        .unwrap();
        let n = s.n_samples();
        let run = |threads| {
            let mut tel = Telemetry::new(s.inertial_sensor.len(), s.sample_rate_hz, n);
            let mut calls = 0;
            let r = run_with(
                &s,
                3,
                Method::Joint,
                threads,
                |_| calls += 1,
                Some(&mut tel),
                None,
            );
            (r.unwrap(), tel, calls)
        };
        let (r1, t1, c1) = run(Threads::One);
        let (r2, t2, c2) = run(Threads::Two);
        assert_eq!(r1.estimate, r2.estimate);
        let (f1, f2) = (r1.faults.unwrap(), r2.faults.unwrap());
        assert!(f1.records.len() > 20, "{} faults", f1.records.len());
        assert_eq!(f1.records.len(), f2.records.len());
        for (a, b) in f1.records.iter().zip(&f2.records) {
            assert_eq!((a.tick, a.kind, a.field), (b.tick, b.kind, b.field));
            assert_eq!(bits(&[a.before, a.after]), bits(&[b.before, b.after]));
        }
        assert_eq!(f1.detected, f2.detected);
        assert_eq!((c1, t1.estimates.len()), (c2, t2.estimates.len()));
        assert_eq!(t1.estimates, t2.estimates);
        assert_eq!(t1.truth_tick.len() as u64, n);
        for (a, b) in [
            (&t1.attitude, &t2.attitude),
            (&t1.tm_acc, &t2.tm_acc),
            (&t1.star_q, &t2.star_q),
            (&t1.is_volts[0], &t2.is_volts[0]),
            (&t1.is_volts[1], &t2.is_volts[1]),
        ] {
            assert_eq!(bits(a), bits(b));
        }
    }

    /// Takes `left` ticks, then fails like a full disk.
    struct Failing {
        left: u32,
    }

    impl Sink for Failing {
        fn record(&mut self, _: &TruthState, _: &SensorSample) -> Result<(), TelemetryError> {
            self.left = self.left.checked_sub(1).ok_or_else(|| {
                TelemetryError::from(crate::sim::files::FileError::write(
                    "telemetry.h5",
                    std::io::Error::other("disk full"),
                ))
            })?;
            Ok(())
        }
        fn record_estimate(&mut self, _: &EstimateMsg) -> Result<(), TelemetryError> {
            Ok(())
        }
    }

    #[test]
    fn a_recording_error_ends_the_campaign_with_it_on_either_threads() {
        let s = Scenario::default();
        for threads in [Threads::One, Threads::Two] {
            let mut sink = Failing { left: 3000 };
            let mut last = 0.0;
            let r = run_with(
                &s,
                1,
                Method::Joint,
                threads,
                |f| last = f,
                Some(&mut sink),
                None,
            );
            let e = r.err().map(|e| e.to_string());
            assert_eq!(
                e.as_deref(),
                Some("cannot write telemetry.h5: disk full"),
                "{threads:?}"
            );
            assert!(last < 0.1, "{threads:?}: ran on to {last}");
        }
    }
}
