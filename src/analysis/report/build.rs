//! The report built from a run: each quantity with its truth, estimate, σ and bound,
//! the requirements judged, the prediction before the run and the prior's share.

use super::table::range_pct;
use super::*;
use crate::analysis::crlb::{Bounds, Crlb};
use crate::sim::msg::EstimateMsg;
pub use crate::sim::requirements::{REQ_COM_M, REQ_SCALE_FACTOR_REL};
use crate::sim::scenario::{Scenario, Schedule};

pub use crate::tuning::PRIOR_DOMINATED_SHARE;

/// A bound `c` with a prior of 1σ `p`: their informations add.
pub(super) fn bound_with_prior(c: f64, p: f64) -> f64 {
    1.0 / (1.0 / (c * c) + 1.0 / (p * p)).sqrt()
}

/// P(|e| < req) for e ~ N(0, σ²).
pub(super) fn within(req: f64, sigma: f64) -> f64 {
    if sigma.is_nan() || sigma <= 0.0 {
        return f64::NAN;
    }
    libm::erf(req / (sigma * std::f64::consts::SQRT_2))
}

impl Report {
    /// The report of a run whose bound is its maneuver's (no torque noise, no data
    /// lost, or a test that needs no other).
    pub fn new(
        s: &Scenario,
        seed: u64,
        mode: &str,
        method: &str,
        est: &EstimateMsg,
        crlb: &Crlb,
    ) -> Report {
        let b = Bounds {
            run: *crlb,
            maneuver: Some(*crlb),
        };
        Report::with_bounds(s, seed, mode, method, est, &b)
    }

    /// The report of a run: the parameters against the run's bound, the maneuver and
    /// the prediction before the run against the maneuver's (`crlb::bounds`).
    pub fn with_bounds(
        s: &Scenario,
        seed: u64,
        mode: &str,
        method: &str,
        est: &EstimateMsg,
        bounds: &Bounds,
    ) -> Report {
        let crlb = &bounds.run;
        // A maneuver that leaves a parameter unbounded by itself: an infinite bound.
        let maneuver = bounds.maneuver.unwrap_or(Crlb::INFINITE);
        let mut iss = Vec::new();
        let mut met = true;
        let priors = s.priors();
        // The truths judged against: the file's, or with `[drift]` at the campaign's middle.
        let truths = s.truths();
        for (i, is) in s.inertial_sensor.iter().enumerate() {
            let q = Quantity::new;
            let mut beta = q(truths.beta[i], est.beta[i], est.beta_sigma[i], crlb.beta[i]);
            let mut k = q(truths.k[i], est.k[i], est.k_sigma[i], crlb.k[i]);
            let mut r = q(
                truths.com_offset_m[i],
                est.r_b[i],
                est.r_sigma[i],
                crlb.com_offset_m[i],
            );
            beta.prior = priors[i].beta;
            k.prior = crate::sim::scenario::k_from_beta(&is.geometry_m, &priors[i].beta);
            r.prior = priors[i].com_offset_m;
            if method == "joint" {
                // The joint estimator's prior (the paper's filter has its own).
                use crate::sim::estimate::joint::{PRIOR_BETA_REL, PRIOR_COM_M};
                beta = beta.with_prior(priors[i].beta.map(|b| PRIOR_BETA_REL * b.abs()));
                let pk = k.prior;
                k = k.with_prior(pk.map(|x| PRIOR_BETA_REL * x.abs()));
                r = r.with_prior([PRIOR_COM_M; 3]);
            }
            for a in 0..3 {
                met &= ((beta.estimate[a] - beta.truth[a]) / beta.truth[a]).abs()
                    < REQ_SCALE_FACTOR_REL;
                met &= ((k.estimate[a] - k.truth[a]) / k.truth[a]).abs() < REQ_SCALE_FACTOR_REL;
                met &= (r.estimate[a] - r.truth[a]).abs() < REQ_COM_M;
            }
            iss.push(IsReport {
                id: i + 1,
                beta,
                k,
                com_offset: r,
            });
        }
        Report {
            scenario: s.name.clone(),
            seed,
            duration_s: s.duration_s,
            mode: mode.into(),
            method: method.into(),
            priors_source: s.priors_source,
            inertial_sensors: iss,
            requirements: Requirements {
                scale_factor_rel: REQ_SCALE_FACTOR_REL,
                com_offset_m: REQ_COM_M,
                met,
                verified: est.status & crate::sim::msg::ST_UNVERIFIED == 0,
            },
            samples_used: est.n_used,
            samples_rejected: est.n_rejected,
            samples_rejected_by_cause: crate::sim::msg::CAUSE_NAMES
                .iter()
                .zip(est.rejected_by_cause)
                .map(|(n, c)| (n.to_string(), c))
                .collect(),
            estimator_status: Some(EstimatorStatus {
                bits: est.status,
                text: crate::sim::msg::status_text(est.status),
                chi2_per_dof: crate::sim::msg::GROUP_NAMES
                    .iter()
                    .zip(est.chi2_per_dof)
                    .map(|(n, c)| (n.to_string(), c))
                    .collect(),
                sigma_inflation: est.sigma_inflation,
            }),
            faults: None,
            wall_time_s: None,
            timing: None,
            restarts: None,
            hosts: None,
            estimator_loop_allocations: None,
            maneuver: Some(crate::analysis::plan::describe(s, Some(&maneuver), None)),
            predicted_probability_requirements_met: None,
            predicted_probability_requirements_met_upper: None,
            probability_requirements_met_run_bound: None,
            prior_dominated: Vec::new(),
            ground_better: Vec::new(),
            warnings: Vec::new(),
        }
        .with_prior_judgement(s, &maneuver)
    }

    /// The prediction from the maneuver's bound (`maneuver`, with the estimator's
    /// prior: what could be said before the run), the prior-dominated parameters, and
    /// the warnings they call for.
    fn with_prior_judgement(mut self, s: &Scenario, maneuver: &Crlb) -> Self {
        let axes = ["x", "y", "z"];
        // Per prediction: the product (independent errors) and the smallest (one
        // common error).
        let (mut p, mut p_run) = ([1.0, 1.0], [1.0, 1.0]);
        let take = |acc: &mut [f64; 2], q: f64| {
            acc[0] *= q;
            acc[1] = acc[1].min(q);
        };
        for (i, is) in self.inertial_sensors.iter().enumerate() {
            for a in 0..3 {
                let req_b = REQ_SCALE_FACTOR_REL * is.beta.truth[a].abs();
                for (name, q, req, of_maneuver) in [
                    ("β", &is.beta, req_b, maneuver.beta[i][a]),
                    ("r", &is.com_offset, REQ_COM_M, maneuver.com_offset_m[i][a]),
                ] {
                    take(
                        &mut p,
                        within(req, bound_with_prior(of_maneuver, q.prior_sigma[a])),
                    );
                    take(&mut p_run, within(req, q.crlb_with_prior[a]));
                    if q.data_share[a] < PRIOR_DOMINATED_SHARE {
                        self.prior_dominated.push(format!(
                            "IS{} {name}{} (data share {:.1} %: it is the estimator's prior)",
                            is.id,
                            axes[a],
                            100.0 * q.data_share[a]
                        ));
                    }
                }
            }
        }
        self.ground_better = self.ground_better_than_data(s);
        let fin = |v: [f64; 2]| v.iter().all(|x| x.is_finite());
        self.predicted_probability_requirements_met = fin(p).then_some(p[0]);
        self.predicted_probability_requirements_met_upper = fin(p).then_some(p[1]);
        self.probability_requirements_met_run_bound = fin(p_run).then_some(p_run);
        let (worst, name) = crate::analysis::plan::worst_ratio(s, maneuver);
        if !s.maneuver.planned && worst > 1.0 {
            let how = if worst.is_finite() {
                format!("bound is {worst:.1}× the requirement ({name})")
            } else {
                format!("bound on {name} is infinite (singular)")
            };
            self.warnings.push(format!(
                "the written maneuver's {how}: the maneuver alone cannot calibrate it{}; `taiji-calib plan` plans a maneuver that does",
                if fin(p) {
                    format!(
                        ", and the bound predicts the requirements met with probability {}",
                        range_pct(p)
                    )
                } else {
                    String::new()
                }
            ));
        }
        if !s.maneuver.planned
            && s.maneuver.schedule == Schedule::Sequential
            && !crate::analysis::plan::schedules(s).contains(&Schedule::Sequential)
        {
            self.warnings.push(
                "the written maneuver rocks one axis at a time, and the thrusters are too quiet to rock the others meanwhile: the estimator fixes the SRP's level only once the last axis rocks, the samples before lack the turn of its fluctuation, and r's σ may be optimistic (r_z's by 1.3× at 10⁴ s, 2× at 10⁵ s); `taiji-calib plan` plans a maneuver that rocks every axis from the start".to_string(),
            );
        }
        // Truths outside the prior's box: the run flew them (item 4 of issue 51).
        self.warnings.extend(s.truth_warnings());
        if !self.prior_dominated.is_empty() {
            self.warnings.push(format!(
                "prior-dominated: {}",
                self.prior_dominated.join("; ")
            ));
        }
        if !self.ground_better.is_empty() {
            self.warnings.push(format!(
                "not better than the ground calibration (σ at or above ground_calibration's error; keep the ground value): {}",
                self.ground_better.join("; ")
            ));
        }
        self
    }

    /// β and r whose σ is at or above the ground calibration's stated error
    /// (`ground_calibration.beta_rel_error`, relative; `com_offset_error_m`): the run
    /// told less than the ground knew. The estimator's own prior is far wider (5 % of
    /// β, 5 cm), so a data share near 1 does not say this.
    fn ground_better_than_data(&self, s: &Scenario) -> Vec<String> {
        let gc = &s.ground_calibration;
        let axes = ["x", "y", "z"];
        let mut out = Vec::new();
        for is in &self.inertial_sensors {
            for a in 0..3 {
                let b = &is.beta;
                // Relative to the estimate: a judgement the run makes without truth.
                let rel = (b.sigma[a] / b.estimate[a]).abs();
                if gc.beta_rel_error > 0.0 && rel >= gc.beta_rel_error {
                    out.push(format!(
                        "IS{} β{} (σ {:.1e} relative, the ground's {:.1e})",
                        is.id, axes[a], rel, gc.beta_rel_error
                    ));
                }
                let r = &is.com_offset;
                if gc.com_offset_error_m > 0.0 && r.sigma[a] >= gc.com_offset_error_m {
                    out.push(format!(
                        "IS{} r{} (σ {:.2} mm, the ground's {:.2} mm)",
                        is.id,
                        axes[a],
                        r.sigma[a] * 1e3,
                        gc.com_offset_error_m * 1e3
                    ));
                }
            }
        }
        out
    }
}
