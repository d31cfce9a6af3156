//! The documented layout of `telemetry.h5`: every dataset, its shape and SI units.
//! The writer, the reader and the README's table all follow this one list.

/// Value of the root attribute `format`.
pub const FORMAT: &str = "taiji-telemetry";
/// Value of the root attribute `format_version`.
pub const FORMAT_VERSION: u64 = 1;

/// One dataset of the file. In `shape`, N is the number of samples, M the number of
/// estimate rows, I the number of inertial sensors (1 or 2).
#[derive(Debug, Clone, Copy)]
pub struct Channel {
    pub path: &'static str,
    pub shape: &'static str,
    pub units: &'static str,
    pub description: &'static str,
}

const fn ch(
    path: &'static str,
    shape: &'static str,
    units: &'static str,
    description: &'static str,
) -> Channel {
    Channel {
        path,
        shape,
        units,
        description,
    }
}

pub const TIME: &str = "time";
pub const TICK: &str = "tick";
pub const TORQUE_CMD: &str = "command/torque";
pub const TORQUE: &str = "truth/torque";
pub const ATTITUDE: &str = "truth/attitude";
pub const OMEGA: &str = "truth/angular_velocity";
pub const OMEGA_DOT: &str = "truth/angular_acceleration";
pub const TM_ACC: &str = "truth/tm_acceleration";
pub const SRP_ACC: &str = "truth/srp_acceleration";
pub const STAR_Q: &str = "star_tracker/attitude";
pub const STAR_VALID: &str = "star_tracker/valid";
/// `is1/voltage`, `is2/voltage`.
pub const IS_VOLTAGE: [&str; 2] = ["is1/voltage", "is2/voltage"];
pub const IS_FLAGS: [&str; 2] = ["is1/flags", "is2/flags"];
pub const EST_TIME: &str = "estimate/time";
pub const EST_TICK: &str = "estimate/tick";
pub const EST_BETA: &str = "estimate/beta";
pub const EST_BETA_SIGMA: &str = "estimate/beta_sigma";
pub const EST_K: &str = "estimate/k";
pub const EST_K_SIGMA: &str = "estimate/k_sigma";
pub const EST_R: &str = "estimate/com_offset";
pub const EST_R_SIGMA: &str = "estimate/com_offset_sigma";
pub const EST_N_USED: &str = "estimate/n_used";
pub const EST_N_REJECTED: &str = "estimate/n_rejected";
pub const EST_FINAL: &str = "estimate/final";
pub const EST_STATUS: &str = "estimate/status";
pub const EST_REJECTED_BY_CAUSE: &str = "estimate/rejected_by_cause";
pub const EST_CHI2: &str = "estimate/chi2_per_dof";
pub const FAULT_TICK: &str = "faults/tick";
pub const FAULT_KIND: &str = "faults/kind";
pub const FAULT_FIELD: &str = "faults/field";
pub const FAULT_BIT: &str = "faults/bit";
pub const FAULT_SAMPLES: &str = "faults/samples";
pub const FAULT_BEFORE: &str = "faults/before";
pub const FAULT_AFTER: &str = "faults/after";
pub const FAULT_SIGMAS: &str = "faults/sigmas";
pub const FAULT_DETECTED: &str = "faults/detected";

/// Every dataset, in file order. `is2/*` is present only with two inertial sensors.
pub const CHANNELS: &[Channel] = &[
    ch(
        TIME,
        "N",
        "s",
        "simulation time at the end of each sample interval",
    ),
    ch(TICK, "N", "1", "sample index n (interval [n, n+1)/fs)"),
    ch(TORQUE_CMD, "N×3", "N m", "commanded torque, body frame"),
    ch(
        TORQUE,
        "N×3",
        "N m",
        "applied thruster torque (mean over the interval), body frame",
    ),
    ch(
        ATTITUDE,
        "N×4",
        "1",
        "true attitude quaternion q_BN (w, x, y, z)",
    ),
    ch(OMEGA, "N×3", "rad/s", "true angular velocity, body frame"),
    ch(
        OMEGA_DOT,
        "N×3",
        "rad/s^2",
        "true angular acceleration (mean over the interval), body frame",
    ),
    ch(
        TM_ACC,
        "N×I×3",
        "m/s^2",
        "true electrostatic acceleration of each test mass, body frame",
    ),
    ch(
        SRP_ACC,
        "N×3",
        "m/s^2",
        "true non-gravitational (SRP + thruster force noise) acceleration, body frame",
    ),
    ch(
        STAR_Q,
        "N×4",
        "1",
        "star-tracker attitude quaternion q_BN (w, x, y, z); NaN-free only where valid",
    ),
    ch(
        STAR_VALID,
        "N",
        "1",
        "1 where the star-tracker sample is valid, 0 in an outage or between samples",
    ),
    ch(
        IS_VOLTAGE[0],
        "N×3×2",
        "V",
        "IS1 electrode drive voltages V_{j,1}, V_{j,2} for j = x, y, z",
    ),
    ch(
        IS_FLAGS[0],
        "N",
        "1",
        "IS1 flags: bit j linear saturation, bit 3+j angular saturation, bit 7 absent",
    ),
    ch(IS_VOLTAGE[1], "N×3×2", "V", "IS2 electrode drive voltages"),
    ch(IS_FLAGS[1], "N", "1", "IS2 flags"),
    ch(EST_TIME, "M", "s", "simulation time of each estimate row"),
    ch(
        EST_TICK,
        "M",
        "1",
        "sample index of the last solve behind the row",
    ),
    ch(
        EST_BETA,
        "M×I×3",
        "rad s^-2 V^-1",
        "angular scale factors β",
    ),
    ch(EST_BETA_SIGMA, "M×I×3", "rad s^-2 V^-1", "1σ of β"),
    ch(
        EST_K,
        "M×I×3",
        "m s^-2 V^-1",
        "linear scale factors k (eq. 2)",
    ),
    ch(EST_K_SIGMA, "M×I×3", "m s^-2 V^-1", "1σ of k"),
    ch(EST_R, "M×I×3", "m", "test-mass CoM offsets r, body frame"),
    ch(EST_R_SIGMA, "M×I×3", "m", "1σ of r"),
    ch(EST_N_USED, "M", "1", "samples used so far"),
    ch(
        EST_N_REJECTED,
        "M",
        "1",
        "samples rejected so far (non-finite, saturated, invalid)",
    ),
    ch(
        EST_FINAL,
        "M",
        "1",
        "1 on the final estimate of the campaign (the last row)",
    ),
    ch(
        EST_STATUS,
        "M",
        "1",
        "estimator status bits: 1 no solution, 2 solve failed, 4 not converged, 8 inconsistent, 16 degraded",
    ),
    ch(
        EST_REJECTED_BY_CAUSE,
        "M×11",
        "1",
        "rejections so far by cause (report.json samples_rejected_by_cause order)",
    ),
    ch(
        EST_CHI2,
        "M×4",
        "1",
        "χ²/dof of the whitened residuals: linear, common mode, star tracker, angular",
    ),
    ch(
        FAULT_TICK,
        "F",
        "1",
        "injected faults ([faults] only): sample tick of each",
    ),
    ch(
        FAULT_KIND,
        "F",
        "1",
        "0 upset, 1 outlier, 2 stuck channel, 3 star jump, 4 IS dropout, 5 star dropout, 6 duplicate, 7 reorder, 8 missing, 9 garbage header",
    ),
    ch(
        FAULT_FIELD,
        "F",
        "1",
        "field: 6 i + 2 j + c for IS i+1 voltage V_{j,c+1}; 12 + i IS flags; 14 + k star quaternion; 18 star valid; 19 header",
    ),
    ch(FAULT_BIT, "F", "1", "bit flipped (upsets)"),
    ch(
        FAULT_SAMPLES,
        "F",
        "1",
        "samples affected (stuck channels, star jumps; else 1)",
    ),
    ch(FAULT_BEFORE, "F", "1", "value before (V, or quaternion component, or flag byte)"),
    ch(FAULT_AFTER, "F", "1", "value after"),
    ch(
        FAULT_SIGMAS,
        "F",
        "1",
        "change in units of the field's noise (inf for flags, non-finite values, bus faults)",
    ),
    ch(
        FAULT_DETECTED,
        "F",
        "1",
        "samples of the fault the estimator rejected",
    ),
];

/// The channel at `path`.
pub fn channel(path: &str) -> &'static Channel {
    CHANNELS
        .iter()
        .find(|c| c.path == path)
        .unwrap_or_else(|| unreachable!("{path} is not in the layout"))
}

/// The layout as a Markdown table (for the README and `report.md`).
pub fn markdown_table() -> String {
    let mut s = String::from("| dataset | shape | units | content |\n|---|---|---|---|\n");
    for c in CHANNELS {
        s += &format!(
            "| `/{}` | {} | {} | {} |\n",
            c.path, c.shape, c.units, c.description
        );
    }
    s
}
