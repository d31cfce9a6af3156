//! Models the estimator itself needs: the attitude kinematics and the noise bank it
//! reuses as the state-space model that whitens the coloured SRP noise.
pub mod attitude;
pub mod noise;
