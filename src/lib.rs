//! In-orbit calibration of the Taiji inertial sensors (Liu et al. 2025; docs/README.md):
//! the std layer above the flight core. The plant, front-end electronics and
//! commander as plain stage types with fixed-size inputs and outputs, so they run in
//! one process or as separate processes over iceoryx2 shared memory; the bus, the
//! process set, telemetry, analysis, figures and the command line.
//!
//! The estimators, the messages they read and write, and their maths are the flight
//! core (`taiji_core`, crates/taiji-core: no_std, no alloc). `math` and `capi` are
//! re-exported from it as they are; `msg`, `estimate` and `model` re-export the core's
//! items and add what only the simulation and the set may see (truth, random streams).
//! The layers are stated in docs/architecture.md and checked by tests/layers.rs.

pub use taiji_core::{capi, math};

pub mod alloc_count;
pub mod bus;
pub mod campaign;
pub mod checkpoint;
pub mod commander;
pub mod crlb;
pub mod estimate;
pub mod export;
pub mod faults;
pub mod fee;
pub mod fuzz;
pub mod launch;

pub mod model;
pub mod monitor;
pub mod montecarlo;
pub mod msg;
pub mod plan;
pub mod plots;
pub mod process;
pub mod progress;
pub mod replay;
pub mod report;
pub mod report_doc;
pub mod requirements;
pub mod rng;
pub mod scenario;
pub mod stage;
pub mod telemetry;
pub mod timing;
pub mod topology;
pub mod upset;
