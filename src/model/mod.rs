//! Physical models: attitude dynamics, thrusters, noise generators and the plant.
pub mod attitude;
pub mod noise;
pub mod plant;
pub mod thruster;
