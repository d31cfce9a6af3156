//! The C99 host (`examples/c/host.c`, built by `tools/c-host` against the no_std static
//! library) on a recording of a scenario other than the defaults: its estimates and σ
//! are bit-identical to `taiji-calib replay` of the same file, and its binary holds no
//! Rust standard library.

mod hosts;
mod support;
mod tmpdir;

use hosts::{assert_same_bits, json, record_and_replay, root, BIN};
use std::process::Command;

#[test]
fn the_c_host_reproduces_replay_bit_for_bit_and_links_no_rust_std() {
    let dir = support::tmp("c-host");
    let (tel, r) = record_and_replay(
        &dir,
        "name = \"c-host\"\nseed = 4242\nduration_s = 3000.0\n\
         [maneuver]\nfrequency_hz = 0.003\ntorque_amplitude_nm = [2.0e-6, 3.0e-6, 2.5e-6]\n\
         [[inertial_sensor]]\nbeta = [5.6e-8, 5.45e-8, 7.3e-8]\ncom_offset_m = [0.2130, -0.1240, 0.0011]\n\
         [[inertial_sensor]]\nbeta = [5.5e-8, 5.58e-8, 7.4e-8]\ncom_offset_m = [0.2170, 0.1262, -0.0006]\n\
         [faults]\nupset_rate = 1e-4\nis_dropout_rate = 0.01\n",
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
    assert_same_bits(&json(&host.stdout), &r, "C host");
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
}
