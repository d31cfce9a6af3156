//! Every tuned constant of the estimators, in one place: a value chosen to trade one
//! behaviour against another (a gate, a prior, a forgetting rate, an iteration count, a
//! split), as opposed to the maths, the physical constants, the layouts and the wire
//! codes, which stay where they are used. Each entry gives what the value does and why,
//! its unit and the test that fails when it changes materially. docs/tuning.md is this
//! table, generated from this file (`TAIJI_BLESS=1 cargo test -p taiji-core tuning`), and
//! a unit test keeps the two equal.
//!
//! The first four are also the defaults of the table's integrity fields; the C header
//! declares them from `EstimatorConfig`, where the same literals stand (asserted there).
//! This module uses nothing of the crate: every estimator depends on it, never it on one.

// ## Integrity defaults (`EstimatorConfig`, overridable per table)

/// Gate of the sample tests: a Gaussian draw exceeds it once in 2.6×10⁷.
/// Unit: σ. Guarded by: `estimate::integrity::tests::a_track_accepts_white_noise_and_rejects_a_spike`.
pub const GATE_SIGMA: f64 = 5.5;

/// Gate of the star test, tighter: a lost star sample costs little.
/// Unit: σ. Guarded by: `estimate::joint::tests::the_star_gate_is_five_sigma`.
pub const STAR_GATE_SIGMA: f64 = 5.0;

/// Least χ²/dof excess judged inconsistent: above what model approximations give.
/// Unit: dimensionless. Guarded by: `estimate::joint::tests::chi2_is_judged_from_2000_dof_within_its_spread`.
pub const CHI2_TOLERANCE: f64 = 0.25;

/// Status degraded above one rejected input in this many.
/// Unit: inputs. Guarded by: `estimate::joint::tests::more_than_one_sample_in_50_rejected_is_degraded`.
pub const DEGRADED_ONE_IN: u64 = 50;

// ## Joint estimator: priors of the solve (1σ)

/// β's prior, a share of the prior β: wide, it keeps H regular early.
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

/// Gauss–Newton iterations of `finish`: a warm start needs 2–3.
/// Unit: iterations. Guarded by: `estimate::joint::tests::finish_iterates_twenty_times_at_most`.
pub const FINISH_ITERATIONS: usize = 20;

/// Iterations of a scheduled solve (warm-started): bounded work.
/// Unit: iterations. Guarded by: `tests/integrity.rs::an_unconverged_first_solve_says_so_and_is_solved_again_at_once`.
pub const SCHEDULED_ITERATIONS: usize = 1;

/// A solve has converged when no parameter moved by more than this share of its σ.
/// Unit: σ. Guarded by: `estimate::joint::tests::a_final_solve_at_the_floating_point_floor_has_converged`.
pub const CONVERGED_STEP: f64 = 1e-4;

/// What a final solve may still be off by and be converged (the rounding floor).
/// Unit: σ. Guarded by: `estimate::joint::tests::a_final_solve_at_the_floating_point_floor_has_converged`.
pub const UNCONVERGED_STEP: f64 = 1e-2;

/// Steps closer in direction than this cosine are closing in on one point.
/// Unit: dimensionless. Guarded by: `estimate::joint::tests::a_final_solve_at_the_floating_point_floor_has_converged`.
pub const CLOSING_IN_COS: f64 = 0.5;

/// Follow-up solves after an unconverged first one, one per update.
/// Unit: solves. Guarded by: `estimate::joint::tests::an_unconverged_first_solve_is_followed_up_three_times`.
pub const FOLLOW_UPS: u64 = 3;

/// Iterations of the bound's nuisance fit: linear but for the SRP's turn.
/// Unit: iterations. Guarded by: `estimate::joint::tests::the_nuisance_fit_takes_six_steps`.
pub const NUISANCE_ITERATIONS: usize = 6;

/// χ²/dof is inconsistent above 1 + this many spreads √(2/dof), or the tolerance.
/// Unit: σ. Guarded by: `estimate::joint::tests::chi2_is_judged_from_2000_dof_within_its_spread`.
pub const CHI2_SPREAD_SIGMAS: f64 = 10.0;

/// Degrees of freedom a group needs before its χ² is judged: fewer scatter too much.
/// Unit: dof. Guarded by: `estimate::joint::tests::chi2_is_judged_from_2000_dof_within_its_spread`.
pub const CHI2_MIN_DOF: f64 = 2000.0;

// ## Joint estimator: input gates and their tracks

/// Margin on the range in the voltage range test: room for priors and ripple.
/// Unit: full scale. Guarded by: `estimate::joint::gates::tests::the_range_gate_is_the_full_scale_times_its_margin`.
pub const RANGE_MARGIN: f64 = 1.25;

/// Cross-IS test's room before the ratio fit: priors' ratio ≤ 22 % off.
/// Unit: dimensionless. Guarded by: `estimate::joint::gates::tests::before_the_fit_the_cross_test_allows_half_the_ratio`.
pub const PRIOR_RATIO_ROOM: f64 = 0.5;

/// Forgetting rate of the linear residual tracks: they follow the drive.
/// Unit: per sample. Guarded by: `estimate::joint::gates::tests::the_linear_track_forgets_at_one_sixty_fourth`.
pub const ALPHA_LIN: f64 = 1.0 / 64.0;

/// Forgetting rate of the star-tracker track: its offset moves with the attitude error.
/// Unit: per star sample. Guarded by: `estimate::joint::tests::the_star_gate_is_five_sigma`.
pub const ALPHA_STAR: f64 = 1.0 / 16.0;

/// A star quaternion whose norm is off 1 by more is invalid (beyond rounding).
/// Unit: dimensionless. Guarded by: `estimate::joint::tests::the_star_gate_is_five_sigma`.
pub const STAR_NORM_TOLERANCE: f64 = 1e-6;

/// A gap longer than this makes the star test learn its offset anew.
/// Unit: s. Guarded by: `estimate::joint::tests::a_gap_over_a_second_relearns_the_star_offset`.
pub const STAR_RELEARN_GAP_S: f64 = 1.0;

/// Samples a residual track accepts unchecked, as its first estimate of the spread.
/// Unit: samples. Guarded by: `estimate::integrity::tests::a_warming_track_rejects_only_gross_outliers`.
pub const TRACK_UNCHECKED: u32 = 8;

/// Samples a track learns before it gates at full strength.
/// Unit: samples. Guarded by: `estimate::integrity::tests::a_warming_track_rejects_only_gross_outliers`.
pub const TRACK_WARM: u32 = 48;

/// Variance factor of a warming track's gate (100×): gross outliers only.
/// Unit: dimensionless. Guarded by: `estimate::integrity::tests::a_warming_track_rejects_only_gross_outliers`.
pub const TRACK_WARMING_VAR: f64 = 1e4;

/// Rejections in a row after which a track re-learns: a lasting change.
/// Unit: samples. Guarded by: `estimate::integrity::tests::a_track_follows_a_slow_drift_and_relearns_after_a_step`.
pub const TRACK_RELEARN: u32 = 200;

/// Accepted pairs before the fitted β2/β1 replaces the priors' ratio.
/// Unit: samples. Guarded by: `estimate::integrity::tests::the_ratio_fit_recovers_the_ratio`.
pub const RATIO_FIT_MIN: u64 = 20;

// ## Joint estimator: bridging, attitude and the SRP's level

/// Most missing ticks one update bridges: no call costs more than this many steps.
/// Unit: ticks. Guarded by: `estimate::joint::tests::a_short_gap_is_bridged_at_once`.
pub const BRIDGE_PER_UPDATE: u64 = 8;

/// Whitening states decaying below this become 0 (no subnormal math).
/// Unit: the state's. Guarded by: `estimate::joint::whiten::tests::decaying_states_reach_zero_without_a_subnormal_number`.
pub const FLUSH_BELOW: f64 = 1e-280;

/// Star group's share c₁ of a bridged tick's rate step (confounds β).
/// Unit: dimensionless. Guarded by: `estimate::joint::tests::a_closed_bridge_splits_its_step_four_thirds_and_four`.
pub const STEP_IN_STAR: f64 = 4.0 / 3.0;

/// Turn rows' share c₂ of a bridged tick's rate step (confounds r).
/// Unit: dimensionless. Guarded by: `estimate::joint::tests::a_closed_bridge_splits_its_step_four_thirds_and_four`.
pub const STEP_IN_TURN: f64 = 4.0;

// The split covers the one step's joint covariance (h₁; h₂)(h₁; h₂)ᵀ whenever
// 1/c₁ + 1/c₂ ≤ 1: it never counts more than the joint likelihood of the one step.
const _: () = assert!(1.0 / STEP_IN_STAR + 1.0 / STEP_IN_TURN <= 1.0 + 1e-12);

/// Forgetting rate of ω̇'s tick-to-tick spread: slow against the edges.
/// Unit: per sample. Guarded by: `estimate::joint::tests::a_torque_edge_moves_the_jerk_spread_by_its_clip`.
pub const ALPHA_JERK: f64 = 1.0 / 256.0;

/// A change of ω̇ counts at most this many variances (4σ): edges clipped.
/// Unit: dimensionless. Guarded by: `estimate::joint::tests::a_torque_edge_moves_the_jerk_spread_by_its_clip`.
pub const JERK_CLIP_VAR: f64 = 16.0;

/// ω̇ variance over readout noise's that rocks an axis (r̂ then 10⁻⁴ off).
/// Unit: dimensionless. Guarded by: `estimate::joint::tests::rocking_is_motion_over_ten_thousand_times_the_noise`.
pub const ROCKED_VAR_RATIO: f64 = 1e4;

/// The excitation's moments take every this many linear samples.
/// Unit: samples. Guarded by: `estimate::joint::tests::the_excitation_takes_every_eighth_sample`.
pub const MOMENT_EVERY: u64 = 8;

// A 64-bit remainder is a library call on a 32-bit CPU; a mask is not.
const _: () = assert!(MOMENT_EVERY.is_power_of_two());

// ## Joint estimator: the SRP's noise model (the simulation's own)

/// Frequency at which the table's `srp_asd_at_3mhz` gives the SRP fluctuation's ASD.
/// Unit: Hz. Guarded by: `estimate::joint::tests::the_srp_model_is_f_to_the_minus_two_thirds_from_3_mhz`.
pub const SRP_REF_HZ: f64 = 3e-3;

/// The SRP fluctuation's PSD slope γ (PSD ∝ f^-γ): the whitening's model.
/// Unit: dimensionless. Guarded by: `estimate::joint::tests::the_srp_model_is_f_to_the_minus_two_thirds_from_3_mhz`.
pub const SRP_PSD_EXPONENT: f64 = 2.0 / 3.0;

// ## The paper's route (`estimate::paper`): the paper's values, reproduced, not tuned

/// Low-pass corner on both sides of the β regression (§2.1).
/// Unit: Hz. Guarded by: `estimate::paper::tests::the_paper_routes_values_are_the_papers`.
pub const PAPER_LOWPASS_HZ: f64 = 0.05;

/// The β regression waits this many periods of the corner (100 s).
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

/// docs/tuning.md: this file's entries as one table, generated and checked here.
#[cfg(test)]
mod tests {
    use super::*;
    use std::format;
    use std::string::{String, ToString};
    use std::vec::Vec;

    /// One entry: name, value as written, unit, what it does, the guarding test.
    struct Entry {
        name: String,
        value: String,
        unit: String,
        what: String,
        guard: String,
    }

    /// A section heading (`// ## …`) or an entry, in the file's order.
    enum Row {
        Section(String),
        Entry(Entry),
    }

    /// This file's rows, parsed from its source (up to the tests).
    fn rows() -> Vec<Row> {
        let src = include_str!("tuning.rs");
        let src = &src[..src.find("#[cfg(test)]").unwrap_or(src.len())];
        let mut rows = Vec::new();
        let mut doc: Vec<&str> = Vec::new();
        for line in src.lines() {
            if let Some(title) = line.strip_prefix("// ## ") {
                rows.push(Row::Section(title.to_string()));
            } else if let Some(d) = line.strip_prefix("/// ") {
                doc.push(d);
            } else if let Some(rest) = line.strip_prefix("pub const ") {
                let (name, rest) = rest.split_once(':').expect("pub const NAME: T = V;");
                let value = rest.split_once(" = ").expect("= value").1;
                let value = value.strip_suffix(';').expect("one line");
                let last = doc.pop().unwrap_or_default();
                let (unit, guard) = last
                    .strip_prefix("Unit: ")
                    .and_then(|l| l.split_once(". Guarded by: `"))
                    .unwrap_or_else(|| panic!("{name}: `Unit: U. Guarded by: `test`.` last"));
                rows.push(Row::Entry(Entry {
                    name: name.to_string(),
                    value: value.to_string(),
                    unit: unit.to_string(),
                    what: doc.join(" "),
                    guard: guard.trim_end_matches("`.").to_string(),
                }));
                doc.clear();
            } else {
                doc.clear();
            }
        }
        rows
    }

    fn entries() -> Vec<Entry> {
        rows()
            .into_iter()
            .filter_map(|r| match r {
                Row::Entry(e) => Some(e),
                Row::Section(_) => None,
            })
            .collect()
    }

    /// docs/tuning.md as this file makes it.
    fn page() -> String {
        let mut out = String::from(
            "# The estimators' tuning\n\n\
             Every tuned constant of the flight core's estimators, with its value, unit, what it\n\
             does and the test that fails when it changes materially. Generated from\n\
             [`crates/taiji-core/src/tuning.rs`](../crates/taiji-core/src/tuning.rs), which the\n\
             code takes each value from; a unit test there fails when this page differs\n\
             (regenerate: `TAIJI_BLESS=1 cargo test -p taiji-core tuning`). Guards name a unit\n\
             test of `taiji_core::estimate` or a test file at the root.\n\n\
             Not here: the maths, physical constants, layouts, wire codes, a table's accepted\n\
             ranges (`EstimatorConfig::check`) and guards that only keep arithmetic finite.\n\n\
             | name | value | unit | what it does | guarded by |\n\
             |---|---|---|---|---|\n",
        );
        for r in rows() {
            match r {
                Row::Section(t) => out += &format!("| **{t}** | | | | |\n"),
                Row::Entry(e) => {
                    let guard = e.guard.strip_prefix("estimate::").unwrap_or(&e.guard);
                    out += &format!(
                        "| `{}` | `{}` | {} | {} | `{}` |\n",
                        e.name, e.value, e.unit, e.what, guard
                    );
                }
            }
        }
        out
    }

    #[test]
    #[cfg_attr(
        miri,
        ignore = "reads the docs and sources as files (Miri isolates the file system); text only, no unsafe"
    )]
    fn docs_tuning_md_is_this_table() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/tuning.md");
        let fresh = page();
        if std::env::var_os("TAIJI_BLESS").is_some() {
            std::fs::write(path, &fresh).expect("write docs/tuning.md");
        }
        let on_disk = std::fs::read_to_string(path).unwrap_or_default();
        assert!(
            on_disk == fresh,
            "docs/tuning.md is stale: regenerate it with TAIJI_BLESS=1 cargo test -p taiji-core tuning"
        );
        assert!(fresh.lines().count() <= 200);
        for line in fresh.lines() {
            assert!(line.chars().count() <= 200, "over 200 characters: {line}");
        }
    }

    /// Every entry has a unit, a line on what it does, and a guard that exists.
    #[test]
    #[cfg_attr(
        miri,
        ignore = "reads the docs and sources as files (Miri isolates the file system); text only, no unsafe"
    )]
    fn every_entry_says_what_it_does_and_names_a_test_that_exists() {
        let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
        let core = concat!(env!("CARGO_MANIFEST_DIR"), "/src");
        for e in entries() {
            assert!(!e.unit.is_empty() && !e.what.is_empty(), "{}", e.name);
            let (file, test) = match e.guard.split_once(".rs::") {
                Some((file, test)) => (format!("{root}/{file}.rs"), test.to_string()),
                None => {
                    let (module, test) = e.guard.rsplit_once("::").expect("path::test");
                    let module = module.strip_suffix("::tests").expect("a tests module");
                    let dir = format!("{core}/{}", module.replace("::", "/"));
                    let file = match std::fs::metadata(format!("{dir}/mod.rs")) {
                        Ok(_) => format!("{dir}/mod.rs"),
                        Err(_) => format!("{dir}.rs"),
                    };
                    (file, test.to_string())
                }
            };
            let text = std::fs::read_to_string(&file).unwrap_or_default();
            assert!(
                text.contains(&format!("fn {test}()")),
                "{}: no test {test} in {file}",
                e.name
            );
        }
    }

    /// The value each entry shows evaluates to the constant's own: the table cannot
    /// show another number than the code uses.
    #[test]
    fn every_entry_shows_the_value_the_code_uses() {
        macro_rules! values {
            ($($c:ident),* $(,)?) => { [$((stringify!($c), $c as f64)),*] };
        }
        let values = values![
            GATE_SIGMA,
            STAR_GATE_SIGMA,
            CHI2_TOLERANCE,
            DEGRADED_ONE_IN,
            PRIOR_BETA_REL,
            PRIOR_COM_M,
            PRIOR_THETA0_RAD,
            PRIOR_THETA_RATE_RAD_S,
            PRIOR_BIAS_V,
            PRIOR_DRIFT_V_S,
            FINISH_ITERATIONS,
            SCHEDULED_ITERATIONS,
            CONVERGED_STEP,
            UNCONVERGED_STEP,
            CLOSING_IN_COS,
            FOLLOW_UPS,
            NUISANCE_ITERATIONS,
            CHI2_SPREAD_SIGMAS,
            CHI2_MIN_DOF,
            RANGE_MARGIN,
            PRIOR_RATIO_ROOM,
            ALPHA_LIN,
            ALPHA_STAR,
            STAR_NORM_TOLERANCE,
            STAR_RELEARN_GAP_S,
            TRACK_UNCHECKED,
            TRACK_WARM,
            TRACK_WARMING_VAR,
            TRACK_RELEARN,
            RATIO_FIT_MIN,
            BRIDGE_PER_UPDATE,
            FLUSH_BELOW,
            STEP_IN_STAR,
            STEP_IN_TURN,
            ALPHA_JERK,
            JERK_CLIP_VAR,
            ROCKED_VAR_RATIO,
            MOMENT_EVERY,
            SRP_REF_HZ,
            SRP_PSD_EXPONENT,
            PAPER_LOWPASS_HZ,
            PAPER_SETTLE_PERIODS,
            PAPER_PRIOR_BETA_REL,
            PAPER_PRIOR_COM_M,
            PAPER_PRIOR_DRIFT,
            PAPER_PRIOR_BIAS,
            PAPER_SRP_SIGMA,
        ];
        let entries = entries();
        let names: Vec<&str> = entries.iter().map(|e| e.name.as_str()).collect();
        let listed: Vec<&str> = values.iter().map(|v| v.0).collect();
        assert_eq!(names, listed, "every entry, in order, is checked here");
        let number = |t: &str| -> f64 { t.replace('_', "").parse().expect("a number") };
        for (e, (_, v)) in entries.iter().zip(values) {
            let shown = match e.value.split_once(" / ") {
                Some((a, b)) => number(a) / number(b),
                None => number(&e.value),
            };
            assert_eq!(shown.to_bits(), v.to_bits(), "{}", e.name);
        }
    }
}
