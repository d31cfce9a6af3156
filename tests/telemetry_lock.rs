//! The recording's lock and child processes, alone in its own test binary: no other
//! test of this process may start a child while the recording is open, as another
//! test's child started between libhdf5's open and the descriptor's close-on-exec flag
//! would inherit the lock.

mod support;
mod tmpdir;
use std::process::Command;

/// A child process started while a recording is open (a test's python3, a supervisor's
/// process) must not inherit libhdf5's descriptor and its lock: once the reader is
/// dropped, the file can be written again although the child still runs.
#[test]
fn a_child_started_while_a_recording_is_open_does_not_hold_its_lock() {
    use taiji::sim::estimate::Method;
    use taiji::telemetry::{read, Meta, Writer};
    let dir = support::tmp("child");
    let s = taiji::sim::scenario::Scenario::from_toml_str(
        "name = \"child\"\nseed = 2\nduration_s = 3000.0\n",
    )
    .unwrap();
    let path = dir.join("child.h5");
    let meta = Meta::of(&s, 2, "joint", "in-process");
    let record = |what: &str| {
        let mut w = Writer::create(&path, &meta, s.n_samples(), 64)
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        taiji::analysis::campaign::run_into(&s, 2, Method::Joint, |_| {}, &mut w).unwrap();
        w.finish(&[], &[]).unwrap();
    };
    record("first recording");
    let reader = read::open(&path).unwrap();
    let mut child = Command::new("sleep").arg("30").spawn().unwrap();
    drop(reader);
    let again = std::panic::catch_unwind(|| record("the same file written again"));
    child.kill().ok();
    child.wait().ok();
    if let Err(e) = again {
        std::panic::resume_unwind(e);
    }
}
