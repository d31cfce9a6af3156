//! Telemetry: every stream of a run, recorded to `telemetry.h5` (HDF5, written and read
//! by the HDF Group's libhdf5) with SI units as attributes, and read back for replay. The layout is in
//! [`layout`]; the README shows it as a table. Recordings stream to disk a chunk at a
//! time ([`Writer`]) and replay reads them a chunk at a time ([`read::Recording`]), so
//! memory does not grow with the campaign.

mod cloexec;
mod columns;
mod isolate;
pub mod layout;
pub mod read;
pub mod truth;
mod write;

pub use isolate::{set_time_limit as set_read_check_limit, Failure as Hdf5Failure};
pub use write::{Compression, CompressionParseError, Writer, CHUNK_ROWS};

use crate::sim::files::FileError;
use crate::sim::msg::{EstimateMsg, SensorSample, TruthState, EST_FINAL};
use std::path::PathBuf;

/// A recording that could not be written or read; the message names the file.
#[derive(Debug, thiserror::Error)]
pub enum TelemetryError {
    #[error("cannot read {}: {source}", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file or folder that could not be read, created or written.
    #[error(transparent)]
    File(#[from] FileError),
    /// The rows handed to a [`Writer`] do not make the recording it was created for.
    #[error("cannot write {}: {what}", path.display())]
    Rows { path: PathBuf, what: String },
    /// The in-memory streams lack rows ([`Telemetry::write`]).
    #[error("telemetry incomplete: {truth_rows} truth rows and {sensor_rows} sensor rows of different ticks")]
    Incomplete {
        truth_rows: usize,
        sensor_rows: usize,
    },
    /// libhdf5 refused an operation of the writer.
    #[error("cannot write {}: {source}", path.display())]
    Hdf5Write {
        path: PathBuf,
        #[source]
        source: hdf5::Error,
    },
    /// The HDF5 reader gave up on the file (it panicked).
    #[error("{}: corrupt HDF5 file", path.display())]
    Corrupt { path: PathBuf },
    /// libhdf5 crashed or hung reading the file (in the child process that reads a
    /// recording first, so this process was not affected).
    #[error("{}: corrupt HDF5 file: libhdf5 {how} (in the child process that reads a file first; this process is unaffected)", path.display())]
    Hdf5Failed { path: PathBuf, how: Hdf5Failure },
    /// The HDF5 reader could not decode the file's structure while reading it.
    #[error("{}: corrupt HDF5 file (its structure could not be decoded)", path.display())]
    CorruptStructure { path: PathBuf },
    #[error("{}: not a readable HDF5 file ({source})", path.display())]
    NotHdf5 {
        path: PathBuf,
        #[source]
        source: hdf5::Error,
    },
    /// The file is shorter than its superblock says (libhdf5's words in `detail`).
    #[error("{}: truncated HDF5 file ({detail})", path.display())]
    Truncated { path: PathBuf, detail: String },
    /// A dataset of the layout is absent.
    #[error("{}: missing dataset /{dataset}", path.display())]
    MissingDataset { path: PathBuf, dataset: String },
    /// A dataset has another shape than the layout's.
    #[error("{}: /{dataset} has shape {got:?}, the layout needs {need:?} ({layout})", path.display())]
    Shape {
        path: PathBuf,
        dataset: String,
        got: Vec<u64>,
        need: Vec<u64>,
        layout: String,
    },
    /// Any other departure from the layout (`what` names the dataset or attribute).
    #[error("{}: {what}", path.display())]
    Format { path: PathBuf, what: String },
}

/// Who wrote the file and what it describes (root attributes).
#[derive(Debug, Clone)]
pub struct Meta {
    /// The scenario as TOML (every key, so a replay rebuilds the same estimator).
    pub scenario_toml: String,
    pub scenario_name: String,
    pub seed: u64,
    pub method: String,
    pub mode: String,
    pub sample_rate_hz: f64,
    pub duration_s: f64,
    pub n_is: usize,
}

/// The recorded streams, column by column (row-major, flattened).
#[derive(Debug, Clone, Default)]
pub struct Telemetry {
    pub n_is: usize,
    pub fs: f64,
    /// Truth rows (plant output), one per tick.
    pub truth_tick: Vec<u64>,
    pub torque_cmd: Vec<f64>,
    pub torque: Vec<f64>,
    pub attitude: Vec<f64>,
    pub omega: Vec<f64>,
    pub omega_dot: Vec<f64>,
    /// I×3 per row.
    pub tm_acc: Vec<f64>,
    pub srp_acc: Vec<f64>,
    /// Sensor rows (front-end output), one per tick.
    pub sensor_tick: Vec<u64>,
    pub star_q: Vec<f64>,
    pub star_valid: Vec<u8>,
    /// 3×2 per row, per IS.
    pub is_volts: [Vec<f64>; 2],
    pub is_flags: [Vec<u8>; 2],
    /// Estimate rows (see [`Telemetry::record_estimate`]).
    pub estimates: Vec<EstimateMsg>,
    /// Injected faults (`[faults]`) and how many of each one's samples were rejected.
    pub faults: Vec<crate::sim::faults::FaultRecord>,
    pub faults_detected: Vec<u64>,
    gate: RowGate,
}

/// Which estimates become estimate rows: the final estimate, and a new solve at least
/// [`crate::tuning::ESTIMATE_ROW_EVERY_S`] after the last row. Fed every estimate of a run in tick
/// order, live or replayed, it keeps the same rows.
#[derive(Debug, Clone, Default)]
pub struct RowGate {
    /// Tick and solve tick of the last row.
    last: Option<(u64, u64)>,
}

impl RowGate {
    /// Is `e` a row (at sample rate `fs` [Hz])? If so it is taken as the last row.
    pub fn due(&mut self, e: &EstimateMsg, fs: f64) -> bool {
        let spacing = (crate::tuning::ESTIMATE_ROW_EVERY_S * fs).round() as u64;
        let due = e.flags & EST_FINAL != 0
            || match self.last {
                Some((tick, solved)) => e.solved_tick != solved && e.header.tick >= tick + spacing,
                None => e.n_used > 0,
            };
        if due {
            self.last = Some((e.header.tick, e.solved_tick));
        }
        due
    }
}

/// Where a campaign's streams go: memory ([`Telemetry`]), a file ([`Writer`]), or
/// both ([`Tee`]).
pub trait Sink {
    /// One tick: the plant's truth and the front-end's sample of it.
    fn record(&mut self, t: &TruthState, s: &SensorSample) -> Result<(), TelemetryError>;
    /// An estimate, kept if a row is due ([`RowGate`]).
    fn record_estimate(&mut self, e: &EstimateMsg) -> Result<(), TelemetryError>;
}

impl Sink for Telemetry {
    fn record(&mut self, t: &TruthState, s: &SensorSample) -> Result<(), TelemetryError> {
        self.record_truth(t);
        self.record_sensor(s);
        Ok(())
    }

    fn record_estimate(&mut self, e: &EstimateMsg) -> Result<(), TelemetryError> {
        Telemetry::record_estimate(self, e);
        Ok(())
    }
}

impl Sink for Writer {
    fn record(&mut self, t: &TruthState, s: &SensorSample) -> Result<(), TelemetryError> {
        Writer::record(self, t, s)
    }

    fn record_estimate(&mut self, e: &EstimateMsg) -> Result<(), TelemetryError> {
        Writer::record_estimate(self, e)
    }
}

/// Both sinks, either optional: the file for `--record`, memory for `--plots`.
pub struct Tee<'a> {
    pub memory: Option<&'a mut Telemetry>,
    pub file: Option<&'a mut Writer>,
}

impl Sink for Tee<'_> {
    fn record(&mut self, t: &TruthState, s: &SensorSample) -> Result<(), TelemetryError> {
        if let Some(m) = self.memory.as_deref_mut() {
            Sink::record(m, t, s)?;
        }
        match self.file.as_deref_mut() {
            Some(f) => f.record(t, s),
            None => Ok(()),
        }
    }

    fn record_estimate(&mut self, e: &EstimateMsg) -> Result<(), TelemetryError> {
        if let Some(m) = self.memory.as_deref_mut() {
            m.record_estimate(e);
        }
        match self.file.as_deref_mut() {
            Some(f) => f.record_estimate(e),
            None => Ok(()),
        }
    }
}

impl Telemetry {
    /// Room for `n` ticks of `n_is` sensors at `fs` [Hz].
    pub fn new(n_is: usize, fs: f64, n: u64) -> Self {
        let n = n as usize;
        Telemetry {
            n_is,
            fs,
            truth_tick: Vec::with_capacity(n),
            torque_cmd: Vec::with_capacity(3 * n),
            torque: Vec::with_capacity(3 * n),
            attitude: Vec::with_capacity(4 * n),
            omega: Vec::with_capacity(3 * n),
            omega_dot: Vec::with_capacity(3 * n),
            tm_acc: Vec::with_capacity(3 * n_is * n),
            srp_acc: Vec::with_capacity(3 * n),
            sensor_tick: Vec::with_capacity(n),
            star_q: Vec::with_capacity(4 * n),
            star_valid: Vec::with_capacity(n),
            is_volts: std::array::from_fn(|i| Vec::with_capacity(if i < n_is { 6 * n } else { 0 })),
            is_flags: std::array::from_fn(|i| Vec::with_capacity(if i < n_is { n } else { 0 })),
            ..Default::default()
        }
    }

    pub fn record_truth(&mut self, t: &TruthState) {
        self.truth_tick.push(t.header.tick);
        self.torque_cmd.extend_from_slice(&t.torque_cmd_b);
        self.torque.extend_from_slice(&t.torque_b);
        self.attitude.extend_from_slice(&t.q_bn);
        self.omega.extend_from_slice(&t.omega_b);
        self.omega_dot.extend_from_slice(&t.omega_dot_b);
        for i in 0..self.n_is {
            self.tm_acc.extend_from_slice(&t.a_tm_b[i]);
        }
        self.srp_acc.extend_from_slice(&t.a_srp_b);
    }

    pub fn record_sensor(&mut self, s: &SensorSample) {
        self.sensor_tick.push(s.header.tick);
        self.star_q.extend_from_slice(&s.star.q_bn);
        self.star_valid.push(s.star.valid);
        for i in 0..self.n_is {
            self.is_volts[i].extend(s.is[i].volts.iter().flatten());
            self.is_flags[i].push(s.is[i].flags);
        }
    }

    /// Record `e` if a row is due (see [`RowGate`]).
    pub fn record_estimate(&mut self, e: &EstimateMsg) {
        if self.gate.due(e, self.fs) {
            self.estimates.push(*e);
        }
    }

    /// Write `path` (HDF5) through a [`Writer`]. Every truth and sensor row must be
    /// present.
    pub fn write(&self, path: &std::path::Path, meta: &Meta) -> Result<(), TelemetryError> {
        write::write(self, path, meta)
    }
}

impl Meta {
    pub fn of(s: &crate::sim::scenario::Scenario, seed: u64, method: &str, mode: &str) -> Self {
        Meta {
            scenario_toml: toml::to_string(s).unwrap_or_default(),
            scenario_name: s.name.clone(),
            seed,
            method: method.into(),
            mode: mode.into(),
            sample_rate_hz: s.sample_rate_hz,
            duration_s: s.duration_s,
            n_is: s.inertial_sensor.len(),
        }
    }
}
