//! Truths outside the prior's box. Only the simulation knows the truth: onboard, a
//! prior far from it, or a maneuver that drives the true |A r| beyond the IS design
//! limit, cannot be seen, and the campaign flies. So does the simulation; these are
//! the warnings that name the parameter and the distance (report.json `warnings`,
//! report.md). What happens then (saturated samples, a degraded or unverified status)
//! is what the run shows.

use crate::sim::scenario::maneuver::{torque_boost, Timeline};
use crate::sim::scenario::{Priors, Scenario, MAX_BETA_PRIOR_REL, MAX_COM_PRIOR_ERROR_M};

impl Scenario {
    /// Every truth outside its prior's box, one line each: β's prior more than 10 %
    /// off (as far as the estimator acquires β), r's more than 5 cm, and the
    /// maneuver's |A r| at the true offsets above the IS design limit. The truths are
    /// the campaign's (`Scenario::truths`: with `[drift]`, at its middle); the priors
    /// the campaign's own (`Scenario::priors`).
    pub fn truth_warnings(&self) -> Vec<String> {
        let t = self.truths();
        let priors = self.priors();
        let axes = ["x", "y", "z"];
        let mut out = Vec::new();
        for (i, p) in priors.iter().enumerate() {
            for a in 0..3 {
                let rel = p.beta[a] / t.beta[i][a] - 1.0;
                if rel.abs() > MAX_BETA_PRIOR_REL {
                    out.push(format!(
                        "inertial_sensor[{i}] β{}: the truth is {:.1} % off its prior (the estimator acquires β from at most {:.0} %); the campaign flies, see its status",
                        axes[a],
                        100.0 * rel.abs(),
                        100.0 * MAX_BETA_PRIOR_REL
                    ));
                }
                let d = p.com_offset_m[a] - t.com_offset_m[i][a];
                if d.abs() > MAX_COM_PRIOR_ERROR_M {
                    out.push(format!(
                        "inertial_sensor[{i}] r{}: the truth is {:.1} mm off its prior (at most {:.0} mm tried); the campaign flies, see its status",
                        axes[a],
                        1e3 * d.abs(),
                        1e3 * MAX_COM_PRIOR_ERROR_M
                    ));
                }
            }
        }
        if let Some(w) = self.true_range_warning(&t, &priors) {
            out.push(w);
        }
        out
    }

    /// The maneuver's |A r| at the true offsets above `front_end.maneuver_limit_m_s2`:
    /// by how much, and how far the truth is from its prior.
    fn true_range_warning(
        &self,
        t: &crate::sim::drift::Truths,
        priors: &[Priors],
    ) -> Option<String> {
        if self.plan_pending {
            return None;
        }
        let inertia = nalgebra::Matrix3::from_fn(|i, j| self.spacecraft.inertia_kg_m2[i][j]);
        let env = Timeline::new(self).ok()?.envelope(&inertia);
        let n = self.inertial_sensor.len();
        let truths: Vec<nalgebra::Vector3<f64>> = t.com_offset_m[..n]
            .iter()
            .map(|r| nalgebra::Vector3::from(*r))
            .collect();
        let (i, acc) = env.peak_acceleration(&truths, torque_boost(self));
        let limit = self.front_end.maneuver_limit_m_s2;
        if acc <= limit {
            return None;
        }
        let far = (0..3)
            .map(|a| (t.com_offset_m[i][a] - priors[i].com_offset_m[a]).abs())
            .fold(0.0, f64::max);
        let box_m = self.ground_calibration.com_offset_error_m;
        let sized = if self.maneuver.planned {
            format!(
                "; the plan kept it within the limit for every offset within ground_calibration.com_offset_error_m = {:.2} mm of the priors",
                box_m * 1e3
            )
        } else {
            String::new()
        };
        Some(format!(
            "inertial_sensor[{i}] r: the true CoM offset is {:.2} mm from its prior{sized}, and the maneuver drives its |A r| to {acc:.4e} m/s², {:.2} % above front_end.maneuver_limit_m_s2 = {limit:.1e} m/s² (with 3σ jitter and overshoot); onboard nothing can know it: the campaign flies, see its status and saturated samples",
            far * 1e3,
            100.0 * (acc / limit - 1.0)
        ))
    }
}
