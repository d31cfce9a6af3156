//! Helpers of the tests that run the estimator outside the Rust binaries (the C host,
//! the emulated flight CPU) and hold their result against `taiji-calib replay`.

use std::path::{Path, PathBuf};
use std::process::Command;

pub const BIN: &str = env!("CARGO_BIN_EXE_taiji-calib");

pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

pub fn json(bytes: &[u8]) -> serde_json::Value {
    serde_json::from_slice(bytes)
        .unwrap_or_else(|e| panic!("not JSON ({e}): {}", String::from_utf8_lossy(bytes)))
}

/// Every estimate and σ of every IS, as bits.
pub fn bits(v: &serde_json::Value) -> Vec<(String, u64)> {
    let mut out = Vec::new();
    for (i, is) in v["inertial_sensors"].as_array().unwrap().iter().enumerate() {
        for p in ["beta", "k", "com_offset"] {
            for q in ["estimate", "sigma"] {
                for (a, x) in is[p][q].as_array().unwrap().iter().enumerate() {
                    out.push((
                        format!("IS{} {p} {q} {a}", i + 1),
                        x.as_f64().unwrap().to_bits(),
                    ));
                }
            }
        }
    }
    out
}

/// Records a campaign of the scenario `toml` in `dir` and replays it: the recording's
/// path and the replay's report.
pub fn record_and_replay(dir: &Path, toml: &str) -> (PathBuf, serde_json::Value) {
    let scenario = dir.join("other.toml");
    std::fs::write(&scenario, toml).unwrap();
    let run = Command::new(BIN)
        .args(["run", "--record", "--scenario"])
        .arg(&scenario)
        .arg("--out")
        .arg(dir.join("run"))
        .output()
        .unwrap();
    let tel = dir.join("run/telemetry.h5");
    assert!(tel.exists(), "{}", String::from_utf8_lossy(&run.stderr));
    let replay = Command::new(BIN)
        .args(["replay", "--telemetry"])
        .arg(&tel)
        .arg("--out")
        .arg(dir.join("replay"))
        .output()
        .unwrap();
    let report = dir.join("replay/report.json");
    assert!(
        report.exists(),
        "{}",
        String::from_utf8_lossy(&replay.stderr)
    );
    (tel, json(&std::fs::read(report).unwrap()))
}

/// `host`'s estimates and σ equal the replay's, bit for bit.
pub fn assert_same_bits(host: &serde_json::Value, replay: &serde_json::Value, who: &str) {
    let (hb, rb) = (bits(host), bits(replay));
    assert_eq!(hb.len(), 36);
    for (x, y) in hb.iter().zip(&rb) {
        assert_eq!(x, y, "{who} and replay differ at {}", x.0);
    }
}
