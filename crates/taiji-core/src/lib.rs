//! The flight core of the Taiji inertial-sensor calibration (docs/architecture.md):
//! the fixed-size messages the estimator reads and writes (`msg`), the estimators
//! (`estimate`) and their tuned constants (`tuning`), the models and maths they need
//! (`model`, `math`) and the C ABI (`capi`). `no_std` without `alloc` on every target;
//! it cannot name truth, random numbers, the bus or the tools, because none of them is a
//! dependency.
#![no_std]

// Unit tests run on the host with std (the library itself never links it).
#[cfg(test)]
extern crate std;

pub mod capi;
pub mod estimate;
pub mod math;
pub mod model;
pub mod msg;
pub mod simd;
pub mod tuning;
