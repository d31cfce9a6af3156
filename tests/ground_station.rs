//! An outside ground station drives the real set: `tools/ground_station.py`, built only
//! on PyPI's `spacepackets` and `space-packet-parser`, runs a whole cycle over UDP
//! against `taiji-supervisor --ground` (ping, start, the end-of-campaign event, one-shot
//! housekeeping decoded from the XTCE dictionary alone and equal to report.json bit for
//! bit, apply, shutdown), and the set then exits 0. Under `CI=true` a missing python3 or
//! package fails the test; elsewhere it is skipped with a note.

#[allow(dead_code)] // this file uses a few of the process-set helpers
mod common;
mod support;
mod tmpdir;

use std::net::UdpSocket;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const SHORT: &str = "name = \"short\"\nseed = 11\nduration_s = 3000.0\n";

fn tool(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tools")
        .join(name)
}

/// python3 with both packages; under `CI=true` their absence fails the test.
fn outside_tools_here() -> bool {
    let ok = Command::new("python3")
        .arg(tool("ground_packets.py"))
        .arg("check")
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        let why = "python3 with spacepackets and space-packet-parser is missing (tools/test installs them)";
        assert!(std::env::var("CI").as_deref() != Ok("true"), "{why}");
        eprintln!("skipped: {why}");
    }
    ok
}

/// The set under test: stopped (SIGTERM, then SIGKILL) if the test fails first.
struct Set(Option<Child>);

impl Drop for Set {
    fn drop(&mut self) {
        if let Some(c) = self.0.as_mut() {
            // SAFETY: sending a signal has no memory-safety preconditions.
            unsafe { libc::kill(c.id() as i32, libc::SIGTERM) };
            let t0 = Instant::now();
            while matches!(c.try_wait(), Ok(None)) && t0.elapsed() < Duration::from_secs(10) {
                std::thread::sleep(Duration::from_millis(20));
            }
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

#[test]
fn an_outside_python_ground_station_runs_a_whole_cycle() {
    if !outside_tools_here() {
        return;
    }
    let t0 = Instant::now();
    let dir = support::tmp("cycle");
    let sc = support::write_scenario(&dir, SHORT);
    let out = dir.join("out");
    let xtce = dir.join("dictionary.xtce");
    let dict = support::calib()
        .args(["ground", "dictionary", "--format", "xtce"])
        .output()
        .unwrap();
    assert!(dict.status.success());
    std::fs::write(&xtce, &dict.stdout).unwrap();
    let pfx = common::prefix("gstation");
    let port = UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let to = format!("127.0.0.1:{port}");
    let mut set = Set(Some(
        Command::new(env!("CARGO_BIN_EXE_taiji-supervisor"))
            .arg("--scenario")
            .arg(&sc)
            .arg("--out")
            .arg(&out)
            .args(["--bus-prefix", &pfx, "--ground", &to])
            .args(["--realtime", "--time-scale", "1000"])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    ));
    // The key file is created, then written: wait for its 64 characters.
    let key = out.join("ground.key");
    common::wait_every(
        Duration::from_millis(20),
        "the key file",
        Duration::from_secs(120),
        || std::fs::metadata(&key).is_ok_and(|m| m.len() >= 64),
    );
    let station = Command::new("python3")
        .arg(tool("ground_station.py"))
        .args(["--to", &to, "--seed", "5"])
        .arg("--key")
        .arg(&key)
        .arg("--xtce")
        .arg(&xtce)
        .arg("--report-dir")
        .arg(&out)
        .output()
        .unwrap();
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    let (said, err) = (text(&station.stdout), text(&station.stderr));
    println!("{said}");
    assert_eq!(station.status.code(), Some(0), "{said}{err}");
    assert!(
        said.contains("36 values decoded from the XTCE equal"),
        "{said}"
    );
    // Shut down by the station's function 5: the supervisor ends by itself, exit 0.
    let mut child = set.0.take().unwrap();
    let t1 = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t1.elapsed() > Duration::from_secs(30) {
            set.0 = Some(child);
            panic!("the set did not end within 30 s of its shutdown");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert!(common::pids_with(&pfx, "taiji-").is_empty());
    println!("the cycle took {:.1} s", t0.elapsed().as_secs_f64());
}
