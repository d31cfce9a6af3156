//! In-orbit calibration of the Taiji inertial sensors (Liu et al. 2025; docs/README.md):
//! the plant, front-end electronics, commander and estimators as plain stage types
//! with fixed-size inputs and outputs, so they run in one process or as separate
//! processes over iceoryx2 shared memory.
pub mod alloc_count;
pub mod bus;
pub mod campaign;
pub mod checkpoint;
pub mod commander;
pub mod crlb;
pub mod estimate;
pub mod faults;
pub mod fee;
pub mod launch;
pub mod model;
pub mod montecarlo;
pub mod msg;
pub mod plots;
pub mod process;
pub mod progress;
pub mod replay;
pub mod report;
pub mod report_doc;
pub mod rng;
pub mod scenario;
pub mod telemetry;
pub mod timing;
