//! The messages of the process set. Those the estimator reads and writes (`Header`,
//! `SensorSample`, `EstimateMsg`, the status and cause codes) belong to the flight core
//! (`taiji_core::msg`) and are re-exported here; the ones below carry truth or run the
//! set, and the core cannot name them. All are fixed-size and `#[repr(C)]`; `bus::Wire`
//! gives each its versioned iceoryx2 type name.

pub use taiji_core::msg::*;

/// Commander → plant: torque commanded for the interval.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub struct TorqueCommand {
    pub header: Header,
    /// Commanded torque, body frame [N m].
    pub torque_cmd_b: [f64; 3],
}

/// Plant → front-end electronics (and recorder only): the true state.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
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

/// The status bits' names, comma-separated ("ok" when none is set).
pub fn status_text(status: u64) -> String {
    let names: Vec<&str> = STATUS_NAMES
        .iter()
        .enumerate()
        .filter(|(i, _)| status & (1 << i) != 0)
        .map(|(_, n)| *n)
        .collect();
    if names.is_empty() {
        "ok".into()
    } else {
        names.join(", ")
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
#[derive(Debug, Clone, Copy, Default, PartialEq)]
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
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub struct Control {
    pub header: Header,
    /// `CMD_*`.
    pub command: u32,
    pub _pad: u32,
}
