//! `run`: the campaign in this process, with its maneuver planned when the scenario
//! has none, recorded and drawn on request.

use super::error::CliError;
use super::output::{check_out, finish, out_dir};
use crate::analysis::progress::Bar;
use crate::analysis::report::Report;
use crate::sim::estimate::Method;
use crate::sim::scenario::Scenario;
use crate::telemetry::{Compression, Meta};
use std::process::ExitCode;

/// Load the scenario and plan its maneuver when it has none (printing the choice).
pub(crate) fn load_planned(
    path: Option<&std::path::Path>,
) -> Result<(Scenario, Option<crate::analysis::plan::PlanInfo>), CliError> {
    let s = Scenario::load_or_default(path)?;
    let (s, plan) = crate::analysis::plan::resolve(s)?;
    if let Some(p) = &plan {
        let how = if p.cached {
            "from the plan cache".to_string()
        } else {
            format!("{} candidates, {:.2} s", p.candidates, p.elapsed_s)
        };
        log::info!(
            "planned the maneuver ({how}): {}",
            crate::analysis::plan::describe(&s, None, Some(p)).line()
        );
    }
    Ok((s, plan))
}

/// `run`: the campaign in this process, recorded and drawn on request.
pub(crate) fn run_campaign(
    scenario: Option<&std::path::Path>,
    seed: Option<u64>,
    out: &std::path::Path,
    method: Method,
    record: Option<Compression>,
    plots: bool,
) -> Result<ExitCode, CliError> {
    check_out(out)?;
    let (s, plan) = load_planned(scenario)?;
    // `--seed` is the scenario's seed from here on: every noise stream and the priors'
    // ground-calibration draw, as in the Monte Carlo's run of that seed (the maneuver
    // stays the one planned for the file).
    let seed = seed.unwrap_or(s.seed);
    let s = Scenario { seed, ..s };
    let t0 = std::time::Instant::now();
    let bar = Bar::new(1000, "campaign");
    let tick = |f: f64| bar.set((f * 1000.0) as u64);
    let (mut report, tel) = if record.is_some() || plots {
        // The recording streams to the folder as the campaign runs.
        out_dir(out)?;
        // The maneuver's bound (its motion alone) on a thread beside the campaign; the
        // run's (at its seed: its torque noise's motion and the data it lost) from the
        // campaign's own simulation (`crlb::run_with_bound`).
        let maneuver = {
            let s = s.clone();
            std::thread::spawn(move || crate::analysis::plan::maneuver_bound(&s))
        };
        let (estimate, tel, faults, run_bound) =
            recorded_campaign(&s, seed, method, out, record, plots, tick)?;
        let maneuver = maneuver
            .join()
            .unwrap_or_else(|e| std::panic::resume_unwind(e));
        let bounds = crate::analysis::crlb::Bounds {
            run: run_bound.ok_or(CliError::Unexcited)?,
            maneuver,
        };
        let mut report =
            Report::with_bounds(&s, seed, "in-process", method.name(), &estimate, &bounds);
        report.faults = faults.map(|f| f.summary());
        (report, tel)
    } else {
        let threads = crate::analysis::campaign::Threads::available();
        let report = crate::analysis::campaign_report::run(&s, seed, method, threads, tick)
            .map_err(|_| CliError::Unexcited)?;
        (report, None)
    };
    bar.finish();
    if let (Some(m), Some(p)) = (report.maneuver.as_mut(), &plan) {
        m.search = Some(p.search_json());
    }
    report.wall_time_s = Some(t0.elapsed().as_secs_f64());
    if let (true, Some(tel)) = (plots, &tel) {
        crate::analysis::plots::write_all(tel, &s, out)?;
    }
    finish(out, &report, plots)
}

/// What a recorded campaign gives: the final estimate, the streams in memory, the fault
/// score and the run's bound.
type Recorded = (
    crate::sim::msg::EstimateMsg,
    Option<crate::telemetry::Telemetry>,
    Option<crate::sim::faults::FaultScore>,
    Option<crate::analysis::crlb::Crlb>,
);

/// The final estimate, the streams in memory (with `plots`), the fault score and the
/// run's bound of a campaign recorded as it runs: to DIR/telemetry.h5 with `record`.
pub(crate) fn recorded_campaign(
    s: &Scenario,
    seed: u64,
    method: Method,
    out: &std::path::Path,
    record: Option<Compression>,
    plots: bool,
    tick: impl FnMut(f64),
) -> Result<Recorded, CliError> {
    // The recording streams to disk as the campaign runs; figures need the streams in
    // memory.
    let mut file = match record {
        Some(z) => Some(crate::telemetry::Writer::create_with(
            &out.join("telemetry.h5"),
            &Meta::of(s, seed, method.name(), "in-process"),
            s.n_samples(),
            crate::telemetry::CHUNK_ROWS,
            z,
        )?),
        None => None,
    };
    let mut tel = plots.then(|| {
        let n = s.n_samples();
        crate::telemetry::Telemetry::new(s.inertial_sensor.len(), s.sample_rate_hz, n)
    });
    let mut sink = crate::telemetry::Tee {
        memory: tel.as_mut(),
        file: file.as_mut(),
    };
    let threads = crate::analysis::campaign::Threads::available();
    let (res, bound) =
        crate::analysis::crlb::run_with_bound(s, seed, method, threads, tick, Some(&mut sink))?;
    if let Some(f) = file {
        let (r, d) = res
            .faults
            .as_ref()
            .map_or((&[][..], &[][..]), |f| (&f.records[..], &f.detected[..]));
        f.finish(r, d)?;
    }
    if let (Some(t), Some(f)) = (tel.as_mut(), &res.faults) {
        t.faults = f.records.clone();
        t.faults_detected = f.detected.clone();
    }
    Ok((res.estimate, tel, res.faults, bound))
}
