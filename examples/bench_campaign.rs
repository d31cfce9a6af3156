//! Times the default campaign in one process; run it through `tools/bench`.
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
}
