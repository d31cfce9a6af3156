//! Single-event upsets in the estimator's own memory, through its C ABI:
//!   cargo run --release --example upset_campaign -- [TRIALS] [DURATION_S] [SEED] [between|during]
//! `between` (the default) flips a bit between two calls; `during` in the middle of an
//! update, a solve or `finish` (a third of the trials each), struck by a timer's signal.
//! Prints the table of outcomes (docs/integrity.md, "Upsets in the estimator's memory").
use taiji::analysis::upset::{run, Campaign, Moment};

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
    let mode = std::env::args().nth(4).unwrap_or_else(|| "between".into());
    let moments: &[Moment] = match mode.as_str() {
        "between" => &[Moment::Between],
        "during" => &[Moment::Update, Moment::Solve, Moment::Finish],
        m => {
            eprintln!("upset_campaign: the moment is `between` or `during`, not `{m}`");
            std::process::exit(2);
        }
    };
    let t0 = std::time::Instant::now();
    let c = Campaign::new(duration, 7);
    let [u, s, f] = c.call_ns();
    println!(
        "{} samples, state {} words; {trials} flips (seed {seed}), one random bit at a random moment {}",
        c.samples.len(),
        Campaign::state_words(),
        if mode == "between" {
            "between two calls".to_string()
        } else {
            format!(
                "in a call (timed over its kind's typical duration: update {:.1} µs, solve {:.2} ms, finish {:.1} ms)",
                u as f64 / 1e3,
                s as f64 / 1e6,
                f as f64 / 1e6
            )
        }
    );
    let table = run(&c, trials, seed, 2, moments);
    println!("| moment | outcome | trials | largest move [σ] |\n|---|---|---|---|");
    for (m, o, k, d) in &table {
        println!(
            "| {m:?} | {o:?} | {k} | {} |",
            match d {
                d if !d.is_finite() => "—".to_string(),
                d if *d >= 1e4 => format!("{d:.1e}"),
                d => format!("{d:.3}"),
            }
        );
    }
    println!("({:.0} s)", t0.elapsed().as_secs_f64());
}
