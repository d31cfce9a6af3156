//! Times the default campaign in one process and through the process set (accelerated),
//! then measures real-time latency of the set and the machine's own timing floor; run
//! it through `tools/bench`.
use std::time::Instant;
use taiji::campaign;
use taiji::estimate::Method;
use taiji::scenario::Scenario;

fn main() {
    let s = Scenario::default();
    let n = s.n_samples();
    let mut times: Vec<f64> = (0..5)
        .map(|i| {
            let t0 = Instant::now();
            let r = campaign::run(&s, 1 + i, Method::Joint, |_| {});
            std::hint::black_box(r.estimate);
            t0.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    let med = times[2];
    println!(
        "default campaign, in-process: {n} samples ({} s simulated)",
        s.duration_s
    );
    println!(
        "  wall time   median {:.3} s   (min {:.3} s, max {:.3} s, 5 runs)",
        med, times[0], times[4]
    );
    println!("  throughput  {:.0} samples/s", n as f64 / med);

    // The same campaign through the process set, accelerated lock-step.
    let sup = std::env::current_exe()
        .unwrap()
        .parent()
        .unwrap()
        .join("../taiji-supervisor");
    let dir = std::env::temp_dir().join(format!("taiji-bench-{}", std::process::id()));
    let prefix = format!("tjbench{}_", std::process::id());
    let run_set = |extra: &[&str], scenario: Option<&std::path::Path>| -> serde_json::Value {
        let mut c = std::process::Command::new(&sup);
        c.args(["--out", dir.to_str().unwrap(), "--bus-prefix", &prefix])
            .args(extra)
            .stdout(std::process::Stdio::null());
        if let Some(sc) = scenario {
            c.arg("--scenario").arg(sc);
        }
        let st = c
            .status()
            .expect("run taiji-supervisor (build it with --bins)");
        assert!(st.code().is_some_and(|c| c <= 1), "supervisor failed: {st}");
        let text = std::fs::read_to_string(dir.join("report.json")).unwrap();
        serde_json::from_str(&text).unwrap()
    };
    let mut set_times: Vec<f64> = (0..3)
        .map(|_| run_set(&[], None)["wall_time_s"].as_f64().unwrap())
        .collect();
    set_times.sort_by(f64::total_cmp);
    println!("default campaign, process set (accelerated lock-step, 4 processes + supervisor):");
    println!(
        "  wall time   median {:.3} s   (min {:.3} s, max {:.3} s, 3 runs; start-up and shutdown included)",
        set_times[1], set_times[0], set_times[2]
    );
    println!("  throughput  {:.0} samples/s", n as f64 / set_times[1]);

    // Real-time: 2000 s simulated at ×100 (1 ms tick period), 20 s of wall time.
    let sc = dir.join("rt.toml");
    std::fs::write(
        &sc,
        "name = \"bench-rt\"\nduration_s = 2000.0\n[maneuver]\nfrequency_hz = 2e-3\n",
    )
    .unwrap();
    let r = run_set(&["--realtime", "--time-scale", "100"], Some(&sc));
    let t = &r["timing"];
    let e = &t["end_to_end_latency_us"];
    println!("real time ×100, 2000 s simulated (20 000 ticks, 1 ms period):");
    println!(
        "  end-to-end latency (plant publish → estimate published)  p50 {:.0} µs  p99 {:.0} µs  max {:.0} µs",
        e["p50"].as_f64().unwrap(),
        e["p99"].as_f64().unwrap(),
        e["max"].as_f64().unwrap()
    );
    for (hop, v) in t["hop_latency_us"].as_object().unwrap() {
        println!(
            "  hop {hop:<17} p50 {:.0} µs  p99 {:.0} µs  max {:.0} µs",
            v["p50"].as_f64().unwrap(),
            v["p99"].as_f64().unwrap(),
            v["max"].as_f64().unwrap()
        );
    }
    println!(
        "  missed deadlines {} (estimate out > 1 period after the tick was due)   samples lost {}",
        t["missed_deadlines"], t["samples_lost"]
    );
    if let Some(line) = taiji::report::scheduling_line(t) {
        println!("  scheduling  {line}");
    }
    platform_floor(20_000, 1_000_000);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The machine's own timing floor: one thread (SCHED_FIFO 43 if allowed) sleeping to
/// absolute deadlines `period_ns` apart, nothing else of ours running. Its overshoots
/// beyond one period are deadlines no process set on this machine can meet.
fn platform_floor(ticks: u64, period_ns: u64) {
    let fifo = taiji::timing::enter_fifo(43).is_ok();
    let t0 = taiji::timing::monotonic_ns() + period_ns;
    let mut over: Vec<u64> = Vec::with_capacity(ticks as usize);
    for k in 0..ticks {
        let due = t0 + k * period_ns;
        let ts = libc::timespec {
            tv_sec: (due / 1_000_000_000) as libc::time_t,
            tv_nsec: (due % 1_000_000_000) as libc::c_long,
        };
        // SAFETY: valid timespec; a null remainder is allowed with TIMER_ABSTIME.
        unsafe {
            libc::clock_nanosleep(
                libc::CLOCK_MONOTONIC,
                libc::TIMER_ABSTIME,
                &ts,
                std::ptr::null_mut(),
            )
        };
        over.push(taiji::timing::monotonic_ns().saturating_sub(due));
    }
    over.sort_unstable();
    let q = |f: f64| over[((over.len() - 1) as f64 * f) as usize] as f64 / 1e3;
    println!(
        "platform floor: one {} thread sleeping to {} µs deadlines, {} ticks:",
        if fifo {
            "SCHED_FIFO"
        } else {
            "normal-priority"
        },
        period_ns / 1000,
        ticks
    );
    println!(
        "  wake-up overshoot p50 {:.0} µs  p99 {:.0} µs  max {:.0} µs   late by > 1 period: {}",
        q(0.5),
        q(0.99),
        q(1.0),
        over.iter().filter(|&&o| o > period_ns).count()
    );
}
