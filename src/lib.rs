//! In-orbit calibration of the Taiji inertial sensors (Liu et al. 2025; docs/README.md):
//! the std layer above the flight core (`taiji_core`, crates/taiji-core: no_std, no
//! alloc), which holds the estimators, the messages they read and write, and their maths.
//!
//! The layers, bottom first, one folder each; a layer uses only the layers declared
//! before it (tests/layers.rs reads them from this list and the tree). A blank line
//! between them keeps rustfmt from sorting them by name.

/// Layer 0: the std layer's tuned constants, one table that every layer reads.
pub mod tuning;

/// Layer 1, simulation: the set's messages, the scenario, the models and the stages.
pub mod sim;

/// Layer 2: the iceoryx2 bus, the set's topology, timing and the allocation counter.
pub mod bus;

/// Layer 3: the `telemetry.h5` recording, written and read.
pub mod telemetry;

/// Layer 4: the ground link's packets: CCSDS space packets, PUS-C, authentication, the dictionary.
pub mod ground;

/// Layer 5: in-process runs, the bound, the planner, reports, figures, fuzz and upsets.
pub mod analysis;

/// Layer 6: the process set, its hosts and the live monitor.
pub mod runtime;

/// Layer 7: the `taiji-calib` command line.
pub mod cli;
