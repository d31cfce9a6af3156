//! Layer 1, simulation: the set's messages, the scenario, the models and the stages.
//!
//! `msg`, `estimate` and `model` re-export the flight core's items and add what only
//! the simulation and the set may see (truth, random streams); `math` and `capi` are
//! the core's, as they are.

pub use taiji_core::{capi, math};

pub mod commander;
pub mod drift;
pub mod estimate;
pub mod faults;
pub mod fee;
pub mod files;
pub mod model;
pub mod msg;
pub mod requirements;
pub mod rng;
pub mod scenario;
pub mod stage;
pub mod trend;
pub mod truth_box;
