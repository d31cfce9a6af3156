//! Single-event upsets in the estimator's own memory (src/analysis/upset.rs): a C-ABI host
//! replays a campaign while one random bit of the state flips at a random moment
//! between calls. No flip may abort, hang or move the final estimate by 3σ unseen; a
//! flip is found at the next call, and the host's restore of its last checkpoint
//! gives back the reference result bit for bit. The full 10 000-flip campaign is
//! `cargo run --release --example upset_campaign` (docs/integrity.md).

use taiji::analysis::upset::{run, Campaign, Outcome};

#[test]
fn random_upsets_are_all_found_and_repaired() {
    let c = Campaign::new(1200.0, 3);
    // Without a flip the trial reproduces the reference exactly.
    assert_eq!(c.trial(None), (Outcome::Harmless, 0.0));
    let table = run(&c, 300, 11, 2);
    let total: usize = table.iter().map(|r| r.1).sum();
    assert_eq!(total, 300);
    for (o, k, d) in &table {
        assert!(
            matches!(o, Outcome::DetectedRepaired | Outcome::Harmless),
            "{k} trials ended {o:?} (largest move {d}σ): {table:?}"
        );
    }
}
