//! Reading `telemetry.h5` (ours, or one another tool wrote in the documented layout)
//! for replay: the scenario and the star-tracker and IS channels, never truth. Every
//! problem is an error naming the file, the dataset and what is wrong. The file is read
//! from disk as needed, a window of rows at a time, so memory does not grow with it.

use super::layout as l;
use super::TelemetryError;
use crate::sim::msg::{Header, IsSample, SensorSample, StarSample, FLAG_ABSENT};
use crate::sim::scenario::Scenario;
use hdf5::types::{VarLenAscii, VarLenUnicode};
use hdf5::File;
use ndarray::IxDyn;
use std::path::{Path, PathBuf};

/// What a replay needs from a recording. The samples stay on disk: [`Recording::samples`]
/// reads them in windows of [`Recording::chunk_rows`] rows.
pub struct Recording {
    /// The scenario of the file's `scenario` attribute, or the default scenario with
    /// the file's sample rate, duration and number of IS.
    pub scenario: Scenario,
    /// The run's seed (`seed` attribute, else the scenario's).
    pub seed: u64,
    /// The estimator the recording was made with (`method` attribute), if any.
    pub method: Option<String>,
    /// Faults injected into the recording (`/faults/*`, from a `[faults]` run).
    pub faults: Vec<crate::sim::faults::FaultRecord>,
    /// Number of samples in the file (fewer than the scenario's in a truncated one).
    pub n: u64,
    /// Number of samples of the scenario.
    pub expected: u64,
    /// Rows per window read.
    pub chunk_rows: u64,
    /// Follow a recording still being written (`replay --follow`): at the end of its
    /// rows, wait for more until the scenario's last sample, or until none came for
    /// this long.
    pub follow: Option<std::time::Duration>,
    /// Rows handed out so far (a followed recording grows past `n`).
    seen: std::cell::Cell<u64>,
    has_tick: bool,
    pub(super) r: Reader,
}

/// A recording whose writer stopped before the end of its campaign.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Truncation {
    /// Samples in the file.
    pub rows: u64,
    /// Samples of the scenario.
    pub expected: u64,
    /// Tick of the last sample in the file.
    pub last_tick: u64,
}

/// The text of a string attribute, whichever string type its writer chose.
/// (A corrupt file's text may not be UTF-8: then it is no text.)
fn text_attr(a: &hdf5::Attribute) -> Option<String> {
    let text = |b: &[u8]| std::str::from_utf8(b).ok().map(str::to_string);
    if let Ok(v) = a.read_scalar::<VarLenUnicode>() {
        return text(v.as_bytes());
    }
    a.read_scalar::<VarLenAscii>()
        .ok()
        .and_then(|v| text(v.as_bytes()))
}

fn num_attr(a: &hdf5::Attribute) -> Option<f64> {
    a.read_scalar::<f64>().ok()
}

/// Rows `[start, end)` of a dataset whose rows have shape `row`: every element of
/// each.
pub(super) fn rows_selection(start: usize, end: usize, row: &[usize]) -> hdf5::Selection {
    let whole = |start, end| hdf5::SliceOrIndex::SliceTo {
        start,
        step: 1,
        end,
        block: 1,
    };
    let mut dims = vec![whole(start, end)];
    dims.extend(row.iter().map(|&n| whole(0, n)));
    hdf5::Selection::new(hdf5::Hyperslab::from(dims))
}

pub(super) struct Reader {
    file: File,
    origin: PathBuf,
}

impl Reader {
    pub(super) fn err(&self, what: impl std::fmt::Display) -> TelemetryError {
        TelemetryError::Format {
            path: self.origin.clone(),
            what: what.to_string(),
        }
    }

    pub(super) fn missing(&self, dataset: &str) -> TelemetryError {
        TelemetryError::MissingDataset {
            path: self.origin.clone(),
            dataset: dataset.into(),
        }
    }

    pub(super) fn has(&self, path: &str) -> bool {
        self.file.dataset(path).is_ok()
    }

    /// Root attribute `name`, if the file has one.
    pub(super) fn attr(&self, name: &str) -> Option<hdf5::Attribute> {
        self.file.attr(name).ok()
    }

    pub(super) fn dataset(&self, path: &str) -> Result<hdf5::Dataset, TelemetryError> {
        self.file.dataset(path).map_err(|_| self.missing(path))
    }

    /// Dataset `path`, which must exist with exactly `shape`.
    pub(super) fn shaped(
        &self,
        path: &str,
        shape: &[u64],
    ) -> Result<hdf5::Dataset, TelemetryError> {
        let d = self.dataset(path)?;
        let got: Vec<u64> = d.shape().iter().map(|&x| x as u64).collect();
        if got != shape {
            return Err(TelemetryError::Shape {
                path: self.origin.clone(),
                dataset: path.into(),
                got,
                need: shape.to_vec(),
                layout: l::channel(path).shape.to_string(),
            });
        }
        Ok(d)
    }

    /// Dataset `path` with `n` rows of `row` shape, or at least `n` rows where the
    /// recording is `truncated` (its datasets were extended one after another).
    pub(super) fn shaped_rows(
        &self,
        path: &str,
        n: u64,
        row: &[u64],
        truncated: bool,
    ) -> Result<hdf5::Dataset, TelemetryError> {
        let mut need = vec![n];
        need.extend(row);
        if !truncated {
            return self.shaped(path, &need);
        }
        let d = self.dataset(path)?;
        let got: Vec<u64> = d.shape().iter().map(|&x| x as u64).collect();
        if got.len() != need.len() || got[0] < n || got[1..] != need[1..] {
            return Err(TelemetryError::Shape {
                path: self.origin.clone(),
                dataset: path.into(),
                got,
                need,
                layout: l::channel(path).shape.to_string(),
            });
        }
        Ok(d)
    }

    pub(super) fn f64s(&self, path: &str, shape: &[u64]) -> Result<Vec<f64>, TelemetryError> {
        self.shaped(path, shape)?
            .read_raw::<f64>()
            .map_err(|e| self.err(format!("/{path}: cannot read its data ({e})")))
    }

    pub(super) fn ints(&self, path: &str, n: u64) -> Result<Vec<u64>, TelemetryError> {
        self.shaped(path, &[n])?
            .read_raw::<u64>()
            .map_err(|e| self.err(format!("/{path}: cannot read it as integers ({e})")))
    }

    /// Rows `[start, start + count)` of `d` (dataset `path`), as `T`, clipped to its
    /// rows.
    pub(super) fn rows<T: hdf5::H5Type>(
        &self,
        d: &hdf5::Dataset,
        path: &str,
        start: u64,
        count: u64,
    ) -> Result<Vec<T>, TelemetryError> {
        let n = d.shape().first().copied().unwrap_or(0) as u64;
        let end = (start + count).min(n);
        if end <= start {
            return Ok(Vec::new());
        }
        let row: Vec<usize> = d.shape().iter().skip(1).copied().collect();
        let a = d
            .read_slice::<T, _, IxDyn>(rows_selection(start as usize, end as usize, &row))
            .map_err(|e| self.err(format!("/{path}: cannot read its data ({e})")))?;
        Ok(a.into_raw_vec_and_offset().0)
    }

    /// Rows of `d` as floats.
    pub(super) fn f64_rows(
        &self,
        d: &hdf5::Dataset,
        path: &str,
        start: u64,
        count: u64,
    ) -> Result<Vec<f64>, TelemetryError> {
        self.rows(d, path, start, count)
    }

    /// Rows of `d` as integers.
    pub(super) fn int_rows(
        &self,
        d: &hdf5::Dataset,
        path: &str,
        start: u64,
        count: u64,
    ) -> Result<Vec<u64>, TelemetryError> {
        self.rows(d, path, start, count)
    }
}

/// Open `path` and check what a replay needs (reading /time and /tick in windows).
/// Unless this file passed already, libhdf5 first reads its every sample window in a
/// child process (`isolate`): a file it crashes or hangs on is refused, naming what it
/// did.
pub fn open(path: &Path) -> Result<Recording, TelemetryError> {
    super::isolate::check(path, "samples", |p| {
        if let Ok(rec) = opened(p) {
            for s in rec.samples() {
                if s.is_err() {
                    break;
                }
            }
        }
    })?;
    opened(path)
}

/// [`open`] without the check in a child (the file is checked, or still being written).
pub(super) fn opened(path: &Path) -> Result<Recording, TelemetryError> {
    let r = load(path)?;
    let c = guarded(&r, read)?;
    Ok(Recording {
        scenario: c.scenario,
        seed: c.seed,
        method: c.method,
        faults: c.faults,
        n: c.n,
        expected: c.expected,
        chunk_rows: super::CHUNK_ROWS as u64,
        follow: None,
        seen: std::cell::Cell::new(0),
        has_tick: c.has_tick,
        r,
    })
}

/// [`open`] a recording that may still be being written, and follow it: until it
/// opens with rows (the file created, its writer in SWMR mode, a first flush), it is
/// tried again for up to `idle`; the last error is returned after that. The file is
/// still being written (by this project's writer): it is not checked in a child first.
pub fn open_following(path: &Path, idle: std::time::Duration) -> Result<Recording, TelemetryError> {
    let since = std::time::Instant::now();
    loop {
        match opened(path) {
            Ok(mut rec) => {
                rec.follow = Some(idle);
                return Ok(rec);
            }
            Err(e) if since.elapsed() >= idle => return Err(e),
            Err(_) => std::thread::sleep(std::time::Duration::from_millis(100)),
        }
    }
}

/// Run `f` on the file; a panic inside the HDF5 binding is reported as corruption.
pub(super) fn guarded<T>(
    r: &Reader,
    f: impl FnOnce(&Reader) -> Result<T, TelemetryError>,
) -> Result<T, TelemetryError> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| f(r))).map_err(|_| {
        TelemetryError::CorruptStructure {
            path: r.origin.clone(),
        }
    })?
}

/// Open the file with libhdf5, which checks its superblock and length (data is read
/// on demand). A file still open for writing, or whose writer died, opens as an SWMR
/// reader sees it: every row flushed so far.
pub(super) fn load(path: &Path) -> Result<Reader, TelemetryError> {
    std::fs::metadata(path).map_err(|source| TelemetryError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let open = |mode| {
        let mut b = File::with_options();
        // An SWMR reader retries metadata whose checksum fails, backing off twice as
        // long each time from 1 ns (100 tries by default: hours on a corrupt file).
        b.fapl()
            .metadata_read_attempts(crate::tuning::SWMR_READ_ATTEMPTS);
        std::panic::catch_unwind(|| b.open_as(path, mode)).map_err(|_| TelemetryError::Corrupt {
            path: path.to_path_buf(),
        })
    };
    let file = match open(hdf5::file::OpenMode::Read)? {
        Ok(f) => f,
        Err(first) => match open(hdf5::file::OpenMode::ReadSWMR)? {
            Ok(f) => f,
            Err(_) => return Err(not_hdf5(path, first)),
        },
    };
    super::cloexec::keep_from_children(&file);
    Ok(Reader {
        file,
        origin: path.to_path_buf(),
    })
}

/// libhdf5 refused to open `path`: truncated, or not HDF5 at all.
fn not_hdf5(path: &Path, source: hdf5::Error) -> TelemetryError {
    let text = source.to_string();
    match text.contains("truncated") {
        true => TelemetryError::Truncated {
            path: path.to_path_buf(),
            detail: text,
        },
        false => TelemetryError::NotHdf5 {
            path: path.to_path_buf(),
            source,
        },
    }
}

/// A recording's metadata, checked.
struct Checked {
    scenario: Scenario,
    seed: u64,
    method: Option<String>,
    faults: Vec<crate::sim::faults::FaultRecord>,
    n: u64,
    expected: u64,
    has_tick: bool,
}

/// Check that `/time` (and `/tick`, if present) hold `n` finite, strictly increasing
/// values, reading them a window at a time.
fn check_increasing(r: &Reader, n: u64, truncated: bool) -> Result<bool, TelemetryError> {
    let rows = super::CHUNK_ROWS as u64;
    let time = r.shaped_rows(l::TIME, n, &[], truncated)?;
    let mut prev: Option<f64> = None;
    for start in (0..n).step_by(rows as usize) {
        let t = r.f64_rows(&time, l::TIME, start, rows.min(n - start))?;
        for (k, &x) in t.iter().enumerate() {
            let i = start + k as u64;
            if !x.is_finite() {
                return Err(r.err(format!("/time[{i}] is not finite")));
            }
            if let Some(p) = prev.filter(|&p| x <= p) {
                return Err(r.err(format!(
                    "/time is not strictly increasing at row {i} ({x} s after {p} s)"
                )));
            }
            prev = Some(x);
        }
    }
    if !r.has(l::TICK) {
        return Ok(false);
    }
    let tick = r.shaped_rows(l::TICK, n, &[], truncated)?;
    let mut prev: Option<u64> = None;
    for start in (0..n).step_by(rows as usize) {
        let t = r.int_rows(&tick, l::TICK, start, rows.min(n - start))?;
        for (k, &x) in t.iter().enumerate() {
            if let Some(p) = prev.filter(|&p| x <= p) {
                return Err(r.err(format!(
                    "/tick is not strictly increasing at row {} ({x} after {p})",
                    start + k as u64
                )));
            }
            prev = Some(x);
        }
    }
    Ok(true)
}

fn read(r: &Reader) -> Result<Checked, TelemetryError> {
    let (rows, t01) = {
        let d = r.dataset(l::TIME)?;
        let shape = d.shape();
        if shape.len() != 1 || shape[0] == 0 {
            return Err(r.err(format!(
                "/time has shape {shape:?}, the layout needs [N] with N > 0"
            )));
        }
        (shape[0] as u64, r.f64_rows(&d, l::TIME, 0, 2)?)
    };
    let ours = r.attr("format").is_some();
    if let Some(a) = r.attr("format_version") {
        let v =
            num_attr(&a).ok_or_else(|| r.err("root attribute `format_version` is not a number"))?;
        if v != l::FORMAT_VERSION as f64 {
            return Err(r.err(format!(
                "format_version {v} is not one this build reads ({}): a newer or foreign layout",
                l::FORMAT_VERSION
            )));
        }
    }
    let two = r.has(l::IS_VOLTAGE[1]);
    if !r.has(l::IS_VOLTAGE[0]) {
        return Err(r.missing(l::IS_VOLTAGE[0]));
    }
    let scenario = match r.attr("scenario") {
        Some(a) => {
            let text =
                text_attr(&a).ok_or_else(|| r.err("root attribute `scenario` is not a string"))?;
            Scenario::from_toml_str(&text)
                .map_err(|e| r.err(format!("root attribute `scenario`: {e}")))?
        }
        None => {
            // Another tool's file: the default scenario at the file's rate and length.
            let fs = match r.attr("sample_rate_hz") {
                Some(a) => num_attr(&a)
                    .ok_or_else(|| r.err("root attribute `sample_rate_hz` is not a number"))?,
                None if rows >= 2 => 1.0 / (t01[1] - t01[0]),
                None => return Err(r.err("one sample and no `sample_rate_hz` attribute")),
            };
            let mut s = Scenario {
                sample_rate_hz: fs,
                duration_s: rows as f64 / fs,
                ..Scenario::default()
            };
            s.star_tracker.rate_hz = s.star_tracker.rate_hz.min(fs);
            if !two {
                s.inertial_sensor.truncate(1);
            }
            s.validated()
                .map_err(|e| r.err(format!("no `scenario` attribute, and {e}")))?
        }
    };
    let n_is = scenario.inertial_sensor.len();
    let expected = scenario.n_samples();
    // A recording of ours cut short (its writer stopped or is still writing): the
    // rows every replayed dataset has. Any other count is an error.
    let truncated = ours && rows < expected;
    let mut paths = vec![l::TIME, l::STAR_Q, l::STAR_VALID];
    for i in 0..n_is.min(2) {
        paths.extend([l::IS_VOLTAGE[i], l::IS_FLAGS[i]]);
    }
    let n = match truncated {
        true => paths
            .iter()
            .chain(r.has(l::TICK).then_some(&l::TICK))
            .filter_map(|p| r.file.dataset(p).ok())
            .map(|d| d.shape().first().copied().unwrap_or(0) as u64)
            .fold(rows, u64::min),
        false => rows,
    };
    if !truncated && expected != n {
        return Err(r.err(format!(
            "/time has {n} rows, but the scenario ({} s at {} Hz) has {expected} samples",
            scenario.duration_s, scenario.sample_rate_hz,
        )));
    }
    if n == 0 {
        return Err(r.err("no sample was written (the recording stopped before its first chunk)"));
    }
    if n_is == 2 && !two {
        return Err(r.err(format!(
            "the scenario has two inertial sensors but /{} is missing",
            l::IS_VOLTAGE[1]
        )));
    }
    let has_tick = check_increasing(r, n, truncated)?;
    let seed = match r.attr("seed") {
        Some(a) => match a.read_scalar::<u64>() {
            Ok(v) => v,
            Err(_) => {
                num_attr(&a).ok_or_else(|| r.err("root attribute `seed` is not a number"))? as u64
            }
        },
        None => scenario.seed,
    };
    let method = r.attr("method").and_then(|a| text_attr(&a));
    r.shaped_rows(l::STAR_Q, n, &[4], truncated)?;
    r.shaped_rows(l::STAR_VALID, n, &[], truncated)?;
    for i in 0..n_is {
        r.shaped_rows(l::IS_VOLTAGE[i], n, &[3, 2], truncated)?;
        r.shaped_rows(l::IS_FLAGS[i], n, &[], truncated)?;
    }
    let faults = read_faults(r, n)?;
    Ok(Checked {
        scenario,
        seed,
        method,
        faults,
        n,
        expected,
        has_tick,
    })
}

impl Recording {
    /// How the recording falls short of its scenario, if it does.
    pub fn truncation(&self) -> Option<Truncation> {
        let rows = self.n.max(self.seen.get());
        if rows >= self.expected {
            return None;
        }
        let last = rows - 1;
        let last_tick = match self.has_tick {
            true => guarded(&self.r, |r| {
                r.int_rows(&r.dataset(l::TICK)?, l::TICK, last, 1)
            })
            .ok()
            .and_then(|v| v.first().copied())
            .unwrap_or(last),
            false => last,
        };
        Some(Truncation {
            rows,
            expected: self.expected,
            last_tick,
        })
    }

    /// The sensor stream, in tick order, read a window at a time.
    pub fn samples(&self) -> Samples<'_> {
        Samples {
            rec: self,
            next: 0,
            avail: self.n,
            window: Vec::new().into_iter(),
            failed: false,
        }
    }

    /// Rows every replayed dataset holds now (re-read from the file: a writer may be
    /// adding them), at most the scenario's.
    fn rows_now(&self) -> u64 {
        let r = &self.r;
        let mut paths = vec![l::TIME, l::STAR_Q, l::STAR_VALID];
        if self.has_tick {
            paths.push(l::TICK);
        }
        for i in 0..self.scenario.inertial_sensor.len().min(2) {
            paths.extend([l::IS_VOLTAGE[i], l::IS_FLAGS[i]]);
        }
        let rows = |p: &&str| -> u64 {
            r.file.dataset(p).ok().map_or(0, |d| {
                let _ = d.refresh();
                d.shape().first().copied().unwrap_or(0) as u64
            })
        };
        paths.iter().map(rows).min().unwrap_or(0).min(self.expected)
    }

    /// Wait, up to `idle` without a new row, for rows past `avail`; the rows now.
    fn wait_for_rows(&self, avail: u64, idle: std::time::Duration) -> u64 {
        let since = std::time::Instant::now();
        loop {
            let now = self.rows_now();
            if now > avail || since.elapsed() >= idle {
                return now.max(avail);
            }
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
    }

    /// Samples `[start, start + count)`.
    fn window(&self, start: u64, count: u64) -> Result<Vec<SensorSample>, TelemetryError> {
        guarded(&self.r, |r| {
            let n_is = self.scenario.inertial_sensor.len();
            let ds = |p: &str| r.file.dataset(p).map_err(|_| r.missing(p));
            let ticks = if self.has_tick {
                r.int_rows(&ds(l::TICK)?, l::TICK, start, count)?
            } else {
                (start..start + count).collect()
            };
            let star_q = r.f64_rows(&ds(l::STAR_Q)?, l::STAR_Q, start, count)?;
            let star_valid = r.int_rows(&ds(l::STAR_VALID)?, l::STAR_VALID, start, count)?;
            let mut volts = Vec::new();
            let mut flags = Vec::new();
            for i in 0..n_is {
                volts.push(r.f64_rows(&ds(l::IS_VOLTAGE[i])?, l::IS_VOLTAGE[i], start, count)?);
                flags.push(r.int_rows(&ds(l::IS_FLAGS[i])?, l::IS_FLAGS[i], start, count)?);
            }
            let m = ticks.len();
            if star_q.len() != 4 * m
                || star_valid.len() != m
                || volts.iter().any(|v| v.len() != 6 * m)
                || flags.iter().any(|f| f.len() != m)
            {
                return Err(r.err(format!(
                    "rows {start}..{} could not all be read",
                    start + count
                )));
            }
            let fs = self.scenario.sample_rate_hz;
            Ok((0..m)
                .map(|k| {
                    let mut s = SensorSample {
                        header: Header::at(start + k as u64, ticks[k], fs),
                        star: StarSample {
                            q_bn: std::array::from_fn(|j| star_q[4 * k + j]),
                            valid: star_valid[k].min(255) as u8,
                            _pad: [0; 7],
                        },
                        ..Default::default()
                    };
                    for i in 0..2 {
                        if i >= n_is {
                            s.is[i].flags = FLAG_ABSENT;
                            continue;
                        }
                        s.is[i] = IsSample {
                            volts: std::array::from_fn(|j| {
                                [volts[i][6 * k + 2 * j], volts[i][6 * k + 2 * j + 1]]
                            }),
                            flags: flags[i][k].min(255) as u8,
                            _pad: [0; 7],
                        };
                    }
                    s
                })
                .collect())
        })
    }
}

/// The samples of a [`Recording`], a window at a time; a read error ends them.
pub struct Samples<'a> {
    rec: &'a Recording,
    next: u64,
    /// Rows known to be in the file.
    avail: u64,
    window: std::vec::IntoIter<SensorSample>,
    failed: bool,
}

impl Iterator for Samples<'_> {
    type Item = Result<SensorSample, TelemetryError>;

    fn next(&mut self) -> Option<Self::Item> {
        if let Some(s) = self.window.next() {
            return Some(Ok(s));
        }
        if self.failed {
            return None;
        }
        if self.next >= self.avail {
            match self.rec.follow {
                Some(idle) if self.avail < self.rec.expected => {
                    self.avail = self.rec.wait_for_rows(self.avail, idle);
                }
                _ => {}
            }
            if self.next >= self.avail {
                return None;
            }
        }
        let count = self.rec.chunk_rows.max(1).min(self.avail - self.next);
        match self.rec.window(self.next, count) {
            Ok(w) => {
                self.next += w.len() as u64;
                self.rec.seen.set(self.rec.seen.get().max(self.next));
                self.window = w.into_iter();
                self.window.next().map(Ok)
            }
            Err(e) => {
                self.failed = true;
                Some(Err(e))
            }
        }
    }
}

/// Fault records a campaign of `n` samples logs at most: per tick two IS dropouts, a
/// star-tracker dropout, the start of a star-tracker jump, an upset and two bus faults
/// (seven), with a spare, plus each outlier and stuck channel (at most `MAX_EVENTS`
/// each). A log that says it is longer is corrupt: it is refused before anything the
/// size of its claim is allocated.
fn max_fault_rows(n: u64) -> u64 {
    let events = crate::sim::scenario::faults::MAX_EVENTS as u64;
    n.saturating_mul(8).saturating_add(2 * events)
}

/// The `/faults/*` log, if the file has one, of a recording of `n` samples.
pub(super) fn read_faults(
    r: &Reader,
    n: u64,
) -> Result<Vec<crate::sim::faults::FaultRecord>, TelemetryError> {
    if !r.has(l::FAULT_TICK) {
        return Ok(Vec::new());
    }
    let nf = r
        .dataset(l::FAULT_TICK)?
        .shape()
        .first()
        .copied()
        .unwrap_or(0) as u64;
    let most = max_fault_rows(n);
    if nf > most {
        return Err(r.err(format!(
            "/{} has {nf} rows, more than a campaign of {n} samples logs (at most {most})",
            l::FAULT_TICK
        )));
    }
    let tick = r.ints(l::FAULT_TICK, nf)?;
    let kind = r.ints(l::FAULT_KIND, nf)?;
    let field = r.ints(l::FAULT_FIELD, nf)?;
    let bit = r.ints(l::FAULT_BIT, nf)?;
    let samples = r.ints(l::FAULT_SAMPLES, nf)?;
    let before = r.f64s(l::FAULT_BEFORE, &[nf])?;
    let after = r.f64s(l::FAULT_AFTER, &[nf])?;
    let sigmas = r.f64s(l::FAULT_SIGMAS, &[nf])?;
    Ok((0..nf as usize)
        .map(|i| crate::sim::faults::FaultRecord {
            tick: tick[i],
            kind: kind[i].min(255) as u8,
            field: field[i].min(255) as u8,
            bit: bit[i].min(63) as u8,
            samples: samples[i].min(u32::MAX as u64) as u32,
            before: before[i],
            after: after[i],
            sigmas: sigmas[i],
        })
        .collect())
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::sim::msg::TruthState;
    use crate::telemetry::{Meta, Telemetry};

    /// 100 samples, with a written maneuver that fits them.
    const TINY: &str = "name = \"tiny\"\nduration_s = 10.0\nsample_rate_hz = 10.0\n\
        [maneuver]\nfrequency_hz = 0.1\nschedule = \"simultaneous\"\n\
        torque_amplitude_nm = [1e-6, 1e-6, 1e-6]\n";

    /// A folder of this test's own.
    pub(in crate::telemetry) fn folder(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("taiji-read-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// A complete recording of quiet samples at `path`.
    pub(in crate::telemetry) fn tiny_recording(path: &Path) {
        let s = Scenario::from_toml_str(TINY).unwrap();
        let n = s.n_samples();
        let mut t = Telemetry::new(s.inertial_sensor.len(), s.sample_rate_hz, n);
        for k in 0..n {
            let mut truth = TruthState::default();
            truth.header.tick = k;
            truth.q_bn = [1.0, 0.0, 0.0, 0.0];
            t.record_truth(&truth);
            let mut x = SensorSample::default();
            x.header.tick = k;
            x.star.q_bn = [1.0, 0.0, 0.0, 0.0];
            x.star.valid = 1;
            t.record_sensor(&x);
        }
        t.write(path, &Meta::of(&s, 1, "joint", "run")).unwrap();
    }

    /// Declares `group/name` 10¹² rows long for each name, without writing a row
    /// (chunked, nothing allocated on disk: the file stays small).
    pub(in crate::telemetry) fn claim_huge(path: &Path, group: &str, names: &[&str]) {
        let f = File::open_rw(path).unwrap();
        let g = f.group(group).or_else(|_| f.create_group(group)).unwrap();
        for name in names {
            if g.link_exists(name) {
                g.unlink(name).unwrap();
            }
            g.new_dataset::<u64>()
                .chunk(1024)
                .shape(1_000_000_000_000usize)
                .create(*name)
                .unwrap();
        }
    }

    #[test]
    fn a_fault_log_longer_than_its_campaign_can_log_is_refused_not_allocated() {
        // Found by the telemetry fuzz target: a 64 KB file whose /faults/* claim 10¹²
        // rows aborted the replay ("memory allocation of 8000000000000 bytes failed").
        let d = folder("huge-faults");
        let path = d.join("telemetry.h5");
        tiny_recording(&path);
        assert!(open(&path).unwrap().faults.is_empty());
        claim_huge(
            &path,
            "faults",
            &["tick", "kind", "field", "bit", "samples"],
        );
        let e = open(&path).err().expect("refused").to_string();
        assert!(
            e.contains(
                "/faults/tick has 1000000000000 rows, more than a campaign of 100 samples logs"
            ),
            "{e}"
        );
        let e = crate::telemetry::truth::fault_log(&path).expect_err("refused");
        assert!(e.to_string().contains("/faults/tick has"), "{e}");
        std::fs::remove_dir_all(&d).unwrap();
    }
}
