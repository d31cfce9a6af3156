//! `telemetry.h5` writer, streaming: one contiguous dataset per channel with `units`
//! and `description` attributes, the scenario and software version on the root.
//!
//! Every dataset's storage is reserved when the file is created (N rows for the
//! samples, a bound for the estimate rows), so the file's structure never moves. Rows
//! are buffered [`CHUNK_ROWS`] at a time; each full chunk is written into the reserved
//! storage, then each dataset's header is rewritten with its new row count. The file
//! on disk is therefore always valid, holding every chunk written so far: a crash loses
//! at most the buffered chunk, and h5py reads a recording while it grows. Memory is
//! one chunk, whatever the campaign's length.

use super::columns::{estimate_columns, sample_columns, Column};
use super::h5::{self, Kind, Msg, Value};
use super::layout as l;
use super::{Meta, RowGate, Telemetry, TelemetryError};
use crate::faults::FaultRecord;
use crate::msg::{EstimateMsg, Header, IsSample, SensorSample, StarSample, TruthState};
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};

/// Samples per chunk: 4096 rows (≈ 1.4 MB with two IS; 410 s of a 10 Hz campaign).
pub const CHUNK_ROWS: usize = 4096;

/// Room left in the root header for the `faults` link added at the end [bytes].
const ROOT_SPARE: usize = 40;

fn align8(x: u64) -> u64 {
    x.div_ceil(8) * 8
}

/// Lays out objects one after another from `at`.
struct Alloc {
    at: u64,
}

impl Alloc {
    fn take(&mut self, bytes: u64) -> u64 {
        let a = self.at;
        self.at = align8(self.at + bytes);
        a
    }
}

/// The strings of a batch of objects, to go into one global heap collection.
#[derive(Default)]
struct Strings {
    all: Vec<String>,
}

impl Strings {
    /// A text attribute value for `s` (the heap's address filled in by `place`).
    fn add(&mut self, s: &str) -> Value {
        self.all.push(s.to_string());
        Value::Text(0, self.all.len() as u32, s.len())
    }

    fn heap(&self) -> Vec<u8> {
        let refs: Vec<&str> = self.all.iter().map(String::as_str).collect();
        h5::global_heap(&refs)
    }
}

/// `units` and `description` of `path`, their strings in `strings`.
fn channel_attrs(path: &str, strings: &mut Strings, heap_at: u64) -> Vec<Msg> {
    let c = l::channel(path);
    [("units", c.units), ("description", c.description)]
        .into_iter()
        .map(|(name, text)| h5::attribute(name, &at_heap(&strings.add(text), heap_at)))
        .collect()
}

/// `v` with its string (if any) in the heap at `heap_at`.
fn at_heap(v: &Value, heap_at: u64) -> Value {
    match *v {
        Value::Text(_, i, n) => Value::Text(heap_at, i, n),
        Value::U64(x) => Value::U64(x),
        Value::F64(x) => Value::F64(x),
    }
}

/// The datasets of `cols` grouped as the layout's paths say: (group, [(name, column)]).
fn groups<'a>(
    cols: impl Iterator<Item = &'a Column>,
) -> Vec<(&'static str, Vec<(&'static str, usize)>)> {
    let mut g: Vec<(&'static str, Vec<(&'static str, usize)>)> = Vec::new();
    for (i, c) in cols.enumerate() {
        let (group, name) = c.path.rsplit_once('/').unwrap_or(("", c.path));
        match g.iter_mut().find(|(n, _)| *n == group) {
            Some((_, v)) => v.push((name, i)),
            None => g.push((group, vec![(name, i)])),
        }
    }
    g
}

/// Streams a recording to `telemetry.h5` as it is made (see the module doc).
pub struct Writer {
    file: std::fs::File,
    path: PathBuf,
    fs: f64,
    n_is: usize,
    /// Samples the file is laid out for.
    n: u64,
    chunk_rows: usize,
    samples: Vec<Column>,
    estimates: Vec<Column>,
    gate: RowGate,
    root_at: u64,
    /// The root's messages but the spare room (links first, then attributes).
    root_msgs: Vec<Msg>,
    eof: u64,
}

impl Writer {
    /// Create `path` for `n` samples of the run `meta` describes, written `chunk_rows`
    /// rows at a time ([`CHUNK_ROWS`] outside tests).
    pub fn create(
        path: &Path,
        meta: &Meta,
        n: u64,
        chunk_rows: usize,
    ) -> Result<Self, TelemetryError> {
        let ni = meta.n_is;
        let fs = meta.sample_rate_hz;
        let (mut samples, mut estimates) = sized_columns(ni, fs, n);
        // Sizes first (they do not depend on addresses), then addresses, then bytes.
        let at = place(meta, &mut samples, &mut estimates);
        let (image, root) = metadata_image(meta, &mut samples, &mut estimates, &at, chunk_rows);
        let file = open_file(path, &image, at.eof)?;
        Ok(Writer {
            file,
            path: path.to_path_buf(),
            fs,
            n_is: ni,
            n,
            chunk_rows: chunk_rows.max(1),
            samples,
            estimates,
            gate: RowGate::default(),
            root_at: at.root,
            root_msgs: root,
            eof: at.eof,
        })
    }

    /// The rows handed over do not make the recording: `what`.
    fn rows_err(&self, what: String) -> TelemetryError {
        TelemetryError::Rows {
            path: self.path.clone(),
            what,
        }
    }

    fn io_err(&self, source: std::io::Error) -> TelemetryError {
        TelemetryError::Write {
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

    /// Write the buffered rows, then publish them in the datasets' headers.
    pub fn flush(&mut self) -> Result<(), TelemetryError> {
        let need = self.estimates[0].rows + self.estimates[0].pending();
        if need > self.estimates[0].capacity {
            self.grow_estimates(need)?;
        }
        let file = &self.file;
        let path = &self.path;
        let err = |source| TelemetryError::Write {
            path: path.clone(),
            source,
        };
        let cols = || self.samples.iter().chain(self.estimates.iter());
        for c in cols().filter(|c| !c.buf.is_empty()) {
            file.write_all_at(&c.buf, c.data_at + c.rows * c.row_bytes)
                .map_err(err)?;
        }
        for c in self.samples.iter_mut().chain(self.estimates.iter_mut()) {
            if !c.buf.is_empty() {
                c.rows += c.pending();
                c.buf.clear();
                file.write_all_at(&c.header(), c.header_at).map_err(err)?;
            }
        }
        Ok(())
    }

    /// Move the estimate columns' storage to the end of the file, with room for
    /// `rows` rows at least.
    fn grow_estimates(&mut self, rows: u64) -> Result<(), TelemetryError> {
        let cap = rows.max(2 * self.estimates[0].capacity);
        let mut chunk = vec![0u8; 1 << 20];
        for k in 0..self.estimates.len() {
            let c = &self.estimates[k];
            let at = self.eof;
            let used = c.rows * c.row_bytes;
            let mut done = 0;
            while done < used {
                let n = (used - done).min(chunk.len() as u64) as usize;
                self.file
                    .read_exact_at(&mut chunk[..n], c.data_at + done)
                    .map_err(|e| self.io_err(e))?;
                self.file
                    .write_all_at(&chunk[..n], at + done)
                    .map_err(|e| self.io_err(e))?;
                done += n as u64;
            }
            self.eof = align8(at + cap * c.row_bytes);
            let c = &mut self.estimates[k];
            c.data_at = at;
            c.capacity = cap;
        }
        self.file.set_len(self.eof).map_err(|e| self.io_err(e))?;
        // The headers point to the new storage once the pending rows are published;
        // until then they still name the old one, intact.
        self.file
            .write_all_at(&h5::superblock(self.eof, self.root_at), 0)
            .map_err(|e| self.io_err(e))
    }

    /// Write what is buffered and the fault log (`[faults]` runs), and close the file.
    /// Fewer samples than the scenario's is an error, after they are written.
    pub fn finish(
        mut self,
        faults: &[FaultRecord],
        detected: &[u64],
    ) -> Result<(), TelemetryError> {
        self.flush()?;
        if !faults.is_empty() {
            self.write_faults(faults, detected)?;
        }
        let got = self.samples[0].rows;
        if got != self.n {
            return Err(self.rows_err(format!("incomplete recording: {got} of {} samples", self.n)));
        }
        Ok(())
    }

    /// The `/faults` group, at the end of the file, then linked from the root.
    fn write_faults(&mut self, f: &[FaultRecord], detected: &[u64]) -> Result<(), TelemetryError> {
        let nf = f.len();
        let u = |g: &dyn Fn(&FaultRecord) -> u64| -> Vec<u8> {
            f.iter().flat_map(|r| g(r).to_le_bytes()).collect()
        };
        let x = |g: &dyn Fn(&FaultRecord) -> f64| -> Vec<u8> {
            f.iter().flat_map(|r| g(r).to_le_bytes()).collect()
        };
        let det: Vec<u8> = (0..nf)
            .flat_map(|i| detected.get(i).copied().unwrap_or(0).to_le_bytes())
            .collect();
        let cols: Vec<(&'static str, Kind, Vec<u8>)> = vec![
            (l::FAULT_TICK, Kind::U64, u(&|r| r.tick)),
            (l::FAULT_KIND, Kind::U64, u(&|r| r.kind as u64)),
            (l::FAULT_FIELD, Kind::U64, u(&|r| r.field as u64)),
            (l::FAULT_BIT, Kind::U64, u(&|r| r.bit as u64)),
            (l::FAULT_SAMPLES, Kind::U64, u(&|r| r.samples as u64)),
            (l::FAULT_BEFORE, Kind::F64, x(&|r| r.before)),
            (l::FAULT_AFTER, Kind::F64, x(&|r| r.after)),
            (l::FAULT_SIGMAS, Kind::F64, x(&|r| r.sigmas)),
            (l::FAULT_DETECTED, Kind::U64, det),
        ];
        let mut strings = Strings::default();
        let placeholder: Vec<Vec<Msg>> = cols
            .iter()
            .map(|c| channel_attrs(c.0, &mut strings, 0))
            .collect();
        let mut alloc = Alloc { at: self.eof };
        let links: Vec<(&str, u64)> = cols.iter().map(|c| (name_of(c.0), 0)).collect();
        let group_at = alloc.take(h5::object_header(&h5::group(&links)).len() as u64);
        let dims = [nf as u64];
        let header_at: Vec<u64> = cols
            .iter()
            .zip(&placeholder)
            .map(|(c, a)| {
                alloc.take(h5::object_header(&h5::dataset(c.1, &dims, 0, a)).len() as u64)
            })
            .collect();
        let heap = strings.heap();
        let heap_at = alloc.take(heap.len() as u64);
        let data_at: Vec<u64> = cols.iter().map(|c| alloc.take(c.2.len() as u64)).collect();
        let eof = alloc.at;

        let mut strings = Strings::default();
        let mut image = vec![0u8; (eof - self.eof) as usize];
        let base = self.eof;
        let mut put = |at: u64, bytes: &[u8]| {
            let at = (at - base) as usize;
            image[at..at + bytes.len()].copy_from_slice(bytes);
        };
        let links: Vec<(&str, u64)> = cols
            .iter()
            .zip(&header_at)
            .map(|(c, &a)| (name_of(c.0), a))
            .collect();
        put(group_at, &h5::object_header(&h5::group(&links)));
        for (k, c) in cols.iter().enumerate() {
            let attrs = channel_attrs(c.0, &mut strings, heap_at);
            put(
                header_at[k],
                &h5::object_header(&h5::dataset(c.1, &dims, data_at[k], &attrs)),
            );
            put(data_at[k], &c.2);
        }
        put(heap_at, &heap);
        let path = self.path.clone();
        let err = |source| TelemetryError::Write {
            path: path.clone(),
            source,
        };
        self.file.write_all_at(&image, base).map_err(err)?;
        self.eof = eof;
        self.file.set_len(eof).map_err(err)?;
        self.file
            .write_all_at(&h5::superblock(eof, self.root_at), 0)
            .map_err(err)?;
        // Last, the link: until it is written the file is the one without faults.
        let root = root_header(&self.root_msgs, Some(group_at));
        self.file.write_all_at(&root, self.root_at).map_err(err)?;
        Ok(())
    }
}

/// The datasets of a file grouped as the layout's paths say (see [`groups`]).
type Tree = Vec<(&'static str, Vec<(&'static str, usize)>)>;

/// The sample and estimate columns of a file for `n` samples of `ni` sensors at `fs`
/// [Hz], with their capacities.
fn sized_columns(ni: usize, fs: f64, n: u64) -> (Vec<Column>, Vec<Column>) {
    let mut samples = sample_columns(ni);
    let mut estimates = estimate_columns(ni);
    // Estimate rows are ≥ one spacing apart, plus the first and the final one; more
    // (a foreign estimator cadence) moves their storage to the end of the file.
    let spacing = ((super::ESTIMATE_ROW_EVERY_S * fs).round() as u64).max(1);
    for c in &mut samples {
        c.capacity = n;
    }
    for c in &mut estimates {
        c.capacity = n / spacing + 2;
    }
    (samples, estimates)
}

/// The root's links: to each top-level dataset and each group, at `addr(group, column)`.
fn root_links(tree: &Tree, addr: &dyn Fn(&str, usize) -> u64) -> Vec<Msg> {
    let mut m = h5::group(&[]);
    for (group, items) in tree {
        if group.is_empty() {
            for &(name, i) in items {
                m.push(h5::link(name, addr("", i)));
            }
        } else {
            m.push(h5::link(group, addr(group, 0)));
        }
    }
    m
}

/// Where every object of a new file goes.
struct Placement {
    root: u64,
    /// Each group's header.
    groups: Vec<(&'static str, u64)>,
    /// Each column's header and storage, samples then estimates.
    headers: Vec<u64>,
    data: Vec<u64>,
    heap: u64,
    /// The global heap's bytes (the strings of every attribute).
    heap_bytes: Vec<u8>,
    /// The end of the metadata (headers and heap).
    meta_end: u64,
    eof: u64,
}

/// The first pass: the objects' sizes (which do not depend on addresses), hence their
/// addresses.
fn place(meta: &Meta, samples: &mut [Column], estimates: &mut [Column]) -> Placement {
    let mut strings = Strings::default();
    let root_attrs = root_attributes(meta, &mut strings);
    for c in samples.iter_mut().chain(estimates.iter_mut()) {
        c.attrs = channel_attrs(c.path, &mut strings, 0);
    }
    let all: Vec<&Column> = samples.iter().chain(estimates.iter()).collect();
    let tree = groups(all.iter().copied());
    let mut root_msgs = root_links(&tree, &|_, _| 0);
    root_msgs.extend(root_attrs.iter().map(|v| h5::attribute(v.0, &v.1)));
    let root_len = root_header(&root_msgs, None).len() as u64;
    let mut alloc = Alloc { at: 48 };
    let root = alloc.take(root_len);
    let mut group_at = Vec::new();
    for (group, items) in &tree {
        if !group.is_empty() {
            let links: Vec<(&str, u64)> = items.iter().map(|&(n, _)| (n, 0)).collect();
            let len = h5::object_header(&h5::group(&links)).len() as u64;
            group_at.push((*group, alloc.take(len)));
        }
    }
    let mut header_at = Vec::new();
    for c in &all {
        header_at.push(alloc.take(c.header().len() as u64));
    }
    let heap = strings.heap();
    let heap_at = alloc.take(heap.len() as u64);
    let meta_end = alloc.at;
    let mut data_at = Vec::new();
    for c in &all {
        data_at.push(alloc.take(c.capacity * c.row_bytes));
    }
    Placement {
        root,
        groups: group_at,
        headers: header_at,
        data: data_at,
        heap: heap_at,
        heap_bytes: heap,
        meta_end,
        eof: alloc.at,
    }
}

/// The second pass: the metadata's bytes (superblock, headers, heap) at the addresses
/// of `at`, the columns given theirs; and the root's messages.
fn metadata_image(
    meta: &Meta,
    samples: &mut [Column],
    estimates: &mut [Column],
    at: &Placement,
    chunk_rows: usize,
) -> (Vec<u8>, Vec<Msg>) {
    let heap_at = at.heap;
    let mut strings = Strings::default();
    let root_attrs = root_attributes(meta, &mut strings);
    for (k, c) in samples.iter_mut().chain(estimates.iter_mut()).enumerate() {
        c.attrs = channel_attrs(c.path, &mut strings, heap_at);
        c.header_at = at.headers[k];
        c.data_at = at.data[k];
        c.buf.reserve(chunk_rows * c.row_bytes as usize);
    }
    let mut image = vec![0u8; at.meta_end as usize];
    let mut put = |addr: u64, bytes: &[u8]| {
        image[addr as usize..addr as usize + bytes.len()].copy_from_slice(bytes);
    };
    let all: Vec<&Column> = samples.iter().chain(estimates.iter()).collect();
    let tree = groups(all.iter().copied());
    let group_addr = |g: &str| at.groups.iter().find(|(n, _)| *n == g).map_or(0, |x| x.1);
    let mut root = root_links(&tree, &|g, i| {
        if g.is_empty() {
            all[i].header_at
        } else {
            group_addr(g)
        }
    });
    root.extend(
        root_attrs
            .iter()
            .map(|v| h5::attribute(v.0, &at_heap(&v.1, heap_at))),
    );
    put(at.root, &root_header(&root, None));
    for (group, items) in &tree {
        if !group.is_empty() {
            let links: Vec<(&str, u64)> =
                items.iter().map(|&(n, i)| (n, all[i].header_at)).collect();
            put(group_addr(group), &h5::object_header(&h5::group(&links)));
        }
    }
    for c in &all {
        put(c.header_at, &c.header());
    }
    put(heap_at, &at.heap_bytes);
    put(0, &h5::superblock(at.eof, at.root));
    (image, root)
}

/// Create `path` holding `image`, `eof` bytes long.
fn open_file(path: &Path, image: &[u8], eof: u64) -> Result<std::fs::File, TelemetryError> {
    let err = |source| TelemetryError::Write {
        path: path.to_path_buf(),
        source,
    };
    // Read too: moving the estimate rows copies them.
    let file = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(true)
        .open(path)
        .map_err(err)?;
    file.write_all_at(image, 0).map_err(err)?;
    // The reserved storage reads as zeros (and takes no disk space) until written.
    file.set_len(eof).map_err(err)?;
    Ok(file)
}

fn name_of(path: &'static str) -> &'static str {
    path.rsplit_once('/').map_or(path, |x| x.1)
}

/// The root header: links, attributes, the `faults` link if any, and padding that
/// keeps its size whether or not that link is there.
fn root_header(msgs: &[Msg], faults: Option<u64>) -> Vec<u8> {
    let mut m = msgs.to_vec();
    let mut spare = ROOT_SPARE;
    if let Some(at) = faults {
        let link = h5::link("faults", at);
        spare -= link.size();
        m.push(link);
    }
    m.push(h5::nil(spare));
    h5::object_header(&m)
}

/// The root attributes (their strings added to `strings`).
fn root_attributes(meta: &Meta, strings: &mut Strings) -> Vec<(&'static str, Value)> {
    vec![
        ("format", strings.add(l::FORMAT)),
        ("format_version", Value::U64(l::FORMAT_VERSION)),
        (
            "software",
            strings.add(concat!(
                env!("CARGO_PKG_NAME"),
                " ",
                env!("CARGO_PKG_VERSION")
            )),
        ),
        ("scenario", strings.add(&meta.scenario_toml)),
        ("scenario_name", strings.add(&meta.scenario_name)),
        ("seed", Value::U64(meta.seed)),
        ("method", strings.add(&meta.method)),
        ("mode", strings.add(&meta.mode)),
        ("sample_rate_hz", Value::F64(meta.sample_rate_hz)),
        ("duration_s", Value::F64(meta.duration_s)),
        ("n_inertial_sensors", Value::U64(meta.n_is as u64)),
    ]
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
    fn estimate_rows_beyond_the_reserved_room_move_to_the_end_of_the_file() {
        let dir = std::env::temp_dir().join(format!("taiji-grow-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("grow.h5");
        let s = crate::scenario::Scenario::default();
        let mut meta = Meta::of(&s, 1, "joint", "in-process");
        meta.n_is = 1;
        // 10 samples at 10 Hz: room for 10 / 100 + 2 = 2 estimate rows; write 9.
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
        let f = hdf5_pure::File::open(&path).unwrap();
        assert_eq!(
            f.dataset(l::EST_TICK).unwrap().read_u64().unwrap(),
            (100..109).collect::<Vec<u64>>()
        );
        assert_eq!(
            f.dataset(l::EST_BETA).unwrap().shape().unwrap(),
            vec![9, 1, 3]
        );
        assert_eq!(
            f.dataset(l::TICK).unwrap().read_u64().unwrap(),
            (0..10).collect::<Vec<u64>>()
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
