//! Single-event upsets in the estimator's own memory, through its C ABI:
//!   cargo run --release --example upset_campaign -- [TRIALS] [DURATION_S] [SEED]
//! Prints the table of outcomes (docs/integrity.md, "Upsets in the estimator's memory").
use taiji::analysis::upset::{run, Campaign};

fn main() {
    let arg = |k: usize, d: f64| {
        std::env::args()
            .nth(k)
            .and_then(|a| a.parse().ok())
            .unwrap_or(d)
    };
    let (trials, duration, seed) = (
        arg(1, 10_000.0) as usize,
        arg(2, 2000.0),
        arg(3, 1.0) as u64,
    );
    let t0 = std::time::Instant::now();
    let c = Campaign::new(duration, 7);
    println!(
        "{} samples, state {} words; {trials} flips (seed {seed}), one random bit at a random moment",
        c.samples.len(),
        Campaign::state_words()
    );
    let table = run(&c, trials, seed, 2);
    println!("| outcome | trials | largest move [σ] |\n|---|---|---|");
    for (o, k, d) in &table {
        println!(
            "| {o:?} | {k} | {} |",
            if d.is_finite() {
                format!("{d:.3}")
            } else {
                "—".into()
            }
        );
    }
    println!("({:.0} s)", t0.elapsed().as_secs_f64());
}
