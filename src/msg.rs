//! Fixed-size `#[repr(C)]` messages exchanged by the stages (and, in the process
//! set, over iceoryx2 shared memory). Units in every field's comment; vectors carry
//! their frame (`_b` body, `_bn` body relative to inertial). Times are integer ns.
//!
//! Every type here is `#[repr(C)]`, fixed-size and `ZeroCopySend`, with a stable
//! `type_name` so that separately built binaries agree on the service's payload type.

use iceoryx2::prelude::ZeroCopySend;

/// Common header of every message.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("taiji::Header")]
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
}

/// Commander → plant: torque commanded for the interval.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("taiji::TorqueCommand")]
#[repr(C)]
pub struct TorqueCommand {
    pub header: Header,
    /// Commanded torque, body frame [N m].
    pub torque_cmd_b: [f64; 3],
}

/// Plant → front-end electronics (and recorder only): the true state.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("taiji::TruthState")]
#[repr(C)]
pub struct TruthState {
    pub header: Header,
    /// Attitude quaternion (w, x, y, z) of B relative to N at the end of the interval [-].
    pub q_bn: [f64; 4],
    /// Angular velocity at the end of the interval, in B [rad/s].
    pub omega_b: [f64; 3],
    /// Mean angular acceleration over the interval, in B [rad/s²].
    pub omega_dot_b: [f64; 3],
    /// Mean electrostatic acceleration applied to TM i over the interval, in B [m/s²] (eq. 15).
    pub a_tm_b: [[f64; 3]; 2],
    /// Mean non-gravitational (SRP + thruster force noise) acceleration, in B [m/s²].
    pub a_srp_b: [f64; 3],
    /// Mean applied torque over the interval, in B [N m].
    pub torque_b: [f64; 3],
    /// Commanded torque for the interval, in B [N m].
    pub torque_cmd_b: [f64; 3],
}

/// Star-tracker sample.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("taiji::StarSample")]
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
/// The IS sample is not present (IS absent in the scenario).
pub const FLAG_ABSENT: u8 = 0b1000_0000;

/// Electrode pair p ∈ {x, y, z} whose difference carries angular axis `ANGULAR_OF_PAIR[p]`
/// (Table 1: ω̇x from the y pair, ω̇y from z, ω̇z from x).
pub const ANGULAR_OF_PAIR: [usize; 3] = [2, 0, 1];
/// Electrode pair carrying angular axis a: the inverse of `ANGULAR_OF_PAIR`.
pub const PAIR_OF_ANGULAR: [usize; 3] = [1, 2, 0];

/// One IS's drive voltages for the interval (Table 1).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("taiji::IsSample")]
#[repr(C)]
pub struct IsSample {
    /// Electrode drive voltages [V], indexed [x, y, z][1, 2] as V_{j,1}, V_{j,2}.
    pub volts: [[f64; 2]; 3],
    /// Saturation / presence flags (`FLAG_*`).
    pub flags: u8,
    pub _pad: [u8; 7],
}

impl IsSample {
    /// Present, finite and not saturated.
    pub fn usable(&self) -> bool {
        self.flags & (FLAG_ABSENT | FLAG_SATURATED_LINEAR | FLAG_SATURATED_ANGULAR) == 0
            && self.volts.iter().flatten().all(|v| v.is_finite())
    }

    /// Voltage differences per angular axis a (ω̇_a = β_a ΔV_a, Table 1) [V].
    pub fn angular_volts(&self) -> [f64; 3] {
        std::array::from_fn(|a| {
            let pair = self.volts[PAIR_OF_ANGULAR[a]];
            pair[0] - pair[1]
        })
    }

    /// Voltage sums per linear axis j (a_j = k_j ΣV_j, Table 1) [V].
    pub fn linear_volts(&self) -> [f64; 3] {
        std::array::from_fn(|j| self.volts[j][0] + self.volts[j][1])
    }
}

impl StarSample {
    /// Valid and finite.
    pub fn usable(&self) -> bool {
        self.valid != 0 && self.q_bn.iter().all(|v| v.is_finite())
    }
}

/// Front-end electronics → estimator: everything the estimator may see.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("taiji::SensorSample")]
#[repr(C)]
pub struct SensorSample {
    pub header: Header,
    pub star: StarSample,
    pub is: [IsSample; 2],
}

/// Estimator → supervisor / recorder: the latest estimates with 1σ.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("taiji::EstimateMsg")]
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
    /// Samples used and samples rejected (non-finite, saturated, invalid).
    pub n_used: u64,
    pub n_rejected: u64,
    /// `EST_FINAL` on the estimate of the whole campaign (after the last sample).
    pub flags: u64,
}

/// `EstimateMsg::flags`: this is the final estimate of the campaign.
pub const EST_FINAL: u64 = 1;

impl Header {
    pub fn at(seq: u64, tick: u64, fs: f64) -> Self {
        Header {
            seq,
            tick,
            sim_time_ns: ((tick + 1) as f64 / fs * 1e9).round() as i64,
            publish_ns: 0,
            origin_ns: 0,
            due_ns: 0,
        }
    }
}

/// Stage identifiers carried in `Progress::process`.
pub const PROC_COMMANDER: u32 = 1;
pub const PROC_PLANT: u32 = 2;
pub const PROC_FEE: u32 = 3;
pub const PROC_ESTIMATOR: u32 = 4;
pub const PROC_RECORDER: u32 = 5;

/// `Progress::state`: ports created, waiting for the supervisor's start.
pub const STATE_READY: u32 = 1;
/// Consuming and producing samples.
pub const STATE_RUNNING: u32 = 2;
/// Every tick of the campaign processed (the estimator: final estimate published).
pub const STATE_DONE: u32 = 3;

/// Every stage → its upstream stage and the supervisor: heartbeat, flow-control credit
/// and counters. Published after each batch of work and at least every 50 ms.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("taiji::Progress")]
#[repr(C)]
pub struct Progress {
    pub header: Header,
    /// `PROC_*` of the publishing stage.
    pub process: u32,
    /// `STATE_*`.
    pub state: u32,
    /// Monotonic ns when this process instance started: changes when a stage restarts.
    pub incarnation: u64,
    /// Every tick below this one has been consumed (the upstream may publish up to
    /// `next_tick + window`).
    pub next_tick: u64,
    /// Estimator: first tick after its last checkpoint; the front-end keeps every
    /// sample from here on so a restarted estimator can catch up. Others: `next_tick`.
    pub resume_tick: u64,
    /// Ticks missing in this stage's input (gaps in the tick sequence).
    pub samples_lost: u64,
    /// Commander: ticks published later than one period after their due time.
    /// Estimator: ticks whose estimate was published more than one period after the
    /// tick was due (`Header::due_ns`).
    pub missed_deadlines: u64,
    /// Heap allocations inside the processing loop since start-up (estimator).
    pub loop_allocations: u64,
    /// Input hop latency (upstream publish → receive) p50, p99, max [µs].
    pub hop_latency_us: [f64; 3],
    /// Estimator: end-to-end latency (plant publish → estimate published) p50, p99, max [µs].
    pub e2e_latency_us: [f64; 3],
    /// Samples in the latency statistics above.
    pub latency_count: u64,
    /// SCHED_FIFO priority the stage runs at (0: normal scheduling).
    pub rt_priority: u32,
    /// CPU the stage is pinned to (−1: not pinned).
    pub cpu: i32,
    pub _pad: u32,
    /// 1 once this stage and every stage downstream of it can take samples (each has
    /// heard its downstream's credit): the commander starts the real-time clock then.
    pub primed: u32,
}

/// `Control::command`: leave the ready state and start the campaign.
pub const CMD_START: u32 = 1;
/// Stop: finish cleanly and exit.
pub const CMD_STOP: u32 = 2;

/// Supervisor → every stage.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("taiji::Control")]
#[repr(C)]
pub struct Control {
    pub header: Header,
    /// `CMD_*`.
    pub command: u32,
    pub _pad: u32,
}
