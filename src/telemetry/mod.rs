//! Telemetry: every stream of a run, recorded to `telemetry.h5` (HDF5, written in pure
//! Rust) with SI units as attributes, and read back for replay. The layout is in
//! [`layout`]; the README shows it as a table.

pub mod layout;
pub mod read;
mod write;

use crate::msg::{EstimateMsg, SensorSample, TruthState, EST_FINAL};

/// Estimate rows are recorded at most this often [s] (and always the final one): the
/// joint estimator solves every 60 s, the paper's filter updates every sample.
pub const ESTIMATE_ROW_EVERY_S: f64 = 10.0;

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
    pub faults: Vec<crate::faults::FaultRecord>,
    pub faults_detected: Vec<u64>,
    last_row_tick: Option<u64>,
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

    /// Record `e` if a row is due: the final estimate, or a new solve at least
    /// `ESTIMATE_ROW_EVERY_S` after the last row. Fed every estimate of a run in tick
    /// order, live or replayed, it keeps the same rows.
    pub fn record_estimate(&mut self, e: &EstimateMsg) {
        let spacing = (ESTIMATE_ROW_EVERY_S * self.fs).round() as u64;
        let due = e.flags & EST_FINAL != 0
            || match (self.last_row_tick, self.estimates.last()) {
                (Some(t), Some(last)) => {
                    e.solved_tick != last.solved_tick && e.header.tick >= t + spacing
                }
                _ => e.n_used > 0,
            };
        if due {
            self.last_row_tick = Some(e.header.tick);
            self.estimates.push(*e);
        }
    }

    /// Write `path` (HDF5). Every truth and sensor row must be present.
    pub fn write(&self, path: &std::path::Path, meta: &Meta) -> Result<(), String> {
        write::write(self, path, meta)
    }
}

impl Meta {
    pub fn of(s: &crate::scenario::Scenario, seed: u64, method: &str, mode: &str) -> Self {
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
