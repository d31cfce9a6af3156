//! The CLI: a user mistake gets a one-line error and exit code 2, never a panic trace.

mod support;
mod tmpdir;
use std::process::Command;

#[test]
fn a_malformed_scenario_is_a_clear_error_not_a_panic() {
    let dir = tmpdir::TmpDir::new("cli");
    let f = dir.join("bad.toml");
    std::fs::write(&f, "duration_s = -1.0\n").unwrap();
    let out = support::calib()
        .args(["run", "--scenario"])
        .arg(&f)
        .arg("--out")
        .arg(&dir)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("duration_s") && !err.contains("panicked"),
        "{err}"
    );
    let out = support::calib()
        .args(["crlb", "--scenario", "/nonexistent/x.toml"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot read scenario"));
}

#[test]
fn run_writes_the_documented_report() {
    let dir = tmpdir::TmpDir::new("cli-run");
    let out = support::calib()
        .args(["run", "--seed", "3", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(table.contains("IS2 rz") && table.contains("Requirements met: yes"));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
    assert_eq!(v["mode"], "in-process");
    assert_eq!(v["seed"], 3);
    assert_eq!(v["requirements"]["met"], true);
    for is in v["inertial_sensors"].as_array().unwrap() {
        for q in ["beta", "k", "com_offset"] {
            for f in ["truth", "estimate", "sigma", "crlb"] {
                assert_eq!(is[q][f].as_array().unwrap().len(), 3, "{q}.{f}");
            }
        }
    }
}

/// `run --seed N` is the Monte Carlo's run of seed N, bit for bit: `--seed` overrides
/// the scenario's seed for the priors' ground-calibration draw too (it drew them at the
/// file's seed, so a Monte Carlo outlier could not be run again alone).
#[test]
fn run_at_a_seed_is_the_monte_carlos_run_of_that_seed() {
    let dir = tmpdir::TmpDir::new("cli-seed");
    let (one, mc) = (dir.join("run"), dir.join("mc"));
    for (args, out) in [
        (["run", "--seed", "3"], &one),
        (["montecarlo", "--seed", "3"], &mc),
    ] {
        let mut c = support::calib();
        c.args(args);
        if args[0] == "montecarlo" {
            c.args(["--runs", "1"]);
        }
        let o = c.arg("--out").arg(out).output().unwrap();
        assert!(
            o.status.code().is_some_and(|c| c <= 1),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let read = |p: std::path::PathBuf| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let run = read(one.join("report.json"));
    let mc = read(mc.join("montecarlo.json"));
    // One seed: every resample of the seeds is that seed, so each group's interval
    // over the seeds is its mean alone.
    for g in 0..3 {
        let m = mc["chi2_by_group"][g].as_f64().unwrap();
        for end in 0..2 {
            let v = mc["chi2_interval_by_group"][g][end].as_f64().unwrap();
            assert!((v - m).abs() <= 1e-12 * m, "group {g}: {v} against {m}");
        }
    }
    let theirs = &mc["reports"][0];
    assert_eq!(theirs["seed"], 3);
    for (a, b) in run["inertial_sensors"]
        .as_array()
        .unwrap()
        .iter()
        .zip(theirs["inertial_sensors"].as_array().unwrap())
    {
        for q in ["beta", "com_offset"] {
            for f in ["truth", "estimate", "sigma"] {
                assert_eq!(a[q][f], b[q][f], "{q}.{f}");
            }
        }
    }
}

#[test]
fn montecarlo_with_no_runs_or_seeds_past_the_end_is_a_user_error() {
    let out = support::calib()
        .args(["montecarlo", "--runs", "0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--runs") && !err.contains("panicked"), "{err}");
    let out = support::calib()
        .args([
            "montecarlo",
            "--runs",
            "2",
            "--seed",
            "18446744073709551615",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--seed") && !err.contains("panicked"), "{err}");
}

#[test]
fn a_scenario_name_with_a_newline_is_refused() {
    let e = taiji::sim::scenario::Scenario::from_toml_str("name = \"a\\n# injected\"\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("name"), "{e}");
}

#[test]
fn run_help_describes_every_option() {
    let out = support::calib().args(["run", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    for (opt, words) in [
        ("--scenario", "Scenario file"),
        ("--seed", "Seed of every noise stream"),
        ("--out", "Output folder"),
        ("--plots", "implies --record"),
    ] {
        assert!(help.contains(opt) && help.contains(words), "{opt}: {help}");
    }
}

#[test]
fn an_out_folder_through_a_file_is_refused_before_the_campaign_runs() {
    let dir = tmpdir::TmpDir::new("cli-outfile");
    let file = dir.join("plain-file");
    std::fs::write(&file, "x").unwrap();
    for out in [file.clone(), file.join("below")] {
        let o = support::calib()
            .args(["run", "--out"])
            .arg(&out)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2));
        let err = String::from_utf8_lossy(&o.stderr);
        // The up-front check's message (the campaign never started: no table).
        assert!(
            err.contains("cannot create this folder") && !err.contains("panicked"),
            "{err}"
        );
        assert!(o.stdout.is_empty());
    }
}

/// A user error leaves no folder behind: the inputs are checked before `--out` is
/// made (a missing scenario, a recording that is no HDF5 file, a refused plan).
#[test]
fn a_user_error_creates_no_output_folder() {
    let dir = tmpdir::TmpDir::new("cli-noout");
    let bad = dir.join("bad.h5");
    std::fs::write(&bad, "not hdf5").unwrap();
    let out = dir.join("X");
    let nosuch = dir.join("nosuch.toml");
    let cases: [Vec<&std::ffi::OsStr>; 5] = [
        vec!["run".as_ref(), "--scenario".as_ref(), nosuch.as_ref()],
        vec!["replay".as_ref(), "--telemetry".as_ref(), bad.as_ref()],
        vec!["export".as_ref(), "--telemetry".as_ref(), bad.as_ref()],
        vec!["plan".as_ref(), "--scenario".as_ref(), nosuch.as_ref()],
        vec![
            "montecarlo".as_ref(),
            "--scenario".as_ref(),
            nosuch.as_ref(),
        ],
    ];
    for args in cases {
        let o = support::calib()
            .args(&args)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(!out.exists(), "{args:?} created {}: {err}", out.display());
    }
}

/// `crlb` prints the planned frequency to a readable precision (it printed
/// 0.0006000240009600384 Hz), and the planner's warning comes once (it came twice,
/// through the log and again as `warning:`).
#[test]
fn crlb_prints_readable_numbers_and_the_planners_warning_once() {
    let o = support::calib().arg("crlb").output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("maneuver 0.6000 mHz"), "{text}");
    assert!(!text.contains("0.00060002"), "{text}");
    // The run's bound first, then the maneuver's alone (the thrusters' random motion
    // left out), looser.
    let beta_x = |line: &str| -> f64 {
        let inside = line.split('[').nth(1).unwrap();
        inside.split(',').next().unwrap().trim().parse().unwrap()
    };
    let run = text.lines().find(|l| l.starts_with("IS1")).unwrap();
    let alone = text
        .lines()
        .find(|l| l.starts_with("maneuver alone: IS1"))
        .unwrap_or_else(|| panic!("{text}"));
    assert!(beta_x(alone) > beta_x(run), "{text}");
    let dir = tmpdir::TmpDir::new("cli-warn");
    let short = dir.join("short.toml");
    std::fs::write(&short, "name = \"short\"\nduration_s = 300.0\n").unwrap();
    let o = support::calib()
        .args(["crlb", "--scenario"])
        .arg(&short)
        .env("TAIJI_PLAN_CACHE", "off")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.matches("flying the best maneuver").count(), 1, "{err}");
}

/// With dropouts `crlb` is the bound of the data a run at the scenario's seed keeps,
/// says so, and is looser than the clean campaign's (it was the clean one's, and
/// dropout runs came out at 1.4–1.9× it).
#[test]
fn crlb_with_dropouts_says_whose_data_it_bounds() {
    let dir = tmpdir::TmpDir::new("cli-drop");
    let lossy = dir.join("lossy.toml");
    std::fs::write(
        &lossy,
        "name = \"lossy\"\nseed = 7\n[faults]\nis_dropout_rate = 0.05\n",
    )
    .unwrap();
    let beta_x = |text: &str| -> f64 {
        let line = text.lines().find(|l| l.starts_with("IS1")).unwrap();
        let inside = line.split('[').nth(1).unwrap();
        inside.split(',').next().unwrap().trim().parse().unwrap()
    };
    let clean = support::calib().arg("crlb").output().unwrap();
    let clean = String::from_utf8_lossy(&clean.stdout).to_string();
    let o = support::calib()
        .args(["crlb", "--scenario"])
        .arg(&lossy)
        .output()
        .unwrap();
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("a run at seed 7 keeps"), "{text}");
    assert!(!clean.contains("keeps"), "{clean}");
    assert!(beta_x(&text) > 1.2 * beta_x(&clean), "{clean}\n{text}");
}

/// `tools/launch --help` prints at once, before any build, and names every way to
/// launch (it ran cargo first and left out --two-hosts and --host).
#[test]
fn launch_help_is_immediate_and_lists_every_mode() {
    let t0 = std::time::Instant::now();
    let o = Command::new(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/launch"))
        .arg("--help")
        .env("CARGO", "/nonexistent/cargo-must-not-run")
        .env("PATH", "/usr/bin:/bin")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for w in [
        "--two-hosts",
        "--host NAME",
        "--graph",
        "--scenario",
        "--out",
    ] {
        assert!(text.contains(w), "{w}: {text}");
    }
    assert!(t0.elapsed().as_secs() < 10, "took {:?}", t0.elapsed());
}

#[test]
fn a_mistyped_maneuver_is_warned_of_and_the_report_says_what_came_from_the_data() {
    // 1 Hz typed for 1 mHz: its bound is 24× the requirement (32× while the SRP's turn
    // was no β evidence).
    let dir = tmpdir::TmpDir::new("cli-typo");
    let f = dir.join("typo.toml");
    std::fs::write(&f, "name = \"typo\"\n[maneuver]\nfrequency_hz = 1.0\n").unwrap();
    let out = support::calib()
        .args(["run", "--scenario"])
        .arg(&f)
        .arg("--out")
        .arg(dir.join("typo"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("Warning: the written maneuver's bound is 24.0× the requirement")
            && text.contains("taiji-calib plan")
            && text.contains("Predicted from the bound: requirements met with probability 0.00–")
            && text.contains("with this run's thruster motion, its bound gives"),
        "{text}"
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("typo/report.json")).unwrap())
            .unwrap();
    assert!(r["warnings"][0].as_str().unwrap().contains("24.0×"), "{r}");
    assert!(
        r["predicted_probability_requirements_met"]
            .as_f64()
            .unwrap()
            < 1e-3
    );
    // The bound gives each σ, not how the errors go together: with one common error the
    // maneuver's would still be below 10 %. The thrusters' random motion, which the run's
    // bound holds, calibrates β (15 of 20 seeds met the requirements): far likelier.
    let upper = r["predicted_probability_requirements_met_upper"]
        .as_f64()
        .unwrap();
    let run = &r["probability_requirements_met_run_bound"];
    let (lo, hi) = (run[0].as_f64().unwrap(), run[1].as_f64().unwrap());
    assert!(upper < 0.1 && 0.3 < lo && lo <= hi && hi <= 1.0, "{r}");
    for is in r["inertial_sensors"].as_array().unwrap() {
        for q in ["beta", "k", "com_offset"] {
            for a in 0..3 {
                let share = is[q]["data_share"][a].as_f64().unwrap();
                let (c, p, cp) = (
                    is[q]["crlb"][a].as_f64().unwrap(),
                    is[q]["prior_sigma"][a].as_f64().unwrap(),
                    is[q]["crlb_with_prior"][a].as_f64().unwrap(),
                );
                assert!(
                    (0.0..=1.0).contains(&share) && cp < c.min(p),
                    "{q} {a}: {is}"
                );
            }
        }
    }
    // The default (planned) maneuver: no warning, the requirements all but certain.
    let out = support::calib()
        .args(["run", "--out"])
        .arg(dir.join("default"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(!text.contains("Warning"), "{text}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("default/report.json")).unwrap())
            .unwrap();
    assert!(
        r["predicted_probability_requirements_met"]
            .as_f64()
            .unwrap()
            > 0.99
    );
    assert!(r.get("warnings").is_none() && r.get("prior_dominated").is_none());
    let share = r["inertial_sensors"][0]["beta"]["data_share"][1]
        .as_f64()
        .unwrap();
    assert!(share > 0.999, "{share}");
}
