//! The std layer's tuning table (src/tuning.rs): every entry has a unit, a line on what
//! it does and a guard that exists, and the guards of the entries no other test holds.

use taiji::analysis::campaign::Threads;
use taiji::analysis::crlb::{bound_at, crlb_curve, Crlb};
use taiji::analysis::plan::{self, PlanOptions};
use taiji::analysis::report::Report;
use taiji::sim::msg::{EstimateMsg, EST_FINAL};
use taiji::sim::scenario::Scenario;
use taiji::telemetry::RowGate;
use taiji::tuning;

fn load(text: &str) -> Scenario {
    Scenario::from_toml_str(text).unwrap_or_else(|e| panic!("{e}"))
}

fn root() -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The file a guard names: `tests/x.rs::name`, or `module::path::tests::…::name` under
/// src/ (the module's file, or its `tests.rs`), and the test's name.
fn guard_files(guard: &str) -> (Vec<std::path::PathBuf>, String) {
    if let Some((file, test)) = guard.split_once(".rs::") {
        return (vec![root().join(format!("{file}.rs"))], test.to_string());
    }
    let (module, test) = guard.rsplit_once("::").expect("path::test");
    let module = &module[..module.find("::tests").expect("a tests module")];
    let dir = root().join("src").join(module.replace("::", "/"));
    let files = vec![
        dir.with_extension("rs"),
        dir.join("mod.rs"),
        dir.join("tests.rs"),
    ];
    (files, test.to_string())
}

#[test]
fn every_entry_has_a_unit_and_names_a_test_that_exists() {
    let src = std::fs::read_to_string(root().join("src/tuning.rs")).unwrap();
    let mut doc: Vec<&str> = Vec::new();
    let mut entries = 0;
    for line in src.lines() {
        if let Some(d) = line.strip_prefix("/// ") {
            doc.push(d);
            continue;
        }
        if let Some(rest) = line.strip_prefix("pub const ") {
            let name = rest.split(':').next().unwrap_or(rest);
            assert!(
                rest.ends_with(';'),
                "{name}: one line, `pub const NAME: T = V;`"
            );
            let last = doc.pop().unwrap_or_default();
            let (unit, guard) = last
                .strip_prefix("Unit: ")
                .and_then(|l| l.split_once(". Guarded by: `"))
                .unwrap_or_else(|| panic!("{name}: `Unit: U. Guarded by: `test`.` last"));
            assert!(
                !unit.is_empty() && !doc.is_empty(),
                "{name}: a unit and what it does"
            );
            let (files, test) = guard_files(guard.trim_end_matches("`."));
            assert!(
                files.iter().any(|f| std::fs::read_to_string(f)
                    .is_ok_and(|t| t.contains(&format!("fn {test}()")))),
                "{name}: no test {test} in {files:?}"
            );
            entries += 1;
        }
        doc.clear();
    }
    assert!(entries >= 15, "{entries} entries");
}

/// The thrusters rock every axis on their own (the planner weighs both schedules) down
/// to about a twentieth of the default torque noise; below, only simultaneous ones.
#[test]
fn thrusters_at_a_twentieth_of_the_default_torque_noise_are_quiet() {
    let at = |share: f64| {
        let s = load(&format!(
            "[thruster]\ntorque_noise_nm_rthz = {:e}\n",
            1.0e-7 * share
        ));
        plan::schedules(&s).len()
    };
    assert_eq!(
        at(1.0 / 16.0),
        2,
        "a sixteenth of the default rocks every axis"
    );
    assert_eq!(at(1.0 / 25.0), 1, "a twenty-fifth is quiet");
}

/// A data share (1 − σ²/prior²) of 40 % is prior-dominated, one of 60 % is not.
#[test]
fn a_parameter_is_prior_dominated_below_half_its_information_from_data() {
    let s = Scenario::default();
    let crlb = taiji::analysis::crlb::crlb(&s).unwrap();
    let priors = s.priors();
    let mut e = EstimateMsg::default();
    for (i, is) in s.inertial_sensor.iter().enumerate() {
        e.beta[i] = is.beta;
        e.k[i] = is.k();
        e.r_b[i] = is.com_offset_m;
        e.beta_sigma[i] = crlb.beta[i];
        e.k_sigma[i] = crlb.k[i];
        e.r_sigma[i] = crlb.com_offset_m[i];
    }
    let prior = |a: usize| taiji::sim::estimate::joint::PRIOR_BETA_REL * priors[0].beta[a];
    e.beta_sigma[0][1] = prior(1) * 0.6f64.sqrt(); // data share 40 %
    e.beta_sigma[0][2] = prior(2) * 0.4f64.sqrt(); // data share 60 %
    let r = Report::new(&s, 1, "in-process", "joint", &e, &crlb);
    let share = r.inertial_sensors[0].beta.data_share;
    assert!(
        (share[1] - 0.4).abs() < 1e-9 && (share[2] - 0.6).abs() < 1e-9,
        "{share:?}"
    );
    assert_eq!(r.prior_dominated.len(), 1, "{:?}", r.prior_dominated);
    assert!(
        r.prior_dominated[0].starts_with("IS1 βy"),
        "{:?}",
        r.prior_dominated
    );
}

/// An estimator that solves every second at 10 Hz gives a row every 10 s, and its final
/// estimate.
#[test]
fn estimate_rows_are_ten_seconds_apart_when_the_estimator_solves_every_second() {
    let mut gate = RowGate::default();
    let mut rows = Vec::new();
    for tick in (0..=1000).step_by(10).chain([1005]) {
        let mut e = EstimateMsg::default();
        e.header.tick = tick;
        e.solved_tick = tick;
        e.n_used = 1;
        if tick == 1005 {
            e.flags |= EST_FINAL;
        }
        if gate.due(&e, 10.0) {
            rows.push(tick);
        }
    }
    let want: Vec<u64> = (0..=1000).step_by(100).chain([1005]).collect();
    assert_eq!(rows, want);
}

/// The largest relative difference of β's and r's bounds.
fn worst_off(a: &Crlb, b: &Crlb) -> f64 {
    let mut w = 0.0f64;
    for i in 0..2 {
        for x in 0..3 {
            w = w.max((a.beta[i][x] / b.beta[i][x] - 1.0).abs());
            w = w.max((a.com_offset_m[i][x] / b.com_offset_m[i][x] - 1.0).abs());
        }
    }
    w
}

/// The live status's bound, interpolated between the curve's points, is within 3 % of
/// the bound on average over the default campaign (half the points: 5 %).
#[test]
fn the_status_bound_is_within_three_percent_of_the_curve_on_average() {
    let default = Scenario::load_or_default(None).unwrap();
    let (s, _) = plan::resolve(default).unwrap();
    let fine = crlb_curve(&s, 1024, Threads::available());
    let curve = crlb_curve(&s, tuning::BOUND_POINTS, Threads::available());
    let errors: Vec<f64> = fine
        .iter()
        .filter_map(|(t, b)| {
            Some(worst_off(
                &bound_at(&curve, *t)?,
                &b.filter(Crlb::is_finite)?,
            ))
        })
        .collect();
    assert!(errors.len() > 900, "{}", errors.len());
    let mean = errors.iter().sum::<f64>() / errors.len() as f64;
    assert!(mean < 0.03, "mean interpolation error {mean:.3}");
}

/// The credit window holds eight beats: the upstream never waits for one.
#[test]
fn eight_beats_cross_the_credit_window() {
    assert_eq!(taiji::bus::wiring::WINDOW / tuning::BEAT_TICKS, 8);
}

/// An idle stage beats twice per status: each status shows it less than one old.
#[test]
fn an_idle_stage_beats_twice_per_status() {
    let status = taiji::runtime::process::status::STATUS_EVERY.as_nanos();
    assert_eq!(2 * tuning::BEAT_NS as u128, status);
}

/// The final bound of a window longer than `FINAL_SAMPLES` at the scenario's rate
/// (4×10⁵ s at 10 Hz, bounded at 5 Hz) is the full-rate bound to 2×10⁻⁵ (at 2.5 Hz:
/// 4×10⁻⁵ off).
#[test]
fn the_final_bound_of_a_long_window_is_the_full_rate_bound_to_two_parts_in_1e5() {
    let s = load("duration_s = 4.0e5\n");
    let exact = PlanOptions {
        exact: true,
        ..PlanOptions::default()
    };
    let p = plan::plan(&s, &exact).unwrap();
    let (s, _) = plan::resolve(s).unwrap();
    assert_eq!(s.maneuver.frequency_hz, p.chosen.maneuver.frequency_hz);
    let full = taiji::analysis::crlb::crlb_at_rate(&s, s.sample_rate_hz).unwrap();
    let off = worst_off(&p.chosen.crlb.unwrap(), &full);
    assert!(p.chosen.rate_hz < s.sample_rate_hz, "{}", p.chosen.rate_hz);
    assert!(
        off < 2e-5,
        "the final bound at {} Hz is {off:.2e} off",
        p.chosen.rate_hz
    );
}

/// The search bound of a 10⁵ s window, where the samples per period set the search
/// rate, is its full-rate bound within 3 % (half the samples per period: 6 % off).
#[test]
fn the_search_bound_of_a_long_window_is_within_three_percent_of_the_full_rate_bound() {
    let s = load("duration_s = 1.0e5\n");
    let p = plan::plan(&s, &PlanOptions::default()).unwrap();
    let f_fast = p
        .candidates
        .iter()
        .flat_map(|c| c.frequencies_hz)
        .fold(0.0, f64::max);
    assert!(
        p.search_rate_hz > tuning::SEARCH_SAMPLES / 1.0e5,
        "{}",
        p.search_rate_hz
    );
    assert!((p.search_rate_hz / f_fast - tuning::SEARCH_SAMPLES_PER_PERIOD).abs() < 1e-9);
    let (s, _) = plan::resolve(s).unwrap();
    assert_eq!(s.maneuver.frequency_hz, p.chosen.maneuver.frequency_hz);
    let full = taiji::analysis::crlb::crlb_at_rate(&s, s.sample_rate_hz).unwrap();
    let looser = p.chosen.worst_ratio / plan::worst_ratio(&s, &full).0 - 1.0;
    assert!(looser.abs() < 0.03, "the search bound is {looser:.3} off");
    // The search judged the chosen maneuver at its own rate: that bound, against the
    // full rate's, is what the samples per period buy.
    let at_search = taiji::analysis::crlb::crlb_at_rate(&s, p.search_rate_hz).unwrap();
    let search_looser = plan::worst_ratio(&s, &at_search).0 / plan::worst_ratio(&s, &full).0 - 1.0;
    assert!(
        search_looser.abs() < 0.03,
        "the search rate's bound of the chosen maneuver is {search_looser:.3} off the full rate's"
    );
}
