//! Every tuned constant of the std layer, in one place: a value chosen to trade one
//! behaviour against another (a search's resolution, a threshold, a period, a number of
//! tries), as opposed to the physical constants, the wire codes, the file names and the
//! array sizes, which stay where they are used. Each entry gives what the value does and
//! why, its unit and the test that fails when it changes materially. The estimators'
//! own are the flight core's table (`taiji_core::tuning`, docs/tuning.md).
//!
//! This module uses nothing of the crate (layer 0): every layer may read it, it reads
//! none. The plan cache keys plans on this file's bytes too.

// ## The planner (`analysis::plan`)

/// Samples per candidate in the search: its sample rate is this over the window.
/// Unit: samples. Guarded by: `tests/docs.rs::every_computed_number_in_the_docs_is_what_its_command_prints_now`.
pub const SEARCH_SAMPLES: f64 = 10_000.0;

/// Least samples per period of the fastest axis in the search: a long window's search bound is then a few per cent loose.
/// It sets the search rate of windows over ~10⁴ s (shorter ones: `SEARCH_SAMPLES`); half of it
/// leaves a 10⁵ s window's search bound about 6 % loose.
/// Unit: samples per period. Guarded by: `tests/tuning.rs::the_search_bound_of_a_long_window_is_within_three_percent_of_the_full_rate_bound`.
pub const SEARCH_SAMPLES_PER_PERIOD: f64 = 32.0;

/// Highest maneuver frequency searched: above it the angles are too small to calibrate β, and the IS noise rises.
/// Unit: Hz. Guarded by: `tests/docs.rs::every_computed_number_in_the_docs_is_what_its_command_prints_now`.
pub const MAX_FREQUENCY_HZ: f64 = 0.02;

/// Periods per axis (sequential) or of the slow axis (simultaneous) of the coarse grid, refined between neighbours.
/// Unit: periods. Guarded by: `tests/docs.rs::every_computed_number_in_the_docs_is_what_its_command_prints_now`.
pub const PERIODS: [u64; 9] = [1, 2, 4, 8, 16, 32, 64, 128, 256];

/// A refinement (start phase, axis order) must beat the plain maneuver by more than the search bound's uncertainty.
/// Unit: ratio. Guarded by: `tests/docs.rs::every_computed_number_in_the_docs_is_what_its_command_prints_now`.
pub const REFINEMENT_GAIN: f64 = 1.05;

/// Most samples of the final bound: a longer campaign's is computed at a lower rate, in bounded time, 10⁻⁵ off.
/// Unit: samples. Guarded by: `tests/tuning.rs::the_final_bound_of_a_long_window_is_the_full_rate_bound_to_two_parts_in_1e5`.
pub const FINAL_SAMPLES: f64 = 2.0e6;

/// Largest planned attitude excursion at the default SRP noise: the estimator turns the DC SRP with the attitude,
/// not its fluctuation, whose product with a larger angle biases r beyond the bound (docs/planning.md).
/// Unit: rad. Guarded by: `tests/docs.rs::every_computed_number_in_the_docs_is_what_its_command_prints_now`.
pub const MODEL_ATTITUDE_RAD: f64 = 5.5e-4;

/// Below this `torque_noise_rocking` the thrusters are quiet: ten times the estimator's own threshold, for its scatter.
/// Unit: dimensionless. Guarded by: `tests/tuning.rs::thrusters_at_a_twentieth_of_the_default_torque_noise_are_quiet`.
pub const QUIET_ROCKING: f64 = 10.0;

// ## The report (`analysis::report`)

/// A parameter whose data share is below this is named prior-dominated: its prior tells more than the data.
/// Unit: share. Guarded by: `tests/tuning.rs::a_parameter_is_prior_dominated_below_half_its_information_from_data`.
pub const PRIOR_DOMINATED_SHARE: f64 = 0.5;

// ## The process set (`runtime::process`)

/// The estimator checkpoints every this long of samples: at most this much is replayed after a restart.
/// Unit: s. Guarded by: `runtime::process::estimator::tests::the_checkpoint_interval_is_100_s_of_samples_within_the_ring`.
pub const CHECKPOINT_EVERY_S: f64 = 100.0;

/// A stage beats every this many ticks of progress; the credit upstream moves with it (`wiring::WINDOW` is 8× as wide).
/// Unit: ticks. Guarded by: `tests/tuning.rs::eight_beats_cross_the_credit_window`.
pub const BEAT_TICKS: u64 = 32;

/// Heartbeat period of an idle stage: twice per status (`status::STATUS_EVERY`), so each shows a fresh beat.
/// Unit: ns. Guarded by: `tests/tuning.rs::an_idle_stage_beats_twice_per_status`.
pub const BEAT_NS: u64 = 50_000_000;

/// Points of the bound's curve that the status interpolates between (`crlb::bound_at`).
/// Unit: points. Guarded by: `tests/tuning.rs::the_status_bound_is_within_three_percent_of_the_curve_on_average`.
pub const BOUND_POINTS: usize = 64;

// ## Telemetry (`telemetry`)

/// Estimate rows are recorded at most this often, and always the final one: the joint estimator solves every 60 s.
/// Unit: s. Guarded by: `tests/tuning.rs::estimate_rows_are_ten_seconds_apart_when_the_estimator_solves_every_second`.
pub const ESTIMATE_ROW_EVERY_S: f64 = 10.0;

/// Tries of an SWMR metadata read whose checksum fails, backing off from 1 ns doubling: 0.13 s in all, longer than a
/// live writer's flush is torn, not hours on a corrupt file.
/// Unit: tries. Guarded by: `tests/telemetry.rs::corrupted_recordings_are_refused_or_replayed_never_a_crash_a_panic_or_a_hang`.
pub const SWMR_READ_ATTEMPTS: u32 = 27;
