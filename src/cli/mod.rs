//! `taiji-calib`: run the calibration campaign in one process, replay or export a
//! recording, a Monte Carlo over seeds, the Cramér–Rao bound of a scenario, the
//! maneuver planner, the live monitor of a running set, or the ground side of the
//! link (telecommands, telemetry, the dictionary). One file per subcommand group; `src/bin/taiji-calib.rs` only calls [`main`].

mod analysis;
mod args;
mod campaign;
mod error;
mod ground;
mod ground_args;
mod output;
mod replay;
mod timeline;

use crate::analysis::montecarlo;
use analysis::{monte_carlo, montecarlo_out, plan, print_crlb};
use args::{Cli, Cmd, MonteCarloCmd};
use campaign::run_campaign;
use clap::Parser as _;
use error::CliError;
use output::{check_out, or_remove_new};
use replay::{export, replay, ReplayHow};
use std::process::ExitCode;

/// The command line: parse, run, print an error as one line with its exit code.
pub fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    match run(Cli::parse()) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}

pub(crate) fn run(cli: Cli) -> Result<ExitCode, CliError> {
    match cli.cmd {
        Cmd::Run {
            scenario,
            seed,
            out,
            method,
            record,
            record_compression,
            plots,
        } => run_campaign(
            scenario.as_deref(),
            seed,
            &out,
            method.into(),
            (record || plots).then_some(record_compression),
            plots,
        ),
        Cmd::Replay {
            telemetry,
            out,
            method,
            follow,
            follow_idle_s,
            complete,
        } => {
            let how = ReplayHow {
                method,
                follow: follow.then(|| std::time::Duration::from_secs_f64(follow_idle_s.max(0.0))),
                complete,
            };
            or_remove_new(&out, || replay(&telemetry, &out, how))
        }
        Cmd::Export { telemetry, out } => or_remove_new(&out, || export(&telemetry, &out)),
        Cmd::Montecarlo {
            merge: Some(MonteCarloCmd::Merge { dirs, out }),
            ..
        } => {
            if let Some(out) = &out {
                check_out(out)?;
            }
            montecarlo_out(&montecarlo::shard::merge(&dirs)?, out)
        }
        Cmd::Montecarlo { merge: None, args } => monte_carlo(args),
        Cmd::Timeline {
            scenario,
            seed,
            out,
            method,
        } => timeline::run(scenario.as_deref(), seed, &out, method.into()),
        Cmd::Crlb { scenario } => print_crlb(scenario.as_deref()),
        Cmd::Plan {
            scenario,
            duration,
            min_duration,
            margin,
            top,
            out,
        } => plan(
            scenario.as_deref(),
            duration,
            min_duration.then_some(margin),
            top,
            &out,
        ),
        Cmd::Monitor(args) => Ok(ExitCode::from(crate::runtime::monitor::run(&args)?)),
        Cmd::Ground { cmd } => ground::run(cmd),
    }
}
