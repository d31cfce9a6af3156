//! `taiji-calib export`: a recording as the inputs a flight host gives the C library —
//! the estimator's table and the sensor samples, each in its `#[repr(C)]` layout
//! (`include/taiji_estimator.h`), so a C program reads them with one `fread`.
//!
//! Each file is a 24-byte header — magic `TJEXP001`, layout version (u32), record size
//! [bytes] (u32), record count (u64), little-endian — then the records:
//! `estimator_config.bin` holds one `TaijiEstimatorConfig`, `sensor_samples.bin` the
//! samples in the order `replay` feeds them to the estimator.

use crate::sim::files::FileError;
use crate::sim::msg::{SensorSample, LAYOUT_VERSION};
use crate::telemetry::read::Recording;
use std::io::Write;
use std::path::Path;

/// File names in the export folder.
pub const CONFIG_FILE: &str = "estimator_config.bin";
pub const SAMPLES_FILE: &str = "sensor_samples.bin";
const MAGIC: [u8; 8] = *b"TJEXP001";

fn header<T>(count: u64) -> [u8; 24] {
    let mut h = [0u8; 24];
    h[0..8].copy_from_slice(&MAGIC);
    h[8..12].copy_from_slice(&LAYOUT_VERSION.to_le_bytes());
    h[12..16].copy_from_slice(&(std::mem::size_of::<T>() as u32).to_le_bytes());
    h[16..24].copy_from_slice(&count.to_le_bytes());
    h
}

/// The export could not be written (or its recording read).
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// A file or folder that could not be read, created or written.
    #[error(transparent)]
    File(#[from] FileError),
    #[error(transparent)]
    Telemetry(#[from] crate::telemetry::TelemetryError),
}

fn create(dir: &Path, name: &str) -> Result<std::io::BufWriter<std::fs::File>, ExportError> {
    let path = dir.join(name);
    std::fs::File::create(&path)
        .map(std::io::BufWriter::new)
        .map_err(|source| ExportError::from(FileError::create(path, source)))
}

/// Writes the export of `rec` into `dir`; returns the number of samples.
pub fn write(rec: &Recording, dir: &Path) -> Result<u64, ExportError> {
    std::fs::create_dir_all(dir)
        .map_err(|source| ExportError::from(FileError::create(dir, source)))?;
    let s = &rec.scenario;
    let cfg = s.estimator_config(&s.priors());
    let mut f = create(dir, CONFIG_FILE)?;
    let err = |source| ExportError::from(FileError::write(dir, source));
    f.write_all(&header::<crate::sim::estimate::EstimatorConfig>(1))
        .map_err(err)?;
    f.write_all(bytemuck::bytes_of(&cfg)).map_err(err)?;
    f.flush().map_err(err)?;
    let n = rec.n;
    let mut f = create(dir, SAMPLES_FILE)?;
    f.write_all(&header::<SensorSample>(n)).map_err(err)?;
    for sample in rec.samples() {
        f.write_all(bytemuck::bytes_of(&sample?)).map_err(err)?;
    }
    f.flush().map_err(err)?;
    Ok(n)
}
