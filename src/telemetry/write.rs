//! `telemetry.h5` writer, on the HDF Group's libhdf5: one chunked dataset per channel,
//! its rows unlimited and extended as they arrive, compressed chunk by chunk (byte
//! shuffle, then deflate); `units` and `description` on every dataset, the scenario and
//! software version on the root.
//!
//! The file is created in the HDF5 1.10 format and switched to SWMR (single writer,
//! multiple readers) once its datasets exist. Rows are buffered [`CHUNK_ROWS`] at a
//! time; each flush extends every dataset, writes its rows and flushes the file, in the
//! order SWMR readers rely on. So h5py (`swmr=True`) and `replay --follow` read the
//! file while it grows, and a writer killed between flushes leaves a file holding every
//! flushed row, its size in proportion to them. Memory is one chunk of rows and
//! libhdf5's chunk cache, whatever the campaign's length. At the end SWMR is left and
//! the fault log added as `/faults` (SWMR creates no new objects).

use super::columns::{estimate_columns, sample_columns, Buf, Column, Kind};
use super::layout as l;
use super::{Meta, RowGate, Telemetry, TelemetryError};
use crate::sim::faults::FaultRecord;
use crate::sim::msg::{EstimateMsg, Header, IsSample, SensorSample, StarSample, TruthState};
use hdf5::types::VarLenUnicode;
use ndarray::{ArrayViewD, IxDyn};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Samples per chunk: 4096 rows (≈ 1.4 MB with two IS before compression; 410 s of a
/// 10 Hz campaign). Also the rows of each sample dataset's HDF5 chunk.
pub const CHUNK_ROWS: usize = 4096;

/// Rows of an estimate dataset's HDF5 chunk (a row every 10 s: 640 s of campaign).
const ESTIMATE_CHUNK_ROWS: usize = 64;

/// How each chunk is compressed on disk: HDF5's byte shuffle, then deflate (zlib).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compression {
    /// Stored as is.
    None,
    /// Level 1 on the datasets whose values repeat or step (ticks, times, flags, the
    /// commanded torque, the estimates: 30–100× smaller), the noise-dominated floats
    /// as they are (deflate saves them 10–30 % at about +50 % of the process set's
    /// wall time). Measured in docs/telemetry.md.
    Auto,
    /// Every dataset at this level, 1 (fastest) to 9.
    Deflate(u8),
}

impl Compression {
    /// The default, chosen by measurement (docs/telemetry.md).
    pub const DEFAULT: Compression = Compression::Auto;

    /// The deflate level of column `c`, if it is compressed.
    fn level(self, c: &Column) -> Option<u8> {
        match self {
            Compression::None => None,
            Compression::Auto => c.steps().then_some(1),
            Compression::Deflate(n) => Some(n),
        }
    }
}

impl std::fmt::Display for Compression {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Compression::None => f.write_str("none"),
            Compression::Auto => f.write_str("auto"),
            Compression::Deflate(n) => write!(f, "{n}"),
        }
    }
}

/// A `--record-compression` value that is neither `none`, `auto` nor a level 1–9.
#[derive(Debug, thiserror::Error)]
#[error("`{0}` is not a compression: give `none`, `auto` or a deflate level 1 to 9")]
pub struct CompressionParseError(String);

impl std::str::FromStr for Compression {
    type Err = CompressionParseError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim() {
            "none" | "0" => Ok(Compression::None),
            "auto" => Ok(Compression::Auto),
            t => match t.parse::<u8>() {
                Ok(n @ 1..=9) => Ok(Compression::Deflate(n)),
                _ => Err(CompressionParseError(s.to_string())),
            },
        }
    }
}

/// Streams a recording to `telemetry.h5` as it is made (see the module doc).
pub struct Writer {
    /// The file; `None` once closed.
    file: Option<hdf5::File>,
    path: PathBuf,
    fs: f64,
    n_is: usize,
    /// Samples the scenario has.
    n: u64,
    chunk_rows: usize,
    samples: Vec<Column>,
    estimates: Vec<Column>,
    gate: RowGate,
    last_flush: Instant,
}

/// `units` and `description` of the layout's channel `path`, on `loc`.
fn channel_attrs(loc: &hdf5::Location, path: &str) -> hdf5::Result<()> {
    let c = l::channel(path);
    text_attr(loc, "units", c.units)?;
    text_attr(loc, "description", c.description)
}

/// A variable-length UTF-8 string attribute (h5py reads it as `str`).
fn text_attr(loc: &hdf5::Location, name: &str, text: &str) -> hdf5::Result<()> {
    let v: VarLenUnicode = text
        .parse()
        .map_err(|e| hdf5::Error::from(format!("attribute {name}: {e}")))?;
    loc.new_attr::<VarLenUnicode>()
        .create(name)?
        .write_scalar(&v)
}

fn scalar_attr<T: hdf5::H5Type>(loc: &hdf5::Location, name: &str, v: T) -> hdf5::Result<()> {
    loc.new_attr::<T>().create(name)?.write_scalar(&v)
}

/// The root attributes of the layout.
fn root_attrs(root: &hdf5::Location, meta: &Meta) -> hdf5::Result<()> {
    text_attr(root, "format", l::FORMAT)?;
    scalar_attr(root, "format_version", l::FORMAT_VERSION)?;
    let software = concat!(env!("CARGO_PKG_NAME"), " ", env!("CARGO_PKG_VERSION"));
    text_attr(root, "software", software)?;
    text_attr(root, "scenario", &meta.scenario_toml)?;
    text_attr(root, "scenario_name", &meta.scenario_name)?;
    scalar_attr(root, "seed", meta.seed)?;
    text_attr(root, "method", &meta.method)?;
    text_attr(root, "mode", &meta.mode)?;
    scalar_attr(root, "sample_rate_hz", meta.sample_rate_hz)?;
    scalar_attr(root, "duration_s", meta.duration_s)?;
    scalar_attr(root, "n_inertial_sensors", meta.n_is as u64)
}

/// Create the groups of `cols`' paths that `file` lacks.
fn groups(file: &hdf5::File, cols: &[&Column]) -> hdf5::Result<()> {
    for c in cols {
        if let Some((g, _)) = c.path.rsplit_once('/') {
            if file.group(g).is_err() {
                file.create_group(g)?;
            }
        }
    }
    Ok(())
}

/// Column `c`'s dataset: no rows yet, unlimited, chunked by `chunk` rows.
fn create_dataset(
    file: &hdf5::File,
    c: &Column,
    chunk: usize,
    z: Compression,
) -> hdf5::Result<hdf5::Dataset> {
    let mut extents = vec![hdf5::Extent::resizable(0)];
    extents.extend(c.row_shape.iter().map(|&n| hdf5::Extent::fixed(n)));
    let mut chunk_dims = vec![chunk.max(1)];
    chunk_dims.extend(&c.row_shape);
    let mut b = match c.kind {
        Kind::F64 => file.new_dataset::<f64>(),
        Kind::U64 => file.new_dataset::<u64>(),
        Kind::U8 => file.new_dataset::<u8>(),
    }
    .chunk(chunk_dims)
    .obj_track_times(false);
    if let Some(level) = z.level(c) {
        b = b.shuffle().deflate(level);
    }
    let ds = b
        .shape(hdf5::SimpleExtents::from_vec(extents))
        .create(c.path)?;
    channel_attrs(&ds, c.path)?;
    Ok(ds)
}

/// Append `c`'s buffered rows to its dataset.
fn write_rows(c: &mut Column) -> hdf5::Result<()> {
    let n = c.pending() as usize;
    if n == 0 {
        return Ok(());
    }
    let Some(ds) = c.ds.as_ref() else {
        return Err(format!("/{} is closed", c.path).into());
    };
    let start = c.rows as usize;
    let mut dims = vec![start + n];
    dims.extend(&c.row_shape);
    ds.resize(dims)?;
    let mut shape = vec![n];
    shape.extend(&c.row_shape);
    let shape = IxDyn(&shape);
    let rows = super::read::rows_selection(start, start + n, &c.row_shape);
    let bad = |e: ndarray::ShapeError| hdf5::Error::from(e.to_string());
    match &c.buf {
        Buf::F64(v) => ds.write_slice(ArrayViewD::from_shape(shape, v).map_err(bad)?, &rows)?,
        Buf::U64(v) => ds.write_slice(ArrayViewD::from_shape(shape, v).map_err(bad)?, &rows)?,
        Buf::U8(v) => ds.write_slice(ArrayViewD::from_shape(shape, v).map_err(bad)?, &rows)?,
    }
    c.rows += n as u64;
    c.buf.clear();
    Ok(())
}

impl Writer {
    /// Create `path` for `n` samples of the run `meta` describes, written `chunk_rows`
    /// rows at a time ([`CHUNK_ROWS`] outside tests), compressed by default.
    pub fn create(
        path: &Path,
        meta: &Meta,
        n: u64,
        chunk_rows: usize,
    ) -> Result<Self, TelemetryError> {
        Self::create_with(path, meta, n, chunk_rows, Compression::DEFAULT)
    }

    /// [`Writer::create`] with compression `z`.
    pub fn create_with(
        path: &Path,
        meta: &Meta,
        n: u64,
        chunk_rows: usize,
        z: Compression,
    ) -> Result<Self, TelemetryError> {
        let chunk_rows = chunk_rows.max(1);
        let mut samples = sample_columns(meta.n_is);
        let mut estimates = estimate_columns(meta.n_is);
        let err = |source| TelemetryError::Hdf5Write {
            path: path.to_path_buf(),
            source,
        };
        let file = hdf5::File::with_options()
            .with_fapl(|p| p.libver_v110())
            .create(path)
            .map_err(err)?;
        super::cloexec::keep_from_children(&file);
        root_attrs(&file, meta).map_err(err)?;
        let all: Vec<&Column> = samples.iter().chain(estimates.iter()).collect();
        groups(&file, &all).map_err(err)?;
        let est_chunk = chunk_rows.min(ESTIMATE_CHUNK_ROWS);
        for (c, rows) in samples
            .iter_mut()
            .map(|c| (c, chunk_rows))
            .chain(estimates.iter_mut().map(|c| (c, est_chunk)))
        {
            c.ds = Some(create_dataset(&file, c, rows, z).map_err(err)?);
            c.reserve(rows);
        }
        // Every object exists: from here readers may follow the file.
        file.start_swmr().map_err(err)?;
        Ok(Writer {
            file: Some(file),
            path: path.to_path_buf(),
            fs: meta.sample_rate_hz,
            n_is: meta.n_is,
            n,
            chunk_rows,
            samples,
            estimates,
            gate: RowGate::default(),
            last_flush: Instant::now(),
        })
    }

    /// The rows handed over do not make the recording: `what`.
    fn rows_err(&self, what: String) -> TelemetryError {
        TelemetryError::Rows {
            path: self.path.clone(),
            what,
        }
    }

    fn h5_err(&self, source: hdf5::Error) -> TelemetryError {
        TelemetryError::Hdf5Write {
            path: self.path.clone(),
            source,
        }
    }

    /// Samples recorded so far (written or buffered).
    pub fn samples(&self) -> u64 {
        self.samples[0].rows + self.samples[0].pending()
    }

    /// Record one tick: the plant's truth and the front-end's sample of it.
    pub fn record(&mut self, t: &TruthState, s: &SensorSample) -> Result<(), TelemetryError> {
        if t.header.tick != s.header.tick {
            return Err(self.rows_err(format!(
                "truth of tick {} recorded with the sample of tick {}",
                t.header.tick, s.header.tick
            )));
        }
        if self.samples() >= self.n {
            return Err(self.rows_err(format!(
                "more than the scenario's {} samples recorded",
                self.n
            )));
        }
        let (fs, ni) = (self.fs, self.n_is);
        for c in &mut self.samples {
            c.put_sample(t, s, fs, ni);
        }
        if self.samples[0].pending() >= self.chunk_rows as u64 {
            self.flush()?;
        }
        Ok(())
    }

    /// Record `e` if a row is due (see [`RowGate`]).
    pub fn record_estimate(&mut self, e: &EstimateMsg) -> Result<(), TelemetryError> {
        if self.gate.due(e, self.fs) {
            self.push_estimate(e)?;
        }
        Ok(())
    }

    /// Append an estimate row.
    fn push_estimate(&mut self, e: &EstimateMsg) -> Result<(), TelemetryError> {
        let (fs, ni) = (self.fs, self.n_is);
        for c in &mut self.estimates {
            c.put_estimate(e, fs, ni);
        }
        if self.estimates[0].pending() >= self.chunk_rows as u64 {
            self.flush()?;
        }
        Ok(())
    }

    /// Write the buffered rows and flush the file: readers see them from here on, and
    /// a crash keeps them.
    pub fn flush(&mut self) -> Result<(), TelemetryError> {
        self.last_flush = Instant::now();
        let pending = self
            .samples
            .iter()
            .chain(self.estimates.iter())
            .any(|c| c.pending() > 0);
        if !pending {
            return Ok(());
        }
        let mut done = Ok(());
        for c in self.samples.iter_mut().chain(self.estimates.iter_mut()) {
            done = done.and_then(|_| write_rows(c));
        }
        let done = done.and_then(|_| match &self.file {
            Some(f) => f.flush(),
            None => Ok(()),
        });
        done.map_err(|e| self.h5_err(e))
    }

    /// Flush if rows wait and the last flush is at least `age` old: a real-time
    /// recorder's rows reach live readers within `age`, not a chunk later.
    pub fn flush_if_older(&mut self, age: Duration) -> Result<(), TelemetryError> {
        if self.last_flush.elapsed() >= age {
            self.flush()?;
        }
        Ok(())
    }

    /// Write what is buffered and the fault log (`[faults]` runs), and close the file.
    /// Fewer samples than the scenario's is an error, after they are written.
    pub fn finish(
        mut self,
        faults: &[FaultRecord],
        detected: &[u64],
    ) -> Result<(), TelemetryError> {
        self.flush()?;
        self.close()?;
        if !faults.is_empty() {
            write_faults(&self.path, faults, detected).map_err(|e| self.h5_err(e))?;
        }
        let got = self.samples[0].rows;
        if got != self.n {
            return Err(self.rows_err(format!("incomplete recording: {got} of {} samples", self.n)));
        }
        Ok(())
    }

    /// Close every dataset, then the file (leaving SWMR).
    fn close(&mut self) -> Result<(), TelemetryError> {
        for c in self.samples.iter_mut().chain(self.estimates.iter_mut()) {
            c.ds = None;
        }
        match self.file.take() {
            Some(f) => f.close().map_err(|e| self.h5_err(e)),
            None => Ok(()),
        }
    }
}

/// The `/faults` group, added to the closed file `path`.
fn write_faults(path: &Path, f: &[FaultRecord], detected: &[u64]) -> hdf5::Result<()> {
    let file = hdf5::File::with_options()
        .with_fapl(|p| p.libver_v110())
        .open_rw(path)?;
    super::cloexec::keep_from_children(&file);
    file.create_group("faults")?;
    let u = |g: &dyn Fn(&FaultRecord) -> u64| -> Vec<u64> { f.iter().map(g).collect() };
    let x = |g: &dyn Fn(&FaultRecord) -> f64| -> Vec<f64> { f.iter().map(g).collect() };
    let det: Vec<u64> = (0..f.len())
        .map(|i| detected.get(i).copied().unwrap_or(0))
        .collect();
    let ints = [
        (l::FAULT_TICK, u(&|r| r.tick)),
        (l::FAULT_KIND, u(&|r| r.kind as u64)),
        (l::FAULT_FIELD, u(&|r| r.field as u64)),
        (l::FAULT_BIT, u(&|r| r.bit as u64)),
        (l::FAULT_SAMPLES, u(&|r| r.samples as u64)),
        (l::FAULT_DETECTED, det),
    ];
    let floats = [
        (l::FAULT_BEFORE, x(&|r| r.before)),
        (l::FAULT_AFTER, x(&|r| r.after)),
        (l::FAULT_SIGMAS, x(&|r| r.sigmas)),
    ];
    for (p, v) in &ints {
        whole_dataset(&file, p, v)?;
    }
    for (p, v) in &floats {
        whole_dataset(&file, p, v)?;
    }
    file.close()
}

/// Dataset `path` of `file` holding `v`, with its channel's attributes.
fn whole_dataset<T: hdf5::H5Type>(file: &hdf5::File, path: &str, v: &[T]) -> hdf5::Result<()> {
    let ds = file
        .new_dataset_builder()
        .obj_track_times(false)
        .with_data(v)
        .create(path)?;
    channel_attrs(&ds, path)
}

/// Write a recording held in memory. Every truth and sensor row must be present.
pub(super) fn write(t: &Telemetry, path: &Path, meta: &Meta) -> Result<(), TelemetryError> {
    let n = t.truth_tick.len();
    if t.sensor_tick.len() != n || t.truth_tick != t.sensor_tick {
        return Err(TelemetryError::Incomplete {
            truth_rows: n,
            sensor_rows: t.sensor_tick.len(),
        });
    }
    let mut w = Writer::create(path, meta, n as u64, CHUNK_ROWS)?;
    let ni = t.n_is;
    let fs = t.fs;
    for k in 0..n {
        let v3 = |v: &[f64]| -> [f64; 3] { std::array::from_fn(|j| v[3 * k + j]) };
        let v4 = |v: &[f64]| -> [f64; 4] { std::array::from_fn(|j| v[4 * k + j]) };
        let header = Header::at(k as u64, t.truth_tick[k], fs);
        let truth = TruthState {
            header,
            q_bn: v4(&t.attitude),
            omega_b: v3(&t.omega),
            omega_dot_b: v3(&t.omega_dot),
            a_tm_b: std::array::from_fn(|i| {
                if i < ni {
                    std::array::from_fn(|j| t.tm_acc[(k * ni + i) * 3 + j])
                } else {
                    [0.0; 3]
                }
            }),
            a_srp_b: v3(&t.srp_acc),
            torque_b: v3(&t.torque),
            torque_cmd_b: v3(&t.torque_cmd),
        };
        let mut sample = SensorSample {
            header,
            star: StarSample {
                q_bn: v4(&t.star_q),
                valid: t.star_valid[k],
                _pad: [0; 7],
            },
            ..Default::default()
        };
        for i in 0..ni {
            sample.is[i] = IsSample {
                volts: std::array::from_fn(|j| {
                    [
                        t.is_volts[i][6 * k + 2 * j],
                        t.is_volts[i][6 * k + 2 * j + 1],
                    ]
                }),
                flags: t.is_flags[i][k],
                _pad: [0; 7],
            };
        }
        w.record(&truth, &sample)?;
    }
    for e in &t.estimates {
        w.push_estimate(e)?;
    }
    w.finish(&t.faults, &t.faults_detected)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compression_values_parse_and_others_are_refused() {
        assert_eq!("none".parse::<Compression>().unwrap(), Compression::None);
        assert_eq!("4".parse::<Compression>().unwrap(), Compression::Deflate(4));
        assert_eq!("auto".parse::<Compression>().unwrap(), Compression::Auto);
        for bad in ["10", "-1", "fast", ""] {
            let e = bad.parse::<Compression>().unwrap_err().to_string();
            assert!(e.contains("`auto` or a deflate level 1 to 9"), "{e}");
        }
    }

    #[test]
    fn estimate_rows_grow_their_datasets_chunk_by_chunk() {
        let dir = std::env::temp_dir().join(format!("taiji-grow-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("grow.h5");
        let s = crate::sim::scenario::Scenario::default();
        let mut meta = Meta::of(&s, 1, "joint", "in-process");
        meta.n_is = 1;
        // 10 samples at 10 Hz, two rows a chunk; 9 estimate rows.
        let mut w = Writer::create(&path, &meta, 10, 2).unwrap();
        for k in 0..10 {
            let header = Header::at(k, k, 10.0);
            let t = TruthState {
                header,
                ..Default::default()
            };
            let x = SensorSample {
                header,
                ..Default::default()
            };
            w.record(&t, &x).unwrap();
            if k < 9 {
                let e = EstimateMsg {
                    header,
                    solved_tick: 100 + k,
                    ..Default::default()
                };
                w.push_estimate(&e).unwrap();
            }
        }
        w.finish(&[], &[]).unwrap();
        let f = hdf5::File::open(&path).unwrap();
        let ticks: Vec<u64> = f.dataset(l::EST_TICK).unwrap().read_raw().unwrap();
        assert_eq!(ticks, (100..109).collect::<Vec<u64>>());
        assert_eq!(f.dataset(l::EST_BETA).unwrap().shape(), vec![9, 1, 3]);
        let ticks: Vec<u64> = f.dataset(l::TICK).unwrap().read_raw().unwrap();
        assert_eq!(ticks, (0..10).collect::<Vec<u64>>());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
