//! Single-event upsets in the estimator's own memory (src/analysis/upset): a C-ABI host
//! replays a campaign while one random bit of the state flips at a random moment,
//! between calls or in the middle of one. Between calls no flip may abort, hang or
//! move the final estimate by 3σ unseen; a flip is found at the next call, and the
//! host's restore of its last checkpoint gives back the reference result bit for bit.
//! During a call none may abort or hang. The full 10 000-flip campaigns are
//! `cargo run --release --example upset_campaign -- 10000 2000 1 between|during`
//! (docs/integrity.md).

use taiji::analysis::upset::{run, Campaign, Moment, Outcome};

#[test]
fn random_upsets_are_all_found_and_repaired() {
    let c = Campaign::new(1200.0, 3);
    // Without a flip the trial reproduces the reference exactly.
    assert_eq!(c.trial(None), (Outcome::Harmless, 0.0));
    let table = run(&c, 300, 11, 2, &[Moment::Between]);
    let total: usize = table.iter().map(|r| r.2).sum();
    assert_eq!(total, 300);
    for (_, o, k, d) in &table {
        assert!(
            matches!(o, Outcome::DetectedRepaired | Outcome::Harmless),
            "{k} trials ended {o:?} (largest move {d}σ): {table:?}"
        );
    }
}

/// Flips in the middle of an update, a solve or `finish` (a timer's signal strikes the
/// call wherever it is): none aborts or hangs, every one found is repaired to the
/// reference's bits, and the statistics' check after a solve and after `finish` finds
/// flips there that the call's own check had already passed.
#[test]
fn upsets_during_calls_never_abort_or_hang_and_finish_finds_its_own() {
    let c = Campaign::new(1200.0, 3);
    let table = run(
        &c,
        240,
        5,
        2,
        &[Moment::Update, Moment::Solve, Moment::Finish],
    );
    let count = |m: Option<Moment>, o: &[Outcome]| -> usize {
        table
            .iter()
            .filter(|r| m.is_none_or(|m| r.0 == m) && o.contains(&r.1))
            .map(|r| r.2)
            .sum()
    };
    assert_eq!(count(None, &[]), 0);
    let all = [
        Outcome::Abort,
        Outcome::Hang,
        Outcome::DetectedRepaired,
        Outcome::DetectedNotRepaired,
        Outcome::Flagged,
        Outcome::Harmless,
        Outcome::Moved,
        Outcome::UndetectedLarge,
        Outcome::Missed,
    ];
    assert_eq!(count(None, &all), 240, "{table:?}");
    let bad = [Outcome::Abort, Outcome::Hang, Outcome::DetectedNotRepaired];
    assert_eq!(count(None, &bad), 0, "{table:?}");
    // The timer lands most flips in the calls they aim at (a missed one is no trial:
    // its signal came while the thread was not in the call, which a loaded machine's
    // preemption makes likelier).
    assert!(count(None, &[Outcome::Missed]) <= 80, "{table:?}");
    // In `finish` (a third of the trials), every flip in the statistics is found,
    // before or after the solves read them: nearly nine tenths of the state.
    let finish =
        count(Some(Moment::Finish), &all) - count(Some(Moment::Finish), &[Outcome::Missed]);
    let found = count(Some(Moment::Finish), &[Outcome::DetectedRepaired]);
    assert!(
        finish >= 40 && found * 10 >= finish * 7,
        "{found} of {finish} flips in finish found: {table:?}"
    );
}

/// Flips in the middle of `estimate` and `checkpoint`: each checks the state again
/// before what it made leaves, so no corrupted estimate or checkpoint gets out (a
/// checkpoint refused is spoilt: `restore` refuses it too).
#[test]
fn no_corrupted_estimate_or_checkpoint_leaves_a_call_a_bit_flipped_in() {
    let c = Campaign::new(600.0, 3);
    // The calls take a few microseconds here: delays within 20 µs land in most.
    let r = taiji::analysis::upset::strike_outputs(&c, 3000, 400, 9, 20_000);
    assert!(r.landed >= 100, "{r:?}");
    assert_eq!(r.leaked, 0, "{r:?}");
    assert!(r.refused > 0, "{r:?}");
}

/// What an update writes is what it reseals (the parts it checks before and reseals
/// after: `JointEstimator::PARTS`): a whole check (`estimate`) passes after every update
/// of a campaign that starts late, has a gap, a corrupted sample and a clock jump,
/// solves included. A part an update writes without resealing fails it.
#[test]
fn every_update_reseals_all_it_writes() {
    use taiji::sim::capi::*;
    use taiji::sim::msg::{EstimateMsg, SensorSample};
    let c = Campaign::new(300.0, 3);
    let mut samples: Vec<SensorSample> = c.samples[7..].to_vec();
    samples.drain(500..800);
    samples[1000].is[0].volts[0][0] = f64::NAN;
    samples[1500].header.tick += 10_000_000;
    samples[1501].header.tick += 10_000_000;
    let mut mem = vec![0u64; taiji_estimator_size().div_ceil(8)];
    let mut work = vec![0u64; taiji_solve_work_size().div_ceil(8)];
    let p = mem.as_mut_ptr() as *mut u8;
    let (w, wn) = (work.as_mut_ptr() as *mut u8, work.len() * 8);
    // SAFETY: 8-aligned memory of the sizes the library asks for, a valid table.
    unsafe {
        assert_eq!(
            taiji_estimator_init(
                p,
                mem.len() * 8,
                &c.cfg,
                TAIJI_ABI_VERSION,
                size_of::<taiji::sim::estimate::EstimatorConfig>(),
                size_of::<SensorSample>(),
                size_of::<EstimateMsg>(),
            ),
            TAIJI_OK
        );
        let mut out = EstimateMsg::default();
        for (i, s) in samples.iter().enumerate() {
            let mut flags = 0u32;
            assert_eq!(
                taiji_estimator_update(p, s, std::ptr::null_mut(), &mut flags),
                TAIJI_OK
            );
            assert_eq!(
                taiji_estimator_estimate(p, &mut out),
                TAIJI_OK,
                "after update {i}"
            );
            if flags & TAIJI_SOLVE_DUE != 0 {
                let rc = taiji_estimator_solve(p, w, wn);
                assert!(rc == TAIJI_OK || rc == TAIJI_ERR_SOLVE, "solve {rc}");
            }
        }
        assert_eq!(taiji_estimator_finish(p, w, wn, &mut out), TAIJI_OK);
        assert!(
            out.n_used > 2000 && out.n_rejected > 0,
            "{} {}",
            out.n_used,
            out.n_rejected
        );
    }
}
