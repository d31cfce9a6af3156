//! The estimator on emulated flight CPUs (`tools/flight-qemu`: the no_std core as a
//! bare-metal program under QEMU) replays recordings of scenarios other than the
//! defaults, with faults, bit-identical to `taiji-calib replay` of the same file, and
//! reports its instructions and stack per call: an ARM Cortex-M7 (mps2-an500) and a
//! SPARC V8 LEON3 (leon3_generic, the BM3803's class). Needs qemu-system-arm,
//! qemu-system-sparc, gcc-sparc64-linux-gnu and nightly Rust with rust-src
//! (tools/test installs them).

mod hosts;
mod support;
mod tmpdir;

use hosts::{assert_same_bits, json, record_and_replay, root, BIN};
use std::path::Path;
use std::process::Command;

/// A scenario with other truths than the defaults, seed `seed`, `duration_s` long, with
/// upsets, IS and star-tracker dropouts.
fn scenario(name: &str, seed: u64, duration_s: f64) -> String {
    format!(
        "name = \"{name}\"\nseed = {seed}\nduration_s = {duration_s:.1}\n\
         [maneuver]\nfrequency_hz = 0.003\ntorque_amplitude_nm = [2.0e-6, 3.0e-6, 2.5e-6]\n\
         [[inertial_sensor]]\nbeta = [5.6e-8, 5.45e-8, 7.3e-8]\ncom_offset_m = [0.2130, -0.1240, 0.0011]\n\
         [[inertial_sensor]]\nbeta = [5.5e-8, 5.58e-8, 7.4e-8]\ncom_offset_m = [0.2170, 0.1262, -0.0006]\n\
         [faults]\nupset_rate = 1e-4\nis_dropout_rate = 0.01\nstar_dropout_rate = 0.02\n"
    )
}

/// Records `toml`, replays it, runs `tools/flight-qemu --cpu cpu` on the recording and
/// holds the result against the replay: the same bits, the same status, and figures
/// measured on the target that are there and plausible.
fn replays_bit_for_bit(dir: &Path, toml: &str, cpu: &str, cpu_name: &str, updates: u64) {
    let (tel, r) = record_and_replay(dir, toml);
    let run = Command::new(root().join("tools/flight-qemu"))
        .env("TAIJI_CALIB_BIN", BIN)
        .args(["--cpu", cpu, "--telemetry"])
        .arg(&tel)
        .arg("--out")
        .arg(dir.join(cpu))
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "tools/flight-qemu --cpu {cpu} failed (tools/test installs what it needs):\n{}\n{}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
    let f = json(&run.stdout);
    assert_same_bits(&f, &r, cpu_name);
    assert_eq!(f["estimator_status"], r["estimator_status"]["bits"]);
    let fl = &f["flight"];
    assert_eq!(fl["cpu"], cpu_name);
    assert_eq!(fl["updates"], updates);
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
    // Every call within a 16 KB stack (the solve's work is the caller's scratch).
    for call in ["init", "update", "solve", "checkpoint", "restore", "finish"] {
        let depth = fl["stack_bytes"][call].as_u64().unwrap();
        assert!(depth <= 16 * 1024, "{call}: {fl}");
    }
}

#[test]
fn the_emulated_cortex_m7_reproduces_replay_bit_for_bit() {
    let dir = support::tmp("flight-m7");
    replays_bit_for_bit(
        &dir,
        &scenario("flight-m7", 5151, 3000.0),
        "m7",
        "cortex-m7",
        30000,
    );
}

/// Big-endian, 32-bit, register windows, its own FPU: the same bits. A shorter
/// recording than the Cortex-M7's (the image's build takes most of the time).
#[test]
fn the_emulated_leon3_reproduces_replay_bit_for_bit() {
    let dir = support::tmp("flight-leon3");
    replays_bit_for_bit(
        &dir,
        &scenario("flight-leon3", 3803, 1000.0),
        "leon3",
        "leon3",
        10000,
    );
}

/// Runs `tool` (`tools/c-host` or `tools/flight-qemu`) on the recording `tel` with
/// `args`, output in `out`; its JSON.
fn host_json(tool: &str, tel: &Path, out: &Path, args: &[&str]) -> serde_json::Value {
    let o = Command::new(root().join(tool))
        .env("TAIJI_CALIB_BIN", BIN)
        .arg("--telemetry")
        .arg(tel)
        .arg("--out")
        .arg(out)
        .args(args)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{tool} {args:?} failed:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    json(&o.stdout)
}

/// A bus that lost 6000 samples (10 min at 10 Hz) mid-campaign: the updates that
/// bridge the gap, 8 ticks a call, are measured on both emulated CPUs and on the
/// x86-64 C host: each within 16 KB of stack, and the three give the same bits.
#[test]
fn updates_that_bridge_a_long_gap_stay_within_16_kb_on_every_cpu() {
    let dir = support::tmp("flight-gap");
    let (tel, _) = record_and_replay(&dir, &scenario("flight-gap", 4242, 1500.0));
    let gap = "5000:6000";
    let run = |tool: &str, cpu: &[&str], out: &str| {
        host_json(tool, &tel, &dir.join(out), &[cpu, &["--gap", gap]].concat())
    };
    let x86 = run("tools/c-host", &[], "c-host");
    for (cpu, f) in [
        ("x86-64", x86.clone()),
        ("m7", run("tools/flight-qemu", &["--cpu", "m7"], "m7")),
        (
            "leon3",
            run("tools/flight-qemu", &["--cpu", "leon3"], "leon3"),
        ),
    ] {
        let fl = &f["flight"];
        assert_eq!(fl["updates"], 9000, "{cpu}: {fl}");
        assert_eq!(fl["gap_ticks_max"], 6000, "{cpu}: {fl}");
        let after = fl["stack_bytes"]["update_after_gap"].as_u64().unwrap();
        assert!(after > 1024 && after <= 16 * 1024, "{cpu}: {fl}");
        assert_same_bits(&f, &x86, cpu);
        assert_eq!(f["samples_used"], x86["samples_used"], "{cpu}");
    }
    // Every tick is used or rejected, the gap's among them.
    let (used, rejected) = (
        x86["samples_used"].as_u64(),
        x86["samples_rejected"].as_u64(),
    );
    assert_eq!(used.unwrap() + rejected.unwrap(), 15000);
}

/// The build for EDAC RAM (`--edac`, feature `edac`: no seal) gives the default build's
/// bits on both emulated CPUs, says it does not check for upsets, and saves each update
/// the seal's checks and reseals of the parts it writes.
#[test]
fn the_edac_build_gives_the_same_bits_without_the_seals_instructions() {
    let dir = support::tmp("flight-edac");
    let (tel, r) = record_and_replay(&dir, &scenario("flight-edac", 2718, 1000.0));
    for cpu in ["m7", "leon3"] {
        let run = |edac: bool| {
            let flags: &[&str] = if edac { &["--edac"] } else { &[] };
            let out = dir.join(format!("{cpu}-{edac}"));
            host_json(
                "tools/flight-qemu",
                &tel,
                &out,
                &[&["--cpu", cpu], flags].concat(),
            )
        };
        let (sealed, edac) = (run(false), run(true));
        assert_same_bits(&edac, &r, cpu);
        assert_same_bits(&sealed, &r, cpu);
        let (fs, fe) = (&sealed["flight"], &edac["flight"]);
        assert_eq!(
            (fs["upset_check"].as_u64(), fe["upset_check"].as_u64()),
            (Some(1), Some(0))
        );
        let p50 = |f: &serde_json::Value| f["update_instructions"]["p50"].as_u64().unwrap();
        // The seal is a quarter to a third of an update (25 % on a LEON3, 33 % on a
        // Cortex-M7 over the default campaign).
        assert!(10 * p50(fe) < 9 * p50(fs), "{fs} {fe}");
    }
}

#[test]
fn a_wrong_cpu_is_refused() {
    let out = Command::new(root().join("tools/flight-qemu"))
        .args(["--cpu", "z80"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("must be m7 or leon3"), "{err}");
}
