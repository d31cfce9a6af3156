//! Physical models of the simulation: the plant and its thrusters, and the noise
//! generators. The attitude kinematics are the flight core's.
pub use taiji_core::model::attitude;
pub mod noise;
pub mod plant;
pub mod thruster;
