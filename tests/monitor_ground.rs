//! `taiji-calib monitor --ground`: the monitor's screen and snapshot drawn from the
//! ground link's telemetry alone, against a fake onboard end (tests/fake_onboard) that
//! streams housekeeping structures 1 and 2 to whoever pinged last. The estimate comes
//! through bit for bit, the health fills the run, latency and process views, and what
//! only the shared memory carries is null (JSON) or `n/a` (screen).

mod fake_onboard;
mod support;
mod tmpdir;

use fake_onboard::{Behaviour, Fake};
use serde_json::Value;
use std::path::Path;
use std::process::Output;
use std::time::Duration;
use support::{calib, tmp};
use taiji::ground::auth::Key;

fn streaming(key: Key) -> Fake {
    Fake::start(
        key,
        Behaviour {
            stream_every: Some(Duration::from_millis(100)),
            ..Default::default()
        },
    )
}

fn monitor(to: &str, key: &Path, extra: &[&str]) -> Output {
    calib()
        .args(["monitor", "--ground", to, "--key"])
        .arg(key)
        .arg("--once")
        .args(extra)
        .output()
        .unwrap()
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

#[test]
fn a_snapshot_from_the_telemetry_alone() {
    let dir = tmp("snapshot");
    let kp = dir.join("ground.key");
    let fake = streaming(Key::create(&kp).unwrap());
    let o = monitor(
        &fake.to(),
        &kp,
        &["--json", "--watch", "0.5", "--timeout", "3"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let j: Value = serde_json::from_slice(&o.stdout).unwrap();
    // The link itself, from structure 2.
    let g = &j["ground"];
    assert_eq!(g["address"], fake.to());
    assert_eq!(
        (g["mode"].as_u64(), g["campaign"].as_u64()),
        (Some(1), Some(2))
    );
    assert_eq!(g["tc_accepted"], 5);
    assert!(g["unavailable"].as_array().unwrap().len() >= 5);
    assert!(j["bus_prefix"].is_null());
    // The run.
    let run = &j["run"];
    assert_eq!(run["state"], "running");
    assert_eq!(run["campaign"], 2);
    assert_eq!(
        (run["tick"].as_u64(), run["n_samples"].as_u64()),
        (Some(500), Some(1000))
    );
    assert_eq!(run["progress"], 0.5);
    for k in ["supervisor_pid", "elapsed_s", "pacing", "maneuver"] {
        assert!(run[k].is_null(), "run.{k}: {}", run[k]);
    }
    // The estimate, bit for bit, from structure 1.
    let want = fake_onboard::estimate();
    let e = &j["estimate"];
    assert_eq!(e["status_word"], 0x18);
    assert_eq!(
        (e["samples_used"].as_u64(), e["samples_rejected"].as_u64()),
        (Some(480), Some(20))
    );
    assert_eq!(e["tick"], 499);
    assert_eq!(e["chi2_per_dof"]["common_mode"], 1.02);
    assert!(e["sigma_inflation"].is_null() && e["rejections"].is_null());
    let params = e["parameters"].as_array().unwrap();
    assert_eq!(params.len(), 18);
    let groups = [
        ("beta", want.beta, want.beta_sigma),
        ("k", want.k, want.k_sigma),
        ("r", want.r_b, want.r_sigma),
    ];
    for p in params {
        let is = p["is"].as_u64().unwrap() as usize - 1;
        let axis = ["x", "y", "z"]
            .iter()
            .position(|a| p["axis"] == *a)
            .unwrap();
        let (_, v, s) = groups.iter().find(|g| p["name"] == g.0).unwrap();
        assert_eq!(
            p["estimate"].as_f64().unwrap().to_bits(),
            v[is][axis].to_bits(),
            "{p}"
        );
        assert_eq!(
            p["sigma"].as_f64().unwrap().to_bits(),
            s[is][axis].to_bits(),
            "{p}"
        );
        assert!(
            p["bound"].is_null() && p["sigma_over_bound"].is_null(),
            "{p}"
        );
    }
    // Latency and processes, from structure 2.
    let l = &j["latency"];
    let since = &l["end_to_end_since_start_us"];
    assert_eq!(
        (
            since["p50"].as_f64(),
            since["p99"].as_f64(),
            since["max"].as_f64()
        ),
        (Some(80.0), Some(120.0), Some(300.0))
    );
    assert!(since["count"].is_null());
    assert!(
        l["end_to_end_us"].is_null() && l["missed_deadlines"].is_null() && l["realtime"].is_null()
    );
    assert_eq!(l["samples_lost"], 7);
    let procs = j["processes"].as_array().unwrap();
    let p = |name: &str| procs.iter().find(|p| p["name"] == name).unwrap().clone();
    assert_eq!(procs.len(), 6);
    let est = p("taiji-estimator");
    assert_eq!(
        (est["restarts"].as_u64(), est["heartbeat_age_ms"].as_f64()),
        (Some(2), Some(21.0))
    );
    assert_eq!(
        (est["next_tick"].as_u64(), est["samples_lost"].as_u64()),
        (Some(500), Some(7))
    );
    assert!(est["host"].is_null());
    let rec = p("taiji-recorder");
    assert_eq!(rec["state"], "down");
    assert!(rec["heartbeat_age_ms"].is_null() && rec["next_tick"].is_null());
    assert_eq!(p("taiji-tmtc")["restarts"], 0);
    // The monitor only pinged (no reports asked for), from a loopback port.
    let heard = fake.heard();
    assert!(!heard.is_empty());
    assert!(heard
        .iter()
        .all(|h| (h.service, h.subtype, h.ack) == (17, 1, 0) && h.mac_ok));
    assert!(heard[0].from.ip().is_loopback());

    // The screen as text and as a PNG.
    let png = dir.join("screen.png");
    let o = monitor(
        &fake.to(),
        &kp,
        &["--watch", "0.3", "--png", png.to_str().unwrap()],
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let screen = text(&o.stdout);
    assert!(
        screen.contains(&format!("taiji monitor · ground link {}", fake.to())),
        "{screen}"
    );
    assert!(
        screen.contains("running · tick 500/1000 (50.0 %)"),
        "{screen}"
    );
    assert!(screen.contains("maneuver: n/a · campaign 2"), "{screen}");
    assert!(screen.contains("rejections by cause: n/a"), "{screen}");
    assert!(
        screen.contains("since start: end to end 80.0 / 120.0 / 300.0"),
        "{screen}"
    );
    assert!(
        screen.contains("missed deadlines n/a · samples lost 7"),
        "{screen}"
    );
    assert!(screen.contains("tmtc"), "{screen}");
    assert!(
        screen.contains("IS2  β z  6.611856e-7    6.61e0        n/a           n/a"),
        "{screen}"
    );
    assert!(
        screen.contains("n/a: not carried by the ground link's telemetry"),
        "{screen}"
    );
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
}

#[test]
fn no_telemetry_exits_1_and_a_refused_ping_exits_2() {
    let dir = tmp("refused");
    let kp = dir.join("ground.key");
    let key = Key::create(&kp).unwrap();
    let silent = Fake::start(
        key.clone(),
        Behaviour {
            silent: true,
            ..Default::default()
        },
    );
    let o = monitor(&silent.to(), &kp, &["--timeout", "0.5"]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains(&format!("no telemetry from {}", silent.to())),
        "{err}"
    );
    drop(silent);
    // Another key: the set answers the ping with bad_mac.
    let fake = streaming(key);
    let other = dir.join("other.key");
    Key::create(&other).unwrap();
    let o = monitor(&fake.to(), &other, &["--timeout", "3"]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("refused the monitor's ping: failure 11 bad_mac"),
        "{err}"
    );
    // --key belongs to --ground, and --ground needs it.
    let o = calib()
        .args(["monitor", "--once", "--key"])
        .arg(&kp)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let o = calib()
        .args(["monitor", "--once", "--ground", &fake.to()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("--key"));
}
