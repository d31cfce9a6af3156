//! Function 3's rule: which campaign results may become the onboard calibration table,
//! and the table they make.

use super::Report;
use crate::ground::dictionary::Failure;
use crate::sim::msg::TableValues;

/// The onboard table from a campaign's report: its final β, k and r of each IS with
/// their σ (IS i in row i; a second row of zeros with one IS). Refused
/// - `UnverifiedResult` when the estimator does not vouch for the result (its status
///   word not clean: `requirements.verified` false), or a value is not finite (β, k
///   not positive, a σ not positive);
/// - `PriorDominated` when any parameter is the estimator's prior rather than the
///   data's (`prior_dominated`), or no better than the ground calibration it would
///   replace (`ground_better`: σ at or above `ground_calibration`'s error);
/// - `NoResult` when the report holds no IS (or more than the table's two).
pub fn table_values(report: &Report) -> Result<TableValues, Failure> {
    let n = report.inertial_sensors.len();
    if n == 0 || n > 2 {
        return Err(Failure::NoResult);
    }
    if !report.requirements.verified {
        return Err(Failure::UnverifiedResult);
    }
    let mut t = TableValues::default();
    for (i, is) in report.inertial_sensors.iter().enumerate() {
        for (q, v, sigma, positive) in [
            (&is.beta, &mut t.beta[i], &mut t.beta_sigma[i], true),
            (&is.k, &mut t.k[i], &mut t.k_sigma[i], true),
            (&is.com_offset, &mut t.r[i], &mut t.r_sigma[i], false),
        ] {
            for a in 0..3 {
                let (x, s) = (q.estimate[a], q.sigma[a]);
                if !(x.is_finite() && s.is_finite() && s > 0.0 && (!positive || x > 0.0)) {
                    return Err(Failure::UnverifiedResult);
                }
            }
            *v = q.estimate;
            *sigma = q.sigma;
        }
    }
    if !report.prior_dominated.is_empty() || !report.ground_better.is_empty() {
        return Err(Failure::PriorDominated);
    }
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::crlb::Crlb;
    use crate::sim::msg::{EstimateMsg, ST_UNVERIFIED};
    use crate::sim::scenario::Scenario;

    /// The report of an estimate off the truth by a little, σ 10⁻⁵ relative (β, k)
    /// and 1 µm (r): verified, data-dominated, better than the ground's.
    fn report(edit: impl Fn(&mut EstimateMsg)) -> Report {
        let s = Scenario::default();
        let mut e = EstimateMsg::default();
        for (i, is) in s.inertial_sensor.iter().enumerate() {
            e.beta[i] = is.beta.map(|b| b * (1.0 + 3e-6));
            e.k[i] = is.k().map(|k| k * (1.0 - 2e-6));
            e.r_b[i] = is.com_offset_m.map(|r| r + 4e-7);
            e.beta_sigma[i] = is.beta.map(|b| b * 1e-5);
            e.k_sigma[i] = is.k().map(|k| k * 1e-5);
            e.r_sigma[i] = [1e-6; 3];
        }
        edit(&mut e);
        let c = Crlb {
            beta: e.beta_sigma,
            k: e.k_sigma,
            com_offset_m: e.r_sigma,
        };
        Report::new(&s, 1, "in-process", "joint", &e, &c)
    }

    #[test]
    fn a_verified_data_dominated_result_is_the_table_bit_for_bit() {
        let r = report(|_| {});
        let t = table_values(&r).unwrap();
        for (i, is) in r.inertial_sensors.iter().enumerate() {
            for (q, v, s) in [
                (&is.beta, t.beta[i], t.beta_sigma[i]),
                (&is.k, t.k[i], t.k_sigma[i]),
                (&is.com_offset, t.r[i], t.r_sigma[i]),
            ] {
                assert_eq!(q.estimate.map(f64::to_bits), v.map(f64::to_bits));
                assert_eq!(q.sigma.map(f64::to_bits), s.map(f64::to_bits));
            }
        }
        // One IS: the second row stays zero.
        let mut one = r.clone();
        one.inertial_sensors.truncate(1);
        assert_eq!(table_values(&one).unwrap().beta[1], [0.0; 3]);
        one.inertial_sensors.clear();
        assert_eq!(table_values(&one), Err(Failure::NoResult));
    }

    #[test]
    fn an_unverified_or_prior_dominated_result_is_refused() {
        let unverified = report(|e| e.status |= ST_UNVERIFIED);
        assert!(!unverified.requirements.verified);
        assert_eq!(table_values(&unverified), Err(Failure::UnverifiedResult));
        // IS2's βy as uncertain as the estimator's prior (5 %).
        let prior = report(|e| e.beta_sigma[1][1] = 0.05 * e.beta[1][1]);
        assert!(!prior.prior_dominated.is_empty());
        assert_eq!(table_values(&prior), Err(Failure::PriorDominated));
        // IS1's r_y σ 3 mm: the ground calibration's 2 mm is better.
        let ground = report(|e| e.r_sigma[0][1] = 3e-3);
        assert!(ground.prior_dominated.is_empty() && !ground.ground_better.is_empty());
        assert_eq!(table_values(&ground), Err(Failure::PriorDominated));
        // Unverified comes first.
        let both = report(|e| {
            e.status |= ST_UNVERIFIED;
            e.r_sigma[0][1] = 3e-3;
        });
        assert_eq!(table_values(&both), Err(Failure::UnverifiedResult));
        for bad in [f64::NAN, f64::INFINITY, 0.0, -1e-9] {
            let r = report(|e| e.k[0][2] = bad);
            assert_eq!(table_values(&r), Err(Failure::UnverifiedResult), "{bad}");
            let r = report(|e| e.r_sigma[1][0] = bad);
            assert_eq!(table_values(&r), Err(Failure::UnverifiedResult), "{bad}");
        }
        // A negative offset is an offset.
        assert!(table_values(&report(|e| e.r_b[0][1] = -0.3)).is_ok());
    }
}
