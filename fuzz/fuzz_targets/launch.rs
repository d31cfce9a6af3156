//! The launch description parser (`LaunchDescription::parse`, src/runtime/launch.rs)
//! on any text: Ok or an error with a message, never a panic. A description accepted is
//! then used as the supervisor uses it: its processes with and without recording, the
//! ground process, each process's host, the host in charge, and every timeout as a
//! `Duration` (the supervisor converts each; a value it cannot convert would panic there).
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::time::Duration;
use taiji::runtime::launch::LaunchDescription;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    match LaunchDescription::parse(&text, "fuzz") {
        Ok(d) => {
            for record in [false, true] {
                for p in d.processes(record) {
                    let _ = d.host_of(p);
                    assert!(!p.name.is_empty());
                }
            }
            let _ = d.ground_process();
            let _ = d.in_charge();
            for (key, v) in [
                ("heartbeat_timeout_s", d.heartbeat_timeout_s),
                ("ready_timeout_s", d.ready_timeout_s),
                ("stop_timeout_s", d.stop_timeout_s),
                ("link_timeout_s", d.link_timeout_s),
            ] {
                assert!(
                    Duration::try_from_secs_f64(v).is_ok(),
                    "{key} = {v} was accepted but is no Duration the supervisor can wait"
                );
            }
        }
        Err(e) => {
            let msg = e.to_string();
            assert!(!msg.trim().is_empty(), "an error without a message");
        }
    }
});
