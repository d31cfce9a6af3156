//! In-orbit calibration of the Taiji inertial sensors (Liu et al. 2025; docs/README.md):
//! the plant, front-end electronics, commander and estimators as plain stage types
//! with fixed-size inputs and outputs, so they run in one process or as separate
//! processes over iceoryx2 shared memory.
//!
//! Built without default features, the library is the flight core alone: `no_std`
//! without `alloc` — the fixed-size messages (`msg`), the estimators (`estimate`), the
//! models and maths they need, and the C ABI (`capi`). The default `std` feature adds
//! the simulation, the bus, telemetry, figures and the command line.
#![cfg_attr(all(not(feature = "std"), not(test)), no_std)]

pub mod capi;
pub mod estimate;
pub mod math;
pub mod model;
pub mod msg;

#[cfg(feature = "std")]
pub mod alloc_count;
#[cfg(feature = "std")]
pub mod bus;
#[cfg(feature = "std")]
pub mod campaign;
#[cfg(feature = "std")]
pub mod checkpoint;
#[cfg(feature = "std")]
pub mod commander;
#[cfg(feature = "std")]
pub mod crlb;
#[cfg(feature = "std")]
pub mod export;
#[cfg(feature = "std")]
pub mod faults;
#[cfg(feature = "std")]
pub mod fee;
#[cfg(feature = "std")]
pub mod launch;
#[cfg(feature = "std")]
pub mod maneuver;
#[cfg(feature = "std")]
pub mod montecarlo;
#[cfg(feature = "std")]
pub mod plan;
#[cfg(feature = "std")]
pub mod plots;
#[cfg(feature = "std")]
pub mod process;
#[cfg(feature = "std")]
pub mod progress;
#[cfg(feature = "std")]
pub mod replay;
#[cfg(feature = "std")]
pub mod report;
#[cfg(feature = "std")]
pub mod report_doc;
#[cfg(feature = "std")]
pub mod rng;
#[cfg(feature = "std")]
pub mod scenario;
#[cfg(feature = "std")]
pub mod telemetry;
#[cfg(feature = "std")]
pub mod timing;
