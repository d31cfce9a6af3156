//! Layer 5, runtime: the process set (its stages, supervisor and hosts), the launch
//! description and the live monitor.

pub mod launch;
pub mod monitor;
pub mod process;
