//! Fuzz the estimator's step: `cargo run --release --example fuzz_estimator -- [CASES] [SEED]`
//! (default 1 000 000 cases). Prints the cases run; exits 1 if any estimate was non-finite
//! (a panic aborts with its message).
fn main() {
    let mut args = std::env::args().skip(1);
    let cases: u64 = args
        .next()
        .and_then(|a| a.parse().ok())
        .unwrap_or(1_000_000);
    let seed: u64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(1);
    let t0 = std::time::Instant::now();
    let s = taiji::analysis::fuzz::run(cases, seed);
    println!(
        "{} samples stepped ({} rejected for some cause), {} non-finite estimates, {:.1} s",
        s.steps,
        s.rejected,
        s.non_finite,
        t0.elapsed().as_secs_f64()
    );
    let by_cause: Vec<String> = taiji::sim::msg::CAUSE_NAMES
        .iter()
        .zip(s.causes)
        .filter(|(_, c)| *c > 0)
        .map(|(n, c)| format!("{n} {c}"))
        .collect();
    println!("rejections by cause: {}", by_cause.join(", "));
    std::process::exit(i32::from(s.non_finite > 0));
}
