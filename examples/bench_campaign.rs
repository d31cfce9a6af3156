//! Times the default campaign in one process (whole process, in-process, and its
//! stages), a 100-seed Monte Carlo, then the campaign through the process set
//! (accelerated), real-time latency of the set and the machine's own timing floor; run
//! it through `tools/bench` (`--in-process`: the first part only).
use std::time::Instant;
use taiji::analysis::campaign::{self, Stages, Threads};
use taiji::sim::commander::Commander;
use taiji::sim::estimate::{JointEstimator, Method};
use taiji::sim::fee::FrontEnd;
use taiji::sim::model::plant::{Plant, PlantNoise};
use taiji::sim::msg::SensorSample;
use taiji::sim::scenario::Scenario;

/// Wall time the default campaign's whole process should take on two cores [s]
/// (half the 0.66 s it took before the campaign was pipelined and sped up).
const TARGET_S: f64 = 0.33;

/// Sorted times of `runs` calls of `f` [s].
fn times(runs: usize, mut f: impl FnMut(u64)) -> Vec<f64> {
    let mut t: Vec<f64> = (0..runs)
        .map(|i| {
            let t0 = Instant::now();
            f(1 + i as u64);
            t0.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t
}

/// CPU time of the calling thread so far [s].
fn thread_cpu_s() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime fills the timespec it is given.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// Medians of `runs` calls of `f` on this thread: (wall time, thread CPU time) [s].
fn stage(runs: usize, mut f: impl FnMut()) -> (f64, f64) {
    let mut cpu = Vec::with_capacity(runs);
    let wall = times(runs, |_| {
        let c0 = thread_cpu_s();
        f();
        cpu.push(thread_cpu_s() - c0);
    });
    cpu.sort_by(f64::total_cmp);
    (wall[runs / 2], cpu[runs / 2])
}

/// "median M s (min, max, N runs)" of sorted times.
fn spread(t: &[f64]) -> String {
    format!(
        "median {:.3} s   (min {:.3} s, max {:.3} s, {} runs)",
        t[t.len() / 2],
        t[0],
        t[t.len() - 1],
        t.len()
    )
}

/// CPU time used so far by the waited-for children (user + system) [s].
fn children_cpu_s() -> f64 {
    // SAFETY: getrusage fills the struct it is given.
    let mut u: libc::rusage = unsafe { std::mem::zeroed() };
    unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, &mut u) };
    let s = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    s(u.ru_utime) + s(u.ru_stime)
}

fn main() {
    let in_process_only = std::env::args().any(|a| a == "--in-process");
    let s = Scenario::default();
    let n = s.n_samples();
    let bin = std::env::current_exe()
        .unwrap()
        .parent()
        .unwrap()
        .join("../taiji-calib");
    let dir = std::env::temp_dir().join(format!("taiji-bench-{}", std::process::id()));
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "{} cores; load average before the bench (1, 5, 15 min): {}",
        std::thread::available_parallelism().map_or(1, |n| n.get()),
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );

    // The whole process, as a user runs it: CRLB, campaign, report.json/md/html.
    let mut cpu = Vec::new();
    let whole = times(5, |_| {
        let c0 = children_cpu_s();
        let st = std::process::Command::new(&bin)
            .args(["run", "--out"])
            .arg(dir.join("run"))
            .stdout(std::process::Stdio::null())
            .status()
            .expect("run taiji-calib (build it with --bins)");
        assert!(
            st.code().is_some_and(|c| c <= 1),
            "taiji-calib failed: {st}"
        );
        cpu.push(children_cpu_s() - c0);
    });
    cpu.sort_by(f64::total_cmp);
    println!(
        "default campaign, whole process (`taiji-calib run`: CRLB beside the campaign, reports): {n} samples ({} s simulated)",
        s.duration_s
    );
    println!("  wall time   {}", spread(&whole));
    println!(
        "  CPU time    median {:.3} s (user + system, both cores)   ×{:.0} real time",
        cpu[2],
        s.duration_s / whole[2]
    );
    println!(
        "  target      ≤ {TARGET_S} s (≥ {:.0}× real time) on two cores: {}",
        s.duration_s / TARGET_S,
        if whole[2] <= TARGET_S {
            "met"
        } else {
            "not met at this load (see the load average above and the stages below)"
        }
    );

    let report = |what: &str, t: &[f64]| {
        println!("{what}");
        println!("  wall time   {}", spread(t));
        println!("  throughput  {:.0} samples/s", n as f64 / t[t.len() / 2]);
    };
    let two = times(5, |seed| {
        let r = campaign::run_on(&s, seed, Method::Joint, Threads::Two, |_| {});
        std::hint::black_box(r.estimate);
    });
    report(
        "default campaign, in-process, simulation and estimator on two threads:",
        &two,
    );
    let one = times(5, |seed| {
        let r = campaign::run_on(&s, seed, Method::Joint, Threads::One, |_| {});
        std::hint::black_box(r.estimate);
    });
    report("default campaign, in-process, one thread:", &one);

    // Its stages alone, one thread each: wall time and the thread's own CPU time (the
    // latter hardly moves with the machine's load). The whole process runs three such
    // threads on two cores (the campaign's simulation, which also gives the bound its
    // noise-free twin, the campaign's estimator and the bound's estimator pass), so the
    // sum of their CPU times over two is about the least its wall time can be. The
    // noise-free simulation alone is what `crlb` (the bound by itself) adds.
    let mut samples: Vec<SensorSample> = Vec::with_capacity(n as usize);
    let sim = stage(3, || {
        let mut st = Stages::new(&s, 1, Method::Joint);
        samples.clear();
        for tick in 0..n {
            let cmd = st.commander.step(tick);
            let truth = st.plant.step(tick, &cmd.torque_cmd_b);
            samples.push(st.fee.step(&truth));
        }
    });
    let est = stage(3, || {
        let mut st = Stages::new(&s, 1, Method::Joint);
        for m in &samples {
            std::hint::black_box(st.estimator.step(m));
        }
        std::hint::black_box(st.estimator.finish());
    });
    let sim0 = stage(3, || {
        let mut cmd = Commander::new(&s);
        let mut plant = Plant::new(&s, s.seed, PlantNoise::NONE);
        let mut fee = FrontEnd::new(&s, s.seed, false);
        samples.clear();
        for tick in 0..n {
            let truth = plant.step(tick, &cmd.step(tick).torque_cmd_b);
            samples.push(fee.step(&truth));
        }
    });
    let est0 = stage(3, || {
        let mut cfg = s.estimator_config(&s.priors());
        cfg.solve_every = u64::MAX;
        let mut e = JointEstimator::new(cfg);
        for m in &samples {
            std::hint::black_box(e.step(m));
        }
    });
    let bound = times(3, |_| {
        std::hint::black_box(taiji::analysis::crlb::crlb(&s));
    });
    println!("stages alone, one thread each (median of 3; wall, and the thread's CPU time):");
    let line = |what: &str, (wall, cpu): (f64, f64)| {
        println!("  {what:<58} {wall:.3} s   CPU {cpu:.3} s");
    };
    line("simulation (commander, plant, front-end)", sim);
    line("estimator (with its solves)", est);
    line(
        "noise-free simulation (the bound alone; `run` twins its own)",
        sim0,
    );
    line("estimator without solves (the bound's pass)", est0);
    println!(
        "  {:<58} {:.3} s   (its two threads)",
        "CRLB (noise-free campaign)", bound[1]
    );
    let sum = sim.1 + est.1 + est0.1;
    println!(
        "  the three threads of `run`: CPU {sum:.3} s, i.e. ≥ {:.3} s of wall time on two cores",
        sum / 2.0
    );

    // 100 seeds, one campaign per core.
    let mc = times(1, |_| {
        let st = std::process::Command::new(&bin)
            .args(["montecarlo", "--runs", "100"])
            .stdout(std::process::Stdio::null())
            .status()
            .expect("run taiji-calib");
        assert!(st.success(), "montecarlo failed: {st}");
    });
    println!(
        "Monte Carlo, 100 seeds (`taiji-calib montecarlo --runs 100`): {:.1} s",
        mc[0]
    );
    let _ = std::fs::remove_dir_all(dir.join("run"));
    if in_process_only {
        return;
    }

    // The same campaign through the process set, accelerated lock-step.
    let sup = std::env::current_exe()
        .unwrap()
        .parent()
        .unwrap()
        .join("../taiji-supervisor");
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
    if let Some(line) = taiji::analysis::report::scheduling_line(t) {
        println!("  scheduling  {line}");
    }
    platform_floor(20_000, 1_000_000);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The machine's own timing floor: one thread (SCHED_FIFO 43 if allowed) sleeping to
/// absolute deadlines `period_ns` apart, nothing else of ours running. Its overshoots
/// beyond one period are deadlines no process set on this machine can meet.
fn platform_floor(ticks: u64, period_ns: u64) {
    let fifo = taiji::bus::timing::enter_fifo(43).is_ok();
    let t0 = taiji::bus::timing::monotonic_ns() + period_ns;
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
        over.push(taiji::bus::timing::monotonic_ns().saturating_sub(due));
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
