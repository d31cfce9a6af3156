//! What a recording holds beyond the samples the estimator reads: the truth streams
//! and the fault log, for figures, fault scoring and tests (never for replay).

use super::layout as l;
use super::read::{guarded, opened, Reader, Recording};
use super::{Telemetry, TelemetryError};
use crate::sim::msg::Header;
use crate::sim::scenario::Scenario;
use std::path::Path;

/// The fault log of a recording and how many samples of each fault were rejected. The
/// recording is opened as for replay: its checked sample count bounds the log. The same
/// reads run in a child process first (`isolate`, as for [`super::read::open`]).
pub fn fault_log(path: &Path) -> Result<FaultLog, TelemetryError> {
    super::isolate::check(path, "fault log", |p| {
        let _ = fault_log_of(p);
    })?;
    fault_log_of(path)
}

/// A recording's fault records and, per record, the samples rejected.
pub type FaultLog = (Vec<crate::sim::faults::FaultRecord>, Vec<u64>);

fn fault_log_of(path: &Path) -> Result<FaultLog, TelemetryError> {
    let mut rec = opened(path)?;
    let recs = std::mem::take(&mut rec.faults);
    guarded(&rec.r, |r| {
        let det = if recs.is_empty() {
            Vec::new()
        } else {
            r.ints(l::FAULT_DETECTED, recs.len() as u64)?
        };
        Ok((recs, det))
    })
}

/// Every stream of a complete recording (truth included), in memory: for figures and
/// tests, not replay. The same reads run in a child process first (`isolate`).
pub fn full(path: &Path) -> Result<(Telemetry, Scenario), TelemetryError> {
    super::isolate::check(path, "every stream", |p| {
        let _ = full_of(p);
    })?;
    full_of(path)
}

fn full_of(path: &Path) -> Result<(Telemetry, Scenario), TelemetryError> {
    let rec = opened(path)?;
    guarded(&rec.r, |r| with_truth(r, &rec))
}

pub(super) fn with_truth(
    r: &Reader,
    rec: &Recording,
) -> Result<(Telemetry, Scenario), TelemetryError> {
    let s = rec.scenario.clone();
    let n = rec.n;
    let ni = s.inertial_sensor.len() as u64;
    let m = r
        .dataset(l::EST_TIME)?
        .shape()
        .first()
        .copied()
        .unwrap_or(0) as u64;
    // At most one estimate row a sample, and the final one: a longer claim is corrupt
    // (refused before anything its size is allocated).
    if m > n.saturating_add(1) {
        return Err(r.err(format!(
            "/{} has {m} rows, more than the recording's {n} samples and its final estimate",
            l::EST_TIME
        )));
    }
    let mut t = Telemetry::new(ni as usize, s.sample_rate_hz, 0);
    t.torque_cmd = r.f64s(l::TORQUE_CMD, &[n, 3])?;
    t.torque = r.f64s(l::TORQUE, &[n, 3])?;
    t.attitude = r.f64s(l::ATTITUDE, &[n, 4])?;
    t.omega = r.f64s(l::OMEGA, &[n, 3])?;
    t.omega_dot = r.f64s(l::OMEGA_DOT, &[n, 3])?;
    t.tm_acc = r.f64s(l::TM_ACC, &[n, ni, 3])?;
    t.srp_acc = r.f64s(l::SRP_ACC, &[n, 3])?;
    for x in rec.samples() {
        let x = x?;
        t.truth_tick.push(x.header.tick);
        t.star_q.extend_from_slice(&x.star.q_bn);
        t.star_valid.push(x.star.valid);
        for i in 0..ni as usize {
            t.is_volts[i].extend(x.is[i].volts.iter().flatten());
            t.is_flags[i].push(x.is[i].flags);
        }
    }
    t.sensor_tick = t.truth_tick.clone();
    t.faults = rec.faults.clone();
    if !t.faults.is_empty() {
        t.faults_detected = r.ints(l::FAULT_DETECTED, t.faults.len() as u64)?;
    }
    let e_tick = r.ints(l::EST_TICK, m)?;
    let e_time = r.f64s(l::EST_TIME, &[m])?;
    let used = r.ints(l::EST_N_USED, m)?;
    let rejected = r.ints(l::EST_N_REJECTED, m)?;
    let fin = r.ints(l::EST_FINAL, m)?;
    let status = r.ints(l::EST_STATUS, m)?;
    let nc = crate::sim::msg::N_CAUSES;
    let by_cause = r
        .shaped(l::EST_REJECTED_BY_CAUSE, &[m, nc as u64])?
        .read_raw::<u64>()
        .map_err(|e| r.err(format!("/{}: {e}", l::EST_REJECTED_BY_CAUSE)))?;
    let chi2 = r.f64s(l::EST_CHI2, &[m, crate::sim::msg::N_GROUPS as u64])?;
    let block = |p: &str| r.f64s(p, &[m, ni, 3]);
    let (beta, beta_s, k, k_s, rr, rr_s) = (
        block(l::EST_BETA)?,
        block(l::EST_BETA_SIGMA)?,
        block(l::EST_K)?,
        block(l::EST_K_SIGMA)?,
        block(l::EST_R)?,
        block(l::EST_R_SIGMA)?,
    );
    let fs = s.sample_rate_hz;
    for row in 0..m as usize {
        let mut e = crate::sim::msg::EstimateMsg {
            header: Header::at(
                row as u64,
                ((e_time[row] * fs).round() as u64).saturating_sub(1),
                fs,
            ),
            solved_tick: e_tick[row],
            n_used: used[row],
            n_rejected: rejected[row],
            status: status[row],
            flags: if fin[row] != 0 {
                crate::sim::msg::EST_FINAL
            } else {
                0
            },
            ..Default::default()
        };
        e.rejected_by_cause = std::array::from_fn(|c| by_cause[row * nc + c]);
        let ng = crate::sim::msg::N_GROUPS;
        e.chi2_per_dof = std::array::from_fn(|g| chi2[row * ng + g]);
        for i in 0..ni as usize {
            let at = |v: &[f64], a: usize| v[(row * ni as usize + i) * 3 + a];
            for a in 0..3 {
                e.beta[i][a] = at(&beta, a);
                e.beta_sigma[i][a] = at(&beta_s, a);
                e.k[i][a] = at(&k, a);
                e.k_sigma[i][a] = at(&k_s, a);
                e.r_b[i][a] = at(&rr, a);
                e.r_sigma[i][a] = at(&rr_s, a);
            }
        }
        t.estimates.push(e);
    }
    Ok((t, s))
}

#[cfg(test)]
mod tests {
    use super::super::read::tests::{claim_huge, folder, tiny_recording};
    use super::*;

    #[test]
    fn an_estimate_log_longer_than_its_samples_is_refused_not_allocated() {
        // Found by the telemetry fuzz target's seeds (a fault log claiming 10¹² rows
        // aborted the replay); the estimate log had the same unchecked claim.
        let d = folder("huge-estimates");
        let path = d.join("telemetry.h5");
        tiny_recording(&path);
        assert!(full(&path).is_ok());
        claim_huge(&path, "estimate", &["time", "tick"]);
        let e = full(&path).expect_err("refused").to_string();
        assert!(
            e.contains(
                "/estimate/time has 1000000000000 rows, more than the recording's 100 samples"
            ),
            "{e}"
        );
        std::fs::remove_dir_all(&d).unwrap();
    }
}
