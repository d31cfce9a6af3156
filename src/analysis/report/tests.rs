//! The report's unit tests: the prior's judgement, the bounds, and the console lines.

use super::*;
use crate::analysis::crlb::{Bounds, Crlb};
use crate::sim::msg::EstimateMsg;
use crate::sim::scenario::{Scenario, Schedule};

mod prior {
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

mod fault_line {
    /// The console line says which count is which, matching report.json's keys.
    #[test]
    fn each_count_is_named_as_in_report_json() {
        let f = serde_json::json!({"by_kind": {"upset": {
            "injected": 9, "detected": 6, "missed": 3, "undetected_within_5_sigma": 2
        }}});
        assert_eq!(
            crate::analysis::report::fault_line(&f),
            "upset 9 injected, 6 detected, 3 missed (2 harmless, within 5σ of noise)"
        );
    }
}
