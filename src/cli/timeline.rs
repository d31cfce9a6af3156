//! `timeline`: a mission, campaign after campaign (`analysis::mission`).

use super::campaign::load_planned;
use super::error::CliError;
use super::output::{check_out, out_dir};
use crate::analysis::mission::{self, figures, output, schedule};
use crate::sim::estimate::Method;
use crate::sim::scenario::Scenario;
use std::process::ExitCode;

/// Share of parameter-days every group must meet its requirement on for exit 0.
pub const MET_SHARE: f64 = 0.995;

/// Fly the mission of `scenario` at `seed` into `out`. Exit 0 when every group met
/// its requirement on at least 99.5 % of its parameter-days, 1 otherwise, 2 on a bad
/// scenario or option.
pub(crate) fn run(
    scenario: Option<&std::path::Path>,
    seed: Option<u64>,
    out: &std::path::Path,
    method: Method,
) -> Result<ExitCode, CliError> {
    check_out(out)?;
    let (s, _) = load_planned(scenario)?;
    let seed = seed.unwrap_or(s.seed);
    let s = Scenario { seed, ..s };
    for w in s.truth_warnings() {
        log::warn!("{w}");
    }
    let threads = crate::analysis::campaign::Threads::available();
    let m = mission::run(&s, seed, method, threads, |c| {
        log::info!(
            "campaign on day {:.2}: {}",
            c.day,
            if c.applied { "applied" } else { "not applied" }
        )
    });
    out_dir(out)?;
    output::write_json(&m, out)?;
    let z = schedule::two_sided_quantile(m.confidence);
    let figs = figures::write(&m, &s, z, out)?;
    let stems: Vec<String> = figs
        .iter()
        .filter_map(|p| p.file_stem().map(|f| f.to_string_lossy().into_owned()))
        .collect();
    output::write_markdown(&m, out, &stems)?;
    print!("{}", output::summary_text(&m));
    println!("Timeline: {}", out.join("timeline.json").display());
    let met = m
        .summary
        .iter()
        .all(|g| g.requirement_met_share >= MET_SHARE);
    Ok(if met {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
