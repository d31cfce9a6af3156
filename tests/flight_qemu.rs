//! The estimator on an emulated flight CPU (`tools/flight-qemu`: the no_std core as a
//! bare-metal Cortex-M7 program under QEMU's mps2-an500) replays a recording of a
//! scenario other than the defaults, with faults, bit-identical to `taiji-calib
//! replay` of the same file, and reports its instructions and stack per call.
//! Needs qemu-system-arm (tools/test installs it).

mod hosts;

use hosts::{assert_same_bits, json, record_and_replay, root, tmp, BIN};
use std::process::Command;

#[test]
fn the_emulated_cortex_m7_reproduces_replay_bit_for_bit() {
    let dir = tmp("flight-m7");
    let (tel, r) = record_and_replay(
        &dir,
        "name = \"flight-m7\"\nseed = 5151\nduration_s = 3000.0\n\
         [maneuver]\nfrequency_hz = 0.003\ntorque_amplitude_nm = [2.0e-6, 3.0e-6, 2.5e-6]\n\
         [[inertial_sensor]]\nbeta = [5.6e-8, 5.45e-8, 7.3e-8]\ncom_offset_m = [0.2130, -0.1240, 0.0011]\n\
         [[inertial_sensor]]\nbeta = [5.5e-8, 5.58e-8, 7.4e-8]\ncom_offset_m = [0.2170, 0.1262, -0.0006]\n\
         [faults]\nupset_rate = 1e-4\nis_dropout_rate = 0.01\nstar_dropout_rate = 0.02\n",
    );
    let m7 = Command::new(root().join("tools/flight-qemu"))
        .env("TAIJI_CALIB_BIN", BIN)
        .args(["--cpu", "m7", "--telemetry"])
        .arg(&tel)
        .arg("--out")
        .arg(dir.join("m7"))
        .output()
        .unwrap();
    assert!(
        m7.status.success(),
        "tools/flight-qemu failed (qemu-system-arm is installed by tools/test):\n{}\n{}",
        String::from_utf8_lossy(&m7.stdout),
        String::from_utf8_lossy(&m7.stderr)
    );
    let f = json(&m7.stdout);
    assert_same_bits(&f, &r, "the Cortex-M7");
    assert_eq!(f["estimator_status"], r["estimator_status"]["bits"]);
    // The figures measured on the target are there and plausible.
    let fl = &f["flight"];
    assert_eq!(fl["cpu"], "cortex-m7");
    assert_eq!(fl["updates"], 30000);
    for key in ["p50", "p99", "max"] {
        assert!(
            fl["update_instructions"][key].as_u64().unwrap() > 1000,
            "{fl}"
        );
    }
    assert!(
        fl["solve_instructions_max"].as_u64().unwrap() > 100_000,
        "{fl}"
    );
    for call in ["update", "solve", "finish"] {
        assert!(fl["stack_bytes"][call].as_u64().unwrap() > 256, "{fl}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn leon3_says_it_is_not_built_and_a_wrong_cpu_is_refused() {
    for (cpu, says) in [("leon3", "not built yet"), ("z80", "must be m7 or leon3")] {
        let out = Command::new(root().join("tools/flight-qemu"))
            .args(["--cpu", cpu])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{cpu}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(says), "{cpu}: {err}");
    }
}
