//! `taiji-calib`: run the calibration campaign in one process, a Monte Carlo over
//! seeds, or the Cramér–Rao bound of a scenario.

use clap::{Parser, Subcommand, ValueEnum};
use std::path::PathBuf;
use std::process::ExitCode;
use taiji::estimate::Method;
use taiji::montecarlo;
use taiji::progress::Bar;
use taiji::report::Report;
use taiji::scenario::Scenario;
use taiji::telemetry::{Compression, Meta};

#[derive(Parser)]
#[command(
    name = "taiji-calib",
    version,
    about = "In-orbit calibration of the Taiji inertial sensors"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Clone, Copy, ValueEnum)]
enum MethodArg {
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
enum Cmd {
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
    Monitor(taiji::monitor::MonitorArgs),
}

#[derive(clap::Args)]
struct MonteCarloArgs {
    /// Number of seeds (campaigns) to run, at least 1
    #[arg(long, default_value_t = 30, value_parser = clap::value_parser!(u64).range(1..))]
    runs: u64,
    #[arg(long)]
    scenario: Option<PathBuf>,
    #[arg(long, value_enum, default_value = "joint")]
    method: MethodArg,
    /// First seed; run i uses seed + i.
    #[arg(long)]
    seed: Option<u64>,
    /// Write the per-run results here as JSON (with --shard: DIR/run-<seed>.json).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Run only shard I of N (I from 0 to N-1): runs i with i % N == I, one result
    /// file per seed in --out; seeds already there are kept. Then `montecarlo merge`.
    #[arg(long, value_name = "I/N", requires = "out")]
    shard: Option<montecarlo::shard::Shard>,
}

#[derive(Subcommand)]
enum MonteCarloCmd {
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

/// Every error of the CLI: one line naming the option, key or file, printed as
/// `error: …` with exit code 2.
#[derive(Debug, thiserror::Error)]
enum CliError {
    /// `--out`: the folder cannot be made.
    #[error("--out {}: cannot create this folder ({source})", path.display())]
    OutDir {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot create {}: {source}", path.display())]
    Create {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot write {}: {source}", path.display())]
    Write {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{0}")]
    Json(#[from] serde_json::Error),
    /// `--duration` is not a window in seconds.
    #[error(
        "--duration: must be a window in seconds, up to {} s, got {duration}",
        taiji::scenario::MAX_DURATION_S
    )]
    Duration { duration: f64 },
    /// A truncated recording where `--complete` asked for a whole one.
    #[error("{what}")]
    Truncated { what: String },
    /// The recording's `method` attribute names no estimator.
    #[error("{}: attribute `method`: {source}", path.display())]
    MethodAttribute {
        path: PathBuf,
        #[source]
        source: Box<taiji::process::ProcessError>,
    },
    /// The bound of the scenario does not exist (`crlb`).
    #[error("the Fisher information of this scenario is singular")]
    Singular,
    /// The bound does not exist because the maneuver misses a parameter.
    #[error("the Fisher information of this scenario is singular: the maneuver does not excite every parameter")]
    Unexcited,
    /// `plan`: the best maneuver misses a requirement; `why` names what binds it.
    #[error("{why}")]
    Shortfall { why: String },
    #[error(transparent)]
    Scenario(#[from] taiji::scenario::ScenarioError),
    #[error(transparent)]
    Plan(#[from] taiji::plan::PlanError),
    #[error(transparent)]
    Telemetry(#[from] taiji::telemetry::TelemetryError),
    #[error(transparent)]
    Export(#[from] taiji::export::ExportError),
    #[error(transparent)]
    MonteCarlo(#[from] montecarlo::MonteCarloError),
    #[error(transparent)]
    Report(#[from] taiji::report::ReportError),
    #[error(transparent)]
    Plot(#[from] taiji::plots::PlotError),
    #[error(transparent)]
    Monitor(#[from] taiji::monitor::MonitorError),
}

impl CliError {
    /// The process's exit code: 2 for every error (1 is a run whose requirements are
    /// not met, or a monitor that found no run; 0 success).
    fn exit_code(&self) -> u8 {
        match self {
            // Nothing to watch (no run on the prefix) is no user error.
            CliError::Monitor(e) => e.exit_code(),
            _ => 2,
        }
    }
}

/// Print the table; with `out`, write DIR/montecarlo.json.
fn montecarlo_out(mc: &montecarlo::MonteCarlo, out: Option<PathBuf>) -> Result<ExitCode, CliError> {
    print!("{}", mc.table());
    if let Some(out) = out {
        std::fs::create_dir_all(&out).map_err(|source| CliError::Create {
            path: out.clone(),
            source,
        })?;
        let path = out.join("montecarlo.json");
        let text = serde_json::to_string_pretty(mc)?;
        std::fs::write(&path, text).map_err(|source| CliError::Write { path, source })?;
    }
    Ok(ExitCode::SUCCESS)
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    match run(Cli::parse()) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}

/// Refuse an `--out` where no folder can be made (a path through a file) before any
/// work, so a campaign is not run for nothing, but without creating it: a user error
/// found later (a bad scenario, a bad recording) must leave no empty folder behind.
fn check_out(out: &std::path::Path) -> Result<(), CliError> {
    let refuse = |source| CliError::OutDir {
        path: out.to_path_buf(),
        source,
    };
    // The nearest existing ancestor decides (an empty one is the working folder).
    for a in out.ancestors().filter(|a| !a.as_os_str().is_empty()) {
        match std::fs::metadata(a) {
            Ok(m) if m.is_dir() => return Ok(()),
            Ok(_) => {
                let why = format!("{} is not a folder", a.display());
                return Err(refuse(std::io::Error::other(why)));
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => return Err(refuse(e)),
        }
    }
    Ok(())
}

/// Create the output folder, once the inputs are known good and something is about to
/// be written there.
fn out_dir(out: &std::path::Path) -> Result<(), CliError> {
    std::fs::create_dir_all(out).map_err(|source| CliError::OutDir {
        path: out.to_path_buf(),
        source,
    })
}

/// Run `f`, which creates `out`; when it fails and `out` did not exist before, remove
/// what it made: a recording found bad while being read (replay, export) leaves
/// neither an empty folder nor a half-written export.
fn or_remove_new(
    out: &std::path::Path,
    f: impl FnOnce() -> Result<ExitCode, CliError>,
) -> Result<ExitCode, CliError> {
    let existed = out.exists();
    let r = f();
    if r.is_err() && !existed {
        let _ = std::fs::remove_dir_all(out);
    }
    r
}

/// Load the scenario and plan its maneuver when it has none (printing the choice).
fn load_planned(
    path: Option<&std::path::Path>,
) -> Result<(Scenario, Option<taiji::plan::PlanInfo>), CliError> {
    let s = Scenario::load_or_default(path)?;
    let (s, plan) = taiji::plan::resolve(s)?;
    if let Some(p) = &plan {
        let how = if p.cached {
            "from the plan cache".to_string()
        } else {
            format!("{} candidates, {:.2} s", p.candidates, p.elapsed_s)
        };
        log::info!(
            "planned the maneuver ({how}): {}",
            taiji::plan::describe(&s, None, Some(p)).line()
        );
    }
    Ok((s, plan))
}

/// Write report.json, .md and .html, print the table; exit 0 when the requirements
/// are met and the estimator verified its result, else 1.
fn finish(out: &std::path::Path, report: &Report, figures: bool) -> Result<ExitCode, CliError> {
    out_dir(out)?;
    taiji::report::write(out, report)?;
    taiji::report_doc::write(report, out, figures)?;
    print!("{}", report.table());
    println!("Report: {}", out.join("report.json").display());
    Ok(if report.requirements.met && report.requirements.verified {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

fn run(cli: Cli) -> Result<ExitCode, CliError> {
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
        Cmd::Monitor(args) => Ok(ExitCode::from(taiji::monitor::run(&args)?)),
    }
}

/// `run`: the campaign in this process, recorded and drawn on request.
fn run_campaign(
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
    // The maneuver's bound (its motion alone) on a thread beside the campaign; the
    // run's (at its seed: its torque noise's motion and the data it lost) from the
    // campaign's own simulation (`crlb::run_with_bound`).
    let maneuver = {
        let s = s.clone();
        std::thread::spawn(move || taiji::plan::maneuver_bound(&s))
    };
    let bar = Bar::new(1000, "campaign");
    let tick = |f: f64| bar.set((f * 1000.0) as u64);
    let (estimate, tel, faults, run_bound) = if record.is_some() || plots {
        // The recording streams to the folder as the campaign runs.
        out_dir(out)?;
        recorded_campaign(&s, seed, method, out, record, plots, tick)?
    } else {
        let threads = taiji::campaign::Threads::available();
        let (res, bound) = taiji::crlb::run_with_bound(&s, seed, method, threads, tick, None)
            .unwrap_or_else(|e| unreachable!("a campaign that records nothing cannot fail: {e}"));
        (res.estimate, None, res.faults, bound)
    };
    bar.finish();
    let maneuver = maneuver
        .join()
        .unwrap_or_else(|e| std::panic::resume_unwind(e));
    let bounds = taiji::crlb::Bounds {
        run: run_bound.ok_or(CliError::Unexcited)?,
        maneuver,
    };
    let mut report = Report::with_bounds(&s, seed, "in-process", method.name(), &estimate, &bounds);
    if let (Some(m), Some(p)) = (report.maneuver.as_mut(), &plan) {
        m.search = Some(p.search_json());
    }
    report.faults = faults.map(|f| f.summary());
    report.wall_time_s = Some(t0.elapsed().as_secs_f64());
    if let (true, Some(tel)) = (plots, &tel) {
        taiji::plots::write_all(tel, &s, out)?;
    }
    finish(out, &report, plots)
}

/// What a recorded campaign gives: the final estimate, the streams in memory, the fault
/// score and the run's bound.
type Recorded = (
    taiji::msg::EstimateMsg,
    Option<taiji::telemetry::Telemetry>,
    Option<taiji::faults::FaultScore>,
    Option<taiji::crlb::Crlb>,
);

/// The final estimate, the streams in memory (with `plots`), the fault score and the
/// run's bound of a campaign recorded as it runs: to DIR/telemetry.h5 with `record`.
fn recorded_campaign(
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
        Some(z) => Some(taiji::telemetry::Writer::create_with(
            &out.join("telemetry.h5"),
            &Meta::of(s, seed, method.name(), "in-process"),
            s.n_samples(),
            taiji::telemetry::CHUNK_ROWS,
            z,
        )?),
        None => None,
    };
    let mut tel = plots.then(|| {
        let n = s.n_samples();
        taiji::telemetry::Telemetry::new(s.inertial_sensor.len(), s.sample_rate_hz, n)
    });
    let mut sink = taiji::telemetry::Tee {
        memory: tel.as_mut(),
        file: file.as_mut(),
    };
    let threads = taiji::campaign::Threads::available();
    let (res, bound) =
        taiji::crlb::run_with_bound(s, seed, method, threads, tick, Some(&mut sink))?;
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

/// How `replay` reads its recording.
struct ReplayHow {
    method: Option<MethodArg>,
    /// Follow a growing file, waiting this long for each new row.
    follow: Option<std::time::Duration>,
    /// A truncated recording is an error.
    complete: bool,
}

/// A truncated recording said plainly; an error where the user asked for a whole one.
fn truncated(
    path: &std::path::Path,
    t: taiji::telemetry::read::Truncation,
    complete: bool,
) -> Result<(), CliError> {
    let what = format!(
        "{}: a truncated recording: {} of {} samples, the last at tick {} (its writer stopped before the end)",
        path.display(),
        t.rows,
        t.expected,
        t.last_tick
    );
    if complete {
        return Err(CliError::Truncated {
            what: format!("{what}; --complete asks for a whole one"),
        });
    }
    eprintln!("warning: {what}; replaying those samples");
    Ok(())
}

/// `replay`: the estimator on a recording's sensor channels.
fn replay(
    telemetry: &std::path::Path,
    out: &std::path::Path,
    how: ReplayHow,
) -> Result<ExitCode, CliError> {
    let t0 = std::time::Instant::now();
    check_out(out)?;
    let rec = match how.follow {
        Some(idle) => taiji::telemetry::read::open_following(telemetry, idle)?,
        None => taiji::telemetry::read::open(telemetry)?,
    };
    if let (Some(t), None) = (rec.truncation(), how.follow) {
        truncated(telemetry, t, how.complete)?;
    }
    let method: Method = match (how.method, rec.method.as_deref()) {
        (Some(m), _) => m.into(),
        (None, Some(name)) => {
            taiji::process::parse_method(name).map_err(|source| CliError::MethodAttribute {
                path: telemetry.to_path_buf(),
                source: Box::new(source),
            })?
        }
        (None, None) => Method::Joint,
    };
    let bar = Bar::new(1000, "replay");
    let res = taiji::replay::run(&rec, method, |f| bar.set((f * 1000.0) as u64))?;
    bar.finish();
    // The bound and the requirements of the samples replayed: a truncated recording's
    // campaign ends at its last row.
    let mut s = rec.scenario.clone();
    s.seed = rec.seed;
    if let Some(t) = rec.truncation() {
        if how.follow.is_some() {
            truncated(telemetry, t, how.complete)?;
        }
        s.duration_s = t.rows as f64 / s.sample_rate_hz;
    }
    let bounds = match (taiji::plan::bounds(&s), rec.truncation()) {
        (Some(b), _) => b,
        // Too short a piece of the campaign to bound every parameter: no bound.
        (None, Some(_)) => taiji::crlb::Bounds {
            run: taiji::crlb::Crlb::INFINITE,
            maneuver: None,
        },
        (None, None) => return Err(CliError::Unexcited),
    };
    let mut report = Report::with_bounds(
        &s,
        rec.seed,
        "replay",
        method.name(),
        &res.estimate,
        &bounds,
    );
    report.faults = res.faults.map(|f| f.summary());
    report.wall_time_s = Some(t0.elapsed().as_secs_f64());
    finish(out, &report, false)
}

/// `export`: a recording as the C library's inputs.
fn export(telemetry: &std::path::Path, out: &std::path::Path) -> Result<ExitCode, CliError> {
    check_out(out)?;
    let rec = taiji::telemetry::read::open(telemetry)?;
    if let Some(t) = rec.truncation() {
        truncated(telemetry, t, false)?;
    }
    out_dir(out)?;
    let n = taiji::export::write(&rec, out)?;
    println!(
        "exported {n} samples and the estimator table to {}",
        out.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// `montecarlo`: every seed here, or one shard's seeds to result files.
fn monte_carlo(args: MonteCarloArgs) -> Result<ExitCode, CliError> {
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
fn print_crlb(scenario: Option<&std::path::Path>) -> Result<ExitCode, CliError> {
    let (s, _) = load_planned(scenario)?;
    let c = taiji::crlb::crlb(&s).ok_or(CliError::Singular)?;
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
    let print = |prefix: &str, c: &taiji::crlb::Crlb| {
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
    if taiji::crlb::seed_matters(&s) {
        println!(
            "(a run at seed {}: the maneuver's motion and the random motion its thrusters add; the maneuver's alone, at the planner's search rate, is what it promises before any run:)",
            s.seed
        );
        match taiji::plan::maneuver_bound(&s) {
            Some(m) => print("maneuver alone: ", &m),
            None => println!("maneuver alone: singular (it leaves a parameter unbounded)"),
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// `plan`: the maneuver for a window, or (`min_duration_margin`) the shortest window.
fn plan(
    scenario: Option<&std::path::Path>,
    duration: Option<f64>,
    min_duration_margin: Option<f64>,
    top: usize,
    out: &std::path::Path,
) -> Result<ExitCode, CliError> {
    if let Some(d) = duration {
        if !(d.is_finite() && d > 0.0 && d <= taiji::scenario::MAX_DURATION_S) {
            return Err(CliError::Duration { duration: d });
        }
    }
    check_out(out)?;
    let s = Scenario::load_or_default(scenario)?;
    let plan = match min_duration_margin {
        Some(margin) => taiji::plan::min_duration(&s, margin),
        None => taiji::plan::plan(
            &s,
            &taiji::plan::PlanOptions {
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
    taiji::plan::write(&s, &plan, out, top, min_duration_margin)?;
    Ok(ExitCode::SUCCESS)
}
