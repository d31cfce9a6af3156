//! In-orbit calibration of the Taiji inertial sensors (Liu et al. 2025; docs/README.md):
//! the std layer above the flight core (`taiji_core`, crates/taiji-core: no_std, no
//! alloc), which holds the estimators, the messages they read and write, and their maths.
//!
//! The layers, bottom first, one folder each; a layer uses only the layers declared
//! before it (tests/layers.rs reads them from this list and the tree):

/// In-process runs, the bound, the planner, reports, figures, fuzz and upset harnesses.
pub mod analysis;
/// The iceoryx2 bus, the set's topology, timing and the allocation counter.
pub mod bus;
/// The `taiji-calib` command line.
pub mod cli;
/// The process set, its hosts and the live monitor.
pub mod runtime;
/// Simulation: the set's messages, the scenario, the models and the stages.
pub mod sim;
/// The `telemetry.h5` recording: writing and reading.
pub mod telemetry;
