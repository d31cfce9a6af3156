//! Joint streaming estimator of β1, β2, r1, r2 (and nuisances) that reaches the
//! Cramér–Rao bound (docs/method.md explains the method and why).
//!
//! Every measurement residual is a linear combination of *data signals* (voltages,
//! their single and double integrals, star-tracker angles, 1, t) with coefficients that
//! are smooth functions of the parameters. So the weighted least-squares cost is
//! `Σ_g c_g(p)ᵀ M_g c_g(p)`, where the Gram matrices `M_g` of the (whitened) signals are
//! fixed-size sufficient statistics accumulated sample by sample. The coloured,
//! common-mode SRP noise lies along one direction of the linear channels; that
//! component is whitened with the innovations filter of its state-space model (the
//! same causal filter applied to every signal, i.e. to measurement and regressors
//! alike), the orthogonal components are white. Solving is Gauss–Newton on 30
//! parameters from those statistics, warm-started, every `solve_every` samples; the
//! covariance is the inverse Gauss–Newton Hessian, i.e. the Fisher information.
//!
//! Groups of residuals, per sample:
//! * star tracker, per axis: θ_st − κ − θ0 − θ̇0 t − ½(β1 Φ1 + β2 Φ2)   (angle domain)
//! * angular consistency, per axis: β1 ΔV1 − β2 ΔV2   (both IS see the same ω̇)
//! * linear, per IS and axis (eq. 15, in volts): ΣV − [A(ω, ω̇) r + (Rᵀ − I) a_srp] / k − b' − α' t
//!   with ω̇ = ½(β1 ΔV1 + β2 ΔV2), ω = β1 Ψ1, k = G β (eq. 2), and the SRP turned by
//!   the exact rotation R̂ of the attitude propagated with the running β̂ (and pulled
//!   onto the star tracker after bridged ticks), linearised in β1 − β̂1:
//!   (Rᵀ − I) a_srp = −(β1 Φ1) × b + W b, W = R̂ᵀ − I + [Φ̂]×.
//!
//! Inputs are gated before they reach the statistics (`integrity`, docs/integrity.md):
//! tick order, flags, range, stuck channels, the two IS against each other, the
//! linear residuals of the current solution and the star tracker against the
//! propagated attitude; each rejection is counted by cause. Every solve judges each
//! group's χ²/dof and sets the status word.

use super::config::EstimatorConfig;
use super::integrity::{RatioFit, Stuck, Track};
// Unused where std is linked anywhere in the build (the std binaries, unit tests):
// std's inherent f64 methods then win for these exact operations, with the same bits.
#[allow(unused_imports)]
use crate::math::Real;
use crate::model::noise::{PowerLawBank, MAX_POLES};
use crate::msg::*;
use crate::tuning;
/// The solve's weak priors, named where the std layer reads them.
pub use crate::tuning::{PRIOR_BETA_REL, PRIOR_COM_M};
use nalgebra::{Matrix3, Quaternion, SMatrix, SVector, UnitQuaternion, Vector3};

mod bridge;
mod defer;
mod gates;
mod layout;
mod model;
mod outputs;
mod parts;
mod sample;
mod solve;
mod star;
mod whiten;

use defer::*;
pub use defer::{PEND, TARGETS};
use gates::*;
use layout::*;
pub use layout::{NP, NS, P_BETA, P_R};
use model::*;
pub use parts::{Extent, Part, Writer, N_PARTS};
pub use solve::SolveWork;
use solve::*;
use whiten::*;

/// The estimator's whole state: fixed-size, plain data (`Pod`: every field a number,
/// no padding), so a checkpoint is its bytes and any bytes that pass the checkpoint's
/// checks are a valid state.
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable, serde::Serialize, serde::Deserialize)]
#[repr(C)]
pub struct JointEstimator {
    cfg: EstimatorConfig,
    /// `START_NONE`, `START_ANGULAR` (the attitude integrals run, the linear
    /// references wait for a sample with every IS) or `START_FULL` (a word, not an
    /// enum: the state is plain data, so any checkpoint bytes are a valid state).
    started: u64,
    /// Next tick expected: every tick below it was processed or bridged.
    next_tick: u64,
    /// Ticks processed or bridged since the first usable sample (the solve schedule).
    n_ticks: u64,
    /// A tick too far ahead to bridge, seen last (a second one after it confirms a
    /// stream that starts late).
    /// (set, tick).
    jump_candidate: [u64; 2],
    sum_ref: [[f64; 3]; 2],
    /// The SRP the attitude turns, as IS1 measured it (inertial, the maneuver's A r̂
    /// out) at the first sample whose running solution could tell (`every_axis_rocked`,
    /// `srp_change_known`) [V, IS1's linear channels], and 1 once set: the turn's
    /// constant part for the samples from then on (on Φ1, with the parameter β1) and the
    /// origin of their measured change (`S_TF`, with the running β̂1); the samples before
    /// it turn the fitted DC (`S_PHI0`).
    srp_level: [f64; 3],
    /// `LEVEL_NONE`, `LEVEL_SET` or `LEVEL_AT_END` (the bound's statistics).
    srp_level_set: u64,
    /// One past the tick where real motion first dominated IS1's readout noise on
    /// every axis (`every_axis_rocked`), 0 before.
    rocked_tick: u64,
    q_ref: UnitQuaternion<f64>,
    q_ref_set: u64,
    psi: [[f64; 3]; 2],
    phi: [[f64; 3]; 2],
    dv_last: [[f64; 3]; 2],
    /// Attitude propagated with the running β̂1 and its first-order part ∫ β̂1 ⊙ Ψ1 dt
    /// [rad]: exact in the attitude however far it wanders, linear in β1 − β̂1.
    q_model: UnitQuaternion<f64>,
    phi_hat: [f64; 3],
    m_star: [SMatrix<f64, 5, 5>; 3],
    /// Innovations filter of the star-tracker residual, per axis: the IS angular noise
    /// double-integrated into Φ is an integrated random walk (angle, rate) [rad, rad/s];
    /// `st_x` is each signal's filter state, `st_p` the shared state covariance.
    st_x: [[[f64; 2]; 5]; 3],
    st_p: [[[f64; 2]; 2]; 3],
    m_ang: [SMatrix<f64, 2, 2>; 3],
    m_raw: [Packed; N_REG],
    m_filt: Packed,
    bank: PowerLawBank,
    /// The SRP filter's state covariance over the `n = bank.poles()` poles in use, n × n
    /// column by column in the first n² words (`(i, j)` at `j n + i`), and each
    /// signal's filter state, pole by pole in the first `n NS` words (pole k of signal
    /// m at `k NS + m`): what an update writes is one run of words (the seal's parts).
    #[serde(with = "array_serde")]
    wp: [f64; MAX_POLES * MAX_POLES],
    #[serde(with = "array_serde")]
    wx: [f64; MAX_POLES * NS],
    /// Gain of the SRP state onto the whitened common-mode channel.
    hn: f64,
    /// Row mapping the 6 linear residuals onto that channel: u0ᵀ L0⁻¹.
    t_u: SVector<f64, 6>,
    /// The turned SRP's attitude error on the two whitened rows across the SRP
    /// (`turn_rows`): IS1's readout noise and ripple integrated twice, with what bridged
    /// ticks add, an integrated random walk per axis (`turn_pq`) beside the rows' white
    /// noise. An innovations filter per row runs on every signal as the SRP's does
    /// (`m_turn` the filtered Grams, `tx` each signal's state (angles, rates: its columns),
    /// `tp` the state covariance [whitened units², per s, per s²]). The rows as the
    /// first sample set them (`turn_w`, channel space), their levers on ω̇'s noise
    /// (`turn_lever`, for their white variance at each sample's drive and its
    /// covariance with the attitude error's step) and on the attitude error per axis
    /// (`turn_z` [whitened units per rad]).
    m_turn: [Packed; 2],
    tx: [SMatrix<f64, NS, 2>; 2],
    tp: [[[f64; 2]; 2]; 2],
    turn_w: SMatrix<f64, 2, 6>,
    turn_lever: [[f64; 3]; 2],
    turn_z: [[f64; 3]; 2],
    /// Per axis, the attitude error's covariance (angle [rad²], angle × rate, rate
    /// [rad²/s²]) added since the turn filters last stepped: the readout noise of
    /// each tick, and what bridged ticks and a kept corrupted IS cost.
    turn_pq: [[f64; 3]; 3],
    p: Par,
    p_prior: Par,
    p_sigma: Par,
    sigma: Par,
    solved_tick: u64,
    /// A solve is due (`solve_every` ticks passed since the last one was due): (due, tick).
    solve_due: [u64; 2],
    n_used: u64,
    n_rejected: u64,
    seq: u64,
    /// Star-tracker samples used.
    n_star: u64,
    /// Integrity: rejections by cause, this tick's causes, status word, χ²/dof per
    /// group at the last solve, the weights that give inconsistent groups their
    /// observed noise, and the resulting σ inflation.
    causes: [u64; N_CAUSES],
    tick_mask: u64,
    status: u64,
    chi2: [f64; N_GROUPS],
    group_weight: [f64; N_GROUPS],
    inflation: f64,
    stuck: [Stuck; 2],
    /// Cross-IS angular test: fitted β2/β1 voltage ratio per axis.
    ratio: [RatioFit; 3],
    /// Per axis, the variance of ω̇'s departure from the straight line through its
    /// neighbours [rad²/s⁴] (learned on clean samples, edges clipped): the error a
    /// bridged tick leaves once the line is drawn across it (`interpolate_bridge`),
    /// the filters' process noise then (0 until learned). With the last clean
    /// sample-to-sample change it is learned from.
    jerk_var: [f64; 3],
    jerk_last: [f64; 3],
    /// Bit a: `jerk_last[a]` is the change into the previous sample, both clean.
    jerk_last_ok: u64,
    /// Consecutive ticks bridged without any angular data, and the last ω̇ voltages
    /// measured before them: when data return, a jump between the two (a torque edge
    /// inside the gap) leaves an unknown rate error that the star filter must allow.
    bridge_run: [u64; 3],
    /// Ticks on which some axis had no angular data at all.
    n_bridged: u64,
    dv_anchor: [[f64; 3]; 2],
    /// Per axis, IS1's angular voltage over every `MOMENT_EVERY`th sample the linear
    /// statistics took: Σv, Σv² [V, V²] (`motion_on_every_axis`).
    rate_moments: [[f64; 2]; 3],
    /// IS1's angular voltages' cross products on the same samples: Σ v_x v_y, Σ v_x v_z,
    /// Σ v_y v_z [V²] (`every_axis_rocked`).
    rate_cross: [f64; 3],
    /// Linear test: whitened residual rows (5 complement + common mode) of the
    /// current solution's coefficients, their tracks and the last accepted signals.
    gate_c: SMatrix<f64, 6, NS>,
    gate_w: SMatrix<f64, 6, 6>,
    /// Per row of `gate_w` (the last one `t_u`: the common-mode channel) and axis a,
    /// its lever on the noise of ω̇_a (the row on ω̇ × r / k at the priors)
    /// [V⁻¹ m s⁻² per rad s⁻²]: with the drive ripple, each row's white variance
    /// follows the sample's drive (`white_var_of_row`).
    gate_lever: [[f64; 3]; 6],
    gate_s: Sig,
    lin_track: [Track; 6],
    /// Lone-IS test: residual of each IS's linear channel (row 3 i + j of `gate_c`, in
    /// volts, not whitened) at the current solution, learned from accepted samples.
    lone_track: [Track; 6],
    /// Star-tracker test: attitude residual at the prior β, per axis [rad].
    star_track: [Track; 3],
    /// Gram updates waiting (`defer`): per matrix (`T_RAW`, `T_FILT`, `T_TURN` + row),
    /// the signals of up to `PEND` linear samples and how many, the raw Gram's regime
    /// of each, and the linear samples taken (whose turn it is to be brought up to
    /// date: `pend_turn` mod `TARGETS`).
    pend: [[Sig; PEND]; TARGETS],
    pend_n: [u64; TARGETS],
    pend_reg: [u64; PEND],
    pend_turn: u64,
}

/// Nothing taken yet.
const START_NONE: u64 = 0;
/// Every reference set (the value a started state always had: old checkpoints agree).
const START_FULL: u64 = 1;
/// The attitude integrals run from a first sample with angular data on every axis, but
/// no sample yet had every IS's linear data for the references. An IS missing at the
/// first tick would otherwise delay the integrals' start to a tick where the
/// spacecraft already turns: that initial rate θ̇₀ is a ramp in the propagated
/// attitude that, once the SRP's turn carries it from a bridged tick on, is a kink no
/// line takes.
const START_ANGULAR: u64 = 2;

/// The SRP's level is not fixed yet: the samples turn the fitted DC (`S_PHI0`).
const LEVEL_NONE: u64 = 0;
/// The level is fixed: the samples turn it, and its measured change (`S_TF`).
const LEVEL_SET: u64 = 1;
/// The level will be fixed after the last sample (`fix_srp_level_at`), and every
/// sample turns it: the bound's statistics, of the model most of a run's samples have.
const LEVEL_AT_END: u64 = 2;

/// How far motion of covariance `cov` [rad²/s⁴] dominates angular readout noise of
/// variance `noise_var` on every axis, in units of `ROCKED_VAR_RATIO`: 4 det / trace²
/// (a lower bound of the smallest eigenvalue, the other two being at most trace / 2
/// each) over `ROCKED_VAR_RATIO` × `noise_var`; above 1, every axis is rocked (NaN
/// without any motion or noise). The estimator asks it of its measured ω̇
/// (`motion_on_every_axis`), the maneuver planner of the thrusters' torque noise alone:
/// without it a sequential schedule leaves the SRP's level waiting for its last axis.
pub fn rocking(cov: &Matrix3<f64>, noise_var: f64) -> f64 {
    let tr = cov.trace();
    4.0 * cov.determinant() / (tuning::ROCKED_VAR_RATIO * noise_var * tr * tr)
}

/// Whether `finish`'s solve converged, from its last three steps (`solve`: their
/// largest moves in σ and the cosines between consecutive ones; `None` when a step
/// failed). Converged: the last step within `UNCONVERGED_STEP`, and where the steps
/// shrink by ρ in one direction, the distance still to go within it too; or where the
/// last two pairs of steps both turn back and shrink, the distance still to go within
/// it, however large the last step. The distance to go of steps that shrink by ρ and
/// turn by the angle between them: the last times ρ/√(1 − 2ρ cos + ρ²), ρ/(1 − ρ) in
/// one direction, ρ/(1 + ρ) turning back. Steps that turn back and shrink slowly, to a
/// point within `UNCONVERGED_STEP`, have converged.
fn finish_converged(moved: Option<[f64; 5]>) -> bool {
    let Some([last, before, cos, earlier, cos_before]) = moved else {
        return false;
    };
    if last < tuning::CONVERGED_STEP {
        return true;
    }
    let rho = last / before;
    let to_go = last * rho / (1.0 - 2.0 * rho * cos + rho * rho).sqrt();
    let turning_back = cos < -tuning::CLOSING_IN_COS && cos_before < -tuning::CLOSING_IN_COS;
    if turning_back && rho < 1.0 && before < earlier {
        return to_go <= tuning::UNCONVERGED_STEP;
    }
    if last.is_nan() || last > tuning::UNCONVERGED_STEP {
        return false;
    }
    let closing_in = rho < 1.0 && cos.abs() > tuning::CLOSING_IN_COS;
    !closing_in || to_go <= tuning::UNCONVERGED_STEP
}

impl JointEstimator {
    /// Byte offset of the message sequence number (`seq`, a `u64`) in the estimator:
    /// `estimate` counts its message there and updates the seal of that word's part
    /// alone (`capi::seal::reseal_word`).
    pub const SEQ_OFFSET: usize = {
        let at = core::mem::offset_of!(Self, seq);
        assert!(at % 8 == 0);
        at
    };

    pub fn new(cfg: EstimatorConfig) -> Self {
        let mut e = <Self as bytemuck::Zeroable>::zeroed();
        Self::init_in_place(&mut e, cfg);
        e
    }

    /// Builds the estimator in place (the C ABI's caller-owned memory): zeroed, then
    /// every field that does not start at zero set, so no 50 kB value is built on the
    /// stack of `taiji_estimator_init`. Whatever the memory held before, the same bytes
    /// result (a unit test).
    pub fn init_in_place(dst: &mut Self, cfg: EstimatorConfig) {
        bytemuck::bytes_of_mut(dst).fill(0);
        let mut p = Par::zeros();
        let mut ps = Par::zeros();
        for i in 0..2 {
            for a in 0..3 {
                p[P_BETA + 3 * i + a] = cfg.beta_prior[i][a];
                ps[P_BETA + 3 * i + a] = tuning::PRIOR_BETA_REL * cfg.beta_prior[i][a];
                p[P_R + 3 * i + a] = cfg.com_prior_m[i][a];
                ps[P_R + 3 * i + a] = tuning::PRIOR_COM_M;
                ps[P_B + 3 * i + a] = tuning::PRIOR_BIAS_V;
                ps[P_AL + 3 * i + a] = tuning::PRIOR_DRIFT_V_S;
            }
        }
        for a in 0..3 {
            ps[P_TH0 + a] = tuning::PRIOR_THETA0_RAD;
            ps[P_THD + a] = tuning::PRIOR_THETA_RATE_RAD_S;
        }
        dst.bank = PowerLawBank::new(
            cfg.srp_asd_at_3mhz,
            tuning::SRP_REF_HZ,
            tuning::SRP_PSD_EXPONENT,
            cfg.fs,
        );
        let nb = dst.bank.poles();
        for (k, &v) in dst.bank.var.iter().enumerate().take(nb) {
            if let Some(w) = dst.wp.get_mut(k * nb + k) {
                *w = v;
            }
        }
        dst.cfg = cfg;
        dst.q_ref = UnitQuaternion::identity();
        dst.q_model = UnitQuaternion::identity();
        dst.p = p;
        dst.p_prior = p;
        dst.p_sigma = ps;
        dst.sigma = ps;
        dst.status = ST_NO_SOLUTION;
        dst.group_weight = [1.0; N_GROUPS];
        dst.inflation = 1.0;
    }

    /// Could this state have come from `new` and `update`s? Its table passes its
    /// check and its counts index within their arrays (a restored checkpoint is
    /// refused otherwise: an index out of range would stop a flight host).
    pub fn is_sane(&self) -> bool {
        self.cfg.check().is_ok()
            && self.bank.n <= MAX_POLES as u64
            && self.started <= START_ANGULAR
            && self.q_ref_set <= 1
            && self.solve_due[0] <= 1 + tuning::FOLLOW_UPS
            && self.pend_reg.iter().all(|&r| r < N_REG as u64)
            && self.waiting_as_updates_leave_it()
    }

    /// Every tick below this one has been processed or bridged.
    pub fn next_tick(&self) -> u64 {
        self.next_tick
    }

    pub fn config(&self) -> &EstimatorConfig {
        &self.cfg
    }

    fn n_is(&self) -> usize {
        self.cfg.n_is.min(2) as usize
    }

    /// Weight of IS l in the two-IS average angular acceleration.
    fn w(&self, l: usize) -> f64 {
        if l < self.n_is() {
            1.0 / self.n_is() as f64
        } else {
            0.0
        }
    }

    fn k_of(&self, p: &Par, i: usize, j: usize) -> f64 {
        // Clamped indices (i < 2, j < 3 at every call): no index check is linked.
        let (i, a) = (i.min(1), PERM[j.min(2)].min(2));
        self.cfg.geometry_m[i][a] * p[P_BETA + 3 * i + a]
    }

    /// Process one sensor sample and, when one is due, solve; returns the estimate
    /// message for this tick (the last solution, refreshed every `solve_every` ticks).
    /// `update` then `solve_scheduled`, as a host calling them separately would.
    pub fn step(&mut self, s: &SensorSample) -> EstimateMsg {
        self.update(s);
        self.solve_scheduled();
        self.message(self.next_tick.saturating_sub(1))
    }

    /// Take one sensor sample into the statistics (no solve: bounded work, at most
    /// `BRIDGE_PER_UPDATE` missing ticks bridged before it). Any content,
    /// header or tick order is accepted without panic: what cannot be trusted is
    /// rejected and counted. Returns this call's rejection causes (bit `1 << CAUSE_*`);
    /// `solve_due` says whether a solve is due.
    pub fn update(&mut self, s: &SensorSample) -> u64 {
        let tick = s.header.tick;
        self.tick_mask = 0;
        if tick < self.next_tick {
            // A duplicate, or a tick that arrived after a later one (already bridged).
            self.reject(CAUSE_TICK_ORDER);
            return self.tick_mask;
        }
        let gap = tick - self.next_tick;
        if gap > self.cfg.max_gap_ticks || tick == u64::MAX {
            // Before anything is accumulated a stream may start late (a recording's
            // first tick), but only two consecutive ticks say so: one wild tick (a
            // garbage header) must not move the timeline.
            let confirmed = self.started == START_NONE
                && self.jump_candidate[0] == 1
                && self.jump_candidate[1] == tick.wrapping_sub(1);
            if !confirmed || tick == u64::MAX {
                // Off the timeline: counted by cause (the message's status says
                // degraded while such samples are more than one in `degraded_one_in`
                // of the ticks), not as a tick.
                self.jump_candidate = [1, tick];
                self.reject(CAUSE_TICK_JUMP);
                return self.tick_mask;
            }
            // The stream starts at the candidate's tick: that one was refused, so the
            // timeline's first tick counts as rejected.
            self.n_rejected += 1;
        } else {
            if gap as f64 > tuning::STAR_RELEARN_GAP_S * self.cfg.fs {
                // A long gap: the star test learns its offset anew rather than
                // rejecting every sample until it gives up.
                self.star_track = [Track::default(); 3];
            }
            let n = gap.min(tuning::BRIDGE_PER_UPDATE);
            for k in 0..n {
                self.bridge(self.next_tick + k);
            }
            if n < gap {
                // Catching up: the next updates bridge the rest of the gap, this
                // sample's tick among it (counted there as missing), so one call's
                // work stays bounded however long the gap.
                self.next_tick += n;
                self.jump_candidate = [0; 2];
                return self.tick_mask;
            }
        }
        self.jump_candidate = [0; 2];
        self.process(tick, s);
        self.next_tick = tick + 1;
        self.tick_mask
    }

    /// Has `solve_every` ticks' worth of data come in since the last due solve, or does
    /// an unconverged solve ask for another (`FOLLOW_UPS`)?
    pub fn solve_due(&self) -> bool {
        self.solve_due[0] != 0
    }

    /// The scheduled solve: one Gauss–Newton iteration (warm-started) if one is due.
    /// Returns whether it ran.
    pub fn solve_scheduled(&mut self) -> bool {
        if !self.solve_due() {
            return false;
        }
        self.solve_now();
        true
    }

    /// `solve_now` with its scratch on the stack (std hosts; a flight host passes its
    /// own to `solve_now_with`).
    pub fn solve_now(&mut self) -> bool {
        self.solve_now_with(&mut SolveWork::zeroed())
    }

    /// One Gauss–Newton iteration on everything taken so far, now (a host may solve at
    /// its own rate; `step` solves exactly when one is due). Returns whether the
    /// iteration succeeded (a failure keeps the previous solution and sets
    /// `ST_SOLVE_FAILED`).
    pub fn solve_now_with(&mut self, w: &mut SolveWork) -> bool {
        let tick = if self.solve_due() {
            self.solve_due[1]
        } else {
            self.next_tick.saturating_sub(1)
        };
        let round = self.solve_due[0];
        self.solve_due = [0; 2];
        if self.started != START_FULL {
            return false;
        }
        let first = self.status & ST_NO_SOLUTION != 0;
        let moved = self
            .solve(tuning::SCHEDULED_ITERATIONS, true, w)
            .map(|m| m[0]);
        self.solved_tick = tick;
        self.follow_up(round, first, moved);
        self.status & ST_SOLVE_FAILED == 0
    }

    /// The first iteration, from the priors, can leave the data looking inconsistent
    /// that the next one fits (a strong maneuver): then solve again from it after the
    /// next sample (one solve per update, at most `FOLLOW_UPS` times), and say
    /// meanwhile that it has not converged. Out of line: the solve's frames are the
    /// deepest stack.
    #[inline(never)]
    fn follow_up(&mut self, round: u64, first: bool, moved: Option<f64>) {
        let unconverged = moved.is_some_and(|m| m > 1.0) && self.status & ST_INCONSISTENT != 0;
        let chain = (round == 1 && first) || (2..=tuning::FOLLOW_UPS).contains(&round);
        if unconverged && chain {
            self.status |= ST_NOT_CONVERGED;
            self.solve_due = [round + 1, self.next_tick];
        } else {
            self.status &= !ST_NOT_CONVERGED;
        }
    }

    /// Final solution: iterate to convergence, with the weak priors (as in the run).
    pub fn finish(&mut self) -> EstimateMsg {
        self.finish_with(&mut SolveWork::zeroed())
    }

    /// `finish` with the caller's scratch (`SolveWork`).
    pub fn finish_with(&mut self, w: &mut SolveWork) -> EstimateMsg {
        if self.solve_due() {
            self.solve_now_with(w);
        }
        self.tick_mask = 0;
        let last = self.next_tick.saturating_sub(1);
        if self.started == START_FULL {
            if finish_converged(self.solve(tuning::FINISH_ITERATIONS, true, w)) {
                self.status &= !ST_NOT_CONVERGED;
            } else {
                self.status |= ST_NOT_CONVERGED;
            }
        }
        self.solved_tick = last;
        self.message(last)
    }
}

/// Serde for arrays longer than serde derives (32 elements): a tuple of the elements,
/// as a derive would write an array. For the whitening filter's per-signal pole states
/// (`NS` of them) and the packed Gram matrices (`layout::Packed`).
pub(super) mod array_serde {
    use serde::de::{Deserialize, Error, SeqAccess, Visitor};
    use serde::ser::{Serialize, SerializeTuple};
    use serde::{Deserializer, Serializer};

    pub fn serialize<S: Serializer, T: Serialize, const N: usize>(
        v: &[T; N],
        s: S,
    ) -> Result<S::Ok, S::Error> {
        let mut t = s.serialize_tuple(N)?;
        for x in v {
            t.serialize_element(x)?;
        }
        t.end()
    }

    pub fn deserialize<'de, D, T, const N: usize>(d: D) -> Result<[T; N], D::Error>
    where
        D: Deserializer<'de>,
        T: Deserialize<'de> + Copy + Default,
    {
        struct V<T, const N: usize>(core::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de> + Copy + Default, const N: usize> Visitor<'de> for V<T, N> {
            type Value = [T; N];
            fn expecting(&self, f: &mut core::fmt::Formatter) -> core::fmt::Result {
                write!(f, "an array of {N} elements")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut a: A) -> Result<[T; N], A::Error> {
                let mut out = [T::default(); N];
                for (i, x) in out.iter_mut().enumerate() {
                    *x = a
                        .next_element()?
                        .ok_or_else(|| Error::invalid_length(i, &self))?;
                }
                Ok(out)
            }
        }
        d.deserialize_tuple(N, V::<T, N>(core::marker::PhantomData))
    }
}

/// A table of the default Taiji case's magnitudes, for the unit tests of this folder.
#[cfg(test)]
pub(super) fn test_config() -> EstimatorConfig {
    EstimatorConfig {
        fs: 10.0,
        n_is: 2,
        geometry_m: [[0.02, 0.025, 0.03], [0.021, 0.024, 0.031]],
        beta_prior: [[2e-6, 2.1e-6, 1.9e-6], [2.05e-6, 1.95e-6, 2e-6]],
        com_prior_m: [[1e-4, -2e-4, 5e-5], [0.0, 1e-4, -1e-4]],
        sigma_star_rad: 3.2e-7,
        sigma_angular: 3e-10,
        sigma_linear: 1e-12,
        sigma_ripple: 1e-6,
        srp_asd_at_3mhz: 1.1e-11,
        sigma_force: 0.0,
        solve_every: 600,
        full_scale_linear: 1e-8,
        full_scale_angular: 1e-7,
        max_gap_ticks: 6000,
        gate_sigma: EstimatorConfig::GATE_SIGMA,
        star_gate_sigma: EstimatorConfig::STAR_GATE_SIGMA,
        chi2_tolerance: EstimatorConfig::CHI2_TOLERANCE,
        degraded_one_in: EstimatorConfig::DEGRADED_ONE_IN,
    }
}

/// Whether the AVX2 path can run here (`simd::has_avx2`: the CPU's, or under Miri the
/// build's target features). Where it cannot, a test of that path says so and returns,
/// and under `CI=true` fails instead (CI's x86-64 machines have AVX2).
#[cfg(test)]
pub(super) fn avx2_here() -> bool {
    if crate::simd::has_avx2() {
        return true;
    }
    let why = "no AVX2 here, so the AVX2 path cannot run";
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "{why} (CI=true)"
    );
    std::eprintln!("SKIPPED: {why}");
    false
}

/// Unit normal draws for the tests (xorshift64 uniforms, Box–Muller): no_std, no
/// crate, the same numbers on every host.
#[cfg(test)]
pub(super) fn gaussian(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        let mut u = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            ((seed >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (-2.0 * u().ln()).sqrt() * (core::f64::consts::TAU * u()).cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tuning::BRIDGE_PER_UPDATE;

    /// The samples waiting for the Gram matrices as updates leave them (the matrix due
    /// next at most `PEND`, each after it one fewer) are sane; more are refused, so an
    /// update writes only the Grams and slots `due_grams` and `next_slot` name.
    #[test]
    fn waiting_counts_no_update_leaves_are_refused() {
        let mut e = JointEstimator::new(test_config());
        assert!(e.is_sane());
        // Due next: matrix 1 (5 mod 4), then 2, 3, 0.
        e.pend_turn = 5;
        e.pend_n = [1, 4, 3, 2];
        assert!(e.is_sane());
        e.pend_n = [2, 4, 3, 2];
        assert!(!e.is_sane());
        e.pend_n = [1, 4, 4, 2];
        assert!(!e.is_sane());
        e.pend_n = [0, 0, 0, 0];
        e.pend_reg[2] = N_REG as u64;
        assert!(!e.is_sane());
    }

    #[test]
    fn init_in_place_gives_the_same_bytes_whatever_the_memory_held() {
        let cfg = test_config();
        let mut a = <JointEstimator as bytemuck::Zeroable>::zeroed();
        let mut b = a;
        bytemuck::bytes_of_mut(&mut b).fill(0xA5);
        JointEstimator::init_in_place(&mut a, cfg);
        JointEstimator::init_in_place(&mut b, cfg);
        assert_eq!(bytemuck::bytes_of(&a), bytemuck::bytes_of(&b));
        assert!(a.is_sane());
        assert_eq!(a.p[P_BETA], cfg.beta_prior[0][0]);
        assert_eq!(a.p_prior, a.p);
        assert_eq!(a.status, ST_NO_SOLUTION);
        assert_eq!(a.wp[0], a.bank.var[0]);
    }

    fn quiet(tick: u64) -> SensorSample {
        let mut s = SensorSample::default();
        s.header.tick = tick;
        s.star.valid = 1;
        s.star.q_bn = [1.0, 0.0, 0.0, 0.0];
        for i in 0..2 {
            s.is[i].volts = [[1e-3, -1e-3], [2e-3, -2e-3], [1.5e-3, -1.5e-3]];
        }
        s
    }

    /// An IS missing at the first tick does not delay the attitude integrals: the
    /// spacecraft turns from that tick on, and a later start would leave its rate out
    /// of them (θ̇₀, a ramp in the attitude that turns the SRP). The linear references wait for a
    /// sample with both IS; with neither, nothing starts.
    #[test]
    #[cfg_attr(
        miri,
        ignore = "60 updates; a start with an IS missing runs under Miri in tests/miri_capi.rs"
    )]
    fn an_is_missing_at_the_first_tick_does_not_delay_the_attitude_integrals() {
        let mut full = JointEstimator::new(alike());
        let mut lost = full;
        let mut none = full;
        let mut first = 0.0;
        for t in 0..20 {
            let s = moving(t);
            full.update(&s);
            let (mut one, mut both) = (s, s);
            if t == 0 {
                first = s.is[0].angular_volts()[0];
                one.is[1].flags = crate::msg::FLAG_DROPOUT;
                both.is[0].flags = crate::msg::FLAG_DROPOUT;
                both.is[1].flags = crate::msg::FLAG_DROPOUT;
            }
            lost.update(&one);
            none.update(&both);
            if t == 0 {
                assert_eq!(lost.started, START_ANGULAR);
                assert_eq!(none.started, START_NONE);
            }
        }
        assert_ne!(full.psi[0][0], 0.0);
        assert_eq!(lost.psi[0], full.psi[0]);
        assert_eq!(lost.started, START_FULL);
        // Started a tick late, the integral lacks that tick's ω̇ dt.
        let dt = 1.0 / full.cfg.fs;
        let lag = full.psi[0][0] - none.psi[0][0];
        assert!((lag - dt * first).abs() < 1e-12, "{lag} {first}");
        assert_eq!(lost.n_ticks, full.n_ticks);
    }

    /// `quiet` with voltages that move (a constant stream is refused as stuck), both IS
    /// alike (with both priors equal, they agree).
    fn moving(t: u64) -> SensorSample {
        let mut s = quiet(t);
        for (j, pair) in s.is[0].volts.iter_mut().enumerate() {
            pair[0] += 1e-5 * ((t * 7 + j as u64 * 3) % 11) as f64;
            pair[1] -= 1e-5 * ((t * 5 + j as u64) % 13) as f64;
        }
        s.is[1].volts = s.is[0].volts;
        s
    }

    fn alike() -> EstimatorConfig {
        let mut cfg = test_config();
        cfg.beta_prior[1] = cfg.beta_prior[0];
        cfg
    }

    /// One wild tick (a garbage header) is refused and counted by cause; the status
    /// says degraded only while such samples are more than one in `degraded_one_in`
    /// of the ticks, not for the rest of the campaign. A clock that jumped for good
    /// (every later tick off the timeline) soon outnumbers the ticks: degraded.
    #[test]
    #[cfg_attr(miri, ignore = "hundreds of updates")]
    fn one_wild_tick_is_outgrown_a_clock_that_jumped_for_good_is_degraded() {
        let cfg = alike();
        let one_in = cfg.degraded_one_in;
        let mut e = JointEstimator::new(cfg);
        for t in 0..20 {
            e.update(&moving(t));
        }
        let wild = e.update(&moving(1 << 40));
        assert_eq!(wild, 1 << CAUSE_TICK_JUMP);
        let mut jumped = e;
        for t in 20..one_in + 30 {
            e.update(&moving(t));
        }
        let m = e.message(one_in + 29);
        assert_eq!(m.rejected_by_cause[CAUSE_TICK_JUMP], 1);
        assert_eq!(m.n_used + m.n_rejected, one_in + 30);
        assert_eq!(m.status & ST_DEGRADED, 0, "one wild tick left degraded");
        for k in 1..=25 {
            jumped.update(&moving((1 << 40) + 2 * k));
        }
        assert_ne!(jumped.message(20).status & ST_DEGRADED, 0);
    }

    /// A stream whose first tick is beyond `max_gap_ticks` (a recording that starts
    /// late) starts there once a second tick confirms it: its first sample is refused,
    /// every sample is counted as used or rejected, and it is not degraded.
    #[test]
    #[cfg_attr(miri, ignore = "hundreds of updates")]
    fn a_stream_that_starts_late_accounts_for_every_sample_and_is_not_degraded() {
        let cfg = alike();
        let start = 10 * cfg.max_gap_ticks;
        let n = 3 * cfg.degraded_one_in;
        let mut e = JointEstimator::new(cfg);
        for t in start..start + n {
            e.update(&moving(t));
        }
        let m = e.message(start + n - 1);
        assert_eq!(m.n_used + m.n_rejected, n);
        assert_eq!(m.rejected_by_cause[CAUSE_TICK_JUMP], 1);
        assert_eq!(m.status & ST_DEGRADED, 0);
    }

    /// However long the gap (up to `max_gap_ticks`), one update bridges at most
    /// `BRIDGE_PER_UPDATE` ticks; the estimator catches up over the next samples and
    /// then takes samples again, with every tick of the timeline accounted for.
    #[test]
    #[cfg_attr(
        miri,
        ignore = "about 850 updates; a gap bridged over two updates runs under Miri in tests/miri_capi.rs"
    )]
    fn an_update_after_a_long_gap_bridges_a_bounded_number_of_ticks() {
        let mut e = JointEstimator::new(test_config());
        for t in 0..100 {
            e.update(&quiet(t));
        }
        let gap = 5999;
        let mut tick = 100 + gap;
        let mut calls = 0;
        loop {
            let (before, next) = (e.causes[CAUSE_TICK_MISSING], e.next_tick());
            let mask = e.update(&quiet(tick));
            let bridged = e.causes[CAUSE_TICK_MISSING] - before;
            assert!(
                bridged <= BRIDGE_PER_UPDATE,
                "call {calls}: {bridged} ticks bridged"
            );
            calls += 1;
            if e.next_tick() == tick + 1 {
                // Caught up: this sample was taken.
                assert_eq!(bridged, tick - next);
                break;
            }
            assert_ne!(mask & (1 << CAUSE_TICK_MISSING), 0);
            assert_eq!(e.next_tick(), next + BRIDGE_PER_UPDATE);
            tick += 1;
            assert!(calls < 2000, "never caught up");
        }
        // B − 1 ticks gained a call.
        assert_eq!(
            calls,
            (gap as usize).div_ceil(BRIDGE_PER_UPDATE as usize - 1)
        );
        // Every tick from 0 on is either used or counted as rejected.
        assert_eq!(e.n_used + e.n_rejected, tick + 1);
    }

    /// A gap up to the bound, 8 ticks, is bridged in the update that sees it; one tick
    /// more takes a second update.
    #[test]
    fn a_short_gap_is_bridged_at_once() {
        let mut e = JointEstimator::new(test_config());
        for t in 0..10 {
            e.update(&quiet(t));
        }
        let mut longer = e;
        e.update(&quiet(10 + 8));
        assert_eq!(e.next_tick(), 11 + 8);
        assert_eq!(e.causes[CAUSE_TICK_MISSING], 8);
        longer.update(&quiet(10 + 9));
        assert_eq!(
            longer.next_tick(),
            10 + 8,
            "the sample waits for the catch-up"
        );
    }

    /// The bridge's process noise is what the line through a gap's neighbours misses:
    /// for white ω̇ of variance σ², 1.5 σ², whatever the maneuver's edges.
    #[test]
    #[cfg_attr(
        miri,
        ignore = "2 x 10^5 steps; learn_jerk runs under Miri in a_torque_edge_moves_the_jerk_spread_by_its_clip"
    )]
    fn the_bridge_noise_is_what_the_line_misses_edges_apart() {
        let mut e = JointEstimator::new(test_config());
        let sigma = 1e-10; // rad/s²
        let mut gauss = gaussian(0x2545_f491_4f6c_dd1d);
        let mut last = [[0.0; 3]; 2];
        for k in 0..200_000u32 {
            // A square wave of 10⁴ σ with an edge every 1000 samples.
            let g = gauss();
            let level = if (k / 1000) % 2 == 0 { 1e4 } else { -1e4 };
            let x = sigma * (g + level);
            let mut dv = [[0.0; 3]; 2];
            for (l, row) in dv.iter_mut().enumerate() {
                row[0] = x / e.cfg.beta_prior[l][0];
            }
            if k > 0 {
                e.learn_jerk(0, &dv, &last);
            }
            last = dv;
        }
        let ratio = e.jerk_var[0] / (1.5 * sigma * sigma);
        assert!((ratio - 1.0).abs() < 0.15, "{ratio}");
    }

    /// Φ's interval mean is the mean of the parabola the held torque draws within each
    /// tick (θ_k + ω_k dt/2 + ω̇ dt²/6), not the midpoint of its ends: the attitude the
    /// IS's SRP is turned by.
    #[test]
    fn the_angle_interval_mean_is_the_mean_over_the_tick() {
        let mut e = JointEstimator::new(test_config());
        let dt = 1.0 / e.cfg.fs;
        let mut gauss = gaussian(0x5851_f42d_4c95_7f2d);
        let (mut omega, mut theta) = (0.0, 0.0);
        for _ in 0..1000 {
            let c = 1e-3 * gauss(); // V: the IS's mean over the tick, held
            let exact = theta + omega * dt / 2.0 + c * dt * dt / 6.0;
            let (psi_mid, phi_mid) = e.integrate(&[[c, 0.0, 0.0]; 2]);
            theta += omega * dt + 0.5 * c * dt * dt;
            omega += c * dt;
            for l in 0..2 {
                assert!((phi_mid[l][0] - exact).abs() <= 1e-12 * theta.abs().max(1e-9));
                assert!(
                    (psi_mid[l][0] - (omega - 0.5 * c * dt)).abs() <= 1e-12 * omega.abs().max(1e-9)
                );
                assert!((e.phi[l][0] - theta).abs() <= 1e-12 * theta.abs().max(1e-9));
            }
        }
    }

    /// The angle's walk within a tick is what the IS's mean misses: ω̇ white over the
    /// plant's ten sub-steps a tick, the angle at the tick's end off by
    /// ∫(dt − s)(ω̇ − ω̄) ds, its variance var_tick dt⁴ (1 − 1/M²)/12; and the star
    /// group's filter takes it, as the turn rows' do.
    #[test]
    #[cfg_attr(
        miri,
        ignore = "10^5 steps; learn_jerk and the star filter's step run under Miri in a_torque_edge_moves_the_jerk_spread_by_its_clip and tests/miri_capi.rs"
    )]
    fn the_walk_within_a_tick_is_what_the_mean_misses() {
        let mut e = JointEstimator::new(test_config());
        let dt = 1.0 / e.cfg.fs;
        const M: usize = 10;
        let h = dt / M as f64;
        let sigma_sub = 1e-9; // rad/s² per sub-step
        let mut gauss = gaussian(0x9e37_79b9_7f4a_7c15);
        let (mut last, mut sum_e2, n) = ([[0.0; 3]; 2], 0.0, 100_000u32);
        for k in 0..n {
            let x: [f64; M] = core::array::from_fn(|_| sigma_sub * gauss());
            let mean = x.iter().sum::<f64>() / M as f64;
            // ∫ over sub-step j of (dt − s) ds = h (dt − j h) − h²/2.
            let err: f64 = (0..M)
                .map(|j| (x[j] - mean) * (h * (dt - j as f64 * h) - 0.5 * h * h))
                .sum();
            sum_e2 += err * err;
            let mut dv = [[0.0; 3]; 2];
            for (l, row) in dv.iter_mut().enumerate() {
                row[0] = mean / e.cfg.beta_prior[l][0];
            }
            if k > 0 {
                e.learn_jerk(0, &dv, &last);
            }
            last = dv;
        }
        let measured = sum_e2 / n as f64;
        let var_tick = sigma_sub * sigma_sub / M as f64;
        let exact = var_tick * dt.powi(4) * (1.0 - 1.0 / (M * M) as f64) / 12.0;
        assert!((measured / exact - 1.0).abs() < 0.03, "{measured} {exact}");
        let walk = e.intra_tick_walk(0);
        assert!((walk / measured - 1.0).abs() < 0.1, "{walk} {measured}");
        // The star filter's angle variance grows by it (the rest of its step held).
        let mut quiet = e;
        quiet.jerk_var = [0.0; 3];
        let (dv, n_valid) = ([[0.0; 3]; 2], [2; 3]);
        e.star_time_update(&dv, &n_valid);
        quiet.star_time_update(&dv, &n_valid);
        let grew = e.st_p[0][0][0] - quiet.st_p[0][0][0];
        assert!((grew / walk - 1.0).abs() < 1e-9, "{grew} {walk}");
    }

    /// The final solve iterates to `CONVERGED_STEP` but is called unconverged only when
    /// it may still be more than `UNCONVERGED_STEP` of σ from its point
    /// (`finish_converged`): a floor of floating-point noise a thousandth of σ is no
    /// failure.
    #[test]
    fn a_final_solve_at_the_floating_point_floor_has_converged() {
        // The last two steps only (no step before them, or one of no pattern).
        let two = |last: f64, before: f64, cos: f64| Some([last, before, cos, f64::INFINITY, 0.0]);
        // Converged to 10⁻⁴ σ, whatever came before.
        assert!(finish_converged(two(0.0, f64::INFINITY, 0.0)));
        assert!(finish_converged(two(5e-5, 1e-2, 1.0)));
        // Steps that barely shrink in one direction: 0.9×10⁻⁴ σ is converged, 1.5×10⁻⁴ σ
        // has far to go.
        assert!(finish_converged(two(0.9e-4, 0.9e-4 / 0.9999, 1.0)));
        assert!(!finish_converged(two(1.5e-4, 1.5e-4 / 0.9999, 1.0)));
        // Wandering on a floor of a thousandth of σ: turning back, or not shrinking;
        // sizes repeating turn back and forth without shrinking.
        assert!(finish_converged(two(2.13e-3, 2.14e-3, -1.0)));
        assert!(finish_converged(two(3e-3, 2e-3, 0.9)));
        assert!(finish_converged(two(1.4e-3, 1.45e-3, 0.2)));
        assert!(finish_converged(Some([
            1.6e-3, 3.2e-3, -0.95, 1.6e-3, -0.9
        ])));
        // Closing in, fast enough that what is left is within 1 % of σ ...
        assert!(finish_converged(two(3e-3, 3e-2, 0.99)));
        // ... or too slowly: 9×10⁻³ σ a step shrinking by 0.9 leaves ~0.05 σ to go.
        assert!(!finish_converged(two(9e-3, 1e-2, 0.99)));
        assert!(!finish_converged(two(5e-3, 5.05e-3, 0.9)));
        // Turning back step after step and shrinking, to where the steps meet:
        // 1.18×10⁻² σ after 1.40 leaves 5.4×10⁻³ σ to go; 2.1×10⁻² after 2.46,
        // 9.7×10⁻³ (seed 27 without thruster noise, the sun along z); 3.0×10⁻² after
        // 3.2, 1.45×10⁻².
        assert!(finish_converged(Some([
            1.18e-2, 1.40e-2, -1.0, 1.66e-2, -1.0
        ])));
        assert!(finish_converged(Some([
            2.1e-2, 2.46e-2, -1.0, 2.88e-2, -1.0
        ])));
        assert!(!finish_converged(Some([
            3.0e-2, 3.2e-2, -1.0, 3.4e-2, -1.0
        ])));
        // Turning less than back: at a cosine of −0.6 the steps meet farther off,
        // 1.2×10⁻² × 0.84 / √(1 + 1.2 × 0.84 + 0.84²) ≈ 6.1×10⁻³ σ.
        assert!(finish_converged(Some([
            1.2e-2, 1.43e-2, -0.6, 1.7e-2, -0.6
        ])));
        assert!(!finish_converged(Some([
            1.9e-2, 2.0e-2, -0.6, 2.1e-2, -0.6
        ])));
        // One pair turning back is no pattern yet: a last step over 1 % is not judged
        // by it, nor one after steps that grew.
        assert!(!finish_converged(two(1.18e-2, 1.40e-2, -1.0)));
        assert!(!finish_converged(Some([
            1.18e-2, 1.40e-2, -1.0, 1.2e-2, -1.0
        ])));
        assert!(!finish_converged(Some([
            1.18e-2, 1.40e-2, -1.0, 1.66e-2, 0.3
        ])));
        // Too large a last step, or none; a large step shrinking fast in one direction
        // says nothing yet of where the steps end.
        assert!(!finish_converged(two(0.05, 0.04, -1.0)));
        assert!(!finish_converged(two(0.05, 0.06, 0.2)));
        assert!(!finish_converged(two(0.05, 1.0, 0.9)));
        assert!(!finish_converged(Some([0.05, 1.0, 0.9, 20.0, 0.9])));
        assert!(!finish_converged(two(0.5, 100.0, -0.9)));
        assert!(!finish_converged(two(f64::INFINITY, f64::INFINITY, 0.0)));
        assert!(!finish_converged(two(f64::NAN, 1.0, 0.0)));
        assert!(!finish_converged(None));
    }

    /// The SRP's level waits for motion of its own on every axis: one axis rocked, and
    /// what the inertia's cross terms couple from it into the others (the same
    /// direction), with readout noise around it, is not that; three independent motions
    /// are. And then a solve must run before the level is measured.
    #[test]
    #[cfg_attr(
        miri,
        ignore = "4 x 10^4 steps; note_excitation runs under Miri in the_excitation_takes_every_eighth_sample"
    )]
    fn the_level_waits_for_independent_motion_on_every_axis() {
        let mut e = JointEstimator::new(test_config());
        let noise = e.cfg.sigma_angular;
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut uniform = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            ((seed >> 11) as f64 + 0.5) / (1u64 << 53) as f64 - 0.5
        };
        let square = |k: u64, period: u64| if (k / period) % 2 == 0 { 1.0 } else { -1.0 };
        let mut feed = |e: &mut JointEstimator, k: u64, independent: bool| {
            // x rocked at 10⁴ × the noise, y and z 1 % and 2 % of it (coupled), or
            // rocked on their own.
            let x = 1e4 * noise * square(k, 600);
            let (y, z) = match independent {
                false => (0.01 * x, 0.02 * x),
                true => (1e3 * noise * square(k, 900), 1e3 * noise * square(k, 1300)),
            };
            let w = [x, y, z];
            let mut dv = [[0.0; 3]; 2];
            for a in 0..3 {
                dv[0][a] = (w[a] + noise * uniform()) / e.cfg.beta_prior[0][a];
            }
            e.n_used = k;
            e.note_excitation(&dv);
        };
        for k in 1..=20_000 {
            feed(&mut e, k, false);
            assert!(!e.every_axis_rocked());
        }
        assert_eq!(e.rocked_tick, 0, "coupled motion counted as rocking");
        for k in 20_001..=40_000 {
            feed(&mut e, k, true);
            assert!(!e.every_axis_rocked(), "no solve has run yet");
        }
        assert_ne!(e.rocked_tick, 0, "independent motion not counted");
        e.status &= !ST_NO_SOLUTION;
        e.solved_tick = e.rocked_tick - 1;
        assert!(!e.every_axis_rocked(), "the solve ran before the motion");
        e.solved_tick = e.rocked_tick;
        assert!(e.every_axis_rocked());
    }

    /// Once the SRP's level is fixed, a sample taken before it still turns the fitted
    /// DC (its Φ1 on `S_PHI` and `S_PHI0`), one taken after it the level (`S_PHI`
    /// alone): a level off by the running solution's error reaches only the samples
    /// whose measured change cancels it.
    #[test]
    fn the_samples_before_the_level_turn_the_fitted_dc() {
        let mut e = JointEstimator::new(test_config());
        e.sum_ref = [[3e-3, -1e-3, 2e-3], [2.9e-3, -1.1e-3, 2.1e-3]];
        let p = e.p;
        let before = e.coeffs(&p).lin;
        e.srp_level = [3.1e-3, -0.8e-3, 2.3e-3];
        e.srp_level_set = LEVEL_SET;
        let after = e.coeffs(&p).lin;
        for row in 0..6 {
            for a in 0..3 {
                assert_eq!(before[(row, S_PHI0 + a)], 0.0);
                let pre = after[(row, S_PHI + a)] + after[(row, S_PHI0 + a)];
                let dc = before[(row, S_PHI + a)];
                assert!(
                    (pre - dc).abs() <= 1e-12 * dc.abs(),
                    "row {row} axis {a}: {pre} {dc}"
                );
            }
        }
        assert_ne!(after.column(S_PHI), before.column(S_PHI));
    }

    /// Before any data, σ is the priors': 5 % of β, 5 cm of r, 10⁻² rad of θ0,
    /// 10⁻⁴ rad/s of θ̇0, 1 V of b′ and 10⁻³ V/s of α′.
    #[test]
    fn before_any_data_sigma_is_the_prior() {
        let cfg = test_config();
        let e = JointEstimator::new(cfg);
        for i in 0..2 {
            for a in 0..3 {
                assert_eq!(e.sigma[P_BETA + 3 * i + a], 0.05 * cfg.beta_prior[i][a]);
                assert_eq!(e.sigma[P_R + 3 * i + a], 0.05);
                assert_eq!(e.sigma[P_B + 3 * i + a], 1.0);
                assert_eq!(e.sigma[P_AL + 3 * i + a], 1e-3);
            }
        }
        for a in 0..3 {
            assert_eq!(e.sigma[P_TH0 + a], 1e-2);
            assert_eq!(e.sigma[P_THD + a], 1e-4);
        }
        assert_eq!(e.p_sigma, e.sigma);
    }

    /// A star-tracker sample of `angle` [rad] about `axis`, its quaternion scaled by
    /// `scale` (1: unit).
    fn star(tick: u64, axis: usize, angle: f64, scale: f64) -> SensorSample {
        let mut s = SensorSample::default();
        s.header.tick = tick;
        s.star.valid = 1;
        let q = UnitQuaternion::from_scaled_axis(Vector3::ith(axis, angle));
        s.star.q_bn = [q.w, q.i, q.j, q.k].map(|x| x * scale);
        s
    }

    /// The star test: a quaternion whose norm is off 1 by 8×10⁻⁷ is taken, by 1.5×10⁻⁶
    /// refused as invalid; a residual within 5σ of its track passes, beyond it is an
    /// outlier; an accepted residual moves the track's spread at the rate 1/16.
    #[test]
    fn the_star_gate_is_five_sigma() {
        let cfg = test_config();
        let sigma = cfg.sigma_star_rad;
        let kappa = Vector3::zeros();
        let mut e = JointEstimator::new(cfg);
        e.update_star(&star(0, 0, 0.0, 1.0), &kappa, 0.0);
        // About x, ±3σ in turn: that track's spread is 9σ², above the floor σ².
        for k in 1..200u64 {
            let x = if k % 2 == 0 { 3.0 } else { -3.0 } * sigma;
            e.update_star(&star(k, 0, x, 1.0), &kappa, 0.0);
        }
        assert_eq!(e.causes[CAUSE_STAR_OUTLIER], 0);
        assert_eq!(e.causes[CAUSE_STAR_INVALID], 0);
        let taken = |e: &JointEstimator, s: SensorSample| {
            let mut e = *e;
            let n = e.n_star;
            e.update_star(&s, &kappa, 0.0);
            (e.n_star == n + 1, e)
        };
        // The norm.
        assert!(taken(&e, star(200, 0, 0.0, 1.0 + 8e-7)).0);
        let (ok, f) = taken(&e, star(200, 0, 0.0, 1.0 + 1.5e-6));
        assert!(!ok && f.causes[CAUSE_STAR_INVALID] == 1);
        // The gate, about y (level 0, spread at its floor σ²).
        assert!(taken(&e, star(200, 1, 4.9 * sigma, 1.0)).0);
        let (ok, f) = taken(&e, star(200, 1, 5.1 * sigma, 1.0));
        assert!(!ok && f.causes[CAUSE_STAR_OUTLIER] == 1);
        // The forgetting rate: var ← (1 − α)(var + α d²), d from the level (near 0).
        let v0 = e.star_track[0].var();
        let (ok, f) = taken(&e, star(200, 0, 12.0 * sigma, 1.0));
        assert!(ok);
        let alpha = 1.0 / 16.0;
        let want = (1.0 - alpha) * (v0 + alpha * (12.0 * sigma).powi(2));
        assert!(
            (f.star_track[0].var() / want - 1.0).abs() < 0.03,
            "{} {want}",
            f.star_track[0].var()
        );
    }

    /// χ²/dof is judged from 2000 degrees of freedom on, against 1 + max(0.25,
    /// 10 √(2/dof)): at 2100 dof the limit is 1.309, at 3×10⁶ it is 1.25.
    #[test]
    fn chi2_is_judged_from_2000_dof_within_its_spread() {
        let judged = |n_star: u64, chi2: f64| {
            let mut e = JointEstimator::new(test_config());
            e.n_star = n_star;
            let mut cost = [0.0; N_GROUPS];
            cost[GROUP_STAR] = chi2 * 3.0 * n_star as f64;
            e.judge_consistency(&cost);
            e.status & ST_INCONSISTENT != 0
        };
        assert!(!judged(666, 5.0), "1998 dof are not judged");
        assert!(judged(667, 5.0), "2001 dof are");
        assert!(!judged(700, 1.30));
        assert!(judged(700, 1.32));
        assert!(!judged(1_000_000, 1.24));
        assert!(judged(1_000_000, 1.26));
    }

    /// Degraded when more than one tick in 50 was rejected.
    #[test]
    fn more_than_one_sample_in_50_rejected_is_degraded() {
        let mut e = JointEstimator::new(test_config());
        (e.n_used, e.n_rejected) = (98, 2);
        assert_eq!(e.message(99).status & ST_DEGRADED, 0);
        (e.n_used, e.n_rejected) = (97, 3);
        assert_ne!(e.message(99).status & ST_DEGRADED, 0);
    }

    /// An unconverged first solve is followed up once per update, three times at most.
    #[test]
    fn an_unconverged_first_solve_is_followed_up_three_times() {
        let mut e = JointEstimator::new(test_config());
        e.status |= ST_INCONSISTENT;
        e.follow_up(1, true, Some(2.0));
        assert_eq!(e.solve_due[0], 2);
        assert_ne!(e.status & ST_NOT_CONVERGED, 0);
        e.follow_up(3, false, Some(2.0));
        assert_eq!(e.solve_due[0], 4);
        e.solve_due = [0; 2];
        e.follow_up(4, false, Some(2.0));
        assert_eq!(e.solve_due[0], 0, "a fourth follow-up");
        assert_eq!(e.status & ST_NOT_CONVERGED, 0);
    }

    /// A gap of more than a second (10 ticks at 10 Hz) makes the star test learn its
    /// offset anew; a gap of a second keeps it.
    #[test]
    fn a_gap_over_a_second_relearns_the_star_offset() {
        let mut e = JointEstimator::new(test_config());
        for t in 0..10 {
            let mut s = quiet(t);
            s.star.valid = 0;
            e.update(&s);
        }
        e.star_track[0].learn(1.0, 0.5);
        let learned = e.star_track;
        let (mut kept, mut lost) = (e, e);
        let mut s = quiet(10 + 10);
        s.star.valid = 0;
        kept.update(&s);
        assert_eq!(kept.star_track, learned);
        s.header.tick = 10 + 11;
        lost.update(&s);
        assert_eq!(lost.star_track, [Track::default(); 3]);
    }

    /// A bridge closed on a jump of ω̇ adds its step's variance v = (span jump)²/12
    /// 4/3 times to the star filter and 4 times to the turn rows; a bridged tick adds
    /// dt² times ω̇'s spread 4 times to the turn rows.
    #[test]
    fn a_closed_bridge_splits_its_step_four_thirds_and_four() {
        let mut e = JointEstimator::new(test_config());
        let (a, n) = (1, 5);
        e.bridge_run[a] = n;
        let mut dv = [[0.0; 3]; 2];
        dv[0][a] = 1e-3;
        dv[1][a] = 1e-3;
        let mut before = e;
        e.close_bridge(a, &dv);
        let span = n as f64 / e.cfg.fs;
        let jump: f64 = (0..2).map(|l| 0.5 * e.cfg.beta_prior[l][a] * 1e-3).sum();
        let v = (span * jump).powi(2) / 12.0;
        let star = e.st_p[a][1][1] - before.st_p[a][1][1];
        let turn = e.turn_pq[a][2] - before.turn_pq[a][2];
        assert!((star / (4.0 / 3.0 * v) - 1.0).abs() < 1e-12, "{star} {v}");
        assert!((turn / (4.0 * v) - 1.0).abs() < 1e-12, "{turn} {v}");
        before.jerk_var[a] = 2e-20;
        let q0 = before.turn_pq[a][2];
        before.turn_bridged(a);
        let dt = 1.0 / before.cfg.fs;
        let want = 4.0 * dt * dt * 2e-20;
        assert!(((before.turn_pq[a][2] - q0) / want - 1.0).abs() < 1e-12);
    }

    /// A torque edge (a change far beyond the spread) moves ω̇'s learned spread by the
    /// rate 1/256 towards its clip, 16 times the spread: by 15/256 of it.
    #[test]
    fn a_torque_edge_moves_the_jerk_spread_by_its_clip() {
        let mut e = JointEstimator::new(test_config());
        let a = 0;
        e.jerk_var[a] = 1e-20;
        e.jerk_last[a] = 0.0;
        e.jerk_last_ok = 1 << a;
        let mut dv = [[0.0; 3]; 2];
        dv[0][a] = 1.0;
        dv[1][a] = 1.0;
        e.learn_jerk(a, &dv, &[[0.0; 3]; 2]);
        let grew = e.jerk_var[a] / 1e-20;
        assert!((grew - (1.0 + 15.0 / 256.0)).abs() < 1e-12, "{grew}");
    }

    /// Every axis is rocked once ω̇'s variance is 10⁴ times the readout noise's: for
    /// isotropic motion of variance v, `rocking` is 4 v / (9 × 10⁴ × noise).
    #[test]
    fn rocking_is_motion_over_ten_thousand_times_the_noise() {
        let noise = 1e-20;
        let v = 9.0 / 4.0 * 1e4 * noise;
        assert!(rocking(&(Matrix3::identity() * (1.01 * v)), noise) > 1.0);
        assert!(rocking(&(Matrix3::identity() * (0.99 * v)), noise) < 1.0);
    }

    /// The excitation's moments take the linear samples 1, 9, 17, …: every eighth.
    #[test]
    fn the_excitation_takes_every_eighth_sample() {
        let mut e = JointEstimator::new(test_config());
        let dv = [[1.0, 0.0, 0.0]; 2];
        for k in 1..=16 {
            e.n_used = k;
            e.note_excitation(&dv);
        }
        assert_eq!(e.rate_moments[0][0], 2.0);
    }

    /// The SRP model the estimator whitens with: its PSD at 3 mHz is the table's ASD
    /// squared, and it falls as f^-2/3 (a factor 100^(2/3) ≈ 21.5 over two decades).
    #[test]
    fn the_srp_model_is_f_to_the_minus_two_thirds_from_3_mhz() {
        let cfg = test_config();
        let e = JointEstimator::new(cfg);
        let at = e.bank.psd(3e-3) / cfg.srp_asd_at_3mhz.powi(2);
        assert!((at - 1.0).abs() < 0.15, "{at}");
        let slope = e.bank.psd(3e-4) / e.bank.psd(3e-2);
        assert!(
            (slope / 100f64.powf(2.0 / 3.0) - 1.0).abs() < 0.15,
            "{slope}"
        );
    }

    /// An estimator fed 3000 samples of voltages no model fits (its Gauss–Newton steps
    /// never settle), every scheduled solve and follow-up done.
    fn unsettled() -> JointEstimator {
        let mut e = JointEstimator::new(test_config());
        let mut gauss = gaussian(0x9e37_79b9_7f4a_7c15);
        for t in 0..3000u64 {
            let mut s = quiet(t);
            let x = 1e-3 * (t as f64 * 0.01).sin();
            let q = UnitQuaternion::from_scaled_axis(Vector3::new(x * 1e-3, 2e-6, -1e-6));
            s.star.q_bn = [q.w, q.i, q.j, q.k];
            for i in 0..2 {
                for p in 0..3 {
                    let v = 1e-3 * (p as f64 + 1.0) + x + 1e-6 * gauss();
                    s.is[i].volts[p] = [v + 1e-4 * gauss(), -v + 1e-4 * gauss()];
                }
            }
            e.update(&s);
        }
        // The scheduled solves and their follow-ups, done: `finish` then only iterates.
        while e.solve_due() {
            e.solve_now();
        }
        e
    }

    /// `finish` iterates up to 20 times: on data whose Gauss–Newton steps never settle
    /// below `CONVERGED_STEP` (voltages no model fits), its solution is that of 20
    /// iterations, not of fewer or more.
    #[test]
    #[cfg_attr(
        miri,
        ignore = "3000 updates and 60 Gauss-Newton iterations; the solve runs under Miri in tests/miri_capi.rs"
    )]
    fn finish_iterates_twenty_times_at_most() {
        let e = unsettled();
        let mut w = SolveWork::zeroed();
        let mut iterate = |n: usize| {
            let mut f = e;
            let moved = f.solve(n, true, &mut w).expect("a step")[0];
            (f.p, moved)
        };
        let (p19, moved) = iterate(19);
        assert!(moved > 1e-4, "converged after 19: {moved}");
        let (p20, _) = iterate(20);
        let (p21, _) = iterate(21);
        let mut finished = e;
        finished.finish();
        assert_eq!(finished.p, p20);
        assert_ne!(p20, p19);
        assert_ne!(p20, p21);
    }

    /// The bound's nuisance fit is six Gauss–Newton steps of the nuisances (β and r
    /// held): on data its steps never settle on, not five, not seven.
    #[test]
    #[cfg_attr(
        miri,
        ignore = "3000 updates and 14 Gauss-Newton steps; the normal equations and the step run under Miri in tests/miri_capi.rs"
    )]
    fn the_nuisance_fit_takes_six_steps() {
        let mut e = unsettled();
        let p = e.params_with(&e.cfg.beta_prior, &e.cfg.com_prior_m);
        let fitted = e.nuisance_fit(p);
        let e = e;
        let mut w = SolveWork::zeroed();
        // One step, as `nuisance_fit` takes it.
        let mut step = |mut p: Par| {
            e.normal_equations(&p, false, &mut w);
            let SolveWork { n, hs, hinv, .. } = &mut w;
            for k in P_BETA..P_TH0 {
                for j in 0..NP {
                    n.hm[(k, j)] = 0.0;
                    n.hm[(j, k)] = 0.0;
                }
                n.hm[(k, k)] = 1.0;
                n.g[k] = 0.0;
            }
            p += JointEstimator::newton_step(&n.hm, &n.g, hs, hinv).expect("a step");
            p
        };
        let mut p = p;
        let mut steps = [p; 8];
        for s in steps.iter_mut() {
            *s = p;
            p = step(p);
        }
        assert_eq!(fitted, steps[6]);
        assert_ne!(fitted, steps[5]);
        assert_ne!(fitted, steps[7]);
    }
}
