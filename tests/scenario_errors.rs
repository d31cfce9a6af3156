//! Bad scenario files get a clear error that names the key; never a panic.

use taiji::sim::scenario::Scenario;

fn err(text: &str) -> String {
    Scenario::from_toml_str(text)
        .expect_err("scenario should be rejected")
        .to_string()
}

#[test]
fn the_default_scenario_is_the_papers_case_and_valid() {
    let s = Scenario::from_toml_str("").unwrap();
    // No waveform key: the maneuver is to be planned, as without a file.
    assert_eq!(
        s,
        Scenario {
            plan_pending: true,
            ..Scenario::default()
        }
    );
    assert_eq!(s, Scenario::load_or_default(None).unwrap());
    assert_eq!(s.inertial_sensor.len(), 2);
    assert_eq!(s.inertial_sensor[0].com_offset_m, [0.2164, -0.1251, 0.0002]);
    assert_eq!(s.duration_s, 10_000.0);
}

#[test]
fn unknown_keys_are_rejected_by_name() {
    assert!(err("durashun_s = 5.0").contains("durashun_s"));
    assert!(err("[maneuver]\nfreq = 1.0").contains("freq"));
}

#[test]
fn wrong_types_are_rejected() {
    assert!(err("duration_s = \"long\"").contains("duration_s"));
}

#[test]
fn a_file_that_does_not_parse_gets_one_line_with_where_and_the_key() {
    for (text, at) in [
        (
            "name = \"x\"\nduration_s = \"long\"",
            "line 2, column 14 (`duration_s = \"long\"`)",
        ),
        ("[srp\ndc_m_s2 = 1e-8", "line 1"),
        ("[[inertial_sensor]]\ncom_offset_m = [0.2, 0.1]", "line 2"),
        ("[thrusters]\nx = 1", "line 1, column 2 (`[thrusters]`)"),
        (
            "name = \"βγ\"\nseed = \"ζ\"",
            "line 2, column 8 (`seed = \"ζ\"`)",
        ),
        ("name = \"x\" ζ", "line 1"),
    ] {
        let e = err(text);
        assert!(!e.contains('\n') && e.contains(at), "{e}");
    }
}

#[test]
fn negative_duration_and_zero_rate_are_rejected() {
    assert!(err("duration_s = -5.0").contains("duration_s"));
    assert!(err("sample_rate_hz = 0.0").contains("sample_rate_hz"));
}

#[test]
fn non_finite_values_are_rejected() {
    assert!(err("[srp]\nasd_at_3mhz = nan").contains("srp.asd_at_3mhz"));
    assert!(err("[star_tracker]\nnoise_3sigma_arcsec = inf")
        .contains("star_tracker.noise_3sigma_arcsec"));
}

#[test]
fn an_srp_dc_buried_in_its_own_noise_is_rejected() {
    let e = err("[srp]\ndc_m_s2 = 1e-12");
    assert!(e.contains("srp.dc_m_s2") && e.contains("direction"), "{e}");
    // Small but still dominant over its fluctuation: accepted.
    let s = Scenario::from_toml_str("[srp]\ndc_m_s2 = 3e-9").unwrap();
    assert_eq!(s.srp.dc_m_s2, 3e-9);
}

#[test]
fn non_positive_definite_or_asymmetric_inertia_is_rejected() {
    let e = err(
        "[spacecraft]\ninertia_kg_m2 = [[1000.0, 0.0, 0.0], [0.0, -5.0, 0.0], [0.0, 0.0, 900.0]]",
    );
    assert!(
        e.contains("inertia_kg_m2") && e.contains("positive definite"),
        "{e}"
    );
    let e = err(
        "[spacecraft]\ninertia_kg_m2 = [[1000.0, 1.0, 0.0], [0.0, 1000.0, 0.0], [0.0, 0.0, 900.0]]",
    );
    assert!(e.contains("symmetric"), "{e}");
}

#[test]
fn a_maneuver_beyond_the_is_range_is_rejected() {
    let e = err("[maneuver]\ntorque_amplitude_nm = [1e-5, 1e-5, 1e-5]");
    assert!(
        e.contains("maneuver.torque_amplitude_nm") && e.contains("limit"),
        "{e}"
    );
}

#[test]
fn the_default_maneuver_respects_the_range_for_any_offset_up_to_0_3_m() {
    for r in [
        [0.3, 0.0, 0.0],
        [0.0, 0.3, 0.0],
        [0.0, 0.0, 0.3],
        [0.173, 0.173, 0.173],
    ] {
        let text =
            format!("[maneuver]\nfrequency_hz = 1e-3\n[[inertial_sensor]]\ncom_offset_m = {r:?}\n");
        Scenario::from_toml_str(&text).unwrap_or_else(|e| panic!("{r:?}: {e}"));
    }
}

#[test]
fn priors_far_from_the_truth_fly_with_a_warning_naming_the_parameter_and_distance() {
    // Onboard nothing knows the truth: a prior 81 % or 11.9 % off it, or 20 cm, is not
    // refused; the run warns (and shows what it cost).
    let load = |t: &str| Scenario::from_toml_str(t).unwrap_or_else(|e| panic!("{t}: {e}"));
    let w = load("[[inertial_sensor]]\nbeta_prior = [1e-7, 5.5e-8, 7.3e-8]").truth_warnings();
    assert!(
        w.len() == 1
            && w[0].starts_with("inertial_sensor[0] βx: the truth is 81.1 % off its prior"),
        "{w:?}"
    );
    let w = load("[[inertial_sensor]]\nbeta_prior = [6.18e-8, 5.52143e-8, 7.36191e-8]")
        .truth_warnings();
    assert!(w.len() == 1 && w[0].contains("11.9 %"), "{w:?}");
    let w = load("[[inertial_sensor]]\ncom_offset_prior_m = [0.4164, -0.1251, 0.0002]")
        .truth_warnings();
    assert!(
        w.len() == 1 && w[0].starts_with("inertial_sensor[0] rx: the truth is 200.0 mm off"),
        "{w:?}"
    );
    // The priors themselves stay checked: positive, finite, plausible.
    for (t, key) in [
        ("beta_prior = [0.0, 5.5e-8, 7.3e-8]", "beta_prior"),
        ("com_offset_prior_m = [nan, 0.0, 0.0]", "com_offset_prior_m"),
        ("com_offset_prior_m = [3.0, 0.0, 0.0]", "com_offset_prior_m"),
    ] {
        let e = err(&format!("[[inertial_sensor]]\n{t}"));
        assert!(e.contains(&format!("inertial_sensor[0].{key}")), "{e}");
    }
}

#[test]
fn ground_calibration_errors_beyond_what_the_estimator_acquires_are_refused() {
    // β's prior 10 % off is acquired (measured); 15 % and 30 % are not: refused.
    ground_key_refused_above("beta_rel_error", &["0.15", "0.3"], "at most 0.1", "0.1");
    // r's prior error: 5 cm at most (a 100 m box once ran and ended unverified, exit 1,
    // instead of being refused).
    ground_key_refused_above(
        "com_offset_error_m",
        &["0.2", "100"],
        "at most 0.05 m",
        "0.05",
    );
}

/// `[ground_calibration] key = v`: each of `refused` names the key and `limit`; `kept`
/// loads.
fn ground_key_refused_above(key: &str, refused: &[&str], limit: &str, kept: &str) {
    for v in refused {
        let e = err(&format!("[ground_calibration]\n{key} = {v}"));
        assert!(
            e.contains(&format!("ground_calibration.{key}")) && e.contains(limit),
            "{e}"
        );
    }
    Scenario::from_toml_str(&format!("[ground_calibration]\n{key} = {kept}")).unwrap();
}

#[test]
fn a_non_finite_com_offset_is_called_not_finite() {
    let e = err("[[inertial_sensor]]\ncom_offset_m = [nan, 0.1, 0.0]");
    assert!(
        e.contains("inertial_sensor[0].com_offset_m") && e.contains("not a finite number"),
        "{e}"
    );
}

#[test]
fn a_frequency_too_low_for_the_duration_is_rejected() {
    assert!(err("[maneuver]\nfrequency_hz = 1e-5").contains("maneuver.frequency_hz"));
}

#[test]
fn every_shipped_scenario_loads_and_says_what_it_shows() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios");
    let mut names = Vec::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let p = entry.unwrap().path();
        if p.extension().is_some_and(|e| e == "toml") {
            let text = std::fs::read_to_string(&p).unwrap();
            assert!(
                text.starts_with("# "),
                "{} has no leading comment",
                p.display()
            );
            let s = taiji::sim::scenario::Scenario::load(&p)
                .unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            // Every shipped scenario leaves its maneuver to the planner.
            assert!(s.plan_pending, "{}", p.display());
            let (s, _) = taiji::analysis::plan::resolve(s)
                .unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            assert!(taiji::analysis::crlb::crlb(&s).is_some(), "{}", p.display());
            names.push(s.name);
        }
    }
    names.sort();
    assert_eq!(
        names,
        [
            "com-shifted",
            "mission-drift",
            "one-is",
            "paper",
            "srp-doubled",
            "star-tracker-4hz",
            "thruster-force-noise"
        ]
    );
}

/// The key a cross-field error blames: the one between backticks at its start.
fn blamed(e: &str) -> &str {
    e.strip_prefix('`')
        .and_then(|r| r.split('`').next())
        .unwrap_or("")
}

#[test]
fn a_sample_rate_beyond_the_thruster_jitter_names_sample_rate_hz_and_its_range() {
    for text in ["sample_rate_hz = 1e6", "sample_rate_hz = 30"] {
        let e = err(text);
        assert_eq!(blamed(&e), "sample_rate_hz", "{e}");
        // Why, and what is allowed given the other settings (the star tracker's 10 Hz
        // below, the default 0.02 s edge jitter above).
        assert!(e.contains("thruster.edge_jitter_s = 0.02 s"), "{e}");
        assert!(
            e.contains("below 25 Hz") && e.contains("allow 10 Hz"),
            "{e}"
        );
    }
    // The range named is the range accepted.
    assert!(
        Scenario::from_toml_str("sample_rate_hz = 24.9\n[star_tracker]\nrate_hz = 10.0").is_ok()
    );
    assert_eq!(blamed(&err("sample_rate_hz = 25.0")), "sample_rate_hz");
    let e = err("sample_rate_hz = 5.0");
    assert!(
        blamed(&e) == "sample_rate_hz"
            && e.contains("at least 10 Hz")
            && e.contains("star_tracker.rate_hz"),
        "{e}"
    );
}

#[test]
fn a_cross_field_check_blames_the_key_the_file_sets() {
    let e = err("[thruster]\nedge_jitter_s = 0.1");
    assert_eq!(blamed(&e), "thruster.edge_jitter_s", "{e}");
    assert!(e.contains("sample_rate_hz") && e.contains("0.05 s"), "{e}");
    let e = err("[star_tracker]\nrate_hz = 20.0");
    assert_eq!(blamed(&e), "star_tracker.rate_hz", "{e}");
    let e = err("duration_s = 5.0\n[maneuver]\nfrequency_hz = 1.0");
    assert_eq!(blamed(&e), "duration_s", "{e}");
    assert!(e.contains("at least 10 s"), "{e}");
    let e = err("[maneuver]\nfrequency_hz = 2e-4");
    assert_eq!(blamed(&e), "maneuver.frequency_hz", "{e}");
    assert!(e.contains("spacecraft.attitude_hold_hz"), "{e}");
    let e = err("[spacecraft]\nattitude_hold_hz = 1e-3\n[maneuver]\naxis_order = \"xyz\"");
    assert_eq!(blamed(&e), "spacecraft.attitude_hold_hz", "{e}");
    let e = err("duration_s = 2000.0\n[maneuver]\ntorque_amplitude_nm = [2e-6, 2e-6, 2e-6]");
    assert_eq!(blamed(&e), "duration_s", "{e}");
    assert!(e.contains("three periods"), "{e}");
    // Without a waveform key the maneuver is planned for the window instead.
    assert!(Scenario::from_toml_str("duration_s = 2000.0").is_ok_and(|s| s.plan_pending));
    let e = err("[srp]\nasd_at_3mhz = 1e-8");
    assert_eq!(blamed(&e), "srp.asd_at_3mhz", "{e}");
    let e = err("[front_end]\nfull_scale_m_s2 = 1e-8");
    assert_eq!(blamed(&e), "front_end.full_scale_m_s2", "{e}");
}

#[test]
fn when_both_keys_of_a_check_are_set_the_error_names_both() {
    let e = err("sample_rate_hz = 24.0\n[thruster]\nedge_jitter_s = 0.05");
    assert_eq!(blamed(&e), "sample_rate_hz", "{e}");
    assert!(
        e.contains("thruster.edge_jitter_s") && e.contains("no sample rate fits"),
        "{e}"
    );
}

#[test]
fn a_com_offset_beyond_the_maneuver_range_names_the_offset_and_the_torque_that_fits() {
    // A hand-written maneuver (a planned one would fit the offset by itself).
    let e = err(
        "[maneuver]\naxis_order = \"xyz\"\n[[inertial_sensor]]\ncom_offset_m = [1.5, 0.0, 0.0]",
    );
    assert_eq!(blamed(&e), "inertial_sensor[0].com_offset_m", "{e}");
    // An offset along x: rocking about y and z swings it, rocking about x barely.
    assert!(!e.contains("on axis x") && e.contains("on axis y"), "{e}");
    // The torques it names fit.
    let fits = |axis: &str| -> f64 {
        e.split(&format!("on axis {axis} at most "))
            .nth(1)
            .and_then(|r| r.split(' ').next())
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("no torque for {axis} in: {e}"))
    };
    let text = format!(
        "[maneuver]\ntorque_amplitude_nm = [2.5e-6, {:e}, {:e}]\n[[inertial_sensor]]\ncom_offset_m = [1.5, 0.0, 0.0]",
        fits("y"),
        fits("z")
    );
    Scenario::from_toml_str(&text).unwrap_or_else(|e| panic!("{e}"));
}
