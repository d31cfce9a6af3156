//! The C99 host (`examples/c/host.c`, built by `tools/c-host` against the no_std static
//! library) on a recording of a scenario other than the defaults: its estimates and σ
//! are bit-identical to `taiji-calib replay` of the same file, and its binary holds no
//! Rust standard library.

use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_taiji-calib");

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("taiji-c-host-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn json(bytes: &[u8]) -> serde_json::Value {
    serde_json::from_slice(bytes)
        .unwrap_or_else(|e| panic!("not JSON ({e}): {}", String::from_utf8_lossy(bytes)))
}

/// Every estimate and σ of every IS, as bits.
fn bits(v: &serde_json::Value) -> Vec<(String, u64)> {
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

#[test]
fn the_c_host_reproduces_replay_bit_for_bit_and_links_no_rust_std() {
    let dir = tmp("replay");
    let scenario = dir.join("other.toml");
    std::fs::write(
        &scenario,
        "name = \"c-host\"\nseed = 4242\nduration_s = 3000.0\n\
         [maneuver]\nfrequency_hz = 0.003\ntorque_amplitude_nm = [2.0e-6, 3.0e-6, 2.5e-6]\n\
         [[inertial_sensor]]\nbeta = [5.6e-8, 5.45e-8, 7.3e-8]\ncom_offset_m = [0.2130, -0.1240, 0.0011]\n\
         [[inertial_sensor]]\nbeta = [5.5e-8, 5.58e-8, 7.4e-8]\ncom_offset_m = [0.2170, 0.1262, -0.0006]\n\
         [faults]\nupset_rate = 1e-4\nis_dropout_rate = 0.01\n",
    )
    .unwrap();
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
    assert!(
        dir.join("replay/report.json").exists(),
        "{}",
        String::from_utf8_lossy(&replay.stderr)
    );
    let host = Command::new(root().join("tools/c-host"))
        .env("TAIJI_CALIB_BIN", BIN)
        .arg("--telemetry")
        .arg(&tel)
        .arg("--out")
        .arg(dir.join("c"))
        .output()
        .unwrap();
    assert!(
        host.status.success(),
        "{}",
        String::from_utf8_lossy(&host.stderr)
    );
    let c = json(&host.stdout);
    let r = json(&std::fs::read(dir.join("replay/report.json")).unwrap());
    let (cb, rb) = (bits(&c), bits(&r));
    assert_eq!(cb.len(), 36);
    for (x, y) in cb.iter().zip(&rb) {
        assert_eq!(x, y, "C host and replay differ at {}", x.0);
    }
    // No symbol of Rust's std in the linked C program (core and libm only).
    let nm = Command::new("nm")
        .arg(dir.join("c/taiji-c-host"))
        .output()
        .unwrap();
    assert!(nm.status.success());
    let syms = String::from_utf8_lossy(&nm.stdout);
    let std_syms: Vec<&str> = syms
        .lines()
        .filter(|l| l.contains("3std") || l.contains("std..") || l.contains("_ZN3std"))
        .take(5)
        .collect();
    assert!(
        std_syms.is_empty(),
        "Rust std symbols in the C host: {std_syms:?}"
    );
    assert!(syms.contains("taiji_estimator_update"));
    let _ = std::fs::remove_dir_all(&dir);
}
