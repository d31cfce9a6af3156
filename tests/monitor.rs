//! `taiji-calib monitor` against real runs: driven in tmux (send-keys, capture-pane)
//! on a `--realtime --time-scale 100` set, its screen shows every parameter's row
//! with numbers, the status and the latency; a second monitor stopped with SIGSTOP
//! mid-run and `--once --json` snapshots taken meanwhile change nothing: the run loses
//! no sample, its estimator loop allocates nothing and its estimates are bit-identical
//! to the in-process run. A stop asked from the monitor (after its y/n question) stops
//! the run through the supervisor; `n` does not.

mod common;
mod support;
mod tmpdir;

use common::{estimates, in_process, prefix, report, serial, shm_left};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::Duration;

const SUPERVISOR: &str = env!("CARGO_BIN_EXE_taiji-supervisor");
const CALIB: &str = env!("CARGO_BIN_EXE_taiji-calib");

/// 1500 s at ×100: 15 s of wall time.
const SCENARIO: &str =
    "name = \"mon\"\nseed = 5\nduration_s = 1500.0\n[maneuver]\nfrequency_hz = 1e-2\n";

fn supervisor(sc: &Path, out: &Path, pfx: &str) -> Child {
    Command::new(SUPERVISOR)
        .arg("--scenario")
        .arg(sc)
        .arg("--out")
        .arg(out)
        .args(["--bus-prefix", pfx, "--realtime", "--time-scale", "100"])
        .env("TAIJI_ALLOC_TRACE", common::alloc_trace_file(out))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn wait_for(what: &str, timeout: Duration, cond: impl FnMut() -> bool) {
    common::wait_every(Duration::from_millis(50), what, timeout, cond);
}

/// A private tmux server (its own socket), killed when dropped.
struct Tmux {
    socket: String,
}

impl Tmux {
    fn new(tag: &str) -> Tmux {
        let t = Tmux {
            socket: format!("tjmon{}{tag}", std::process::id()),
        };
        assert!(
            Command::new("tmux")
                .arg("-V")
                .status()
                .is_ok_and(|s| s.success()),
            "tmux is missing: tools/test installs it"
        );
        t
    }

    fn cmd(&self) -> Command {
        let mut c = Command::new("tmux");
        c.args(["-L", &self.socket]);
        c
    }

    /// A window of 160 × 50 running `args` (exec'd: the pane's pid is the monitor's).
    fn start(&self, window: &str, args: &[&str]) -> i32 {
        let line = format!("exec {CALIB} {}", args.join(" "));
        let new = if self.has_session() {
            vec!["new-window", "-t", "mon", "-n", window]
        } else {
            vec![
                "new-session",
                "-d",
                "-s",
                "mon",
                "-n",
                window,
                "-x",
                "160",
                "-y",
                "50",
            ]
        };
        let ok = self.cmd().args(&new).arg(&line).status().unwrap();
        assert!(ok.success(), "tmux {new:?}");
        // Keep the pane after the monitor exits, to read how it ended.
        let _ = self
            .cmd()
            .args([
                "set-option",
                "-t",
                &format!("mon:{window}"),
                "remain-on-exit",
                "on",
            ])
            .status();
        let pid = self
            .cmd()
            .args([
                "display-message",
                "-p",
                "-t",
                &format!("mon:{window}"),
                "#{pane_pid}",
            ])
            .output()
            .unwrap();
        String::from_utf8_lossy(&pid.stdout).trim().parse().unwrap()
    }

    fn has_session(&self) -> bool {
        self.cmd()
            .args(["has-session", "-t", "mon"])
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    }

    fn capture(&self, window: &str) -> String {
        let o = self
            .cmd()
            .args(["capture-pane", "-p", "-t", &format!("mon:{window}")])
            .output()
            .unwrap();
        String::from_utf8_lossy(&o.stdout).into_owned()
    }

    fn keys(&self, window: &str, keys: &[&str]) {
        let ok = self
            .cmd()
            .args(["send-keys", "-t", &format!("mon:{window}")])
            .args(keys)
            .status()
            .unwrap();
        assert!(ok.success());
    }

    /// Has the pane's process exited?
    fn dead(&self, window: &str) -> bool {
        let o = self
            .cmd()
            .args([
                "display-message",
                "-p",
                "-t",
                &format!("mon:{window}"),
                "#{pane_dead}",
            ])
            .output()
            .unwrap();
        String::from_utf8_lossy(&o.stdout).trim() == "1"
    }
}

impl Drop for Tmux {
    fn drop(&mut self) {
        let _ = self.cmd().arg("kill-server").stderr(Stdio::null()).status();
    }
}

fn signal(pid: i32, sig: i32) {
    // SAFETY: sending a signal has no memory-safety preconditions.
    unsafe { libc::kill(pid, sig) };
}

fn snapshot(pfx: &str, extra: &[&str]) -> Value {
    let o = support::calib()
        .args(["monitor", "--bus-prefix", pfx, "--once", "--json"])
        .args(extra)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

/// A parameter row of the screen: `IS1  β x  <number>`.
fn row_with_numbers(screen: &str, is: usize, par: &str, axis: &str) -> bool {
    let head = format!("IS{is}  {par} {axis}");
    screen.lines().any(|l| {
        l.find(&head).is_some_and(|i| {
            let rest = &l[i + head.len()..];
            let nums = rest
                .split_whitespace()
                .filter(|w| w.trim_end_matches(['m', 'µ']).parse::<f64>().is_ok())
                .count();
            nums >= 3
        })
    })
}

/// The JSON snapshot of a run in progress, checked field by field.
fn check_snapshot(j: &Value, with_truth: bool) {
    let run = &j["run"];
    assert_eq!(run["state"], "running", "{j}");
    assert_eq!(run["pacing"], "realtime");
    assert_eq!(run["time_scale"], 100.0);
    assert!(run["tick"].as_u64().unwrap() > 0);
    assert_eq!(run["n_samples"], 15000);
    let e = &j["estimate"];
    let params = e["parameters"].as_array().unwrap();
    assert_eq!(params.len(), 18, "{e}");
    for p in params {
        assert!(p["estimate"].as_f64().unwrap().is_finite(), "{p}");
        assert!(p["sigma"].as_f64().unwrap() > 0.0, "{p}");
        assert_eq!(p["truth"].is_number(), with_truth, "{p}");
        assert_eq!(p["err_over_sigma"].is_number(), with_truth, "{p}");
    }
    assert!(e["status"].is_string() && e["status_word"].is_u64());
    assert_eq!(e["chi2_per_dof"].as_object().unwrap().len(), 4);
    assert_eq!(e["rejections"].as_array().unwrap().len(), 11);
    let l = &j["latency"];
    assert_eq!(l["realtime"], true);
    let e2e = &l["end_to_end_us"];
    assert!(e2e["count"].as_u64().unwrap() > 0, "{l}");
    let (p50, p99, max) = (
        e2e["p50"].as_f64().unwrap(),
        e2e["p99"].as_f64().unwrap(),
        e2e["max"].as_f64().unwrap(),
    );
    assert!(0.0 < p50 && p50 <= p99 && p99 <= max, "{e2e}");
    assert_eq!(l["hops_since_start_us"].as_object().unwrap().len(), 3);
    // Each stage's segment over the window; together they make up the end to end.
    let segs = l["segments_us"].as_object().unwrap();
    assert_eq!(segs.len(), 3, "{l}");
    for (name, s) in segs {
        assert!(s["count"].as_u64().unwrap() > 0, "{name}: {s}");
        assert!(s["p50"].as_f64().unwrap() > 0.0, "{name}: {s}");
    }
    let procs = j["processes"].as_array().unwrap();
    let names: Vec<&str> = procs.iter().map(|p| p["name"].as_str().unwrap()).collect();
    for stage in [
        "taiji-commander",
        "taiji-plant",
        "taiji-fee",
        "taiji-estimator",
    ] {
        assert!(names.contains(&stage), "{names:?}");
    }
    for p in procs {
        assert!(p["heartbeat_age_ms"].as_f64().unwrap() < 1000.0, "{p}");
        assert_eq!(p["restarts"], 0);
    }
}

fn finish(child: Child) -> Output {
    child.wait_with_output().unwrap()
}

#[test]
fn a_monitor_in_tmux_shows_the_run_and_stalled_or_detaching_monitors_change_nothing() {
    let _s = serial();
    let dir = tmpdir::TmpDir::new("monitor-tmux");
    let sc = dir.join("scenario.toml");
    std::fs::write(&sc, SCENARIO).unwrap();
    let out = dir.join("out");
    let pfx = prefix("m");
    let tmux = Tmux::new("a");
    // Started before the run: it waits for it.
    let planned = out.join("scenario.toml");
    let ui = tmux.start(
        "ui",
        &[
            "monitor",
            "--bus-prefix",
            &pfx,
            "--scenario",
            sc.to_str().unwrap(),
        ],
    );
    let child = supervisor(&sc, &out, &pfx);
    let stalled = tmux.start("stalled", &["monitor", "--bus-prefix", &pfx]);
    // The screen, once the run is well under way.
    let mut screen = String::new();
    wait_for("the monitor's screen", Duration::from_secs(60), || {
        screen = tmux.capture("ui");
        // After the first solves: the status is then a verdict, not "no solution yet".
        screen.contains("running ·")
            && !screen.contains("no_solution")
            && screen.contains("last 10 s: end to end")
            && row_with_numbers(&screen, 2, "r", "z")
            && [
                "commander->plant out",
                "plant->fee out",
                "fee->estimator out",
            ]
            .iter()
            .all(|s| screen.contains(s))
    });
    for is in [1, 2] {
        for par in ["β", "k", "r"] {
            for axis in ["x", "y", "z"] {
                assert!(
                    row_with_numbers(&screen, is, par, axis),
                    "IS{is} {par} {axis} missing:\n{screen}"
                );
            }
        }
    }
    // The status word, by name (early in a run it may still be anything).
    let names = ["ok"].into_iter().chain(taiji::sim::msg::STATUS_NAMES);
    let status = screen.split("status ").nth(2).unwrap_or_default();
    assert!(
        names.into_iter().any(|n| status.starts_with(n)) && screen.contains("(word 0x"),
        "{screen}"
    );
    assert!(
        screen.contains("χ²/dof angular") && screen.contains("linear "),
        "{screen}"
    );
    // "last 10 s: end to end P50 / P99 / MAX (N samples)", each a positive number.
    let e2e = screen
        .lines()
        .find_map(|l| l.split("last 10 s: end to end").nth(1))
        .unwrap();
    let figures: Vec<f64> = e2e
        .split(['/', '('])
        .take(3)
        .filter_map(|w| w.trim().parse::<f64>().ok())
        .collect();
    assert!(
        figures.len() == 3 && figures.iter().all(|&x| x > 0.0),
        "{e2e}"
    );
    for seg in [
        "commander->plant out",
        "plant->fee out",
        "fee->estimator out",
    ] {
        assert!(screen.contains(seg), "{seg}: {screen}");
    }
    assert!(screen.contains("hop commander->plant"), "{screen}");
    assert!(screen.contains("missed deadlines"), "{screen}");
    assert!(
        screen.contains("estimator") && screen.contains("alloc 0"),
        "{screen}\n{}",
        common::alloc_trace(&out)
    );
    // A monitor stopped mid-run (SIGSTOP) while the run goes on: snapshots taken
    // meanwhile show it advancing at its pace (×100 at 10 Hz: 1000 ticks/s).
    signal(stalled, libc::SIGSTOP);
    let a = snapshot(&pfx, &["--scenario", planned.to_str().unwrap()]);
    check_snapshot(&a, true);
    std::thread::sleep(Duration::from_secs(2));
    let b = snapshot(&pfx, &[]);
    check_snapshot(&b, false);
    let advanced = b["run"]["tick"].as_u64().unwrap() - a["run"]["tick"].as_u64().unwrap();
    assert!(advanced > 1500, "{advanced} ticks in about 3 s");
    // `q` leaves the monitor only, mid-run.
    tmux.keys("ui", &["q"]);
    wait_for("the monitor to quit", Duration::from_secs(10), || {
        tmux.dead("ui")
    });
    signal(stalled, libc::SIGCONT);
    let o = finish(child);
    let stderr = String::from_utf8_lossy(&o.stderr);
    // 1500 s misses the β requirement (exit 1, as in-process); it must run to the end.
    assert!(matches!(o.status.code(), Some(0 | 1)), "{stderr}");
    let r = report(&out);
    assert_eq!(
        r["estimator_loop_allocations"],
        0,
        "{stderr}\n{}",
        common::alloc_trace(&out)
    );
    assert_eq!(r["timing"]["samples_lost"], 0);
    assert_eq!(estimates(&r), in_process(&sc, 5));
    // The resumed monitor saw the run end and keeps its last screen.
    wait_for(
        "the resumed monitor to see the end",
        Duration::from_secs(20),
        || tmux.capture("stalled").contains("the run ended"),
    );
    assert!(!ui_pid_alive(ui));
    tmux.keys("stalled", &["q"]);
    wait_for("the monitor to quit", Duration::from_secs(10), || {
        tmux.dead("stalled")
    });
    // Nothing of the run is left on the bus once every monitor left.
    let left = shm_left(&pfx);
    assert!(left.is_empty(), "left in /dev/shm: {left:?}");
}

fn ui_pid_alive(pid: i32) -> bool {
    PathBuf::from(format!("/proc/{pid}")).exists()
        && std::fs::read_to_string(format!("/proc/{pid}/stat")).is_ok_and(|s| !s.contains(") Z "))
}

#[test]
fn a_stop_asked_from_the_monitor_is_confirmed_first_and_stops_the_run_through_the_supervisor() {
    let _s = serial();
    let dir = tmpdir::TmpDir::new("monitor-stop");
    let sc = dir.join("scenario.toml");
    std::fs::write(&sc, SCENARIO).unwrap();
    let out = dir.join("out");
    let pfx = prefix("s");
    let tmux = Tmux::new("s");
    let child = supervisor(&sc, &out, &pfx);
    tmux.start("ui", &["monitor", "--bus-prefix", &pfx]);
    wait_for("the run on the monitor", Duration::from_secs(60), || {
        tmux.capture("ui").contains("running ·")
    });
    // Asked, then declined: nothing happens.
    tmux.keys("ui", &["s"]);
    wait_for("the question", Duration::from_secs(5), || {
        tmux.capture("ui").contains("Stop the run?")
    });
    tmux.keys("ui", &["n"]);
    wait_for("the answer", Duration::from_secs(5), || {
        tmux.capture("ui").contains("not stopped")
    });
    std::thread::sleep(Duration::from_millis(500));
    assert!(tmux.capture("ui").contains("running ·"));
    // Asked and confirmed: the supervisor stops every process, as on SIGINT.
    tmux.keys("ui", &["s"]);
    wait_for("the question", Duration::from_secs(5), || {
        tmux.capture("ui").contains("Stop the run?")
    });
    tmux.keys("ui", &["y"]);
    let o = finish(child);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("stop requested from a monitor"), "{stderr}");
    assert!(!out.join("report.json").exists());
    wait_for(
        "the monitor to see the end",
        Duration::from_secs(20),
        || tmux.capture("ui").contains("the run ended"),
    );
    tmux.keys("ui", &["q"]);
    wait_for("the monitor to quit", Duration::from_secs(10), || {
        tmux.dead("ui")
    });
}

#[test]
fn a_snapshot_without_a_run_says_so_and_leaves_nothing_on_the_bus() {
    let pfx = prefix("none");
    let o = support::calib()
        .args([
            "monitor",
            "--bus-prefix",
            &pfx,
            "--once",
            "--json",
            "--timeout",
            "1",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("no run on bus prefix") && err.contains("--timeout"),
        "{err}"
    );
    assert!(o.stdout.is_empty());
    let left = shm_left(&pfx);
    assert!(left.is_empty(), "left in /dev/shm: {left:?}");
    // User mistakes are refused with a line naming the option.
    let o = support::calib()
        .args(["monitor", "--bus-prefix", &pfx, "--once", "--watch", "-1"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let o = support::calib()
        .args(["monitor", "--hosts", "/nonexistent/hosts.toml", "--once"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--hosts"));
}

/// A monitor still attached when a run ends (here stopped with SIGSTOP, so it cannot
/// notice and detach) is no stray node of that run: the next run on the prefix starts.
#[test]
fn a_monitor_left_attached_does_not_keep_the_next_run_from_starting() {
    let _s = serial();
    let dir = tmpdir::TmpDir::new("monitor-next");
    let sc = dir.join("scenario.toml");
    // 300 s at ×100: 3 s of wall time.
    std::fs::write(
        &sc,
        "name = \"next\"\nseed = 5\nduration_s = 300.0\n[maneuver]\nfrequency_hz = 1e-2\n",
    )
    .unwrap();
    let pfx = prefix("n");
    let tmux = Tmux::new("n");
    let first = supervisor(&sc, &dir.join("a"), &pfx);
    let pid = tmux.start("ui", &["monitor", "--bus-prefix", &pfx]);
    wait_for("the run on the monitor", Duration::from_secs(60), || {
        tmux.capture("ui").contains("running ·")
    });
    signal(pid, libc::SIGSTOP);
    let o = finish(first);
    assert!(
        matches!(o.status.code(), Some(0 | 1)),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let o = finish(supervisor(&sc, &dir.join("b"), &pfx));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(matches!(o.status.code(), Some(0 | 1)), "{stderr}");
    assert_eq!(
        report(&dir.join("b"))["estimator_loop_allocations"],
        0,
        "{}",
        common::alloc_trace(&dir.join("b"))
    );
    signal(pid, libc::SIGCONT);
    tmux.keys("ui", &["q"]);
    wait_for("the monitor to quit", Duration::from_secs(10), || {
        tmux.dead("ui")
    });
    let left = shm_left(&pfx);
    assert!(left.is_empty(), "left in /dev/shm: {left:?}");
}
