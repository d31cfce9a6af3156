//! The report as printed: the result table like the paper's Tables 2–3, the estimator's
//! lines, timing, faults and the prediction line.

use super::*;
pub use crate::sim::requirements::{REQ_COM_M, REQ_SCALE_FACTOR_REL};
use std::fmt::Write as _;

impl Report {
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
            "Scenario {:?}, seed {}, {} s, {} ({} estimator){}",
            self.scenario,
            self.seed,
            self.duration_s,
            self.mode,
            self.method,
            match self.priors_source {
                PriorsSource::Scenario => "",
                PriorsSource::OnboardTable => ", priors from the onboard calibration table",
            }
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
pub(super) fn range_pct([lo, hi]: [f64; 2]) -> String {
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
