//! The run report (every key: docs/report.md) and the result table printed like the
//! paper's Tables 2–3.

use crate::analysis::crlb::{Bounds, Crlb};
use crate::sim::files::FileError;
use crate::sim::msg::EstimateMsg;
pub use crate::sim::requirements::{REQ_COM_M, REQ_SCALE_FACTOR_REL};
use crate::sim::scenario::{Scenario, Schedule};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Quantity {
    pub truth: [f64; 3],
    pub estimate: [f64; 3],
    pub sigma: [f64; 3],
    /// The bound of the data alone (the Cramér–Rao bound of the maneuver flown).
    pub crlb: [f64; 3],
    /// 1σ of the estimator's own prior (joint: 5 % of β's prior, 5 cm for r).
    #[serde(default)]
    pub prior_sigma: [f64; 3],
    /// The bound with that prior: 1/√(1/crlb² + 1/prior_sigma²).
    #[serde(default)]
    pub crlb_with_prior: [f64; 3],
    /// How much of the information behind σ came from the data, 1 − (σ/prior_sigma)²:
    /// 0 where the estimate is its prior, 1 where the prior did not matter.
    #[serde(default)]
    pub data_share: [f64; 3],
}

impl Quantity {
    fn new(truth: [f64; 3], estimate: [f64; 3], sigma: [f64; 3], crlb: [f64; 3]) -> Self {
        Quantity {
            truth,
            estimate,
            sigma,
            crlb,
            prior_sigma: [f64::NAN; 3],
            crlb_with_prior: [f64::NAN; 3],
            data_share: [f64::NAN; 3],
        }
    }

    /// Set the estimator's prior σ, and what follows from it.
    fn with_prior(mut self, prior_sigma: [f64; 3]) -> Self {
        self.prior_sigma = prior_sigma;
        for a in 0..3 {
            let (c, p) = (self.crlb[a], prior_sigma[a]);
            self.crlb_with_prior[a] = bound_with_prior(c, p);
            self.data_share[a] = (1.0 - (self.sigma[a] / p).powi(2)).clamp(0.0, 1.0);
        }
        self
    }
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct IsReport {
    pub id: usize,
    pub beta: Quantity,
    pub k: Quantity,
    pub com_offset: Quantity,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Requirements {
    pub scale_factor_rel: f64,
    pub com_offset_m: f64,
    /// Every error within its requirement (judged against the scenario's truths).
    pub met: bool,
    /// The estimator vouches for its own result (no solve failure, converged, every
    /// residual group consistent with its noise model): what onboard software knows.
    #[serde(default = "yes")]
    pub verified: bool,
}

fn yes() -> bool {
    true
}

/// What the estimator says of its own result (`EstimateMsg::status`).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct EstimatorStatus {
    /// `ST_*` bits and their names ("ok" when none).
    pub bits: u64,
    pub text: String,
    /// χ²/dof of the whitened residuals per group at the final solve (1: the noise
    /// model fits).
    pub chi2_per_dof: std::collections::BTreeMap<String, f64>,
    /// Factor the σ were inflated by for inconsistent groups (1: none).
    pub sigma_inflation: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Report {
    pub scenario: String,
    pub seed: u64,
    pub duration_s: f64,
    pub mode: String,
    pub method: String,
    pub inertial_sensors: Vec<IsReport>,
    pub requirements: Requirements,
    /// Samples the estimator used and rejected (non-finite, saturated, invalid).
    pub samples_used: u64,
    pub samples_rejected: u64,
    /// Rejections by cause (a sample may count under several; see docs/integrity.md).
    #[serde(default)]
    pub samples_rejected_by_cause: std::collections::BTreeMap<String, u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub estimator_status: Option<EstimatorStatus>,
    /// Injected faults and how many the estimator detected, by kind (with `[faults]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub faults: Option<serde_json::Value>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wall_time_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub timing: Option<serde_json::Value>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub restarts: Option<serde_json::Value>,
    /// Sets spread over hosts: where each process ran, the tunnel, link events.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hosts: Option<serde_json::Value>,
    /// Heap allocations the estimator process made in its filter loop (multi-process).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub estimator_loop_allocations: Option<u64>,
    /// The maneuver flown: waveform, schedule, whether planned, envelope, bound.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub maneuver: Option<crate::analysis::plan::ManeuverReport>,
    /// Probability of meeting every requirement that the bound with the estimator's
    /// prior predicts (β and r of each IS, each error normal with that σ): before
    /// the run, from the maneuver and the noise model alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub predicted_probability_requirements_met: Option<f64>,
    /// The same if the errors were one common error (the smallest probability of one
    /// parameter): the bound gives each σ, not how the errors go together, so the
    /// probability lies between this and the product above (β's six errors are
    /// mostly one common scale error, which puts it nearer this one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub predicted_probability_requirements_met_upper: Option<f64>,
    /// Both from the run's bound (its thrusters' random motion at this seed
    /// included, which can calibrate what the maneuver alone cannot), [product,
    /// smallest]: known after the run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub probability_requirements_met_run_bound: Option<[f64; 2]>,
    /// Parameters whose estimate is mostly the estimator's prior (data share < 50 %).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub prior_dominated: Vec<String>,
    /// Parameters the data calibrated no better than the ground calibration claims
    /// (σ at or above `ground_calibration`'s error): its value is the one to keep.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub ground_better: Vec<String>,
    /// What the user should know before trusting the result (also printed).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

/// A data share below this: the parameter is named prior-dominated.
pub const PRIOR_DOMINATED_SHARE: f64 = 0.5;

/// A bound `c` with a prior of 1σ `p`: their informations add.
fn bound_with_prior(c: f64, p: f64) -> f64 {
    1.0 / (1.0 / (c * c) + 1.0 / (p * p)).sqrt()
}

/// P(|e| < req) for e ~ N(0, σ²).
fn within(req: f64, sigma: f64) -> f64 {
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
        for (i, is) in s.inertial_sensor.iter().enumerate() {
            let q = Quantity::new;
            let mut beta = q(is.beta, est.beta[i], est.beta_sigma[i], crlb.beta[i]);
            let mut k = q(is.k(), est.k[i], est.k_sigma[i], crlb.k[i]);
            let mut r = q(
                is.com_offset_m,
                est.r_b[i],
                est.r_sigma[i],
                crlb.com_offset_m[i],
            );
            if method == "joint" {
                // The joint estimator's prior (the paper's filter has its own).
                use crate::sim::estimate::joint::{PRIOR_BETA_REL, PRIOR_COM_M};
                let pk = crate::sim::scenario::k_from_beta(&is.geometry_m, &priors[i].beta);
                beta = beta.with_prior(priors[i].beta.map(|b| PRIOR_BETA_REL * b.abs()));
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

    /// One row per parameter and axis, formatted as the tables print it.
    pub fn rows(&self) -> Vec<Row> {
        let axes = ["x", "y", "z"];
        let mut out = Vec::new();
        for is in &self.inertial_sensors {
            let groups: [(&str, &Quantity, bool); 3] = [
                ("β", &is.beta, true),
                ("k", &is.k, true),
                ("r", &is.com_offset, false),
            ];
            for (name, q, rel) in groups {
                for a in 0..3 {
                    let err = q.estimate[a] - q.truth[a];
                    let (error, sigma, crlb, crlb_with_prior, requirement, pass) = if rel {
                        let e = err / q.truth[a];
                        (
                            format!("{:+.2e}", e),
                            format!("{:.2e}", q.sigma[a] / q.truth[a]),
                            format!("{:.2e}", q.crlb[a] / q.truth[a]),
                            format!("{:.2e}", q.crlb_with_prior[a] / q.truth[a]),
                            "3.0e-4".to_string(),
                            e.abs() < REQ_SCALE_FACTOR_REL,
                        )
                    } else {
                        (
                            format!("{:+.2} µm", err * 1e6),
                            format!("{:.2} µm", q.sigma[a] * 1e6),
                            format!("{:.2} µm", q.crlb[a] * 1e6),
                            format!("{:.2} µm", q.crlb_with_prior[a] * 1e6),
                            "75 µm".to_string(),
                            err.abs() < REQ_COM_M,
                        )
                    };
                    out.push(Row {
                        name: format!("IS{} {}{}", is.id, name, axes[a]),
                        truth: q.truth[a],
                        estimate: q.estimate[a],
                        sigma,
                        error,
                        crlb,
                        crlb_with_prior,
                        data_share: q.data_share[a],
                        prior_tightens: q.crlb_with_prior[a] < 0.99 * q.crlb[a],
                        requirement,
                        pass,
                        z: if q.sigma[a] > 0.0 {
                            err / q.sigma[a]
                        } else {
                            f64::NAN
                        },
                    });
                }
            }
        }
        out
    }

    /// The result table: truth, estimate ± 1σ, error, requirement, pass/fail, CRLB.
    pub fn table(&self) -> String {
        let mut o = String::new();
        self.write_parameters(&mut o);
        self.write_estimator_lines(&mut o);
        if let Some(t) = &self.timing {
            write_timing(&mut o, t);
        }
        if let Some(r) = &self.restarts {
            let _ = writeln!(o, "Restarts: {}", r);
        }
        if let Some(a) = self.estimator_loop_allocations {
            let _ = writeln!(o, "Heap allocations in the estimator's filter loop: {a}");
        }
        if let Some(w) = self.wall_time_s {
            let _ = writeln!(o, "Wall time: {w:.2} s");
        }
        o
    }

    /// The run's line and the table of parameters, then the maneuver's line.
    fn write_parameters(&self, o: &mut String) {
        let _ = writeln!(
            o,
            "Scenario {:?}, seed {}, {} s, {} ({} estimator)",
            self.scenario, self.seed, self.duration_s, self.mode, self.method
        );
        let _ = writeln!(
            o,
            "{:<10} {:>14} {:>14} {:>11} {:>11} {:>11} {:>7} {:>9} {:>5} {:>11}",
            "parameter", "truth", "estimate", "1σ", "error", "CRLB", "data", "req", "pass", "err/σ"
        );
        let rows = self.rows();
        for r in &rows {
            let _ = writeln!(
                o,
                "{:<10} {:>14.6e} {:>14.6e} {:>11} {:>11} {:>11} {:>7} {:>9} {:>5} {:>+11.2}",
                r.name,
                r.truth,
                r.estimate,
                r.sigma,
                r.error,
                r.crlb,
                share(r.data_share),
                r.requirement,
                if r.pass { "ok" } else { "FAIL" },
                r.z
            );
        }
        let _ = writeln!(
            o,
            "(β, k: 1σ, error and CRLB relative; r: absolute. CRLB: the data's bound alone; data: the share of σ's information from the data, not the estimator's prior)"
        );
        let _ = writeln!(o, "{}", with_prior_line(&rows));
        if let Some(m) = &self.maneuver {
            let _ = writeln!(o, "{}", m.line());
        }
    }

    /// The difference of two sensors' offsets, the estimator's status, the samples it
    /// used, the faults and whether the requirements are met.
    fn write_estimator_lines(&self, o: &mut String) {
        if let [a, b] = &self.inertial_sensors[..] {
            // Common-mode errors (e.g. thruster force noise) cancel in the difference.
            let d: Vec<String> = (0..3)
                .map(|j| {
                    let e = (a.com_offset.estimate[j] - b.com_offset.estimate[j])
                        - (a.com_offset.truth[j] - b.com_offset.truth[j]);
                    format!("{:+.2}", e * 1e6)
                })
                .collect();
            let _ = writeln!(o, "r1 − r2 error (x, y, z): [{}] µm", d.join(", "));
        }
        if let Some(st) = &self.estimator_status {
            let chi: Vec<String> = st
                .chi2_per_dof
                .iter()
                .map(|(k, v)| format!("{k} {v:.2}"))
                .collect();
            let _ = writeln!(
                o,
                "Estimator status: {}; χ²/dof {}{}",
                st.text,
                chi.join(", "),
                if st.sigma_inflation > 1.0 {
                    format!("; σ inflated ×{:.2}", st.sigma_inflation)
                } else {
                    String::new()
                }
            );
        }
        let rejected: Vec<String> = self
            .samples_rejected_by_cause
            .iter()
            .filter(|(_, c)| **c > 0)
            .map(|(k, c)| format!("{k} {c}"))
            .collect();
        let _ = writeln!(
            o,
            "Samples used {}, rejected {}{}",
            self.samples_used,
            self.samples_rejected,
            if rejected.is_empty() {
                String::new()
            } else {
                format!(" (by cause: {})", rejected.join(", "))
            }
        );
        if let Some(f) = &self.faults {
            let _ = writeln!(o, "Faults: {}", fault_line(f));
        }
        if let Some(line) = prediction_line(self) {
            let _ = writeln!(o, "{line}");
        }
        for w in &self.warnings {
            let _ = writeln!(o, "Warning: {w}");
        }
        let _ = writeln!(
            o,
            "Requirements met: {}{}{}",
            if self.requirements.met { "yes" } else { "NO" },
            match (self.requirements.met, self.prior_dominated.is_empty()) {
                (true, false) => " — by the prior only for the prior-dominated parameters above",
                _ => "",
            },
            if self.requirements.verified {
                ""
            } else {
                " — but the estimator marks the result UNVERIFIED (see its status)"
            }
        );
    }
}

/// The timing of a multi-process run: real-time latencies and deadlines, or the
/// accelerated lock-step's losses.
fn write_timing(o: &mut String, t: &serde_json::Value) {
    let lat = |v: &serde_json::Value| {
        format!(
            "p50 {:.0} µs, p99 {:.0} µs, max {:.0} µs",
            v["p50"].as_f64().unwrap_or(f64::NAN),
            v["p99"].as_f64().unwrap_or(f64::NAN),
            v["max"].as_f64().unwrap_or(f64::NAN)
        )
    };
    if t["pacing"] == "realtime" {
        let _ = writeln!(
            o,
            "Real-time ×{} (tick period {:.0} µs): End-to-end latency {}; missed deadlines {}; samples lost {}",
            t["time_scale"],
            t["period_us"].as_f64().unwrap_or(f64::NAN),
            lat(&t["end_to_end_latency_us"]),
            t["missed_deadlines"],
            t["samples_lost"]
        );
        if let Some(line) = scheduling_line(t) {
            let _ = writeln!(o, "  scheduling: {line}");
        }
        if let Some(hops) = t["hop_latency_us"].as_object() {
            for (hop, v) in hops {
                let _ = writeln!(o, "  hop {hop:<17} {}", lat(v));
            }
        }
    } else {
        let _ = writeln!(
            o,
            "Accelerated lock-step: samples lost {}",
            t["samples_lost"]
        );
    }
}

/// One parameter on one axis, formatted for the tables (β, k relative; r in µm).
#[derive(Debug, Clone)]
pub struct Row {
    pub name: String,
    pub truth: f64,
    pub estimate: f64,
    pub sigma: String,
    pub error: String,
    pub crlb: String,
    /// The bound with the estimator's prior, formatted as `crlb`.
    pub crlb_with_prior: String,
    /// How much of σ's information came from the data (0–1; NaN without a prior).
    pub data_share: f64,
    /// The prior tightens the bound by more than 1 %.
    pub prior_tightens: bool,
    pub requirement: String,
    pub pass: bool,
    /// error / σ.
    pub z: f64,
}

/// A probability, or the range between independent errors and one common error.
fn range_pct([lo, hi]: [f64; 2]) -> String {
    if hi - lo >= 0.005 {
        format!("{:.2}–{:.2} %", 100.0 * lo, 100.0 * hi)
    } else {
        format!("{:.2} %", 100.0 * lo)
    }
}

/// "Predicted from the bound: …": the maneuver's prediction (a range where the
/// errors' going together matters), and the run's bound's where it differs (its
/// thrusters' random motion calibrated more than the maneuver's motion).
pub fn prediction_line(r: &Report) -> Option<String> {
    let lo = r.predicted_probability_requirements_met?;
    let p = [
        lo,
        r.predicted_probability_requirements_met_upper.unwrap_or(lo),
    ];
    let mut line = format!(
        "Predicted from the bound: requirements met with probability {}",
        range_pct(p)
    );
    if let Some(q) = r.probability_requirements_met_run_bound {
        if (q[0] - p[0]).abs() >= 0.005 || (q[1] - p[1]).abs() >= 0.005 {
            let _ = write!(
                line,
                " (the maneuver's motion alone; with this run's thruster motion, its bound gives {})",
                range_pct(q)
            );
        }
    }
    if p[1] - p[0] >= 0.005 {
        line.push_str("; a range: from errors independent to one common error");
    }
    Some(line)
}

/// A data share as the table prints it: "100 %", "97.3 %", "—" without a prior.
fn share(v: f64) -> String {
    if v.is_nan() {
        "—".into()
    } else if v >= 0.9995 {
        "100 %".into()
    } else {
        format!("{:.1} %", 100.0 * v)
    }
}

/// The bound with the estimator's prior, beside the data's: where the prior tightens
/// it by more than 1 %, those parameters (bound without → with); else that it does not.
fn with_prior_line(rows: &[Row]) -> String {
    let moved: Vec<String> = rows
        .iter()
        // k's bound moves with β's (k = G β).
        .filter(|r| r.prior_tightens && !r.name.contains(" k"))
        .map(|r| format!("{} {} → {}", r.name, r.crlb, r.crlb_with_prior))
        .collect();
    if rows.iter().all(|r| r.data_share.is_nan()) {
        "CRLB with the estimator's prior: — (this method's prior is its own)".into()
    } else if moved.is_empty() {
        "CRLB with the estimator's prior (5 % of β and k, 5 cm of r): within 1 % of the data's for every parameter".into()
    } else {
        format!(
            "CRLB with the estimator's prior (5 % of β and k, 5 cm of r), where it is tighter than the data's: {}",
            moved.join("; ")
        )
    }
}

/// "upset 9 injected, 6 detected, 3 missed; star_jump …" from a report's `faults`: each
/// count named as in report.json (`injected`, `detected`, `missed`), so the line
/// cannot be read backwards as a bare "6/9" under an "injected / detected" label was.
pub fn fault_line(f: &serde_json::Value) -> String {
    let Some(kinds) = f["by_kind"].as_object() else {
        return "none".into();
    };
    let list: Vec<String> = kinds
        .iter()
        .map(|(k, v)| {
            let n = |key: &str| v[key].as_u64().unwrap_or(0);
            let within = n("undetected_within_5_sigma");
            format!(
                "{k} {} injected, {} detected, {} missed{}",
                n("injected"),
                n("detected"),
                n("missed"),
                if within > 0 {
                    format!(" ({within} harmless, within 5σ of noise)")
                } else {
                    String::new()
                }
            )
        })
        .collect();
    list.join("; ")
}

#[cfg(test)]
mod prior_tests {
    use super::*;

    /// An estimate at the truth with σ the bound `c`.
    fn at_truth_with_sigma(s: &Scenario, c: &Crlb) -> EstimateMsg {
        let mut e = EstimateMsg::default();
        for (i, is) in s.inertial_sensor.iter().enumerate() {
            e.beta[i] = is.beta;
            e.k[i] = is.k();
            e.r_b[i] = is.com_offset_m;
            e.beta_sigma[i] = c.beta[i];
            e.k_sigma[i] = c.k[i];
            e.r_sigma[i] = c.com_offset_m[i];
        }
        e
    }

    /// An estimate whose σ is its prior's: the report names it prior-dominated, and a
    /// requirement met says it was met by the prior only.
    #[test]
    fn an_estimate_that_is_its_prior_is_named_and_its_success_qualified() {
        let s = Scenario::default();
        let crlb = crate::analysis::crlb::crlb(&s).unwrap();
        let priors = s.priors();
        let mut e = at_truth_with_sigma(&s, &crlb);
        // IS1's βy as uncertain as its prior.
        e.beta_sigma[0][1] = crate::sim::estimate::joint::PRIOR_BETA_REL * priors[0].beta[1];
        let r = Report::new(&s, 1, "in-process", "joint", &e, &crlb);
        assert_eq!(r.inertial_sensors[0].beta.data_share[1], 0.0);
        assert!(r.inertial_sensors[0].beta.data_share[0] > 0.999);
        assert_eq!(r.prior_dominated.len(), 1, "{:?}", r.prior_dominated);
        assert!(r.prior_dominated[0].starts_with("IS1 βy (data share 0.0 %"));
        let t = r.table();
        assert!(t.contains("Warning: prior-dominated: IS1 βy"), "{t}");
        assert!(
            t.contains("Requirements met: yes — by the prior only"),
            "{t}"
        );
        // The paper's filter has a prior of its own: nothing is judged.
        let p = Report::new(&s, 1, "in-process", "paper", &e, &crlb);
        assert!(p.prior_dominated.is_empty() && p.inertial_sensors[0].beta.data_share[0].is_nan());
        // The data share per parameter in the table, the prior's bound under it.
        assert!(
            t.lines()
                .any(|l| l.starts_with("IS1 βy") && l.contains("0.0 %")),
            "{t}"
        );
        assert!(
            t.lines()
                .any(|l| l.starts_with("IS1 βx") && l.contains("100 %")),
            "{t}"
        );
        assert!(t.contains("CRLB with the estimator's prior"), "{t}");
    }

    /// A σ no better than the ground calibration's stated error is said so, though
    /// the data share (against the estimator's far wider prior) is near 1.
    #[test]
    fn a_sigma_above_the_ground_calibrations_error_says_keep_the_ground_value() {
        let s = Scenario::default();
        let crlb = crate::analysis::crlb::crlb(&s).unwrap();
        let mut e = at_truth_with_sigma(&s, &crlb);
        let none = Report::new(&s, 1, "in-process", "joint", &e, &crlb);
        assert!(none.ground_better.is_empty(), "{:?}", none.ground_better);
        // IS2's βz at 0.9 %, the ground's 0.5 %; IS1's r_x at 3 mm, the ground's 2 mm.
        e.beta_sigma[1][2] = 9e-3 * s.inertial_sensor[1].beta[2];
        e.r_sigma[0][0] = 3e-3;
        let r = Report::new(&s, 1, "in-process", "joint", &e, &crlb);
        assert!(r.inertial_sensors[1].beta.data_share[2] > 0.95);
        assert_eq!(r.ground_better.len(), 2, "{:?}", r.ground_better);
        assert!(r
            .ground_better
            .iter()
            .any(|g| g.starts_with("IS2 βz (σ 9.0e-3 relative, the ground's 5.0e-3)")));
        assert!(r
            .ground_better
            .iter()
            .any(|g| g.starts_with("IS1 rx (σ 3.00 mm, the ground's 2.00 mm)")));
        assert!(r
            .table()
            .contains("Warning: not better than the ground calibration"));
    }

    /// The parameters stand against the run's bound; the maneuver's line, the
    /// prediction before the run and the written-maneuver warning against the
    /// maneuver's. A written maneuver whose own bound is 100× the run's (the run's
    /// random motion informing what the maneuver does not) is warned of, and one
    /// that bounds nothing by itself too.
    #[test]
    fn the_run_and_the_maneuver_have_a_bound_each() {
        let mut s = Scenario::default();
        s.maneuver.planned = false;
        let run = crate::analysis::crlb::crlb(&s).unwrap();
        let e = at_truth_with_sigma(&s, &run);
        let scale = |c: &Crlb, f: f64| Crlb {
            beta: c.beta.map(|v| v.map(|x| x * f)),
            k: c.k.map(|v| v.map(|x| x * f)),
            com_offset_m: c.com_offset_m.map(|v| v.map(|x| x * f)),
        };
        let weak = scale(&run, 100.0);
        let b = Bounds {
            run,
            maneuver: Some(weak),
        };
        let r = Report::with_bounds(&s, 1, "in-process", "joint", &e, &b);
        assert_eq!(r.inertial_sensors[1].beta.crlb, run.beta[1]);
        let (worst, _) = crate::analysis::plan::worst_ratio(&s, &weak);
        let m = r.maneuver.as_ref().unwrap();
        assert_eq!(m.predicted_worst_ratio, worst);
        assert!(worst > 1.0);
        assert!(r.predicted_probability_requirements_met.unwrap() < 0.5);
        assert!(
            r.warnings[0].contains("the written maneuver's bound is"),
            "{:?}",
            r.warnings
        );
        // The same run against its own bound alone: no warning, all but certain.
        let same = Report::new(&s, 1, "in-process", "joint", &e, &run);
        assert!(same.warnings.is_empty(), "{:?}", same.warnings);
        assert!(same.predicted_probability_requirements_met.unwrap() > 0.99);
        // A maneuver that bounds nothing by itself.
        let none = Bounds {
            run,
            maneuver: None,
        };
        let r = Report::with_bounds(&s, 1, "in-process", "joint", &e, &none);
        assert!(
            r.warnings[0].contains("is infinite (singular)"),
            "{:?}",
            r.warnings
        );
        assert!(r.predicted_probability_requirements_met.unwrap() < 1e-3);
    }

    /// A written sequential maneuver with thrusters too quiet to rock the other axes
    /// is warned of (its r_z σ would be optimistic); a simultaneous one, or the same
    /// with the default torque noise, is not.
    #[test]
    fn a_written_sequential_maneuver_with_quiet_thrusters_is_warned_of() {
        let mut s = Scenario::default();
        s.maneuver.planned = false;
        s.maneuver.schedule = Schedule::Sequential;
        let crlb = crate::analysis::crlb::crlb(&s).unwrap();
        let e = at_truth_with_sigma(&s, &crlb);
        let quiet_warning = |s: &Scenario| {
            Report::new(s, 1, "in-process", "joint", &e, &crlb)
                .warnings
                .iter()
                .any(|w| w.contains("the thrusters are too quiet"))
        };
        assert!(!quiet_warning(&s));
        s.thruster.torque_noise_nm_rthz = 0.0;
        assert!(quiet_warning(&s));
        // The planner's own maneuver is never warned of in this way.
        s.maneuver.planned = true;
        assert!(!quiet_warning(&s));
        s.maneuver.planned = false;
        s.maneuver.schedule = Schedule::Simultaneous;
        assert!(!quiet_warning(&s));
    }
}

#[cfg(test)]
mod fault_line_tests {
    /// The console line says which count is which, matching report.json's keys.
    #[test]
    fn each_count_is_named_as_in_report_json() {
        let f = serde_json::json!({"by_kind": {"upset": {
            "injected": 9, "detected": 6, "missed": 3, "undetected_within_5_sigma": 2
        }}});
        assert_eq!(
            super::fault_line(&f),
            "upset 9 injected, 6 detected, 3 missed (2 harmless, within 5σ of noise)"
        );
    }
}

/// A report that could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A file or folder that could not be read, created or written.
    #[error(transparent)]
    File(#[from] FileError),
    #[error("{0}")]
    Json(#[from] serde_json::Error),
}

/// Write `DIR/report.json` (creating DIR).
pub fn write(out: &std::path::Path, report: &Report) -> Result<(), ReportError> {
    std::fs::create_dir_all(out)
        .map_err(|source| ReportError::from(FileError::create(out.to_path_buf(), source)))?;
    let path = out.join("report.json");
    let text = serde_json::to_string_pretty(report)?;
    std::fs::write(&path, text + "\n")
        .map_err(|source| ReportError::from(FileError::write(path, source)))
}

/// How each real-time stage was scheduled, from a report's `timing`, on one line
/// ("taiji-commander SCHED_FIFO 40 on CPU 1; …"); `None` without that field.
pub fn scheduling_line(timing: &serde_json::Value) -> Option<String> {
    let list: Vec<String> = timing["scheduling"]
        .as_object()?
        .iter()
        .map(|(k, v)| format!("{k} {}", v.as_str().unwrap_or("?")))
        .collect();
    Some(list.join("; "))
}
