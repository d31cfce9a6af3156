//! Monte Carlo on a cluster: four `montecarlo --shard I/4` jobs and `montecarlo merge`
//! give the single-machine run's table and montecarlo.json byte for byte; a missing, a
//! duplicated, a malformed or a foreign result is an error naming it, never counted.

mod support;
mod tmpdir;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

const RUNS: &str = "8";

fn calib() -> Command {
    let mut c = support::calib();
    // Every job plans the maneuver itself, as on separate cluster nodes.
    c.env("TAIJI_PLAN_CACHE", "off");
    c
}

/// A short planned campaign (2000 s: ~0.1 s a seed).
fn scenario() -> PathBuf {
    static S: OnceLock<PathBuf> = OnceLock::new();
    S.get_or_init(|| {
        let f = remove_at_exit(support::tmp("scenario")).join("short.toml");
        std::fs::write(&f, "name = \"short\"\nduration_s = 2000.0\n").unwrap();
        f
    })
    .clone()
}

fn ok(o: &Output) -> String {
    assert!(
        o.status.success(),
        "exit {:?}: {}",
        o.status.code(),
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn shard(i: u32, extra: &[&str], out: &Path) -> Output {
    calib()
        .args(["montecarlo", "--runs", RUNS, "--scenario"])
        .arg(scenario())
        .arg("--shard")
        .arg(format!("{i}/4"))
        .args(extra)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap()
}

/// A folder shared by the tests through a static (never dropped), removed when the
/// test process exits.
fn remove_at_exit(d: tmpdir::TmpDir) -> PathBuf {
    static SHARED: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());
    static REGISTER: std::sync::Once = std::sync::Once::new();
    extern "C" fn remove_shared() {
        let dirs = SHARED.lock().unwrap_or_else(|e| e.into_inner());
        for d in dirs.iter() {
            let _ = std::fs::remove_dir_all(d);
        }
    }
    // SAFETY: registers a plain function, called once by `exit` after the tests.
    REGISTER.call_once(|| unsafe {
        libc::atexit(remove_shared);
    });
    let d = d.keep();
    SHARED
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push(d.clone());
    d
}

/// The four shards' result files, run once for every test.
fn shards() -> &'static Path {
    static D: OnceLock<PathBuf> = OnceLock::new();
    D.get_or_init(|| {
        let d = remove_at_exit(support::tmp("shards"));
        for i in 0..4 {
            let out = ok(&shard(i, &[], &d));
            assert!(
                out.contains(&format!("shard {i}/4: ran 2 seed(s)")),
                "{out}"
            );
        }
        d
    })
}

/// A folder holding copies of the shards' files for `seeds`.
fn copy(name: &str, seeds: &[u64]) -> tmpdir::TmpDir {
    let d = support::tmp(name);
    for s in seeds {
        let f = format!("run-{s}.json");
        std::fs::copy(shards().join(&f), d.join(&f)).unwrap();
    }
    d
}

fn merge(dirs: &[&Path]) -> Output {
    calib()
        .args(["montecarlo", "merge"])
        .args(dirs)
        .output()
        .unwrap()
}

/// Exit 2, no table, and the error message.
fn refused(o: &Output) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(o.stdout.is_empty() && !err.contains("panicked"), "{err}");
    err
}

#[test]
fn four_shards_merged_are_the_single_run_byte_for_byte() {
    let single = support::tmp("single");
    let table = ok(&calib()
        .args(["montecarlo", "--runs", RUNS, "--scenario"])
        .arg(scenario())
        .arg("--out")
        .arg(&single)
        .output()
        .unwrap());
    let files: Vec<_> = std::fs::read_dir(shards()).unwrap().collect();
    assert_eq!(files.len(), 8, "one file per seed, no temporary left");
    // Two folders, as from two clusters' scratch spaces.
    let (a, b) = (copy("a", &[1, 2, 3, 5, 6, 7]), copy("b", &[4, 8]));
    let merged = support::tmp("merged");
    let merged_table = ok(&calib()
        .args(["montecarlo", "merge"])
        .args([&a, &b])
        .arg("--out")
        .arg(&merged)
        .output()
        .unwrap());
    assert!(table.contains("8 runs from seed 1"), "{table}");
    assert_eq!(merged_table, table);
    let one = std::fs::read(single.join("montecarlo.json")).unwrap();
    let two = std::fs::read(merged.join("montecarlo.json")).unwrap();
    if let Some(at) = (0..one.len().max(two.len())).find(|&i| one.get(i) != two.get(i)) {
        let around = |b: &[u8]| {
            String::from_utf8_lossy(&b[at.saturating_sub(80)..(at + 80).min(b.len())]).into_owned()
        };
        panic!(
            "montecarlo.json differs at byte {at}:\nsingle: {}\nmerged: {}",
            around(&one),
            around(&two)
        );
    }
    let v: serde_json::Value = serde_json::from_slice(&one).unwrap();
    assert_eq!(v["reports"].as_array().unwrap().len(), 8);
}

#[test]
fn a_rerun_shard_keeps_the_results_already_written() {
    let d = copy("rerun", &[2, 6]);
    let before = std::fs::read(d.join("run-2.json")).unwrap();
    std::fs::remove_file(d.join("run-6.json")).unwrap();
    let out = ok(&shard(1, &[], &d));
    assert!(out.contains("ran 1 seed(s), kept 1"), "{out}");
    assert_eq!(std::fs::read(d.join("run-2.json")).unwrap(), before);
    assert_eq!(
        std::fs::read(d.join("run-6.json")).unwrap(),
        std::fs::read(shards().join("run-6.json")).unwrap(),
        "a seed run again gives the same file"
    );
}

#[test]
fn a_missing_shard_is_reported_not_merged() {
    let d = copy("missing", &[1, 2, 4, 5, 6, 8]);
    let err = refused(&merge(&[&d]));
    assert!(err.contains("2 of 8 seeds have no result: 3, 7"), "{err}");
    assert!(err.contains("shard 2/4 wrote none of its 2"), "{err}");
    // A shard cut short: one of its seeds.
    std::fs::copy(shards().join("run-3.json"), d.join("run-3.json")).unwrap();
    let err = refused(&merge(&[&d]));
    assert!(err.contains("1 of 8 seeds have no result: 7"), "{err}");
    assert!(err.contains("shard 2/4 lacks 1 of its 2"), "{err}");
}

#[test]
fn a_duplicated_shard_is_reported_not_counted_twice() {
    let all = copy("all", &[1, 2, 3, 4, 5, 6, 7, 8]);
    let again = copy("again", &[2, 6]);
    let err = refused(&merge(&[&all, &again]));
    assert!(err.contains("2 seed(s) have more than one result"), "{err}");
    let line = err.lines().find(|l| l.contains("seed 6:")).unwrap_or("");
    assert!(
        line.contains(&all.join("run-6.json").display().to_string())
            && line.contains(&again.join("run-6.json").display().to_string()),
        "{err}"
    );
    // The same folder twice is a duplicate too.
    let err = refused(&merge(&[&all, &all]));
    assert!(err.contains("8 seed(s) have more than one result"), "{err}");
}

#[test]
fn a_malformed_or_misnamed_result_file_is_named() {
    let d = copy("malformed", &[1, 2, 3, 4, 5, 6, 7, 8]);
    let f = d.join("run-5.json");
    let text = std::fs::read_to_string(&f).unwrap();
    for (bad, says) in [
        (
            text[..text.len() / 2].to_string(),
            "not a Monte Carlo result file",
        ),
        ("{}".to_string(), "not a Monte Carlo result file"),
        (
            text.replace("montecarlo run 1", "montecarlo run 0"),
            "made by another version",
        ),
        (
            text.replace("duration_s = 2000.0", "duration_s = 2001.0"),
            "does not match its scenario_hash",
        ),
    ] {
        std::fs::write(&f, bad).unwrap();
        let err = refused(&merge(&[&d]));
        assert!(
            err.contains(&f.display().to_string()) && err.contains(says),
            "{says}: {err}"
        );
    }
    // A result under another seed's name.
    std::fs::write(&f, &text).unwrap();
    std::fs::rename(d.join("run-1.json"), d.join("run-9.json")).unwrap();
    let err = refused(&merge(&[&d]));
    assert!(err.contains("run-9.json: holds seed 1"), "{err}");
    let empty = support::tmp("empty");
    let err = refused(&merge(&[&empty]));
    assert!(err.contains("no result files"), "{err}");
}

#[test]
fn results_of_another_campaign_are_refused() {
    let other = support::tmp("other");
    ok(&shard(1, &["--seed", "2"], &other));
    let all = copy("mine", &[1, 2, 3, 4, 5, 6, 7, 8]);
    let err = refused(&merge(&[&all, &other]));
    assert!(
        err.contains("2 different campaigns") && err.contains("differ in first_seed"),
        "{err}"
    );
    // A file from another build, or of another scenario (a different maneuver planned,
    // say): the campaigns are listed with a file of each.
    let f = all.join("run-4.json");
    let text = std::fs::read_to_string(&f).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["campaign"]["build"] = "0.1.0 exe 0000000000000000".into();
    std::fs::write(&f, v.to_string()).unwrap();
    let err = refused(&merge(&[&all]));
    assert!(
        err.contains("differ in build") && err.contains(&f.display().to_string()),
        "{err}"
    );
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let toml = v["scenario_toml"]
        .as_str()
        .unwrap()
        .replace("torque_amplitude_nm = [", "torque_amplitude_nm = [1e-6, ");
    let hash = format!(
        "{:016x}",
        taiji::sim::estimate::snapshot::fnv1a(toml.as_bytes())
    );
    v["scenario_toml"] = toml.into();
    v["campaign"]["scenario_hash"] = hash.into();
    std::fs::write(&f, v.to_string()).unwrap();
    let err = refused(&merge(&[&all]));
    assert!(
        err.contains("differ in scenario_hash") && err.contains(&f.display().to_string()),
        "{err}"
    );
    // Writing into another campaign's folder is refused before anything runs (shard
    // 2/4 from seed 1 is seeds 3 and 7, which the other campaign wrote).
    let err = refused(&shard(2, &[], &other));
    assert!(
        err.contains(&other.join("run-3.json").display().to_string())
            && err.contains("another campaign"),
        "{err}"
    );
}

#[test]
fn bad_shard_arguments_are_user_errors() {
    let d = support::tmp("args");
    for (spec, says) in [
        ("4/4", "0-based"),
        ("0/0", "at least 1"),
        ("x/4", "not a whole number"),
        ("2", "I/N"),
    ] {
        let o = calib()
            .args(["montecarlo", "--runs", "8", "--out"])
            .arg(&d)
            .arg(format!("--shard={spec}"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{spec}: {err}");
        assert!(err.contains(says), "{spec}: {err}");
    }
    // More shards than runs; a shard without a folder for its results.
    let o = calib()
        .args(["montecarlo", "--runs", "3", "--shard", "0/4", "--out"])
        .arg(&d)
        .arg("--scenario")
        .arg(scenario())
        .output()
        .unwrap();
    assert!(refused(&o).contains("more shards than runs"));
    let o = calib()
        .args(["montecarlo", "--runs", "3", "--shard", "0/2"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--out"));
    assert_eq!(std::fs::read_dir(&d).unwrap().count(), 0);
}

#[test]
fn every_key_of_a_result_file_is_documented() {
    let text = std::fs::read_to_string(shards().join("run-1.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let doc =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/report.md")).unwrap();
    let mut keys = Vec::new();
    for (k, x) in v.as_object().unwrap() {
        keys.push(k.clone());
        if k != "report" {
            keys.extend(
                x.as_object()
                    .into_iter()
                    .flat_map(|o| o.keys().map(|n| format!("{k}.{n}"))),
            );
        }
    }
    assert!(keys.len() > 10, "{keys:?}");
    let missing: Vec<_> = keys
        .iter()
        .filter(|k| !doc.contains(&format!("`{k}`")))
        .collect();
    assert!(missing.is_empty(), "docs/report.md lacks {missing:?}");
    assert!(doc.contains("run-<seed>.json"));
}

#[test]
fn a_report_with_nan_and_infinities_reads_back_bit_for_bit() {
    use taiji::analysis::montecarlo::shard::{read_run_file, write_run_file};
    let mut f = read_run_file(&shards().join("run-1.json")).unwrap();
    let is = &mut f.report.inertial_sensors[1];
    is.beta.estimate[0] = f64::NAN;
    is.k.sigma[2] = -f64::NAN;
    is.com_offset.estimate[1] = f64::INFINITY;
    let m = f.report.maneuver.as_mut().unwrap();
    m.peak_rate_rad_s = f64::NEG_INFINITY;
    if let Some(s) = f.report.estimator_status.as_mut() {
        s.chi2_per_dof.insert("linear".into(), f64::NAN);
    }
    let d = support::tmp("nonfinite");
    write_run_file(&d, &f).unwrap();
    let text = std::fs::read_to_string(d.join("run-1.json")).unwrap();
    assert!(
        text.contains("\"/inertial_sensors/1/k/sigma/2\": \"-NaN\""),
        "{text}"
    );
    let back = read_run_file(&d.join("run-1.json")).unwrap();
    let bits = |r: &taiji::analysis::report::Report| {
        let v = serde_json::to_string(r).unwrap();
        let is = &r.inertial_sensors[1];
        let m = r.maneuver.as_ref().unwrap();
        let chi2 = r
            .estimator_status
            .as_ref()
            .map(|s| s.chi2_per_dof["linear"].to_bits());
        (
            v,
            is.beta.estimate[0].to_bits(),
            is.k.sigma[2].to_bits(),
            is.com_offset.estimate[1].to_bits(),
            m.peak_rate_rad_s.to_bits(),
            chi2,
        )
    };
    assert_eq!(bits(&back.report), bits(&f.report));
    // A nonfinite entry that names no null is a malformed file.
    let bad = text.replace(
        "/inertial_sensors/1/k/sigma/2",
        "/inertial_sensors/1/k/sigma/1",
    );
    std::fs::write(d.join("run-1.json"), bad).unwrap();
    let err = read_run_file(&d.join("run-1.json"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("run-1.json") && err.contains("nonfinite"),
        "{err}"
    );
}
