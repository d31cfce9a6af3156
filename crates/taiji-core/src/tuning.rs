//! Every tuned constant of the estimators, in one place: a value chosen to trade one
//! behaviour against another (a gate, a prior, a forgetting rate, an iteration count, a
//! split), as opposed to the maths, the physical constants, the layouts and the wire
//! codes, which stay where they are used. Each entry gives what the value does and why,
//! its unit and the test that fails when it changes materially. docs/tuning.md is this
//! table, generated from this file (`TAIJI_BLESS=1 cargo test -p taiji-core tuning`), and
//! a unit test keeps the two equal.
//!
//! The first four are also the defaults of the table's integrity fields; the C header
//! declares them from `EstimatorConfig`, where the same literals stand (asserted below).

use crate::estimate::EstimatorConfig;

// ## Integrity defaults (`EstimatorConfig`, overridable per table)

/// Gate of the sample tests: a Gaussian residual passes it but once in 2.6×10⁷ draws.
/// Unit: σ. Guarded by: `estimate::integrity::tests::a_track_accepts_white_noise_and_rejects_a_spike`.
pub const GATE_SIGMA: f64 = 5.5;

/// Gate of the star-tracker test, tighter than the IS's: a lost star sample costs little.
/// Unit: σ. Guarded by: `estimate::joint::tests::the_star_gate_is_five_sigma`.
pub const STAR_GATE_SIGMA: f64 = 5.0;

/// Least χ²/dof excess judged inconsistent: above the model's approximations on clean data.
/// Unit: dimensionless. Guarded by: `estimate::joint::tests::chi2_is_judged_from_2000_dof_within_its_spread`.
pub const CHI2_TOLERANCE: f64 = 0.25;

/// Status degraded above one rejected input in this many: the estimate rests on less data.
/// Unit: samples. Guarded by: `estimate::joint::tests::more_than_one_sample_in_50_rejected_is_degraded`.
pub const DEGRADED_ONE_IN: u64 = 50;

// The C header is generated from `EstimatorConfig`'s literals: they must be these.
const _: () = assert!(
    GATE_SIGMA == EstimatorConfig::GATE_SIGMA
        && STAR_GATE_SIGMA == EstimatorConfig::STAR_GATE_SIGMA
        && CHI2_TOLERANCE == EstimatorConfig::CHI2_TOLERANCE
        && DEGRADED_ONE_IN == EstimatorConfig::DEGRADED_ONE_IN
);

// ## Joint estimator: priors of the solve (1σ)

/// β's prior, as a fraction of the prior β: wide against the data, it keeps H regular early.
/// Unit: dimensionless. Guarded by: `estimate::joint::tests::before_any_data_sigma_is_the_prior`.
pub const PRIOR_BETA_REL: f64 = 0.05;

/// CoM offset's prior: beyond any plausible test-mass offset.
/// Unit: m. Guarded by: `estimate::joint::tests::before_any_data_sigma_is_the_prior`.
pub const PRIOR_COM_M: f64 = 0.05;

/// Star-tracker reference offset θ0's prior (0.6°).
/// Unit: rad. Guarded by: `estimate::joint::tests::before_any_data_sigma_is_the_prior`.
pub const PRIOR_THETA0_RAD: f64 = 1e-2;

/// Star-tracker reference rate θ̇0's prior.
/// Unit: rad/s. Guarded by: `estimate::joint::tests::before_any_data_sigma_is_the_prior`.
pub const PRIOR_THETA_RATE_RAD_S: f64 = 1e-4;

/// Linear-channel bias b′'s prior: beyond any drive-voltage offset.
/// Unit: V. Guarded by: `estimate::joint::tests::before_any_data_sigma_is_the_prior`.
pub const PRIOR_BIAS_V: f64 = 1.0;

/// Linear-channel drift α′'s prior.
/// Unit: V/s. Guarded by: `estimate::joint::tests::before_any_data_sigma_is_the_prior`.
pub const PRIOR_DRIFT_V_S: f64 = 1e-3;

// ## Joint estimator: solve and convergence

/// Gauss–Newton iterations of `finish`: the warm-started run needs 2–3, the rest is margin.
/// Unit: iterations. Guarded by: `tests/integrity.rs::a_final_solve_whose_steps_turn_back_and_shrink_has_converged`.
pub const FINISH_ITERATIONS: usize = 20;

/// Gauss–Newton iterations of a scheduled solve: one, warm-started, bounds its work.
/// Unit: iterations. Guarded by: `tests/integrity.rs::an_unconverged_first_solve_says_so_and_is_solved_again_at_once`.
pub const SCHEDULED_ITERATIONS: usize = 1;

/// A solve has converged when no parameter moved by more than this share of its σ.
/// Unit: σ. Guarded by: `estimate::joint::tests::a_final_solve_at_the_floating_point_floor_has_converged`.
pub const CONVERGED_STEP: f64 = 1e-4;

/// What a final solve may still be off by and be called converged (the floating-point floor).
/// Unit: σ. Guarded by: `estimate::joint::tests::a_final_solve_at_the_floating_point_floor_has_converged`.
pub const UNCONVERGED_STEP: f64 = 1e-2;

/// Consecutive steps closer in direction than this cosine follow one pattern of closing in.
/// Unit: dimensionless. Guarded by: `estimate::joint::tests::a_final_solve_at_the_floating_point_floor_has_converged`.
pub const CLOSING_IN_COS: f64 = 0.5;

/// Follow-up solves after an unconverged first one, one per update: bounded catch-up.
/// Unit: solves. Guarded by: `estimate::joint::tests::an_unconverged_first_solve_is_followed_up_three_times`.
pub const FOLLOW_UPS: u64 = 3;

/// Gauss–Newton iterations of the bound's nuisance fit: linear but for the SRP's turn, 2 suffice.
/// Unit: iterations. Guarded by: `estimate::joint::tests::the_nuisance_fit_reaches_its_fixed_point`.
pub const NUISANCE_ITERATIONS: usize = 6;

/// A group's χ²/dof is inconsistent above 1 + this many of its spread √(2/dof) (or the tolerance).
/// Unit: σ of χ²/dof. Guarded by: `estimate::joint::tests::chi2_is_judged_from_2000_dof_within_its_spread`.
pub const CHI2_SPREAD_SIGMAS: f64 = 10.0;

/// Degrees of freedom a group needs before its χ² is judged: fewer scatter too much.
/// Unit: dof. Guarded by: `estimate::joint::tests::chi2_is_judged_from_2000_dof_within_its_spread`.
pub const CHI2_MIN_DOF: f64 = 2000.0;

// ## Joint estimator: input gates and their tracks

/// Margin on the measurement range in the voltage range test: room for the priors and ripple.
/// Unit: full scale. Guarded by: `estimate::joint::gates::tests::the_range_gate_is_the_full_scale_times_its_margin`.
pub const RANGE_MARGIN: f64 = 1.25;

/// Room of the cross-IS test before the ratio fit: the priors' ratio may be 22 % off.
/// Unit: share of the prior ratio's voltage. Guarded by: `estimate::joint::gates::tests::before_the_fit_the_cross_test_allows_half_the_ratio`.
pub const PRIOR_RATIO_ROOM: f64 = 0.5;

/// Forgetting rate of the linear residual tracks: the spread follows the drive over ~64 samples.
/// Unit: per sample. Guarded by: `estimate::joint::gates::tests::the_linear_track_forgets_at_one_sixty_fourth`.
pub const ALPHA_LIN: f64 = 1.0 / 64.0;

/// Forgetting rate of the star-tracker track: its offset moves with the attitude error.
/// Unit: per star sample. Guarded by: `estimate::joint::tests::the_star_gate_is_five_sigma`.
pub const ALPHA_STAR: f64 = 1.0 / 16.0;

/// A star-tracker quaternion whose norm is off 1 by more is invalid: far beyond its rounding.
/// Unit: dimensionless. Guarded by: `estimate::joint::tests::the_star_gate_is_five_sigma`.
pub const STAR_NORM_TOLERANCE: f64 = 1e-6;

/// A gap longer than this lets the star test learn its offset anew rather than reject.
/// Unit: s. Guarded by: `estimate::joint::tests::a_gap_over_a_second_relearns_the_star_offset`.
pub const STAR_RELEARN_GAP_S: f64 = 1.0;

/// Samples a residual track accepts unchecked, as its first estimate of the spread.
/// Unit: samples. Guarded by: `estimate::integrity::tests::a_warming_track_rejects_only_gross_outliers`.
pub const TRACK_UNCHECKED: u32 = 8;

/// Samples a track learns before it gates at full strength (it rejects gross outliers before).
/// Unit: samples. Guarded by: `estimate::integrity::tests::a_warming_track_rejects_only_gross_outliers`.
pub const TRACK_WARM: u32 = 48;

/// While warming, a track's gate is widened by the root of this factor (100×): gross outliers only.
/// Unit: dimensionless (on the variance). Guarded by: `estimate::integrity::tests::a_warming_track_rejects_only_gross_outliers`.
pub const TRACK_WARMING_VAR: f64 = 1e4;

/// Consecutive rejections after which a track re-learns: a persistent change is the new normal.
/// Unit: samples. Guarded by: `estimate::integrity::tests::a_track_follows_a_slow_drift_and_relearns_after_a_step`.
pub const TRACK_RELEARN: u32 = 200;

/// Accepted pairs before the fitted β2/β1 ratio replaces the priors' in the cross-IS test.
/// Unit: samples. Guarded by: `estimate::integrity::tests::the_ratio_fit_recovers_the_ratio`.
pub const RATIO_FIT_MIN: u64 = 20;

// ## Joint estimator: bridging, attitude and the SRP's level

/// Most missing ticks one update bridges: no call costs more than this many steps.
/// Unit: ticks. Guarded by: `estimate::joint::tests::a_short_gap_is_bridged_at_once`.
pub const BRIDGE_PER_UPDATE: u64 = 8;

/// The star group's share c₁ of a bridged tick's rate step (it confounds β there).
/// Unit: dimensionless. Guarded by: `estimate::joint::tests::a_closed_bridge_splits_its_step_four_thirds_and_four`.
pub const STEP_IN_STAR: f64 = 4.0 / 3.0;

/// The turn rows' share c₂ of a bridged tick's rate step (it confounds r there).
/// Unit: dimensionless. Guarded by: `estimate::joint::tests::a_closed_bridge_splits_its_step_four_thirds_and_four`.
pub const STEP_IN_TURN: f64 = 4.0;

// The split covers the one step's joint covariance (h₁; h₂)(h₁; h₂)ᵀ whenever
// 1/c₁ + 1/c₂ ≤ 1: it never counts more than the joint likelihood of the one step.
const _: () = assert!(1.0 / STEP_IN_STAR + 1.0 / STEP_IN_TURN <= 1.0 + 1e-12);

/// Forgetting rate of ω̇'s learned tick-to-tick spread (`jerk_var`): slow against the edges.
/// Unit: per sample. Guarded by: `estimate::joint::tests::a_torque_edge_moves_the_jerk_spread_by_its_clip`.
pub const ALPHA_JERK: f64 = 1.0 / 256.0;

/// A change of ω̇ counts into its spread at most this many variances (4σ): edges are clipped.
/// Unit: dimensionless (on the variance). Guarded by: `estimate::joint::tests::a_torque_edge_moves_the_jerk_spread_by_its_clip`.
pub const JERK_CLIP_VAR: f64 = 16.0;

/// Motion rocks an axis once ω̇'s variance is this many times the readout noise's (r̂ 10⁻⁴ off).
/// Unit: dimensionless. Guarded by: `estimate::joint::tests::rocking_is_motion_over_ten_thousand_times_the_noise`.
pub const ROCKED_VAR_RATIO: f64 = 1e4;

/// The excitation's moments take every this many linear samples (a power of two: no division).
/// Unit: samples. Guarded by: `estimate::joint::tests::the_excitation_takes_every_eighth_sample`.
pub const MOMENT_EVERY: u64 = 8;

// A 64-bit remainder is a library call on a 32-bit CPU; a mask is not.
const _: () = assert!(MOMENT_EVERY.is_power_of_two());

// ## Joint estimator: the SRP's noise model (the simulation's, src/model/plant.rs)

/// Frequency at which the table's `srp_asd_at_3mhz` gives the SRP fluctuation's ASD.
/// Unit: Hz. Guarded by: `estimate::joint::tests::the_srp_model_is_f_to_the_minus_two_thirds_from_3_mhz`.
pub const SRP_REF_HZ: f64 = 3e-3;

/// The SRP fluctuation's PSD slope γ (PSD ∝ f^-γ, ASD ∝ f^-1/3): the whitening filter's model.
/// Unit: dimensionless. Guarded by: `estimate::joint::tests::the_srp_model_is_f_to_the_minus_two_thirds_from_3_mhz`.
pub const SRP_PSD_EXPONENT: f64 = 2.0 / 3.0;

// ## The paper's route (`estimate::paper`): the paper's values, reproduced, not tuned

/// Low-pass corner on both sides of the β regression (§2.1).
/// Unit: Hz. Guarded by: `estimate::paper::tests::the_paper_routes_values_are_the_papers`.
pub const PAPER_LOWPASS_HZ: f64 = 0.05;

/// The β regression waits this many periods of the corner (100 s): the low-passes' start-up.
/// Unit: periods. Guarded by: `estimate::paper::tests::the_paper_routes_values_are_the_papers`.
pub const PAPER_SETTLE_PERIODS: f64 = 5.0;

/// β's prior, as a fraction of the prior β.
/// Unit: dimensionless. Guarded by: `estimate::paper::tests::the_paper_routes_values_are_the_papers`.
pub const PAPER_PRIOR_BETA_REL: f64 = 0.05;

/// CoM offset's prior.
/// Unit: m. Guarded by: `estimate::paper::tests::the_paper_routes_values_are_the_papers`.
pub const PAPER_PRIOR_COM_M: f64 = 5e-3;

/// Linear drift α's prior.
/// Unit: m/s³. Guarded by: `estimate::paper::tests::the_paper_routes_values_are_the_papers`.
pub const PAPER_PRIOR_DRIFT: f64 = 1e-10;

/// Linear bias b's prior.
/// Unit: m/s². Guarded by: `estimate::paper::tests::the_paper_routes_values_are_the_papers`.
pub const PAPER_PRIOR_BIAS: f64 = 1e-6;

/// The SRP folded into the CoM filter's measurement noise (§3.2.2), 1σ.
/// Unit: m/s². Guarded by: `estimate::paper::tests::the_paper_routes_values_are_the_papers`.
pub const PAPER_SRP_SIGMA: f64 = 2e-12;
