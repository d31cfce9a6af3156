//! Helpers shared by the process-set tests (one host and two): a run's report and the
//! in-process estimates it must equal bit for bit.

use serde_json::Value;
use std::path::Path;
use taiji::sim::estimate::Method;
use taiji::sim::scenario::Scenario;

pub fn report(out: &Path) -> Value {
    let text = std::fs::read_to_string(out.join("report.json")).expect("report.json");
    serde_json::from_str(&text).unwrap()
}

/// The estimates (value and σ) of a report, per IS: the fields that must be bit-identical.
pub fn estimates(r: &Value) -> Vec<Value> {
    r["inertial_sensors"]
        .as_array()
        .unwrap()
        .iter()
        .map(|is| {
            serde_json::json!([
                is["beta"]["estimate"],
                is["beta"]["sigma"],
                is["k"]["estimate"],
                is["k"]["sigma"],
                is["com_offset"]["estimate"],
                is["com_offset"]["sigma"],
            ])
        })
        .collect()
}

/// In-process estimates (`taiji-calib run`) of the same scenario and seed, serialised
/// the same way.
pub fn in_process(scenario: &Path, seed: u64) -> Vec<Value> {
    // Planned as the supervisor plans it, when the file gives no maneuver; the seed is
    // the scenario's from there on, as `--seed` makes it.
    let (s, _) = taiji::analysis::plan::resolve(Scenario::load(scenario).unwrap()).unwrap();
    let s = Scenario { seed, ..s };
    let res = taiji::analysis::campaign::run(&s, seed, Method::Joint, |_| {});
    let crlb = taiji::analysis::crlb::crlb(&s).unwrap();
    let r =
        taiji::analysis::report::Report::new(&s, seed, "in-process", "joint", &res.estimate, &crlb);
    // Through the same text form as report.json, so both sides parse identically.
    let text = serde_json::to_string(&r).unwrap();
    estimates(&serde_json::from_str(&text).unwrap())
}

/// Processes whose command line carries this bus prefix (the set of one test).
#[allow(dead_code)] // the tests that kill a process of the set use it
pub fn pids_with(prefix: &str, exe: &str) -> Vec<i32> {
    let mut pids = Vec::new();
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(pid) = entry.file_name().to_string_lossy().parse::<i32>() else {
            continue;
        };
        let Ok(cmd) = std::fs::read(entry.path().join("cmdline")) else {
            continue;
        };
        let cmd = String::from_utf8_lossy(&cmd).replace('\0', " ");
        if cmd.contains(prefix) && cmd.split(' ').next().is_some_and(|a| a.ends_with(exe)) {
            pids.push(pid);
        }
    }
    pids
}

/// The process-set tests of one binary run one at a time: a real-time run measures
/// the set alone, not several sets sharing two cores.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

#[allow(dead_code)] // not every test binary runs sets
pub fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

/// A bus prefix of this test process alone (`tools/test`'s leftover check knows `tjt`).
#[allow(dead_code)] // not every test binary runs sets
pub fn prefix(name: &str) -> String {
    format!("tjt{}{name}_", std::process::id())
}

/// Entries of /dev/shm whose names start with `prefix`: what a run left there.
#[allow(dead_code)] // not every test binary runs sets
pub fn shm_left(prefix: &str) -> Vec<String> {
    std::fs::read_dir("/dev/shm")
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(prefix))
        .collect()
}

/// Poll `cond` every `poll` until it holds; fail naming `what` after `timeout`.
#[allow(dead_code)] // the tests that wait on a running set use it
pub fn wait_every(
    poll: std::time::Duration,
    what: &str,
    timeout: std::time::Duration,
    mut cond: impl FnMut() -> bool,
) {
    let t0 = std::time::Instant::now();
    while !cond() {
        assert!(t0.elapsed() < timeout, "timed out waiting for {what}");
        std::thread::sleep(poll);
    }
}

/// Where a run's estimator writes a backtrace of each allocation in its filter loop
/// (`TAIJI_ALLOC_TRACE`, set on the supervisor: the stages inherit it).
pub fn alloc_trace_file(dir: &Path) -> std::path::PathBuf {
    dir.join("alloc-trace.txt")
}

/// The backtraces written there, for an assertion's message.
pub fn alloc_trace(dir: &Path) -> String {
    std::fs::read_to_string(alloc_trace_file(dir))
        .unwrap_or_else(|_| "no allocation traced".to_string())
}
