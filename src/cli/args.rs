//! The command line's arguments: subcommands and their options (clap).

use crate::analysis::montecarlo;
use crate::sim::estimate::Method;
use crate::telemetry::Compression;
use clap::{Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

pub(crate) use super::ground_args::GroundCmd;

#[derive(Parser)]
#[command(
    name = "taiji-calib",
    version,
    about = "In-orbit calibration of the Taiji inertial sensors"
)]
pub(crate) struct Cli {
    #[command(subcommand)]
    pub(crate) cmd: Cmd,
}

#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum MethodArg {
    /// Joint angle-domain estimator (reaches the CRLB).
    Joint,
    /// The paper's route, for comparison.
    Paper,
}

impl From<MethodArg> for Method {
    fn from(m: MethodArg) -> Self {
        match m {
            MethodArg::Joint => Method::Joint,
            MethodArg::Paper => Method::Paper,
        }
    }
}

#[derive(Subcommand)]
pub(crate) enum Cmd {
    /// Run the whole campaign in this process and write DIR/report.json.
    Run {
        /// Scenario file (TOML; see scenarios/); the paper's case when absent.
        #[arg(long)]
        scenario: Option<PathBuf>,
        /// Seed of every noise stream (overrides the scenario's `seed`).
        #[arg(long)]
        seed: Option<u64>,
        /// Output folder: report.json, report.md, report.html (and telemetry, plots).
        #[arg(long, default_value = "out")]
        out: PathBuf,
        #[arg(long, value_enum, default_value = "joint")]
        method: MethodArg,
        /// Record every stream to DIR/telemetry.h5.
        #[arg(long)]
        record: bool,
        /// With --record: each chunk shuffled and deflated at this level (1–9), or
        /// `none`.
        #[arg(long, default_value_t = Compression::DEFAULT, value_name = "none|N")]
        record_compression: Compression,
        /// Also draw the figures to DIR/plots/ (PNG and SVG; implies --record); the
        /// reports embed them.
        #[arg(long)]
        plots: bool,
    },
    /// Run the estimator on a recording's star-tracker and IS channels (never truth)
    /// and write DIR/report.json.
    Replay {
        /// A telemetry.h5 (ours, or another tool's in the documented layout).
        #[arg(long)]
        telemetry: PathBuf,
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Estimator (default: the recording's `method` attribute, else joint).
        #[arg(long, value_enum)]
        method: Option<MethodArg>,
        /// Follow a recording still being written: at the end of its rows, wait for
        /// more, until the campaign's last sample or FOLLOW_IDLE_S without a new row.
        #[arg(long)]
        follow: bool,
        /// With --follow: seconds without a new row after which the recording is
        /// taken as ended.
        #[arg(long, default_value_t = 30.0, value_name = "S")]
        follow_idle_s: f64,
        /// Exit non-zero (2) on a truncated recording instead of replaying its rows.
        #[arg(long)]
        complete: bool,
    },
    /// Write a recording as the C library's inputs: DIR/estimator_config.bin (the
    /// estimator's table) and DIR/sensor_samples.bin (the samples replay feeds), each
    /// in its repr(C) layout of include/taiji_estimator.h (see tools/c-host).
    Export {
        /// A telemetry.h5 (ours, or another tool's in the documented layout).
        #[arg(long)]
        telemetry: PathBuf,
        #[arg(long, default_value = "out/export")]
        out: PathBuf,
    },
    /// Run N seeds and report RMS error, normalized error, CRLB ratio and pass count;
    /// `--shard I/N` runs a share of the seeds (a cluster job), `merge` sums the shares.
    #[command(args_conflicts_with_subcommands = true)]
    Montecarlo {
        #[command(subcommand)]
        merge: Option<MonteCarloCmd>,
        #[command(flatten)]
        args: MonteCarloArgs,
    },
    /// Fly a mission (the scenario's `[timeline]` and `[drift]`): campaign after
    /// campaign, each applied by function 3's rules and taken into the trend filters;
    /// write DIR/timeline.json, DIR/report.md and DIR/plots/timeline_*.png/.svg.
    Timeline {
        /// Scenario file (TOML); without `[timeline]`, a year with `campaigns = "auto"`.
        #[arg(long)]
        scenario: Option<PathBuf>,
        /// The mission's seed: its truths' history, and every campaign's seed from it
        /// (overrides the scenario's `seed`).
        #[arg(long)]
        seed: Option<u64>,
        #[arg(long, default_value = "out")]
        out: PathBuf,
        #[arg(long, value_enum, default_value = "joint")]
        method: MethodArg,
    },
    /// Print the Cramér–Rao bound of β, k, r for a scenario.
    Crlb {
        #[arg(long)]
        scenario: Option<PathBuf>,
    },
    /// Plan the calibration maneuver for a window from the Cramér–Rao bound: print the
    /// best candidates, write DIR/maneuver.toml, DIR/plan.json and the figure
    /// DIR/plan_bound.png/.svg.
    Plan {
        /// Scenario file (TOML); its `[maneuver]` limits bind the plan, its waveform is
        /// replaced. The paper's case when absent.
        #[arg(long)]
        scenario: Option<PathBuf>,
        /// The window [s] (default: the scenario's duration_s).
        #[arg(long)]
        duration: Option<f64>,
        /// Find the shortest window whose plan meets every requirement with --margin.
        #[arg(long)]
        min_duration: bool,
        /// Margin on the bound for --min-duration: worst CRLB / requirement ≤ 1 / M.
        #[arg(long, default_value_t = 3.0)]
        margin: f64,
        /// Candidates to print.
        #[arg(long, default_value_t = 8)]
        top: usize,
        #[arg(long, default_value = "out/plan")]
        out: PathBuf,
    },
    /// Watch a running process set live (terminal UI; --once prints one snapshot):
    /// estimates against the bound, status, rejections, latency, every process. It
    /// changes nothing in the run; `q` leaves the monitor only.
    Monitor(crate::runtime::monitor::MonitorArgs),
    /// The ground side of the link: one subcommand per telecommand, `listen` for the
    /// telemetry, and the dictionary of packets, services, functions, failure codes,
    /// events, parameters and housekeeping layouts (docs/ground.md).
    Ground {
        #[command(subcommand)]
        cmd: GroundCmd,
    },
}

#[derive(clap::Args)]
pub(crate) struct MonteCarloArgs {
    /// Number of seeds (campaigns) to run, at least 1
    #[arg(long, default_value_t = 30, value_parser = clap::value_parser!(u64).range(1..))]
    pub(crate) runs: u64,
    #[arg(long)]
    pub(crate) scenario: Option<PathBuf>,
    #[arg(long, value_enum, default_value = "joint")]
    pub(crate) method: MethodArg,
    /// First seed; run i uses seed + i.
    #[arg(long)]
    pub(crate) seed: Option<u64>,
    /// Write the per-run results here as JSON (with --shard: DIR/run-<seed>.json).
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    /// Run only shard I of N (I from 0 to N-1): runs i with i % N == I, one result
    /// file per seed in --out; seeds already there are kept. Then `montecarlo merge`.
    #[arg(long, value_name = "I/N", requires = "out")]
    pub(crate) shard: Option<montecarlo::shard::Shard>,
}

#[derive(Subcommand)]
pub(crate) enum MonteCarloCmd {
    /// Check that the shards' result files make one whole campaign (every seed once,
    /// one scenario, estimator and build) and print the table of a single-machine run.
    Merge {
        /// Folders holding run-<seed>.json files.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Write DIR/montecarlo.json, as `montecarlo --out DIR` would.
        #[arg(long)]
        out: Option<PathBuf>,
    },
}
