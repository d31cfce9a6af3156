//! The mission's calibration requirements (Taiji; docs/physics.md): what a result is judged
//! against by the report, the planner and the Monte Carlo summary alike.

/// Scale-factor requirement, relative per axis (0.03 %).
pub const REQ_SCALE_FACTOR_REL: f64 = 3e-4;
/// CoM requirement per axis [m].
pub const REQ_COM_M: f64 = 75e-6;
