/* taiji-calib: the joint estimator of the Taiji inertial-sensor calibration, as a C library.
 *
 * BUILD  cargo build --profile flight -p taiji-c   ->  target/flight/libtaiji.a
 *        (no_std, panic = abort: nothing unwinds into C; link with -lm). Nothing is global
 *        and nothing is allocated: all state is the caller's memory.
 *
 * PANICS No panic is reachable from any function below: tools/panic-proof links every
 *        one of them with --gc-sections against a build whose panic handler names a
 *        symbol that exists nowhere, and the link succeeds (a CI test; with --probe, a
 *        deliberately reachable panic, the same link fails).
 *
 * MEMORY The state: taiji_estimator_size() bytes (62 848) aligned to
 *        taiji_estimator_align() (8). A checkpoint: taiji_checkpoint_size() bytes (62 336),
 *        any alignment. solve and finish also take scratch:
 *        taiji_solve_work_size() bytes (133 928), 8-aligned, not overlapping the state;
 *        its contents do not matter before or after a call, so one buffer serves every
 *        estimator of a task. In all (196 776) bytes, fixed at start-up (the sizes in
 *        parentheses are the library's, checked by tests/c_header.rs). Stack per call,
 *        measured by painting (docs/flight.md, every call): update 7.4 KB (7.8 KB on a LEON3, 8.0 KB on
 *        x86-64); init 3.3 KB and restore 1.2 KB (they build the state in place);
 *        checkpoint 0.3 KB; solve and finish 12.3 / 12.9 KB on a Cortex-M7, 12.6 / 13.3
 *        KB on a LEON3, 12.8 / 13.4 KB on x86-64. A 16 KB task stack holds every call.
 *
 * TIME   Instructions per call on a Cortex-M7 (tools/flight-qemu, default 10^4 s campaign):
 *        update 94 500 typical, 108 000 worst (the first sample; each includes the
 *        upset check and reseal, UPSETS below); solve 5.91 M worst; finish 17.6 M. On a
 *        LEON3 (--cpu leon3): update 134 300 typical, 154 000 worst; solve 9.52 M;
 *        finish 28.4 M.
 *        After a gap, update bridges at most 8 missing ticks (about 7 500 instructions
 *        each): the worst update after a 5 999-tick gap was 159 440 (35 signals). Longer gaps are
 *        caught up over the next updates, 7 ticks gained a call; the samples that
 *        arrive meanwhile are bridged too (a 600 s gap costs about 86 s of data). No
 *        input makes a call cost more.
 *
 * TICKS  Samples carry header.tick, the sample index from 0 at the campaign's start,
 *        one per 1/fs. The estimator expects tick 0 first: a first tick N counts N ticks
 *        as missing. A tick below the next expected is refused (CAUSE_TICK_ORDER); a gap
 *        up to max_gap_ticks is bridged (CAUSE_TICK_MISSING per tick, at most 8 a
 *        call: TIME above). A larger jump is
 *        refused (CAUSE_TICK_JUMP): before the first usable sample two consecutive ticks
 *        confirm it (a stream that starts late: the first is refused, and the timeline
 *        starts at it, so used + rejected counts every sample); after it, the timeline
 *        cannot be re-established and every later sample is refused too: the campaign
 *        must be restarted. Samples refused this way are counted by cause, not as
 *        ticks; the status says degraded while they are more than one in
 *        degraded_one_in of the ticks (one wild tick is outgrown, a clock that jumped
 *        for good is soon degraded). A gap within max_gap_ticks is bridged, not
 *        skipped: a jump of G ticks within it costs about G/7 of the samples after it
 *        (TIME), so max_gap_ticks bounds what a clock jump can cost (10^5 ticks:
 *        about 14 300 samples). Only header.tick is read; seq, times and epoch are
 *        the bus's.
 *
 * SOLVE  update sets TAIJI_SOLVE_DUE in *flags once every solve_every ticks (60 s of
 *        data) and keeps it set until taiji_estimator_solve runs. Solving right after the
 *        update that raised it gives results bit-identical to taiji-calib replay; solving
 *        later (a slower rate group) takes the samples of the delay into that iteration
 *        and gives slightly different (equally valid) estimates. A host that never solves
 *        gets only finish's iterations, on all data: a degraded result.
 *
 * UPSETS Every call first checks a digest of the whole state against the one the library
 *        left (a fold of its words: any single flipped bit changes it) and returns
 *        TAIJI_ERR_UPSET, reading nothing of it, when they differ; every call that
 *        writes the state reseals it. A bit flipped while the state rests between calls
 *        is therefore found before it is used: restore the last checkpoint (and replay
 *        the samples since) or init. The state's first 8 bytes, a magic word, are not
 *        sealed: up to 4 bits flipped there is TAIJI_ERR_UPSET too; memory whose word
 *        is further from it never held a state (TAIJI_ERR_STATE; init and restore write
 *        0 there until they succeed). A flip during a call is not covered. The check
 *        and the reseal cost two passes over the state (about 65 000 instructions on a
 *        Cortex-M7, 22 000 on x86-64); docs/integrity.md has the upset campaign.
 *
 * LIFECYCLE  init (or restore) -> update* / solve* / estimate* / checkpoint* -> finish.
 *        finish is terminal and idempotent: it returns the same final estimate every
 *        time (its scratch is checked every time, null refused, and written only the
 *        first), and update, solve and checkpoint after it return TAIJI_ERR_FINISHED. init
 *        checks the host's header (TAIJI_ABI_ARGS) and refuses another with
 *        TAIJI_ERR_VERSION; restore checks the checkpoint against the host's table.
 *
 * THREADS One state per estimator; calls on one state must not overlap (no locks
 *        inside). Different states may be used from different threads. No call blocks,
 *        sleeps, allocates or does I/O; none re-enters the library.
 *
 * EXPORT `taiji-calib export --telemetry F --out DIR` writes estimator_config.bin and
 *        sensor_samples.bin: a 24-byte header (8 bytes magic "TJEXP001", u32 layout
 *        version, u32 record size in bytes, u64 record count, little-endian), then the
 *        records as the structs below (TaijiEstimatorConfig, TaijiSensorSample).
 *
 * Every call returns TAIJI_OK (0) or a TAIJI_ERR_* code. Units are in each field's comment. */

#ifndef TAIJI_ESTIMATOR_H
#define TAIJI_ESTIMATOR_H

/* Generated by cbindgen from crates/taiji-core/src/{capi.rs,msg.rs,estimate/config.rs} and src/sim/msg.rs: do not edit. Regenerate: TAIJI_BLESS=1 cargo test --release --test c_header */

#include <stddef.h>
#include <stdint.h>
/* What this header declares, for taiji_estimator_init to check against the library:
 * taiji_estimator_init(mem, size, &table, TAIJI_ABI_ARGS). */
#define TAIJI_ABI_ARGS TAIJI_ABI_VERSION, sizeof(struct TaijiEstimatorConfig), \
    sizeof(struct TaijiSensorSample), sizeof(struct TaijiEstimateMsg)


// Success.
#define TAIJI_OK 0

// A required pointer is null.
#define TAIJI_ERR_NULL 1

// The state's memory is not aligned to `taiji_estimator_align()`.
#define TAIJI_ERR_ALIGNMENT 2

// A buffer is smaller than needed (`taiji_estimator_size`, `taiji_checkpoint_size`).
#define TAIJI_ERR_SIZE 3

// The configuration table fails its check (a field out of range).
#define TAIJI_ERR_CONFIG 4

// The state's memory does not hold an initialised estimator.
#define TAIJI_ERR_STATE 5

// The checkpoint is not one: wrong magic, size or checksum, or an impossible state.
#define TAIJI_ERR_CHECKPOINT 6

// The checkpoint was written by a build with another layout or state version.
#define TAIJI_ERR_VERSION 7

// The solve failed (singular normal equations); the previous solution is kept and the
// estimate's status word says so.
#define TAIJI_ERR_SOLVE 8

// `update`, `solve` or `checkpoint` after `finish`: the campaign is over (`finish` and
// `estimate` still return the final estimate).
#define TAIJI_ERR_FINISHED 9

// The state changed since the library last left it: a bit flipped in the caller's
// memory between calls (an upset), or something else wrote to it. Nothing of it is
// used; restore the last checkpoint (or init) to go on.
#define TAIJI_ERR_UPSET 10

// The scratch passed to `solve` or `finish` overlaps the state: it would overwrite
// it. Nothing is done; pass memory of its own.
#define TAIJI_ERR_OVERLAP 11

// Version of this C interface: the functions' signatures and every layout they pass
// (bumped with `LAYOUT_VERSION` and whenever a signature changes). A host passes the
// value of its header to `taiji_estimator_init` (`TAIJI_ABI_ARGS`), which refuses
// another with `TAIJI_ERR_VERSION`.
#define TAIJI_ABI_VERSION 4

// `update` flag: a solve is due (the host may run it now or in its slower rate group).
#define TAIJI_SOLVE_DUE 1

// Version of the layouts of these messages and of the estimator's state: bump it
// whenever a field changes. It is part of every bus payload's type name
// (`taiji::v1::EstimateMsg`; a test keeps the two in step) and of every checkpoint,
// so builds with different layouts refuse each other with a clear error instead of
// misreading bytes. A change of what the state's fields mean, at the same layout,
// bumps `estimate::snapshot::STATE_VERSION` instead (checkpoints only).
#define TAIJI_LAYOUT_VERSION 1

// Saturation flags of an IS sample: bit j for the linear channel j, bit 3+j angular.
#define TAIJI_FLAG_SATURATED_LINEAR 7

#define TAIJI_FLAG_SATURATED_ANGULAR 56

// No data this interval (an IS dropout); the voltages are not meaningful.
#define TAIJI_FLAG_DROPOUT 64

// The IS sample is not present (IS absent in the scenario).
#define TAIJI_FLAG_ABSENT 128

// Why an input was rejected: index into `EstimateMsg::rejected_by_cause`.
#define TAIJI_CAUSE_IS_FLAGGED 0

#define TAIJI_CAUSE_NON_FINITE 1

#define TAIJI_CAUSE_OUT_OF_RANGE 2

#define TAIJI_CAUSE_STUCK 3

#define TAIJI_CAUSE_ANGULAR_MISMATCH 4

#define TAIJI_CAUSE_LINEAR_OUTLIER 5

#define TAIJI_CAUSE_STAR_INVALID 6

#define TAIJI_CAUSE_STAR_OUTLIER 7

#define TAIJI_CAUSE_TICK_ORDER 8

#define TAIJI_CAUSE_TICK_MISSING 9

#define TAIJI_CAUSE_TICK_JUMP 10

#define TAIJI_N_CAUSES 11

// Residual groups of the joint estimator (`EstimateMsg::chi2_per_dof`).
#define TAIJI_GROUP_LINEAR 0

#define TAIJI_GROUP_COMMON_MODE 1

#define TAIJI_GROUP_STAR 2

#define TAIJI_GROUP_ANGULAR 3

#define TAIJI_N_GROUPS 4

// `EstimateMsg::status`: no solution yet (the priors are shown).
#define TAIJI_ST_NO_SOLUTION 1

// The last solve failed (singular normal equations); the previous solution is shown.
#define TAIJI_ST_SOLVE_FAILED 2

// The final Gauss–Newton iterations did not converge: they may still be more than 1 %
// of some parameter's σ from their point (judged from their last two steps).
#define TAIJI_ST_NOT_CONVERGED 4

// A residual group's χ²/dof says the model does not fit the data; σ inflated.
#define TAIJI_ST_INCONSISTENT 8

// Many inputs rejected (over 2 % of ticks) or the tick sequence broke.
#define TAIJI_ST_DEGRADED 16

// Bits that make a result unverified (the exit code says so).
#define TAIJI_ST_UNVERIFIED (((TAIJI_ST_NO_SOLUTION | TAIJI_ST_SOLVE_FAILED) | TAIJI_ST_NOT_CONVERGED) | TAIJI_ST_INCONSISTENT)

// `EstimateMsg::flags`: this is the final estimate of the campaign.
#define TAIJI_EST_FINAL 1

// Stage identifiers carried in `Progress::process`.
#define TAIJI_PROC_COMMANDER 1

#define TAIJI_PROC_PLANT 2

#define TAIJI_PROC_FEE 3

#define TAIJI_PROC_ESTIMATOR 4

#define TAIJI_PROC_RECORDER 5

// `Progress::state`: ports created, waiting for the supervisor's start.
#define TAIJI_STATE_READY 1

// Consuming and producing samples.
#define TAIJI_STATE_RUNNING 2

// Every tick of the campaign processed (the estimator: final estimate published).
#define TAIJI_STATE_DONE 3

// `Control::command`: leave the ready state and start the campaign.
#define TAIJI_CMD_START 1

// Stop: finish cleanly and exit.
#define TAIJI_CMD_STOP 2

// The estimator's table: plain numbers, `#[repr(C)]`, like a cFS table — the C ABI
// takes it as it is. Built by `Scenario::estimator_config` (std) or by the host.
struct TaijiEstimatorConfig {
  // Sample rate [Hz].
  double fs;
  // Number of inertial sensors (1 or 2).
  uint64_t n_is;
  // Known geometry ratios (Gx, Gy, Gz) of eq. 2 per IS [m].
  double geometry_m[2][3];
  // Ground-calibration priors per IS.
  double beta_prior[2][3];
  double com_prior_m[2][3];
  // Star-tracker noise per axis per sample, 1σ [rad].
  double sigma_star_rad;
  // Per-sample 1σ of the IS readout noise: angular [rad/s²], linear [m/s²].
  double sigma_angular;
  double sigma_linear;
  // Per-sample 1σ of the relative drive ripple [-].
  double sigma_ripple;
  // ASD of the SRP fluctuation at 3 mHz [m s^-2 Hz^-1/2] (∝ f^-1/3).
  double srp_asd_at_3mhz;
  // Per-sample 1σ of the common-mode thruster force-noise acceleration [m/s²] (0 = off).
  double sigma_force;
  // Solve (publish new estimates) every this many samples.
  uint64_t solve_every;
  // IS measurement ranges (the front-end clips and flags beyond them): linear
  // [m/s²] and angular [rad/s²]; a voltage no in-range acceleration can give is rejected.
  double full_scale_linear;
  double full_scale_angular;
  // Longest run of missing ticks bridged as a dropout (bounds the work of one call);
  // a longer jump of the tick is rejected as implausible.
  uint64_t max_gap_ticks;
  // Integrity tuning; the defaults (`EstimatorConfig::GATE_SIGMA` …) are the
  // measured values, with their derivations there. Gate of the sample tests (IS
  // residual tracks, the cross-IS angular test) [σ].
  double gate_sigma;
  // Gate of the star-tracker test [σ].
  double star_gate_sigma;
  // A group's χ² per degree of freedom is inconsistent above
  // 1 + max(this, 10 √(2/dof)) [-].
  double chi2_tolerance;
  // The status says degraded when more than one input in this many was rejected.
  uint64_t degraded_one_in;
};
// Gate in σ: a Gaussian residual exceeds it once in 2.6×10⁷ draws, so clean data
// lose about one sample per campaign, while an upset moving a voltage by a few
// noise σ already fails the cross-IS test (whose noise is far below a voltage's own).
#define TaijiEstimatorConfig_GATE_SIGMA 5.5
// Star-tracker gate in σ, tighter than the IS's: a lost star-tracker sample costs
// little, and an upset of a quaternion component by 5 noise σ turns the attitude
// by 5σ.
#define TaijiEstimatorConfig_STAR_GATE_SIGMA 5.0
// χ² tolerance: model approximations stay well below it on clean data; an
// unmodelled effect or a wrong noise level does not.
#define TaijiEstimatorConfig_CHI2_TOLERANCE 0.25
// Degraded above 2 % rejected: the estimate then rests on visibly less data than
// planned, and the bound with it.
#define TaijiEstimatorConfig_DEGRADED_ONE_IN 50

// Common header of every message.
struct TaijiHeader {
  // Per-publisher sequence number, from 0, no gaps.
  uint64_t seq;
  // Simulation tick n; the sample describes the interval [n, n+1) / fs.
  uint64_t tick;
  // Simulation time at the end of the interval [ns].
  int64_t sim_time_ns;
  // Monotonic clock (CLOCK_MONOTONIC) when published [ns] (0 in-process).
  uint64_t publish_ns;
  // Monotonic clock when the plant published this tick's truth [ns]: carried
  // downstream so the estimator can measure end-to-end latency (0 in-process).
  uint64_t origin_ns;
  // Real-time pacing: monotonic clock when the commander was due to start this tick
  // [ns], carried downstream; the tick's deadline is one period later (0 otherwise).
  uint64_t due_ns;
  // Sensor samples: incarnation of the estimator the front-end addressed this to
  // (changes when it resends after an estimator restart; 0 elsewhere).
  uint64_t epoch;
};

// Star-tracker sample.
struct TaijiStarSample {
  // Measured attitude (w, x, y, z) of B relative to N [-].
  double q_bn[4];
  // 1 when the sample is valid, 0 in an outage or between star-tracker samples.
  uint8_t valid;
  uint8_t _pad[7];
};

// One IS's drive voltages for the interval (Table 1).
struct TaijiIsSample {
  // Electrode drive voltages [V], indexed [x, y, z][1, 2] as V_{j,1}, V_{j,2}.
  double volts[3][2];
  // Saturation / presence flags (`FLAG_*`).
  uint8_t flags;
  uint8_t _pad[7];
};

// Front-end electronics → estimator: everything the estimator may see.
struct TaijiSensorSample {
  struct TaijiHeader header;
  struct TaijiStarSample star;
  struct TaijiIsSample is[2];
};

// Estimator → supervisor / recorder: the latest estimates with 1σ.
struct TaijiEstimateMsg {
  struct TaijiHeader header;
  // Tick of the last solve; the estimates below are as of that tick.
  uint64_t solved_tick;
  // Angular scale factors per IS [rad s^-2 V^-1] and their 1σ.
  double beta[2][3];
  double beta_sigma[2][3];
  // Linear scale factors per IS [m s^-2 V^-1] and their 1σ (eq. 2).
  double k[2][3];
  double k_sigma[2][3];
  // CoM offsets per IS, body frame [m], and their 1σ.
  double r_b[2][3];
  double r_sigma[2][3];
  // Ticks whose IS data entered the linear statistics, and ticks whose did not
  // (rejected, invalid or missing); together every tick from the first on.
  uint64_t n_used;
  uint64_t n_rejected;
  // `EST_FINAL` on the estimate of the whole campaign (after the last sample).
  uint64_t flags;
  // `ST_*` bits: how far the estimate can be trusted (0: a verified solution).
  uint64_t status;
  // Rejections since start by cause (`CAUSE_*` index; a sample may count in several).
  uint64_t rejected_by_cause[TAIJI_N_CAUSES];
  // `1 << CAUSE_*` of what was rejected in the sample behind this message.
  uint64_t tick_rejections;
  // χ² per degree of freedom of the whitened residuals at the last solve, per
  // residual group (`GROUP_*`): 1 when the noise model fits the data.
  double chi2_per_dof[TAIJI_N_GROUPS];
  // Factor the σ above were inflated by because a group's χ²/dof was too large (1: none).
  double sigma_inflation;
};

// Commander → plant: torque commanded for the interval.
struct TaijiTorqueCommand {
  struct TaijiHeader header;
  // Commanded torque, body frame [N m].
  double torque_cmd_b[3];
};

// Plant → front-end electronics (and recorder only): the true state.
struct TaijiTruthState {
  struct TaijiHeader header;
  // Attitude quaternion (w, x, y, z) of B relative to N at the end of the interval [-].
  double q_bn[4];
  // Angular velocity at the end of the interval, in B [rad/s].
  double omega_b[3];
  // Mean angular acceleration over the interval, in B [rad/s²].
  double omega_dot_b[3];
  // Mean electrostatic acceleration applied to TM i over the interval, in B [m/s²] (eq. 15).
  double a_tm_b[2][3];
  // Mean non-gravitational (SRP + thruster force noise) acceleration, in B [m/s²].
  double a_srp_b[3];
  // Mean applied torque over the interval, in B [N m].
  double torque_b[3];
  // Commanded torque for the interval, in B [N m].
  double torque_cmd_b[3];
};

// Every stage → its upstream stage and the supervisor: heartbeat, flow-control credit
// and counters. Published after each batch of work and at least every 50 ms.
struct TaijiProgress {
  struct TaijiHeader header;
  // `PROC_*` of the publishing stage.
  uint32_t process;
  // `STATE_*`.
  uint32_t state;
  // Monotonic ns when this process instance started: changes when a stage restarts.
  uint64_t incarnation;
  // Every tick below this one has been consumed (the upstream may publish up to
  // `next_tick + window`).
  uint64_t next_tick;
  // Estimator: first tick after its last checkpoint; the front-end keeps every
  // sample from here on so a restarted estimator can catch up. Others: `next_tick`.
  uint64_t resume_tick;
  // Ticks missing in this stage's input (gaps in the tick sequence).
  uint64_t samples_lost;
  // Commander: ticks published later than one period after their due time.
  // Estimator: ticks whose estimate was published more than one period after the
  // tick was due (`Header::due_ns`).
  uint64_t missed_deadlines;
  // Heap allocations inside the processing loop since start-up (estimator).
  uint64_t loop_allocations;
  // Input hop latency (upstream publish → receive) p50, p99, max [µs].
  double hop_latency_us[3];
  // Estimator: end-to-end latency (plant publish → estimate published) p50, p99, max [µs].
  double e2e_latency_us[3];
  // Samples in the latency statistics above.
  uint64_t latency_count;
  // SCHED_FIFO priority the stage runs at (0: normal scheduling).
  uint32_t rt_priority;
  // CPU the stage is pinned to (−1: not pinned).
  int32_t cpu;
  uint32_t _pad;
  // 1 once this stage and every stage downstream of it can take samples (each has
  // heard its downstream's credit): the commander starts the real-time clock then.
  uint32_t primed;
};

// Supervisor → every stage.
struct TaijiControl {
  struct TaijiHeader header;
  // `CMD_*`.
  uint32_t command;
  uint32_t _pad;
};

#ifdef __cplusplus
extern "C" {
#endif // __cplusplus

// Bytes the estimator's state needs.
size_t taiji_estimator_size(void);

// Alignment the estimator's state needs [bytes].
size_t taiji_estimator_align(void);

// Version of the message and state layouts this library was built with.
uint32_t taiji_layout_version(void);

// Bytes a checkpoint needs.
size_t taiji_checkpoint_size(void);

// Bytes of the scratch memory `solve` and `finish` take (8-aligned): the Gauss–Newton
// Jacobian, the normal equations and one residual group's products. Its contents do
// not matter before or after a call, so one buffer may serve every estimator of a task.
size_t taiji_solve_work_size(void);

// Version of this C interface (`TAIJI_ABI_VERSION` of the library's build).
uint32_t taiji_abi_version(void);

// Builds an estimator from the table `cfg` in the caller's memory `mem` of
// `mem_size` bytes (at least `taiji_estimator_size()`, aligned to
// `taiji_estimator_align()`). Nothing is allocated; `mem` is the whole state.
//
// The last four arguments are what the host was compiled against: pass
// `TAIJI_ABI_ARGS` (the header's `TAIJI_ABI_VERSION` and the sizes of its
// `TaijiEstimatorConfig`, `TaijiSensorSample` and `TaijiEstimateMsg`). A host built
// against another header is refused with `TAIJI_ERR_VERSION` before anything is read.
//
// # Safety
// `mem` must point to `mem_size` writable bytes and `cfg` to a readable table, or be
// null (refused).
int32_t taiji_estimator_init(uint8_t *mem,
                             size_t mem_size,
                             const struct TaijiEstimatorConfig *cfg,
                             uint32_t abi_version,
                             size_t config_size,
                             size_t sample_size,
                             size_t estimate_size);

// Takes one sensor sample (bounded work; no solve). `rejected` (may be null) receives
// the causes this sample was rejected for (bit `1 << CAUSE_*`, 0 if accepted),
// `flags` (may be null) `TAIJI_SOLVE_DUE` when a solve is due.
//
// # Safety
// Pointers must be valid for their types or null.
int32_t taiji_estimator_update(uint8_t *mem,
                               const struct TaijiSensorSample *sample,
                               uint64_t *rejected,
                               uint32_t *flags);

// One Gauss–Newton iteration on everything taken so far (warm-started; the host
// schedules it, typically when `update` flags `TAIJI_SOLVE_DUE`). `work` is the
// caller's scratch of `work_size` bytes (at least `taiji_solve_work_size()`, 8-aligned,
// apart from the state: else `TAIJI_ERR_OVERLAP`): the Jacobian and the normal
// equations go there, not on the stack.
//
// # Safety
// `mem` must be the state passed to `taiji_estimator_init`, or null (refused); `work`
// must point to `work_size` writable bytes, or be null (refused).
int32_t taiji_estimator_solve(uint8_t *mem, uint8_t *work, size_t work_size);

// The current estimate (β, k, r with σ, status word, rejection counts) into `out`.
//
// # Safety
// Pointers must be valid for their types or null (refused).
int32_t taiji_estimator_estimate(uint8_t *mem, struct TaijiEstimateMsg *out);

// End of campaign: runs a due solve, iterates to convergence and writes the final
// estimate (flagged `EST_FINAL`) into `out`. Terminal and idempotent: a second call
// writes the same estimate again, and `update`, `solve` and `checkpoint` are refused
// from then on (`TAIJI_ERR_FINISHED`); `init` or `restore` starts afresh. `work` as
// for `solve`, checked on every call (a repeated finish does not write it).
//
// # Safety
// Pointers must be valid for their types (`work` for `work_size` bytes) or null
// (refused).
int32_t taiji_estimator_finish(uint8_t *mem,
                               uint8_t *work,
                               size_t work_size,
                               struct TaijiEstimateMsg *out);

// Writes a checkpoint of the state into `buf` (`len` ≥ `taiji_checkpoint_size()`;
// no alignment needed); `written` (may be null) receives its size.
//
// # Safety
// `buf` must point to `len` writable bytes; other pointers valid or null.
int32_t taiji_estimator_checkpoint(uint8_t *mem, uint8_t *buf, size_t len, size_t *written);

// Restores the state in `mem` (as for `init`) from a checkpoint of `len` bytes,
// made under the table `cfg`. A buffer that is not an intact checkpoint of this
// layout is refused (`TAIJI_ERR_CHECKPOINT`, `_SIZE`, `_VERSION`), and so is one made
// under another table (`TAIJI_ERR_CONFIG`: the host's table is the authority); `mem`
// is then left uninitialised (calls on it return `TAIJI_ERR_STATE`).
//
// # Safety
// `mem` must point to `mem_size` writable bytes, `buf` to `len` readable bytes, `cfg`
// to a readable table.
int32_t taiji_estimator_restore(uint8_t *mem,
                                size_t mem_size,
                                const uint8_t *buf,
                                size_t len,
                                const struct TaijiEstimatorConfig *cfg);

#ifdef __cplusplus
}  // extern "C"
#endif  // __cplusplus

#endif  /* TAIJI_ESTIMATOR_H */
