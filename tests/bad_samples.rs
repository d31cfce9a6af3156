//! NaN/Inf samples, saturation and star-tracker gaps are rejected and counted; the
//! estimate stays finite and the campaign still converges.

use taiji::analysis::campaign::Stages;
use taiji::sim::estimate::Method;
use taiji::sim::msg::FLAG_SATURATED_LINEAR;
use taiji::sim::scenario::Scenario;

#[test]
fn non_finite_and_saturated_samples_are_rejected_and_counted() {
    let s = Scenario::default();
    let mut st = Stages::new(&s, 3, Method::Joint);
    let mut bad = 0;
    for tick in 0..s.n_samples() {
        let cmd = st.commander.step(tick);
        let truth = st.plant.step(tick, &cmd.torque_cmd_b);
        let mut sample = st.fee.step(&truth);
        if tick > 10 && tick % 997 == 0 {
            sample.is[0].volts[1][0] = f64::NAN;
            bad += 1;
        } else if tick > 10 && tick % 1009 == 0 {
            sample.is[1].volts[2][1] = f64::INFINITY;
            bad += 1;
        } else if tick > 10 && tick % 1013 == 0 {
            sample.is[1].flags |= FLAG_SATURATED_LINEAR;
            bad += 1;
        }
        if tick % 1500 == 0 {
            sample.star.q_bn = [f64::NAN; 4];
        }
        st.estimator.step(&sample);
    }
    let e = st.estimator.finish();
    assert_eq!(e.n_rejected, bad);
    assert_eq!(e.n_used + e.n_rejected, s.n_samples());
    for i in 0..2 {
        for a in 0..3 {
            assert!(e.beta[i][a].is_finite() && e.r_b[i][a].is_finite());
            assert!(
                ((e.beta[i][a] - s.inertial_sensor[i].beta[a]) / s.inertial_sensor[i].beta[a])
                    .abs()
                    < 3e-4
            );
            assert!((e.r_b[i][a] - s.inertial_sensor[i].com_offset_m[a]).abs() < 75e-6);
        }
    }
}

#[test]
fn a_star_tracker_outage_is_survived() {
    let s = Scenario::from_toml_str(
        "[star_tracker]\noutages_s = [[2000.0, 2600.0], [7000.0, 7100.0]]\n",
    )
    .unwrap();
    let res = taiji::analysis::campaign::run(&s, 5, Method::Joint, |_| {});
    for i in 0..2 {
        for a in 0..3 {
            assert!(
                ((res.estimate.beta[i][a] - s.inertial_sensor[i].beta[a])
                    / s.inertial_sensor[i].beta[a])
                    .abs()
                    < 3e-4
            );
            assert!((res.estimate.r_b[i][a] - s.inertial_sensor[i].com_offset_m[a]).abs() < 75e-6);
        }
    }
}
