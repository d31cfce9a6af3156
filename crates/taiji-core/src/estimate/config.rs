//! What the estimators may know: priors, known geometry and the noise specifications —
//! never the truths. Built from a scenario by copying only those fields.

/// The estimator's table: plain numbers, `#[repr(C)]`, like a cFS table — the C ABI
/// takes it as it is. Built by `Scenario::estimator_config` (std) or by the host.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    bytemuck::Pod,
    bytemuck::Zeroable,
    serde::Serialize,
    serde::Deserialize,
)]
#[repr(C)]
pub struct EstimatorConfig {
    /// Sample rate [Hz].
    pub fs: f64,
    /// Number of inertial sensors (1 or 2).
    pub n_is: u64,
    /// Known geometry ratios (Gx, Gy, Gz) of eq. 2 per IS [m].
    pub geometry_m: [[f64; 3]; 2],
    /// Ground-calibration priors per IS.
    pub beta_prior: [[f64; 3]; 2],
    pub com_prior_m: [[f64; 3]; 2],
    /// Star-tracker noise per axis per sample, 1σ [rad].
    pub sigma_star_rad: f64,
    /// Per-sample 1σ of the IS readout noise: angular [rad/s²], linear [m/s²].
    pub sigma_angular: f64,
    pub sigma_linear: f64,
    /// Per-sample 1σ of the relative drive ripple [-].
    pub sigma_ripple: f64,
    /// ASD of the SRP fluctuation at 3 mHz [m s^-2 Hz^-1/2] (∝ f^-1/3).
    pub srp_asd_at_3mhz: f64,
    /// Per-sample 1σ of the common-mode thruster force-noise acceleration [m/s²] (0 = off).
    pub sigma_force: f64,
    /// Solve (publish new estimates) every this many samples.
    pub solve_every: u64,
    /// IS measurement ranges (the front-end clips and flags beyond them): linear
    /// [m/s²] and angular [rad/s²]; a voltage no in-range acceleration can give is rejected.
    pub full_scale_linear: f64,
    pub full_scale_angular: f64,
    /// Longest run of missing ticks bridged as a dropout (bounds the work of one call);
    /// a longer jump of the tick is rejected as implausible.
    pub max_gap_ticks: u64,
    /// Integrity tuning; the defaults (`EstimatorConfig::GATE_SIGMA` …) are the
    /// measured values, with their derivations there. Gate of the sample tests (IS
    /// residual tracks, the cross-IS angular test) [σ].
    #[serde(default = "default_gate_sigma")]
    pub gate_sigma: f64,
    /// Gate of the star-tracker test [σ].
    #[serde(default = "default_star_gate_sigma")]
    pub star_gate_sigma: f64,
    /// A group's χ² per degree of freedom is inconsistent above
    /// 1 + max(this, 10 √(2/dof)) [-].
    #[serde(default = "default_chi2_tolerance")]
    pub chi2_tolerance: f64,
    /// The status says degraded when more than one input in this many was rejected.
    #[serde(default = "default_degraded_one_in")]
    pub degraded_one_in: u64,
}

fn default_gate_sigma() -> f64 {
    EstimatorConfig::GATE_SIGMA
}
fn default_star_gate_sigma() -> f64 {
    EstimatorConfig::STAR_GATE_SIGMA
}
fn default_chi2_tolerance() -> f64 {
    EstimatorConfig::CHI2_TOLERANCE
}
fn default_degraded_one_in() -> u64 {
    EstimatorConfig::DEGRADED_ONE_IN
}

/// Why a table is refused (`EstimatorConfig::check`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConfigError {
    /// A field is out of its range; the name says which.
    Field(&'static str),
}

impl EstimatorConfig {
    // The integrity defaults, as literals: the C header is generated from them. Their
    // entries (what, why, unit, guarding test) are `crate::tuning`'s, and they are its
    // values (asserted below the impl).

    /// Gate in σ: a Gaussian residual exceeds it once in 2.6×10⁷ draws, so clean data
    /// lose about one sample per campaign, while an upset moving a voltage by a few
    /// noise σ already fails the cross-IS test (whose noise is far below a voltage's own).
    pub const GATE_SIGMA: f64 = 5.5;
    /// Star-tracker gate in σ, tighter than the IS's: a lost star-tracker sample costs
    /// little, and an upset of a quaternion component by 5 noise σ turns the attitude
    /// by 5σ.
    pub const STAR_GATE_SIGMA: f64 = 5.0;
    /// χ² tolerance: model approximations stay well below it on clean data; an
    /// unmodelled effect or a wrong noise level does not.
    pub const CHI2_TOLERANCE: f64 = 0.25;
    /// Degraded above 2 % rejected: the estimate then rests on visibly less data than
    /// planned, and the bound with it.
    pub const DEGRADED_ONE_IN: u64 = 50;

    /// Validates the table before an estimator is built on it: every count in range,
    /// every rate, noise level and range finite and positive, priors finite and the
    /// scale-factor priors nonzero. An estimator never runs on a table that fails.
    pub fn check(&self) -> Result<(), ConfigError> {
        let pos = |x: f64| x.is_finite() && x > 0.0;
        let nonneg = |x: f64| x.is_finite() && x >= 0.0;
        let bad = |name| Err(ConfigError::Field(name));
        if !(self.fs.is_finite() && (1e-2..=1e4).contains(&self.fs)) {
            return bad("fs");
        }
        if !(1..=2).contains(&self.n_is) {
            return bad("n_is");
        }
        if !pos(self.sigma_star_rad) {
            return bad("sigma_star_rad");
        }
        if !pos(self.sigma_angular) {
            return bad("sigma_angular");
        }
        if !pos(self.sigma_linear) {
            return bad("sigma_linear");
        }
        if !nonneg(self.sigma_ripple) {
            return bad("sigma_ripple");
        }
        if !pos(self.srp_asd_at_3mhz) {
            return bad("srp_asd_at_3mhz");
        }
        if !nonneg(self.sigma_force) {
            return bad("sigma_force");
        }
        if self.solve_every == 0 || self.solve_every > 1 << 40 {
            return bad("solve_every");
        }
        if !pos(self.full_scale_linear) {
            return bad("full_scale_linear");
        }
        if !pos(self.full_scale_angular) {
            return bad("full_scale_angular");
        }
        // It bounds the work of one update (each missing tick is bridged).
        if self.max_gap_ticks == 0 || self.max_gap_ticks > 10_000_000 {
            return bad("max_gap_ticks");
        }
        // Below 3σ a clean campaign loses a visible share of its samples; above 20σ
        // the gates pass upsets the size of the signal.
        if !(self.gate_sigma.is_finite() && (3.0..=20.0).contains(&self.gate_sigma)) {
            return bad("gate_sigma");
        }
        if !(self.star_gate_sigma.is_finite() && (3.0..=20.0).contains(&self.star_gate_sigma)) {
            return bad("star_gate_sigma");
        }
        if !(self.chi2_tolerance.is_finite() && (0.01..=10.0).contains(&self.chi2_tolerance)) {
            return bad("chi2_tolerance");
        }
        if !(2..=1_000_000).contains(&self.degraded_one_in) {
            return bad("degraded_one_in");
        }
        for i in 0..2 {
            for a in 0..3 {
                if !pos(self.geometry_m[i][a].abs()) {
                    return bad("geometry_m");
                }
                if !pos(self.beta_prior[i][a].abs()) {
                    return bad("beta_prior");
                }
                if !(self.com_prior_m[i][a].is_finite() && self.com_prior_m[i][a].abs() < 10.0) {
                    return bad("com_prior_m");
                }
            }
        }
        Ok(())
    }
}

// The C header's defaults are the tuning table's values.
const _: () = assert!(
    EstimatorConfig::GATE_SIGMA == crate::tuning::GATE_SIGMA
        && EstimatorConfig::STAR_GATE_SIGMA == crate::tuning::STAR_GATE_SIGMA
        && EstimatorConfig::CHI2_TOLERANCE == crate::tuning::CHI2_TOLERANCE
        && EstimatorConfig::DEGRADED_ONE_IN == crate::tuning::DEGRADED_ONE_IN
);

/// Eq. 2: linear scale factors from the angular ones and the known geometry,
/// kx = Gz βz, ky = Gx βx, kz = Gy βy [m s⁻² V⁻¹].
pub fn k_from_beta(g: &[f64; 3], beta: &[f64; 3]) -> [f64; 3] {
    [g[2] * beta[2], g[0] * beta[0], g[1] * beta[1]]
}
