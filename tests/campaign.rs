//! The in-process campaign: requirements, determinism, and that the estimator stands on
//! sensor data alone.

use taiji::analysis::campaign;
use taiji::analysis::report::{REQ_COM_M, REQ_SCALE_FACTOR_REL};
use taiji::sim::estimate::Method;
use taiji::sim::msg::EstimateMsg;
use taiji::sim::scenario::Scenario;

fn short() -> Scenario {
    // Three 3 mHz periods per axis in 3 000 s.
    Scenario::from_toml_str("duration_s = 3000.0\n[maneuver]\nfrequency_hz = 0.003\ntorque_amplitude_nm = [2.5e-6, 2.5e-6, 2.5e-6]\n").unwrap()
}

fn errors(s: &Scenario, e: &EstimateMsg) -> (f64, f64) {
    let (mut beta, mut r) = (0.0f64, 0.0f64);
    for (i, is) in s.inertial_sensor.iter().enumerate() {
        for a in 0..3 {
            beta = beta.max(((e.beta[i][a] - is.beta[a]) / is.beta[a]).abs());
            beta = beta.max(((e.k[i][a] - is.k()[a]) / is.k()[a]).abs());
            r = r.max((e.r_b[i][a] - is.com_offset_m[a]).abs());
        }
    }
    (beta, r)
}

#[test]
fn default_campaign_meets_the_requirements_on_both_is() {
    let s = Scenario::default();
    for seed in [1, 2, 3] {
        let res = campaign::run(&s, seed, Method::Joint, |_| {});
        let (beta, r) = errors(&s, &res.estimate);
        assert!(
            beta < REQ_SCALE_FACTOR_REL / 2.0,
            "seed {seed}: scale factor error {beta:e}"
        );
        assert!(r < REQ_COM_M / 10.0, "seed {seed}: CoM error {r:e}");
    }
}

#[test]
fn priors_2_percent_and_5_mm_off_still_converge() {
    let s = Scenario::from_toml_str(
        "[ground_calibration]\nbeta_rel_error = 0.02\ncom_offset_error_m = 0.005\n",
    )
    .unwrap();
    let res = campaign::run(&s, 4, Method::Joint, |_| {});
    let (beta, r) = errors(&s, &res.estimate);
    assert!(beta < REQ_SCALE_FACTOR_REL / 2.0, "{beta:e}");
    assert!(r < REQ_COM_M / 10.0, "{r:e}");
}

#[test]
fn same_seed_gives_bit_identical_estimates_and_another_seed_different_ones() {
    let s = short();
    let a = campaign::run(&s, 7, Method::Joint, |_| {}).estimate;
    let b = campaign::run(&s, 7, Method::Joint, |_| {}).estimate;
    let c = campaign::run(&s, 8, Method::Joint, |_| {}).estimate;
    assert_eq!(a, b);
    assert_ne!(a.beta, c.beta);
    assert_ne!(a.r_b, c.r_b);
}

#[test]
fn the_estimator_configuration_holds_no_truth() {
    // Priors given explicitly: changing every truth must not change what the estimator knows.
    let base = "[[inertial_sensor]]\nbeta_prior = [5.5e-8, 5.5e-8, 7.3e-8]\ncom_offset_prior_m = [0.2, -0.12, 0.0]\n";
    let s1 = Scenario::from_toml_str(base).unwrap();
    let s2 = Scenario::from_toml_str(&format!(
        "{base}com_offset_m = [0.21, -0.13, 0.001]\nbeta = [5.6e-8, 5.45e-8, 7.4e-8]\n"
    ))
    .unwrap();
    let c1 = s1.estimator_config(&s1.priors());
    let c2 = s2.estimator_config(&s2.priors());
    assert_eq!(c1, c2);
}

#[test]
fn the_paper_route_runs_and_is_worse_than_the_joint_estimator() {
    let s = Scenario::default();
    let paper = campaign::run(&s, 1, Method::Paper, |_| {}).estimate;
    let joint = campaign::run(&s, 1, Method::Joint, |_| {}).estimate;
    let (pb, pr) = errors(&s, &paper);
    let (jb, jr) = errors(&s, &joint);
    assert!(pb.is_finite() && pr.is_finite());
    // An independent reference found β ≈ 4e-3 (worst 1e-2), r ≈ 0.7 mm: it misses the
    // requirement (docs/method.md).
    assert!(
        (REQ_SCALE_FACTOR_REL..2e-2).contains(&pb) && (REQ_COM_M..5e-3).contains(&pr),
        "paper route: β {pb:e}, r {pr:e}"
    );
    assert!(
        pb > 10.0 * jb && pr > 10.0 * jr,
        "paper {pb:e} {pr:e} vs joint {jb:e} {jr:e}"
    );
}

#[test]
fn one_inertial_sensor_only_is_supported() {
    let s = Scenario::from_toml_str("[[inertial_sensor]]\n").unwrap();
    assert_eq!(s.inertial_sensor.len(), 1);
    let res = campaign::run(&s, 1, Method::Joint, |_| {});
    let (beta, r) = errors(&s, &res.estimate);
    assert!(
        beta < REQ_SCALE_FACTOR_REL && r < REQ_COM_M,
        "{beta:e} {r:e}"
    );
}

/// Honesty and efficiency over 30 seeds: mean (error/σ)² per group within [0.5, 2] and
/// the RMS error of every parameter within 2× its Cramér–Rao bound.
fn assert_honest_and_efficient(s: &Scenario) -> taiji::analysis::montecarlo::MonteCarlo {
    let mc = taiji::analysis::montecarlo::run(s, 1, 30, Method::Joint).unwrap();
    for (g, chi2) in ["β", "k", "r"].iter().zip(mc.chi2_by_group) {
        assert!(
            (0.5..=2.0).contains(&chi2),
            "{}: mean (err/σ)² of {g} is {chi2:.2}",
            s.name
        );
    }
    for p in &mc.params {
        assert!(
            p.crlb_ratio < 2.0,
            "{}: {} RMS/CRLB {:.2}",
            s.name,
            p.name,
            p.crlb_ratio
        );
    }
    mc
}

#[test]
fn thirty_seeds_give_honest_sigma_and_reach_the_crlb() {
    let mc = assert_honest_and_efficient(&Scenario::default());
    assert_eq!(mc.runs_meeting_requirements, 30);
}

#[test]
fn sigma_stays_honest_with_thruster_force_noise_and_other_truths() {
    // Force noise degrades absolute r to ~200 µm (docs/physics.md); σ must say so.
    let s = Scenario::from_toml_str(
        "name = \"force-noise\"\n[thruster]\nforce_noise_n_rthz = 1.0e-7\n",
    )
    .unwrap();
    assert_honest_and_efficient(&s);
    let s = Scenario::from_toml_str(
        "name = \"other-truths\"\n[spacecraft]\ninertia_kg_m2 = [[1500.0, -20.0, 10.0], [-20.0, 800.0, 15.0], [10.0, 15.0, 1200.0]]\n\
         [ground_calibration]\nbeta_rel_error = 0.02\ncom_offset_error_m = 0.005\n\
         [[inertial_sensor]]\ncom_offset_m = [0.25, -0.10, 0.05]\nbeta = [6.0e-8, 5.0e-8, 7.0e-8]\n\
         [[inertial_sensor]]\ncom_offset_m = [-0.15, 0.20, -0.08]\nbeta = [5.3e-8, 5.7e-8, 7.5e-8]\n",
    )
    .unwrap();
    assert_honest_and_efficient(&s);
}
