//! The CLI: a user mistake gets a one-line error and exit code 2, never a panic trace.

use std::process::Command;

fn calib() -> Command {
    Command::new(env!("CARGO_BIN_EXE_taiji-calib"))
}

#[test]
fn a_malformed_scenario_is_a_clear_error_not_a_panic() {
    let dir = std::env::temp_dir().join(format!("taiji-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("bad.toml");
    std::fs::write(&f, "duration_s = -1.0\n").unwrap();
    let out = calib()
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
    let out = calib()
        .args(["crlb", "--scenario", "/nonexistent/x.toml"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot read scenario"));
}

#[test]
fn run_writes_the_documented_report() {
    let dir = std::env::temp_dir().join(format!("taiji-cli-run-{}", std::process::id()));
    let out = calib()
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

#[test]
fn montecarlo_with_no_runs_or_seeds_past_the_end_is_a_user_error() {
    let out = calib()
        .args(["montecarlo", "--runs", "0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--runs") && !err.contains("panicked"), "{err}");
    let out = calib()
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
    let e = taiji::scenario::Scenario::from_toml_str("name = \"a\\n# injected\"\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("name"), "{e}");
}

#[test]
fn run_help_describes_every_option() {
    let out = calib().args(["run", "--help"]).output().unwrap();
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
    let dir = std::env::temp_dir().join(format!("taiji-cli-outfile-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("plain-file");
    std::fs::write(&file, "x").unwrap();
    for out in [file.clone(), file.join("below")] {
        let o = calib().args(["run", "--out"]).arg(&out).output().unwrap();
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
