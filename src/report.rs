//! The run report (every key: docs/report.md) and the result table printed like the
//! paper's Tables 2–3.

use crate::crlb::Crlb;
use crate::msg::EstimateMsg;
pub use crate::requirements::{REQ_COM_M, REQ_SCALE_FACTOR_REL};
use crate::scenario::Scenario;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Quantity {
    pub truth: [f64; 3],
    pub estimate: [f64; 3],
    pub sigma: [f64; 3],
    pub crlb: [f64; 3],
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
    pub maneuver: Option<crate::plan::ManeuverReport>,
}

impl Report {
    pub fn new(
        s: &Scenario,
        seed: u64,
        mode: &str,
        method: &str,
        est: &EstimateMsg,
        crlb: &Crlb,
    ) -> Report {
        let mut iss = Vec::new();
        let mut met = true;
        for (i, is) in s.inertial_sensor.iter().enumerate() {
            let q = |truth: [f64; 3], e: [f64; 3], sg: [f64; 3], c: [f64; 3]| Quantity {
                truth,
                estimate: e,
                sigma: sg,
                crlb: c,
            };
            let beta = q(is.beta, est.beta[i], est.beta_sigma[i], crlb.beta[i]);
            let k = q(is.k(), est.k[i], est.k_sigma[i], crlb.k[i]);
            let r = q(
                is.com_offset_m,
                est.r_b[i],
                est.r_sigma[i],
                crlb.com_offset_m[i],
            );
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
                verified: est.status & crate::msg::ST_UNVERIFIED == 0,
            },
            samples_used: est.n_used,
            samples_rejected: est.n_rejected,
            samples_rejected_by_cause: crate::msg::CAUSE_NAMES
                .iter()
                .zip(est.rejected_by_cause)
                .map(|(n, c)| (n.to_string(), c))
                .collect(),
            estimator_status: Some(EstimatorStatus {
                bits: est.status,
                text: crate::msg::status_text(est.status),
                chi2_per_dof: crate::msg::GROUP_NAMES
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
            maneuver: Some(crate::plan::describe(s, Some(crlb), None)),
        }
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
                    let (error, sigma, crlb, requirement, pass) = if rel {
                        let e = err / q.truth[a];
                        (
                            format!("{:+.2e}", e),
                            format!("{:.2e}", q.sigma[a] / q.truth[a]),
                            format!("{:.2e}", q.crlb[a] / q.truth[a]),
                            "3.0e-4".to_string(),
                            e.abs() < REQ_SCALE_FACTOR_REL,
                        )
                    } else {
                        (
                            format!("{:+.2} µm", err * 1e6),
                            format!("{:.2} µm", q.sigma[a] * 1e6),
                            format!("{:.2} µm", q.crlb[a] * 1e6),
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
            "{:<10} {:>14} {:>14} {:>11} {:>11} {:>11} {:>9} {:>5} {:>11}",
            "parameter", "truth", "estimate", "1σ", "error", "CRLB", "req", "pass", "err/σ"
        );
        for r in self.rows() {
            let _ = writeln!(
                o,
                "{:<10} {:>14.6e} {:>14.6e} {:>11} {:>11} {:>11} {:>9} {:>5} {:>+11.2}",
                r.name,
                r.truth,
                r.estimate,
                r.sigma,
                r.error,
                r.crlb,
                r.requirement,
                if r.pass { "ok" } else { "FAIL" },
                r.z
            );
        }
        let _ = writeln!(o, "(β, k: 1σ, error and CRLB relative; r: absolute)");
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
        let _ = writeln!(
            o,
            "Requirements met: {}{}",
            if self.requirements.met { "yes" } else { "NO" },
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
    pub requirement: String,
    pub pass: bool,
    /// error / σ.
    pub z: f64,
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
    #[error("cannot create {}: {source}", path.display())]
    Create {
        path: std::path::PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot write {}: {source}", path.display())]
    Write {
        path: std::path::PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{0}")]
    Json(#[from] serde_json::Error),
}

/// Write `DIR/report.json` (creating DIR).
pub fn write(out: &std::path::Path, report: &Report) -> Result<(), ReportError> {
    std::fs::create_dir_all(out).map_err(|source| ReportError::Create {
        path: out.to_path_buf(),
        source,
    })?;
    let path = out.join("report.json");
    let text = serde_json::to_string_pretty(report)?;
    std::fs::write(&path, text + "\n").map_err(|source| ReportError::Write { path, source })
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
