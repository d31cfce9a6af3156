//! Fixed-size `#[repr(C)]` messages exchanged by the stages (and, in the process
//! set, over iceoryx2 shared memory). Units in every field's comment; vectors carry
//! their frame (`_b` body, `_bn` body relative to inertial). Times are integer ns.
//!
//! Every type here is `#[repr(C)]` and fixed-size, with its padding spelled out as
//! fields. The bus layer (`taiji::bus::Wire`) gives each one it carries a stable,
//! versioned iceoryx2 type name, so separately built binaries agree on the payload.

// Unused where std is linked anywhere in the build (the std binaries, unit tests):
// std's inherent f64 methods then win for these exact operations, with the same bits.
#[allow(unused_imports)]
use crate::math::Real;

/// Version of the layouts of these messages and of the estimator's state: bump it
/// whenever a field changes. It is part of every bus payload's type name
/// (`taiji::v1::EstimateMsg`; a test keeps the two in step) and of every checkpoint,
/// so builds with different layouts refuse each other with a clear error instead of
/// misreading bytes. A change of what the state's fields mean, at the same layout,
/// bumps `estimate::snapshot::STATE_VERSION` instead (checkpoints only).
pub const LAYOUT_VERSION: u32 = 1;

/// Common header of every message.
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct Header {
    /// Per-publisher sequence number, from 0, no gaps.
    pub seq: u64,
    /// Simulation tick n; the sample describes the interval [n, n+1) / fs.
    pub tick: u64,
    /// Simulation time at the end of the interval [ns].
    pub sim_time_ns: i64,
    /// Monotonic clock (CLOCK_MONOTONIC) when published [ns] (0 in-process).
    pub publish_ns: u64,
    /// Monotonic clock when the plant published this tick's truth [ns]: carried
    /// downstream so the estimator can measure end-to-end latency (0 in-process).
    pub origin_ns: u64,
    /// Real-time pacing: monotonic clock when the commander was due to start this tick
    /// [ns], carried downstream; the tick's deadline is one period later (0 otherwise).
    pub due_ns: u64,
    /// Sensor samples: incarnation of the estimator the front-end addressed this to
    /// (changes when it resends after an estimator restart; 0 elsewhere).
    pub epoch: u64,
}

/// Star-tracker sample.
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct StarSample {
    /// Measured attitude (w, x, y, z) of B relative to N [-].
    pub q_bn: [f64; 4],
    /// 1 when the sample is valid, 0 in an outage or between star-tracker samples.
    pub valid: u8,
    pub _pad: [u8; 7],
}

/// Saturation flags of an IS sample: bit j for the linear channel j, bit 3+j angular.
pub const FLAG_SATURATED_LINEAR: u8 = 0b0000_0111;
pub const FLAG_SATURATED_ANGULAR: u8 = 0b0011_1000;
/// No data this interval (an IS dropout); the voltages are not meaningful.
pub const FLAG_DROPOUT: u8 = 0b0100_0000;
/// The IS sample is not present (IS absent in the scenario).
pub const FLAG_ABSENT: u8 = 0b1000_0000;

/// Electrode pair p ∈ {x, y, z} whose difference carries angular axis `ANGULAR_OF_PAIR[p]`
/// (Table 1: ω̇x from the y pair, ω̇y from z, ω̇z from x).
pub const ANGULAR_OF_PAIR: [usize; 3] = [2, 0, 1];
/// Electrode pair carrying angular axis a: the inverse of `ANGULAR_OF_PAIR`.
pub const PAIR_OF_ANGULAR: [usize; 3] = [1, 2, 0];

/// One IS's drive voltages for the interval (Table 1).
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct IsSample {
    /// Electrode drive voltages [V], indexed [x, y, z][1, 2] as V_{j,1}, V_{j,2}.
    pub volts: [[f64; 2]; 3],
    /// Saturation / presence flags (`FLAG_*`).
    pub flags: u8,
    pub _pad: [u8; 7],
}

impl IsSample {
    /// Present, finite, not saturated and no flag bit set (an unknown bit, e.g. from an
    /// upset, makes the sample untrustworthy too).
    pub fn usable(&self) -> bool {
        self.flags == 0 && self.volts.iter().flatten().all(|v| v.is_finite())
    }

    /// Voltage differences per angular axis a (ω̇_a = β_a ΔV_a, Table 1) [V].
    pub fn angular_volts(&self) -> [f64; 3] {
        core::array::from_fn(|a| {
            let pair = self.volts[PAIR_OF_ANGULAR[a]];
            pair[0] - pair[1]
        })
    }

    /// Voltage sums per linear axis j (a_j = k_j ΣV_j, Table 1) [V].
    pub fn linear_volts(&self) -> [f64; 3] {
        core::array::from_fn(|j| self.volts[j][0] + self.volts[j][1])
    }
}

impl StarSample {
    /// Valid (exactly 1: any other value is a corrupted flag) and finite.
    pub fn usable(&self) -> bool {
        self.valid == 1 && self.q_bn.iter().all(|v| v.is_finite())
    }
}

/// Front-end electronics → estimator: everything the estimator may see.
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct SensorSample {
    pub header: Header,
    pub star: StarSample,
    pub is: [IsSample; 2],
}

/// Estimator → supervisor / recorder: the latest estimates with 1σ.
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct EstimateMsg {
    pub header: Header,
    /// Tick of the last solve; the estimates below are as of that tick.
    pub solved_tick: u64,
    /// Angular scale factors per IS [rad s^-2 V^-1] and their 1σ.
    pub beta: [[f64; 3]; 2],
    pub beta_sigma: [[f64; 3]; 2],
    /// Linear scale factors per IS [m s^-2 V^-1] and their 1σ (eq. 2).
    pub k: [[f64; 3]; 2],
    pub k_sigma: [[f64; 3]; 2],
    /// CoM offsets per IS, body frame [m], and their 1σ.
    pub r_b: [[f64; 3]; 2],
    pub r_sigma: [[f64; 3]; 2],
    /// Ticks whose IS data entered the linear statistics, and ticks whose did not
    /// (rejected, invalid or missing); together every tick from the first on.
    pub n_used: u64,
    pub n_rejected: u64,
    /// `EST_FINAL` on the estimate of the whole campaign (after the last sample).
    pub flags: u64,
    /// `ST_*` bits: how far the estimate can be trusted (0: a verified solution).
    pub status: u64,
    /// Rejections since start by cause (`CAUSE_*` index; a sample may count in several).
    pub rejected_by_cause: [u64; N_CAUSES],
    /// `1 << CAUSE_*` of what was rejected in the sample behind this message.
    pub tick_rejections: u64,
    /// χ² per degree of freedom of the whitened residuals at the last solve, per
    /// residual group (`GROUP_*`): 1 when the noise model fits the data.
    pub chi2_per_dof: [f64; N_GROUPS],
    /// Factor the σ above were inflated by because a group's χ²/dof was too large (1: none).
    pub sigma_inflation: f64,
}

/// Why an input was rejected: index into `EstimateMsg::rejected_by_cause`.
pub const CAUSE_IS_FLAGGED: usize = 0;
pub const CAUSE_NON_FINITE: usize = 1;
pub const CAUSE_OUT_OF_RANGE: usize = 2;
pub const CAUSE_STUCK: usize = 3;
pub const CAUSE_ANGULAR_MISMATCH: usize = 4;
pub const CAUSE_LINEAR_OUTLIER: usize = 5;
pub const CAUSE_STAR_INVALID: usize = 6;
pub const CAUSE_STAR_OUTLIER: usize = 7;
pub const CAUSE_TICK_ORDER: usize = 8;
pub const CAUSE_TICK_MISSING: usize = 9;
pub const CAUSE_TICK_JUMP: usize = 10;
pub const N_CAUSES: usize = 11;
/// Report names of the causes, by index.
pub const CAUSE_NAMES: [&str; N_CAUSES] = [
    "is_flagged",
    "non_finite",
    "out_of_range",
    "stuck_channel",
    "angular_mismatch",
    "linear_outlier",
    "star_invalid",
    "star_outlier",
    "tick_order",
    "tick_missing",
    "tick_jump",
];

/// Residual groups of the joint estimator (`EstimateMsg::chi2_per_dof`).
pub const GROUP_LINEAR: usize = 0;
pub const GROUP_COMMON_MODE: usize = 1;
pub const GROUP_STAR: usize = 2;
pub const GROUP_ANGULAR: usize = 3;
pub const N_GROUPS: usize = 4;
pub const GROUP_NAMES: [&str; N_GROUPS] = ["linear", "common_mode", "star_tracker", "angular"];

/// `EstimateMsg::status`: no solution yet (the priors are shown).
pub const ST_NO_SOLUTION: u64 = 1;
/// The last solve failed (singular normal equations); the previous solution is shown.
pub const ST_SOLVE_FAILED: u64 = 2;
/// The final Gauss–Newton iterations did not converge: they may still be more than 1 %
/// of some parameter's σ from their point (judged from their last two steps).
pub const ST_NOT_CONVERGED: u64 = 4;
/// A residual group's χ²/dof says the model does not fit the data; σ inflated.
pub const ST_INCONSISTENT: u64 = 8;
/// Many inputs rejected (over 2 % of ticks) or the tick sequence broke.
pub const ST_DEGRADED: u64 = 16;
/// Bits that make a result unverified (the exit code says so).
pub const ST_UNVERIFIED: u64 =
    ST_NO_SOLUTION | ST_SOLVE_FAILED | ST_NOT_CONVERGED | ST_INCONSISTENT;
/// Report names of the status bits, lowest first.
pub const STATUS_NAMES: [&str; 5] = [
    "no_solution",
    "solve_failed",
    "not_converged",
    "inconsistent",
    "degraded",
];

/// `EstimateMsg::flags`: this is the final estimate of the campaign.
pub const EST_FINAL: u64 = 1;

impl Header {
    pub fn at(seq: u64, tick: u64, fs: f64) -> Self {
        Header {
            seq,
            tick,
            sim_time_ns: ((tick as f64 + 1.0) / fs * 1e9).round() as i64,
            publish_ns: 0,
            origin_ns: 0,
            due_ns: 0,
            epoch: 0,
        }
    }
}
