//! Every error of the command line, and its exit code.

use crate::analysis::montecarlo;
use crate::sim::files::FileError;
use std::path::PathBuf;

/// Every error of the CLI: one line naming the option, key or file, printed as
/// `error: …` with exit code 2.
#[derive(Debug, thiserror::Error)]
pub(crate) enum CliError {
    /// `--out`: the folder cannot be made.
    #[error("--out {}: cannot create this folder ({source})", path.display())]
    OutDir {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file or folder that could not be read, created or written.
    #[error(transparent)]
    File(#[from] FileError),
    #[error("{0}")]
    Json(#[from] serde_json::Error),
    /// `--duration` is not a window in seconds.
    #[error(
        "--duration: must be a window in seconds, up to {} s, got {duration}",
        crate::sim::scenario::MAX_DURATION_S
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
        source: Box<crate::runtime::process::ProcessError>,
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
    Scenario(#[from] crate::sim::scenario::ScenarioError),
    #[error(transparent)]
    Plan(#[from] crate::analysis::plan::PlanError),
    #[error(transparent)]
    Telemetry(#[from] crate::telemetry::TelemetryError),
    #[error(transparent)]
    Export(#[from] crate::analysis::export::ExportError),
    #[error(transparent)]
    MonteCarlo(#[from] montecarlo::MonteCarloError),
    #[error(transparent)]
    Report(#[from] crate::analysis::report::ReportError),
    #[error(transparent)]
    Plot(#[from] crate::analysis::plots::PlotError),
    #[error(transparent)]
    Monitor(#[from] crate::runtime::monitor::MonitorError),
    /// The ground link: the key, the sequence counter, the socket.
    #[error(transparent)]
    GroundLink(#[from] crate::ground::client::ClientError),
    /// A telecommand's arguments (names, IDs, values).
    #[error(transparent)]
    Telecommand(#[from] crate::ground::tc::TcError),
    #[error(transparent)]
    Exchange(#[from] crate::ground::exchange::NothingEnds),
    /// A number of seconds that is none.
    #[error("--{name}: must be seconds ≥ 0, not {value}")]
    Seconds { name: &'static str, value: f64 },
    /// `listen --save` or `decode`: the file.
    #[error("{}: {source}", path.display())]
    Save {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// `decode`: a saved stream that ends inside a record.
    #[error("{}: {source}", path.display())]
    Saved {
        path: PathBuf,
        #[source]
        source: crate::ground::client::saved::SavedError,
    },
}

impl CliError {
    /// The process's exit code: 2 for every error (1 is a run whose requirements are
    /// not met, or a monitor that found no run; 0 success).
    pub(crate) fn exit_code(&self) -> u8 {
        match self {
            // Nothing to watch (no run on the prefix) is no user error.
            CliError::Monitor(e) => e.exit_code(),
            _ => 2,
        }
    }
}
