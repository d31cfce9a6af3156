//! Physical models: attitude dynamics, thrusters, noise generators and the plant.
pub mod attitude;
pub mod noise;
#[cfg(feature = "std")]
pub mod plant;
#[cfg(feature = "std")]
pub mod thruster;
