//! The maneuver planner: it plans any window a scenario leaves open, its constraints
//! hold, an impossible request names what binds it, and its bound predicts reality.

mod support;
mod tmpdir;
use nalgebra::{Matrix3, Vector3};
use taiji::analysis::plan::{self, PlanOptions};
use taiji::sim::scenario::maneuver::{torque_boost, Timeline};
use taiji::sim::scenario::Scenario;

fn load(text: &str) -> Scenario {
    Scenario::from_toml_str(text).unwrap_or_else(|e| panic!("{e}"))
}

fn planned(text: &str) -> (Scenario, plan::PlanInfo) {
    let (s, p) = plan::resolve(load(text)).unwrap_or_else(|e| panic!("{e}"));
    (s, p.expect("a scenario without waveform keys is planned"))
}

/// A Monte Carlo of `s` (seeds 1–12): every requirement met, each group's mean
/// (err/σ)² near 1 (loosely: 12 seeds).
fn flies_honest_on_12_seeds(s: &Scenario) {
    let mc =
        taiji::analysis::montecarlo::run(s, 1, 12, taiji::sim::estimate::Method::Joint).unwrap();
    assert_eq!(mc.runs_meeting_requirements, 12, "{}", mc.table());
    for (g, v) in mc.chi2_by_group.iter().enumerate() {
        assert!(
            (0.3..3.0).contains(v),
            "group {g}: mean (err/σ)² {v}\n{}",
            mc.table()
        );
    }
}

fn inertia(s: &Scenario) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| s.spacecraft.inertia_kg_m2[i][j])
}

#[test]
fn a_2000_s_window_without_a_maneuver_is_planned_and_meets_every_requirement() {
    let (s, p) = planned("duration_s = 2000.0");
    assert!(s.maneuver.planned && !s.plan_pending);
    assert!(p.shortfall.is_none());
    let tl = Timeline::new(&s).unwrap();
    assert!(tl.periods().iter().all(|&n| n >= 1));
    let (_, end) = tl.span_ticks();
    assert!(end <= s.n_samples());
    // A Monte Carlo of the planned maneuver: requirements met, σ honest, at the bound.
    flies_honest_on_12_seeds(&s);
    // The report records the plan.
    let res = taiji::analysis::campaign::run(&s, 3, taiji::sim::estimate::Method::Joint, |_| {});
    let crlb = taiji::analysis::crlb::crlb(&s).unwrap();
    let mut report =
        taiji::analysis::report::Report::new(&s, 3, "in-process", "joint", &res.estimate, &crlb);
    report.maneuver = Some(plan::describe(&s, Some(&crlb), Some(&p)));
    let json = serde_json::to_value(&report).unwrap();
    assert_eq!(json["maneuver"]["planned"], true);
    assert!(json["maneuver"]["search"]["candidates"].as_u64().unwrap() > 5);
    assert!(report.table().contains("Maneuver (planned)"));
    assert!(report.requirements.met);
}

#[test]
fn the_planned_default_is_at_least_as_good_as_the_hand_made_maneuver() {
    let s = Scenario::load_or_default(None).unwrap();
    let p = plan::plan(&s, &PlanOptions::default()).unwrap();
    let b = p.chosen.crlb.unwrap();
    let today = [1.14e-6, 0.63e-6, 0.020e-6];
    for i in 0..2 {
        for a in 0..3 {
            let rel = b.beta[i][a] / s.inertial_sensor[i].beta[a];
            assert!(rel <= 1.3e-5, "β IS{} axis {a}: {rel:e}", i + 1);
            assert!(
                b.com_offset_m[i][a] <= today[a],
                "r IS{} axis {a}: {:e}",
                i + 1,
                b.com_offset_m[i][a]
            );
        }
    }
    // The plan is deterministic and its TOML reads back as the same maneuver.
    let again = plan::plan(&s, &PlanOptions::default()).unwrap();
    assert_eq!(again.chosen.maneuver, p.chosen.maneuver);
    let back = load(&plan::maneuver_toml(&p.chosen.maneuver));
    assert!(!back.plan_pending);
    assert_eq!(back.maneuver, p.chosen.maneuver);
}

#[test]
fn offsets_up_to_0_3_m_stay_within_the_is_range() {
    for r in [
        [0.3, 0.0, 0.0],
        [0.0, 0.3, 0.0],
        [0.0, 0.0, 0.3],
        [0.173, 0.173, 0.173],
    ] {
        let text = format!("[[inertial_sensor]]\ncom_offset_m = {r:?}\n");
        let (s, p) = planned(&text);
        let env = Timeline::new(&s).unwrap().envelope(&inertia(&s));
        // Every corner of the priors' box, and the truth, with overshoot and jitter.
        let mut points = plan::offset_corners(&s);
        points.push(Vector3::from(r));
        let peak = env.peak_acceleration(&points, torque_boost(&s)).1;
        assert!(
            peak <= s.front_end.maneuver_limit_m_s2 * (1.0 + 1e-9),
            "{r:?}: {peak:e}"
        );
        assert!(p.peak_acceleration_m_s2 <= 1e-9 * (1.0 + 1e-9));
    }
}

#[test]
fn a_tight_attitude_limit_binds_the_torque() {
    let (s, p) = planned("[maneuver]\nmax_attitude_rad = 1e-4");
    assert_eq!(p.binding, "maneuver.max_attitude_rad");
    let env = Timeline::new(&s).unwrap().envelope(&inertia(&s));
    assert!(env.peak_attitude_rad * torque_boost(&s) <= 1e-4 * (1.0 + 1e-9));
    // The rate limit likewise.
    let (s, _) = planned("[maneuver]\nmax_rate_rad_s = 2e-7");
    let env = Timeline::new(&s).unwrap().envelope(&inertia(&s));
    assert!(env.peak_rate_rad_s * torque_boost(&s) <= 2e-7 * (1.0 + 1e-9));
}

#[test]
fn no_rocking_during_a_known_star_tracker_outage() {
    let (s, p) = planned("[star_tracker]\noutages_s = [[4000.0, 5000.0]]");
    assert!(s.maneuver.pause_in_outages);
    assert!(p.shortfall.is_none());
    let tl = Timeline::new(&s).unwrap();
    let fs = s.sample_rate_hz;
    for t in (4000.0 * fs) as u64..=(5000.0 * fs) as u64 {
        assert_eq!(tl.torque(t), [0.0; 3], "tick {t}");
    }
    assert!(tl.periods().iter().all(|&n| n >= 1));
}

#[test]
fn an_impossible_request_names_the_binding_constraint() {
    // A 100 s window holds no useful maneuver: the window binds.
    let e = plan::plan(
        &load(""),
        &PlanOptions {
            duration_s: Some(100.0),
            ..PlanOptions::default()
        },
    )
    .map(|p| p.shortfall.unwrap_or_default())
    .unwrap_or_else(|e| e.to_string());
    assert!(e.contains("duration_s"), "{e}");
    // Thrusters too weak: their maximum torque binds.
    let p = plan::plan(
        &load("[thruster]\nmax_torque_nm = 2e-9"),
        &PlanOptions::default(),
    );
    let e = p
        .map(|p| p.shortfall.unwrap_or_default())
        .unwrap_or_else(|e| e.to_string());
    assert!(e.contains("thruster.max_torque_nm"), "{e}");
    // `run` flies the best maneuver and says so; `plan` refuses (see the CLI test).
}

#[test]
fn the_shortest_window_meets_every_requirement_with_the_margin() {
    let s = load("");
    let p = plan::min_duration(&s, 3.0).unwrap();
    assert!(p.chosen.worst_ratio * 3.0 <= 1.0);
    assert!(p.duration_s < s.duration_s, "{}", p.duration_s);
    // 10 % shorter no longer does.
    let shorter = plan::plan(
        &s,
        &PlanOptions {
            duration_s: Some(p.duration_s * 0.9),
            exact: false,
            ..PlanOptions::default()
        },
    );
    assert!(shorter.map_or(true, |q| q.chosen.worst_ratio * 3.0 > 1.0
        || q.shortfall.is_some()));
}

#[test]
fn the_plan_command_writes_the_maneuver_and_refuses_an_impossible_window() {
    let tmp = tmpdir::TmpDir::new("plan");
    let dir = tmp.join("out");
    let out = support::calib()
        .args(["plan", "--duration", "5000", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("Chosen") && text.contains("best sequential"),
        "{text}"
    );
    let toml_text = std::fs::read_to_string(dir.join("maneuver.toml")).unwrap();
    let s = load(&format!("duration_s = 5000.0\n{toml_text}"));
    assert!(s.maneuver.planned && !s.plan_pending);
    for f in ["plan.json", "plan_bound.png", "plan_bound.svg"] {
        assert!(dir.join(f).is_file(), "{f}");
    }
    let _ = std::fs::remove_dir_all(&dir);
    let out = support::calib()
        .args(["plan", "--duration", "100", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("duration_s") && !err.contains("panicked"),
        "{err}"
    );
    // A refused plan leaves no empty output folder behind.
    assert!(!dir.exists(), "{} was created", dir.display());
}

#[test]
fn a_second_run_of_a_scenario_reuses_its_plan_from_the_cache() {
    let dir = tmpdir::TmpDir::new("plan-cache");
    let sc = dir.join("s.toml");
    std::fs::write(&sc, "name = \"cache\"\nduration_s = 3000.0\n").unwrap();
    let crlb = |cache: &str| {
        let o = support::calib()
            .args(["crlb", "--scenario"])
            .arg(&sc)
            .env("TAIJI_PLAN_CACHE", cache)
            .env("RUST_LOG", "info")
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        (
            String::from_utf8_lossy(&o.stdout).to_string(),
            String::from_utf8_lossy(&o.stderr).to_string(),
        )
    };
    let cache = dir.join("plans");
    let cache = cache.to_str().unwrap();
    let (first, log1) = crlb(cache);
    assert!(
        log1.contains("candidates") && !log1.contains("plan cache"),
        "{log1}"
    );
    let entries = std::fs::read_dir(dir.join("plans")).unwrap().count();
    assert_eq!(entries, 1);
    let (second, log2) = crlb(cache);
    assert!(log2.contains("from the plan cache"), "{log2}");
    assert_eq!(first, second);
    // A corrupt entry is a miss, not an error; `off` disables the cache.
    for e in std::fs::read_dir(dir.join("plans")).unwrap() {
        std::fs::write(e.unwrap().path(), "{ not json").unwrap();
    }
    let (third, log3) = crlb(cache);
    assert!(!log3.contains("from the plan cache"), "{log3}");
    assert_eq!(first, third);
    let (fourth, log4) = crlb("off");
    assert!(!log4.contains("from the plan cache"));
    assert_eq!(first, fourth);
}

#[test]
fn any_truth_within_the_priors_uncertainty_flies_its_plan_and_one_outside_is_named() {
    // The IS range binds the plan (a low design limit); IS1's CoM prior is given, with a
    // ground-calibration uncertainty of ±2 mm. The plan sees the priors only.
    let scenario = |r: [f64; 3]| {
        format!(
            "name = \"box\"\n[front_end]\nmaneuver_limit_m_s2 = 5e-10\n\
             [ground_calibration]\ncom_offset_error_m = 0.002\n\
             [[inertial_sensor]]\ncom_offset_m = [{}, {}, {}]\n\
             com_offset_prior_m = [0.2164, -0.1251, 0.0002]\n\
             [[inertial_sensor]]\ncom_offset_m = [0.2164, 0.1251, 0.0002]\n\
             com_offset_prior_m = [0.2164, 0.1251, 0.0002]\n",
            r[0], r[1], r[2]
        )
    };
    let prior = [0.2164, -0.1251, 0.0002];
    let (s, _) = planned(&scenario(prior));
    assert!(s.maneuver.planned);
    let flies = |r: [f64; 3]| {
        let mut t = load(&scenario(prior));
        t.inertial_sensor[0].com_offset_m = r;
        t.maneuver = s.maneuver.clone();
        t.plan_pending = false;
        t.validated()
    };
    // 60 truths drawn inside the ±2 mm box (its corners among them): each flies the plan.
    let mut x = 12345u64;
    let mut unit = || {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    for k in 0..60 {
        let r: [f64; 3] = std::array::from_fn(|a| {
            let u = if k < 8 {
                if k >> a & 1 == 1 {
                    1.0
                } else {
                    -1.0
                }
            } else {
                unit()
            };
            prior[a] + 0.002 * u * (1.0 - 1e-9)
        });
        flies(r).unwrap_or_else(|e| panic!("truth {r:?} inside the box: {e}"));
    }
    // A truth 5 mm out flies the same plan (onboard nothing knows the truth), with a
    // warning naming the parameter, the distance and the overshoot.
    let (out, _) = planned(&scenario([0.2214, -0.1301, 0.0052]));
    assert_eq!(out.maneuver, s.maneuver);
    let w = out.truth_warnings().join("\n");
    assert!(
        w.contains("inertial_sensor[0] r")
            && w.contains("5.00 mm from its prior")
            && w.contains("% above front_end.maneuver_limit_m_s2"),
        "{w}"
    );
    // Inside the box, no warning.
    assert!(flies(prior).unwrap().truth_warnings().is_empty());
}

#[test]
fn quiet_thrusters_get_a_maneuver_that_rocks_every_axis_from_the_start() {
    use taiji::sim::scenario::Schedule;
    // The default thrusters' torque noise rocks every axis on its own, far beyond the
    // estimator's test, and both schedules are weighed.
    let s = Scenario::load_or_default(None).unwrap();
    let rocking = plan::torque_noise_rocking(&s);
    assert!(rocking > 1e3, "default: {rocking:e}");
    assert_eq!(plan::schedules(&s).len(), 2);
    // Without torque noise a sequential maneuver would leave the SRP's level waiting
    // for its last axis: only simultaneous maneuvers are weighed, and a short
    // campaign flies honest.
    let (s, p) = planned("duration_s = 2000.0\n[thruster]\ntorque_noise_nm_rthz = 0.0\n");
    assert_eq!(plan::torque_noise_rocking(&s), 0.0);
    assert_eq!(s.maneuver.schedule, Schedule::Simultaneous);
    assert_eq!(p.best_by_schedule.len(), 1, "{:?}", p.best_by_schedule);
    assert_eq!(p.best_by_schedule[0].0, "simultaneous");
    assert!(p.shortfall.is_none());
    flies_honest_on_12_seeds(&s);
}
