//! `montecarlo`, `crlb` and `plan`: the analyses that print a table.

use super::args::MonteCarloArgs;
use super::campaign::load_planned;
use super::error::CliError;
use super::output::{check_out, out_dir};
use crate::analysis::montecarlo;
use crate::sim::files::FileError;
use crate::sim::scenario::Scenario;
use std::path::PathBuf;
use std::process::ExitCode;

/// Print the table; with `out`, write DIR/montecarlo.json.
pub(crate) fn montecarlo_out(
    mc: &montecarlo::MonteCarlo,
    out: Option<PathBuf>,
) -> Result<ExitCode, CliError> {
    print!("{}", mc.table());
    if let Some(out) = out {
        std::fs::create_dir_all(&out)
            .map_err(|source| CliError::from(FileError::create(out.clone(), source)))?;
        let path = out.join("montecarlo.json");
        let text = serde_json::to_string_pretty(mc)?;
        std::fs::write(&path, text)
            .map_err(|source| CliError::from(FileError::write(path, source)))?;
    }
    Ok(ExitCode::SUCCESS)
}

/// `montecarlo`: every seed here, or one shard's seeds to result files.
pub(crate) fn monte_carlo(args: MonteCarloArgs) -> Result<ExitCode, CliError> {
    let MonteCarloArgs {
        runs,
        scenario,
        method,
        seed,
        out,
        shard,
    } = args;
    if let Some(out) = &out {
        check_out(out)?;
    }
    let (s, _) = load_planned(scenario.as_deref())?;
    let first = seed.unwrap_or(s.seed);
    if let (Some(shard), Some(dir)) = (shard, &out) {
        out_dir(dir)?;
        let build = montecarlo::shard::build_id()?;
        let m = method.into();
        let done = montecarlo::shard::run_shard(&s, first, runs, m, shard, &build, dir)?;
        println!(
            "shard {shard}: ran {} seed(s), kept {} already in {}; then: taiji-calib montecarlo merge DIR...",
            done.ran.len(),
            done.kept.len(),
            dir.display()
        );
        return Ok(ExitCode::SUCCESS);
    }
    montecarlo_out(&montecarlo::run(&s, first, runs, method.into())?, out)
}

/// `crlb`: print the bound of β, k, r.
pub(crate) fn print_crlb(scenario: Option<&std::path::Path>) -> Result<ExitCode, CliError> {
    let (s, _) = load_planned(scenario)?;
    let c = crate::analysis::crlb::crlb(&s).ok_or(CliError::Singular)?;
    // Planned values are raw floats (0.0006000240009600384 Hz): printed to the
    // precision a reader compares them at.
    let torque: Vec<String> = s
        .maneuver
        .torque_amplitude_nm
        .iter()
        .map(|t| format!("{t:.3e}"))
        .collect();
    println!(
        "Cramér–Rao bound (1σ) for scenario {:?}: {} s, maneuver {:.4} mHz, torque [{}] N m",
        s.name,
        s.duration_s,
        s.maneuver.frequency_hz * 1e3,
        torque.join(", ")
    );
    if s.faults.loses_data() {
        println!(
            "(the bound of the data a run at seed {} keeps: the ticks its [faults] dropouts and missing ticks lose are left out)",
            s.seed
        );
    }
    let print = |prefix: &str, c: &crate::analysis::crlb::Crlb| {
        for (i, is) in s.inertial_sensor.iter().enumerate() {
            let rel: Vec<String> = (0..3)
                .map(|a| format!("{:.2e}", c.beta[i][a] / is.beta[a]))
                .collect();
            let r: Vec<String> = (0..3)
                .map(|a| format!("{:.3} µm", c.com_offset_m[i][a] * 1e6))
                .collect();
            println!(
                "{prefix}IS{}  β (relative, = k relative): [{}]   r: [{}]",
                i + 1,
                rel.join(", "),
                r.join(", ")
            );
        }
    };
    print("", &c);
    if crate::analysis::crlb::seed_matters(&s) {
        println!(
            "(a run at seed {}: the maneuver's motion and the random motion its thrusters add; the maneuver's alone, at the planner's search rate, is what it promises before any run:)",
            s.seed
        );
        match crate::analysis::plan::maneuver_bound(&s) {
            Some(m) => print("maneuver alone: ", &m),
            None => println!("maneuver alone: singular (it leaves a parameter unbounded)"),
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// `plan`: the maneuver for a window, or (`min_duration_margin`) the shortest window.
pub(crate) fn plan(
    scenario: Option<&std::path::Path>,
    duration: Option<f64>,
    min_duration_margin: Option<f64>,
    top: usize,
    out: &std::path::Path,
) -> Result<ExitCode, CliError> {
    if let Some(d) = duration {
        if !(d.is_finite() && d > 0.0 && d <= crate::sim::scenario::MAX_DURATION_S) {
            return Err(CliError::Duration { duration: d });
        }
    }
    check_out(out)?;
    let s = Scenario::load_or_default(scenario)?;
    let plan = match min_duration_margin {
        Some(margin) => crate::analysis::plan::min_duration(&s, margin),
        None => crate::analysis::plan::plan(
            &s,
            &crate::analysis::plan::PlanOptions {
                duration_s: duration,
                amplitude_sweep: true,
                exact: true,
            },
        ),
    }?;
    if let Some(why) = &plan.shortfall {
        return Err(CliError::Shortfall { why: why.clone() });
    }
    out_dir(out)?;
    crate::analysis::plan::write(&s, &plan, out, top, min_duration_margin)?;
    Ok(ExitCode::SUCCESS)
}
