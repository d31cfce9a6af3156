//! The messages of the process set. Those the estimator reads and writes (`Header`,
//! `SensorSample`, `EstimateMsg`, the status and cause codes) belong to the flight core
//! (`taiji_core::msg`) and are re-exported here; the ones below carry truth or run the
//! set, and the core cannot name them. All are fixed-size and `#[repr(C)]`; `wiring::Wire`
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

/// Processes a `SetStatus` describes at most (the five stages, with room).
pub const MAX_MEMBERS: usize = 8;
/// Hosts a `SetStatus` names at most.
pub const MAX_HOSTS: usize = 4;
/// Bytes of a host name in a `SetStatus` (UTF-8, NUL-padded; longer names are cut).
pub const HOST_NAME_BYTES: usize = 16;

/// One process of the set as the supervisor in charge sees it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub struct MemberStatus {
    /// `PROC_*` (0: an unused slot).
    pub process: u32,
    /// Index of its host in `SetStatus::host_names` (0 on one host).
    pub host: u32,
    /// Times the supervisor restarted it.
    pub restarts: u32,
    /// 1 once its first heartbeat arrived (`last` is then meaningful).
    pub heard: u32,
    /// Time since its last heartbeat reached the supervisor [ns].
    pub heartbeat_age_ns: u64,
    /// Its last heartbeat: state, ticks, counters, latency since it started.
    pub last: Progress,
}

/// `SetStatus::state`: the processes are starting (not all ready yet).
pub const SET_STARTING: u32 = 1;
/// The campaign runs.
pub const SET_RUNNING: u32 = 2;
/// The final estimate is in; the set is being stopped.
pub const SET_FINISHED: u32 = 3;
/// Stopping before the end: a stop was requested (`REQ_ABORT`), or a signal.
pub const SET_STOPPING: u32 = 4;

/// Supervisor in charge → outside monitors (`wiring::SVC_STATUS`), every
/// `STATUS_EVERY_NS`: what only the supervisor knows (every process's heartbeat age,
/// restarts and host; the maneuver's phase). Carries no truth: on a set over hosts it
/// crosses to the flight host.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C)]
pub struct SetStatus {
    pub header: Header,
    /// Process id of the supervisor in charge.
    pub supervisor_pid: u32,
    /// `SET_*`.
    pub state: u32,
    /// Samples in the campaign.
    pub n_samples: u64,
    /// Sample rate [Hz].
    pub sample_rate_hz: f64,
    /// Real-time tick period [ns] (0: accelerated lock-step).
    pub period_ns: u64,
    /// Real-time speed-up (simulated s per wall-clock s; 0 when accelerated).
    pub time_scale: f64,
    /// Wall-clock time since the supervisor started [ns].
    pub elapsed_ns: u64,
    /// Tick the maneuver phase below is given at (the estimator's next tick).
    pub maneuver_tick: u64,
    /// Commanded body torque at `maneuver_tick` [N m] (zero: no axis rocked).
    pub maneuver_torque_nm: [f64; 3],
    /// Cramér–Rao bound (1σ) of the samples up to `maneuver_tick`, from the scenario's
    /// noise-free campaign (`crlb::crlb_curve`), per IS and axis: β [rad s^-2 V^-1],
    /// k [m s^-2 V^-1], r [m]; NaN before every parameter has been excited.
    pub bound_beta: [[f64; 3]; 2],
    pub bound_k: [[f64; 3]; 2],
    pub bound_r: [[f64; 3]; 2],
    /// Process id of the monitor whose stop request was accepted (0: none).
    pub stop_requested_by: u32,
    /// Slots used in `members`, and names used in `host_names`.
    pub n_members: u32,
    pub n_hosts: u32,
    pub _pad: u32,
    pub members: [MemberStatus; MAX_MEMBERS],
    /// The launch description's host names (one host: empty).
    pub host_names: [[u8; HOST_NAME_BYTES]; MAX_HOSTS],
}

impl Default for SetStatus {
    fn default() -> Self {
        SetStatus {
            header: Header::default(),
            supervisor_pid: 0,
            state: 0,
            n_samples: 0,
            sample_rate_hz: 0.0,
            period_ns: 0,
            time_scale: 0.0,
            elapsed_ns: 0,
            maneuver_tick: 0,
            maneuver_torque_nm: [0.0; 3],
            bound_beta: [[f64::NAN; 3]; 2],
            bound_k: [[f64::NAN; 3]; 2],
            bound_r: [[f64::NAN; 3]; 2],
            stop_requested_by: 0,
            n_members: 0,
            n_hosts: 0,
            _pad: 0,
            members: [MemberStatus::default(); MAX_MEMBERS],
            host_names: [[0; HOST_NAME_BYTES]; MAX_HOSTS],
        }
    }
}

impl SetStatus {
    /// Host `i`'s name ("" when unnamed: a set on one host).
    pub fn host_name(&self, i: u32) -> String {
        let Some(raw) = self.host_names.get(i as usize) else {
            return String::new();
        };
        let end = raw.iter().position(|&b| b == 0).unwrap_or(raw.len());
        String::from_utf8_lossy(&raw[..end]).into_owned()
    }

    /// Store `name` as host `i` (cut to `HOST_NAME_BYTES` at a character boundary).
    pub fn set_host_name(&mut self, i: usize, name: &str) {
        let Some(slot) = self.host_names.get_mut(i) else {
            return;
        };
        let mut end = name.len().min(HOST_NAME_BYTES);
        while !name.is_char_boundary(end) {
            end -= 1;
        }
        *slot = [0; HOST_NAME_BYTES];
        slot[..end].copy_from_slice(&name.as_bytes()[..end]);
    }
}

/// `Request::command`: stop the run now (the supervisor stops every process, as on
/// SIGINT, and exits 130).
pub const REQ_STOP: u32 = 1;

/// Outside monitor → supervisor in charge (`wiring::SVC_REQUEST`): an operator's control
/// action. Only the supervisor commands the stages (`Control`), so a monitor never
/// publishes where a stage listens.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub struct Request {
    pub header: Header,
    /// `REQ_*`.
    pub command: u32,
    /// Process id of the requesting monitor (on its host).
    pub requester_pid: u32,
}

/// `Progress::process` of the TMTC process (`taiji-tmtc`, started with `--ground` only).
pub const PROC_TMTC: u32 = 6;

/// The onboard calibration table's values: β, k and r per IS and axis, with their 1σ
/// (the units of `EstimateMsg`'s).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub struct TableValues {
    pub beta: [[f64; 3]; 2],
    pub beta_sigma: [[f64; 3]; 2],
    pub k: [[f64; 3]; 2],
    pub k_sigma: [[f64; 3]; 2],
    pub r: [[f64; 3]; 2],
    pub r_sigma: [[f64; 3]; 2],
}

/// TMTC process → supervisor (`wiring::SVC_GROUND_REQUEST`): a function of service 8
/// that the TMTC process accepted (authenticated, fresh, in range). The supervisor
/// executes it and answers with `GroundNote`s carrying the same token.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub struct GroundRequest {
    pub header: Header,
    /// The TMTC process's tag for the telecommand (echoed in the answers).
    pub token: u64,
    /// Function ID (`ground::dictionary::FUNCTIONS`).
    pub function: u32,
    pub _pad: u32,
    /// Function 1: the campaign's seed.
    pub seed: u64,
    /// Function 1: its duration [s] (0: the scenario's).
    pub duration_s: f64,
    /// Function 1: its epoch [mission day] (service-20 parameter
    /// `campaign_epoch_day` when it was accepted).
    pub epoch_day: f64,
}

/// `GroundNote::kind`: execution of request `token` started (a 1,3 report).
pub const NOTE_STARTED: u32 = 1;
/// Request `token` completed: `code` 0 (a 1,7 report) or its failure code (1,8).
pub const NOTE_DONE: u32 = 2;
/// An event of the set: `code` is its event ID, `args` its auxiliary data.
pub const NOTE_EVENT: u32 = 3;

/// Supervisor → TMTC process (`wiring::SVC_GROUND_NOTE`): what happened to a request,
/// or an event only the supervisor sees.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub struct GroundNote {
    pub header: Header,
    /// `NOTE_*`.
    pub kind: u32,
    /// `NOTE_DONE`: 0 or a failure code; `NOTE_EVENT`: the event ID.
    pub code: u32,
    /// The request's token (`NOTE_STARTED`, `NOTE_DONE`).
    pub token: u64,
    /// `NOTE_EVENT`: the event's auxiliary data, as its dictionary entry types them
    /// (an f64 as its bits).
    pub args: [u64; 4],
}

/// Supervisor → TMTC process (`wiring::SVC_GROUND_STATE`), every 100 ms and when the
/// estimate's status word changes: the set's mode, its campaigns, the onboard
/// calibration table, and the campaign's latest estimate and status. Relayed by the
/// supervisor, so the TMTC process connects to no port of a campaign's processes: a
/// campaign that starts or ends changes none of its connections (iceoryx2 allocates
/// when a connection is made).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub struct GroundState {
    pub header: Header,
    /// Process id of the supervisor.
    pub supervisor_pid: u32,
    /// `ground::dictionary::Mode` as its number.
    pub mode: u32,
    /// The running campaign's number, or the last one's (0: none yet).
    pub campaign: u32,
    /// Times the supervisor restarted the TMTC process.
    pub tmtc_restarts: u32,
    /// Restarts of the stages over every campaign so far.
    pub stage_restarts: u32,
    /// 1 when the table holds values (applied from a campaign, or loaded).
    pub table_valid: u32,
    /// The campaign whose result the table holds (0: none).
    pub table_campaign: u32,
    /// 1 when a previous table can be restored (function 4).
    pub table_previous: u32,
    pub table: TableValues,
    /// The latest estimate of the running or last campaign (`header.seq` 0: none yet).
    pub estimate: EstimateMsg,
    /// The running campaign's latest `SetStatus` (`state` 0: no campaign runs).
    pub set: SetStatus,
}
