//! Upset campaign: single-event upsets in the estimator's own memory. A C-ABI host
//! (the cycle of examples/c/host.c, driven from Rust through `capi`) replays a
//! campaign; in each trial one random bit of the state's memory flips at a random
//! moment, between two calls or in the middle of an `update`, a `solve` or `finish`
//! (a timer's signal, `timer.rs`), and the run goes on to `finish`. Every trial is
//! classified: an abort (panic), a hang (a call far over its bound), detected (a call
//! returned an error code; the host then restores its last checkpoint and replays
//! from it, as the front end's ring allows in the set), flagged (the final status is
//! unverified), or how far the final estimate moved in units of its σ. Used by
//! `cargo run --release --example upset_campaign -- TRIALS` and tests/upsets.rs.

mod timer;

use crate::analysis::fuzz::Bits;
use crate::sim::capi::*;
use crate::sim::estimate::{EstimatorConfig, Method};
use crate::sim::msg::{EstimateMsg, SensorSample, ST_UNVERIFIED};
use crate::sim::scenario::Scenario;
use std::mem::size_of;
use std::time::{Duration, Instant};

/// A host checkpoints every this many samples (as the estimator process does).
const CHECKPOINT_EVERY: usize = 1000;

/// How one trial ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Outcome {
    /// A panic reached the host (an abort in the C library).
    Abort,
    /// A call took over `HANG` (its bound is milliseconds).
    Hang,
    /// A call returned an error code at the flip; after restoring the last
    /// checkpoint and replaying, the final estimate is bit-identical to the reference.
    DetectedRepaired,
    /// Detected, but the repaired run's final estimate differs from the reference.
    DetectedNotRepaired,
    /// No error; the final status says unverified.
    Flagged,
    /// No error, no flag; the estimate moved by less than 0.1σ (or not at all).
    Harmless,
    /// No error, no flag; moved by 0.1σ to 3σ.
    Moved,
    /// No error, no flag; moved by 3σ or more: a failure.
    UndetectedLarge,
    /// A flip meant for the middle of a call never landed in one (the calls of its
    /// kind all returned before the timer fired): not a trial.
    Missed,
}

/// When the bit flips.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Moment {
    /// Between two calls (before the update of sample `at`, or before `finish`).
    Between,
    /// In the middle of an update: the first, from sample `at` on, that the timer
    /// strikes.
    Update,
    /// In the middle of a solve, the first from sample `at` on that the timer strikes.
    Solve,
    /// In the middle of `finish`.
    Finish,
}

/// A call slower than this is a hang.
const HANG: Duration = Duration::from_secs(2);

/// One trial's draw.
#[derive(Debug, Clone, Copy)]
pub struct Flip {
    /// Before the update of this sample (`n`: before finish).
    pub at: usize,
    /// Word of the state's memory and bit in it.
    pub word: usize,
    pub bit: u32,
    pub moment: Moment,
    /// Seeds the timer's delays (uniform over the call's typical duration).
    pub delays: u64,
}

/// The replay every trial runs: the samples, the table and the reference result.
pub struct Campaign {
    pub cfg: EstimatorConfig,
    pub samples: Vec<SensorSample>,
    reference: EstimateMsg,
    checkpoints: Vec<Vec<u8>>,
    /// The reference run's median update, median solve and `finish` [ns]: a flip
    /// during a call is timed uniformly over its kind's.
    call_ns: [u64; 3],
}

/// 8-aligned memory for one state.
fn memory() -> Vec<u64> {
    vec![0u64; taiji_estimator_size().div_ceil(8)]
}

std::thread_local! {
    /// The solve's scratch (`taiji_solve_work_size()` bytes), one per thread: its
    /// contents never matter between calls.
    static WORK: std::cell::RefCell<Vec<u64>> =
        std::cell::RefCell::new(vec![0u64; taiji_solve_work_size().div_ceil(8)]);
}

/// Runs `f` with the thread's scratch for `solve` and `finish` (pointer, bytes).
fn with_work<R>(f: impl FnOnce(*mut u8, usize) -> R) -> R {
    WORK.with(|w| {
        let mut w = w.borrow_mut();
        let bytes = w.len() * 8;
        f(w.as_mut_ptr() as *mut u8, bytes)
    })
}

fn init(mem: &mut [u64], cfg: &EstimatorConfig) -> i32 {
    // SAFETY: `mem` is 8-aligned and holds `taiji_estimator_size()` bytes.
    unsafe {
        taiji_estimator_init(
            mem.as_mut_ptr() as *mut u8,
            mem.len() * 8,
            cfg,
            TAIJI_ABI_VERSION,
            size_of::<EstimatorConfig>(),
            size_of::<SensorSample>(),
            size_of::<EstimateMsg>(),
        )
    }
}

/// A flip waiting for its call: the timer, the word's address, the bit and its
/// delays' draws.
struct Pending<'a> {
    timer: &'a timer::Timer,
    moment: Moment,
    word: *mut u64,
    bit: u32,
    delays: Bits,
    /// The typical duration of the call it waits for [ns].
    span_ns: u64,
}

impl Pending<'_> {
    /// Runs `call`, struck in its middle when this is the flip's kind of call.
    /// Returns the call's code and whether the flip landed in it.
    fn around(&mut self, kind: Moment, call: impl FnOnce() -> i32) -> (i32, bool) {
        if kind != self.moment {
            return (call(), false);
        }
        let delay = 1 + self.delays.below(self.span_ns.max(1));
        self.timer.strike(self.word, self.bit, delay, call)
    }
}

/// Runs `f`, through the pending flip when there is one.
fn call(pending: &mut Option<Pending>, kind: Moment, f: impl FnOnce() -> i32) -> (i32, bool) {
    match pending {
        Some(pd) => pd.around(kind, f),
        None => (f(), false),
    }
}

/// One host cycle: update, and the solve when it is due (a pending flip strikes the
/// call of its kind). Returns the first error code and whether the flip landed.
fn cycle(mem: &mut [u64], s: &SensorSample, pending: &mut Option<Pending>) -> (i32, bool) {
    let p = mem.as_mut_ptr() as *mut u8;
    let mut flags = 0u32;
    // SAFETY: an 8-aligned state buffer, a valid sample and outputs.
    let (rc, mut landed) = call(pending, Moment::Update, || unsafe {
        taiji_estimator_update(p, s, std::ptr::null_mut(), &mut flags)
    });
    if rc != TAIJI_OK {
        return (rc, landed);
    }
    if flags & TAIJI_SOLVE_DUE != 0 {
        if landed {
            // Landed: the solve runs unstruck, as the host would run it.
            *pending = None;
        }
        // SAFETY: as above.
        let (rc, l) = call(pending, Moment::Solve, || {
            with_work(|w, n| unsafe { taiji_estimator_solve(p, w, n) })
        });
        landed |= l;
        if rc != TAIJI_OK && rc != TAIJI_ERR_SOLVE {
            return (rc, landed);
        }
    }
    (TAIJI_OK, landed)
}

fn checkpoint(mem: &mut [u64]) -> Vec<u8> {
    let mut buf = vec![0u8; taiji_checkpoint_size()];
    let mut n = 0usize;
    // SAFETY: an initialised state and a buffer of the checkpoint's size.
    let rc = unsafe {
        taiji_estimator_checkpoint(
            mem.as_mut_ptr() as *mut u8,
            buf.as_mut_ptr(),
            buf.len(),
            &mut n,
        )
    };
    assert_eq!(rc, TAIJI_OK, "checkpoint");
    buf.truncate(n);
    buf
}

fn restore(mem: &mut [u64], ck: &[u8], cfg: &EstimatorConfig) -> i32 {
    // SAFETY: an 8-aligned state buffer, a checkpoint and the table.
    unsafe {
        taiji_estimator_restore(
            mem.as_mut_ptr() as *mut u8,
            mem.len() * 8,
            ck.as_ptr(),
            ck.len(),
            cfg,
        )
    }
}

/// `finish` (struck in its middle by a pending flip of that kind); the estimate or the
/// error code, and whether the flip landed.
fn finish(mem: &mut [u64], pending: &mut Option<Pending>) -> (Result<EstimateMsg, i32>, bool) {
    let mut out = EstimateMsg::default();
    // SAFETY: an 8-aligned state buffer and an output.
    let p = mem.as_mut_ptr() as *mut u8;
    let (rc, landed) = call(pending, Moment::Finish, || {
        with_work(|w, n| unsafe { taiji_estimator_finish(p, w, n, &mut out) })
    });
    (if rc == TAIJI_OK { Ok(out) } else { Err(rc) }, landed)
}

/// Largest |estimate − reference| / σ_reference over β, k and r of both IS.
fn moved_sigma(a: &EstimateMsg, r: &EstimateMsg) -> f64 {
    let mut worst: f64 = 0.0;
    for i in 0..2 {
        for j in 0..3 {
            for (x, y, s) in [
                (a.beta[i][j], r.beta[i][j], r.beta_sigma[i][j]),
                (a.k[i][j], r.k[i][j], r.k_sigma[i][j]),
                (a.r_b[i][j], r.r_b[i][j], r.r_sigma[i][j]),
            ] {
                let d = ((x - y) / s).abs();
                worst = worst.max(if d.is_nan() { f64::INFINITY } else { d });
            }
        }
    }
    worst
}

impl Campaign {
    /// The default scenario shortened to `duration_s`, its samples simulated with
    /// `seed`, and the reference run (with the host's checkpoints).
    pub fn new(duration_s: f64, seed: u64) -> Campaign {
        let s = Scenario {
            duration_s,
            ..Scenario::default()
        };
        let s = crate::analysis::plan::resolve(s)
            .map(|(s, _)| s)
            .unwrap_or_else(|e| panic!("{e}"));
        let cfg = s.estimator_config(&s.priors());
        let mut st = crate::analysis::campaign::Stages::new(&s, seed, Method::Joint);
        let samples = st.sensor_samples(s.n_samples());
        let mut mem = memory();
        assert_eq!(init(&mut mem, &cfg), TAIJI_OK);
        let mut checkpoints = Vec::new();
        let (mut updates, mut solves) = (Vec::new(), Vec::new());
        for (i, smp) in samples.iter().enumerate() {
            if i % CHECKPOINT_EVERY == 0 {
                checkpoints.push(checkpoint(&mut mem));
            }
            // Timed as the trials strike them: the update alone, then the solve.
            let p = mem.as_mut_ptr() as *mut u8;
            let mut flags = 0u32;
            let t0 = Instant::now();
            // SAFETY: an 8-aligned, initialised state, a valid sample and outputs.
            let rc = unsafe { taiji_estimator_update(p, smp, std::ptr::null_mut(), &mut flags) };
            updates.push(t0.elapsed().as_nanos() as u64);
            assert_eq!(rc, TAIJI_OK);
            if flags & TAIJI_SOLVE_DUE != 0 {
                let t0 = Instant::now();
                // SAFETY: as above, and the thread's scratch.
                let rc = with_work(|w, n| unsafe { taiji_estimator_solve(p, w, n) });
                solves.push(t0.elapsed().as_nanos() as u64);
                assert!(rc == TAIJI_OK || rc == TAIJI_ERR_SOLVE, "solve: {rc}");
            }
        }
        let t0 = Instant::now();
        let reference = finish(&mut mem, &mut None).0.expect("reference finish");
        let mut finish_ns = t0.elapsed().as_nanos() as u64;
        // The first finish runs cold (a trial's takes a fraction of it): timed again
        // from the last checkpoint, warm, and the shorter kept.
        if let Some(ck) = checkpoints.last() {
            let mut again = memory();
            assert_eq!(restore(&mut again, ck, &cfg), TAIJI_OK);
            let from = (checkpoints.len() - 1) * CHECKPOINT_EVERY;
            for smp in &samples[from..] {
                assert_eq!(cycle(&mut again, smp, &mut None).0, TAIJI_OK);
            }
            let t0 = Instant::now();
            let _ = finish(&mut again, &mut None);
            finish_ns = finish_ns.min(t0.elapsed().as_nanos() as u64);
        }
        let median = |v: &mut Vec<u64>| {
            v.sort_unstable();
            v.get(v.len() / 2).copied().unwrap_or(1)
        };
        Campaign {
            cfg,
            call_ns: [median(&mut updates), median(&mut solves), finish_ns],
            samples,
            reference,
            checkpoints,
        }
    }

    /// The reference run's median update, median solve and `finish` [ns].
    pub fn call_ns(&self) -> [u64; 3] {
        self.call_ns
    }

    /// The host's last checkpoint at or before sample `i` (taken before its update).
    fn last_checkpoint(&self, i: usize) -> usize {
        (i.min(self.samples.len().saturating_sub(1)) / CHECKPOINT_EVERY) * CHECKPOINT_EVERY
    }

    /// The words of the state's memory (where a flip can land).
    pub fn state_words() -> usize {
        taiji_estimator_size() / 8
    }

    /// Runs one trial: replay with `flip` (None: none), the host recovering from its
    /// last checkpoint when a call reports an error.
    pub fn trial(&self, flip: Option<Flip>) -> (Outcome, f64) {
        let run = std::panic::catch_unwind(|| self.run(flip));
        match run {
            Err(_) => (Outcome::Abort, f64::INFINITY),
            Ok(r) => r,
        }
    }

    fn run(&self, flip: Option<Flip>) -> (Outcome, f64) {
        let at = flip.map_or(self.samples.len() + 1, |f| f.at);
        // Start from the one before the flip (without a flip: from the start).
        let start = if flip.is_some() {
            self.last_checkpoint(at)
        } else {
            0
        };
        let mut mem = memory();
        if start == 0 {
            assert_eq!(init(&mut mem, &self.cfg), TAIJI_OK);
        } else {
            let ck = &self.checkpoints[start / CHECKPOINT_EVERY];
            assert_eq!(restore(&mut mem, ck, &self.cfg), TAIJI_OK);
        }
        // This thread's timer, for a flip in the middle of a call.
        std::thread_local! {
            static TIMER: timer::Timer = timer::Timer::new();
        }
        TIMER.with(|t| self.replay(&mut mem, flip, start, t))
    }

    /// The trial's replay from sample `start` to `finish`, the flip struck as drawn.
    fn replay(
        &self,
        mem: &mut [u64],
        flip: Option<Flip>,
        start: usize,
        timer: &timer::Timer,
    ) -> (Outcome, f64) {
        let n = self.samples.len();
        let (mut detected, mut flipped) = (false, flip.is_none());
        let mut pending: Option<Pending> = None;
        let mut i = start;
        while i <= n {
            if let Some(f) = flip.filter(|f| i == f.at && !flipped && pending.is_none()) {
                if f.moment == Moment::Between {
                    mem[f.word] ^= 1u64 << f.bit;
                    flipped = true;
                } else {
                    let span_ns = self.call_ns[match f.moment {
                        Moment::Update => 0,
                        Moment::Solve => 1,
                        _ => 2,
                    }];
                    pending = Some(Pending {
                        timer,
                        moment: f.moment,
                        word: &mut mem[f.word] as *mut u64,
                        bit: f.bit,
                        delays: Bits(f.delays),
                        span_ns,
                    });
                }
            }
            let t0 = Instant::now();
            let (rc, landed) = if i < n {
                cycle(mem, &self.samples[i], &mut pending)
            } else {
                let (r, landed) = finish(mem, &mut pending);
                if !flipped && !landed {
                    return (Outcome::Missed, 0.0);
                }
                match r {
                    Ok(e) => {
                        if t0.elapsed() > HANG {
                            return (Outcome::Hang, f64::INFINITY);
                        }
                        let d = moved_sigma(&e, &self.reference);
                        let same = e == self.reference;
                        return (
                            match (detected, same) {
                                (true, true) => Outcome::DetectedRepaired,
                                (true, false) => Outcome::DetectedNotRepaired,
                                _ if e.status & ST_UNVERIFIED != 0 => Outcome::Flagged,
                                _ if d >= 3.0 => Outcome::UndetectedLarge,
                                _ if d >= 0.1 => Outcome::Moved,
                                _ => Outcome::Harmless,
                            },
                            d,
                        );
                    }
                    Err(rc) => (rc, landed),
                }
            };
            if landed {
                flipped = true;
                pending = None;
            }
            if t0.elapsed() > HANG {
                return (Outcome::Hang, f64::INFINITY);
            }
            if rc != TAIJI_OK {
                if detected {
                    // A second error after the repair: not repaired.
                    return (Outcome::DetectedNotRepaired, f64::INFINITY);
                }
                if !flipped {
                    // An error before any flip landed: the run itself failed.
                    return (Outcome::DetectedNotRepaired, f64::INFINITY);
                }
                detected = true;
                // Scrub: the last checkpoint at or before this sample, and replay.
                let c = self.last_checkpoint(i);
                mem.iter_mut().for_each(|w| *w = 0);
                let rc = if c == 0 {
                    init(mem, &self.cfg)
                } else {
                    restore(mem, &self.checkpoints[c / CHECKPOINT_EVERY], &self.cfg)
                };
                if rc != TAIJI_OK {
                    return (Outcome::DetectedNotRepaired, f64::INFINITY);
                }
                i = c;
                continue;
            }
            i += 1;
        }
        unreachable!("the loop returns at finish")
    }
}

/// A flip at a random moment of one of the `moments` (between calls: before any
/// update or before finish; in a call: from a random sample on, or in `finish`), word
/// and bit.
fn draw_flip(bits: &mut Bits, samples: usize, moments: &[Moment]) -> Flip {
    let moment = moments
        .get(bits.below(moments.len() as u64) as usize)
        .copied()
        .unwrap_or(Moment::Between);
    let at = bits.below(samples as u64 + 1) as usize;
    Flip {
        at: if moment == Moment::Finish {
            samples
        } else {
            at
        },
        word: bits.below(Campaign::state_words() as u64) as usize,
        bit: bits.below(64) as u32,
        moment,
        delays: bits.next(),
    }
}

/// Counts of every outcome over `trials` random flips at the `moments` (drawn among
/// them evenly), on `threads` threads: per moment and outcome, the trials and the
/// largest move [σ].
pub fn run(
    c: &Campaign,
    trials: usize,
    seed: u64,
    threads: usize,
    moments: &[Moment],
) -> Vec<(Moment, Outcome, usize, f64)> {
    let threads = threads.max(1);
    let mut bits = Bits(seed);
    let flips: Vec<Flip> = (0..trials)
        .map(|_| draw_flip(&mut bits, c.samples.len(), moments))
        .collect();
    let results: Vec<(Moment, Outcome, f64)> = std::thread::scope(|sc| {
        let handles: Vec<_> = flips
            .chunks(trials.div_ceil(threads).max(1))
            .map(|chunk| {
                sc.spawn(move || {
                    chunk
                        .iter()
                        .map(|f| {
                            let (o, d) = c.trial(Some(*f));
                            (f.moment, o, d)
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_default())
            .collect()
    });
    let mut table: Vec<(Moment, Outcome, usize, f64)> = Vec::new();
    for (m, o, d) in results {
        match table.iter_mut().find(|r| r.0 == m && r.1 == o) {
            Some(row) => {
                row.2 += 1;
                row.3 = row.3.max(d);
            }
            None => table.push((m, o, 1, d)),
        }
    }
    table.sort_by_key(|r| (r.0, r.1));
    table
}

/// What flips struck in the middle of `estimate` and `checkpoint` gave: the flips that
/// landed in a call, and the calls that let a corrupted result out (an estimate other
/// than the unflipped state's, or a checkpoint that `restore`s to other bytes, with
/// `TAIJI_OK`; or a spoilt checkpoint that `restore` took).
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct OutputStrikes {
    pub landed: usize,
    pub refused: usize,
    pub leaked: usize,
}

/// `trials` flips, half in `estimate` and half in `checkpoint`, each on a fresh copy of
/// the state after the campaign's first `after` samples, at a random delay within
/// `span_ns` (about the call's duration on this machine).
pub fn strike_outputs(
    c: &Campaign,
    after: usize,
    trials: usize,
    seed: u64,
    span_ns: u64,
) -> OutputStrikes {
    let mut base = memory();
    assert_eq!(init(&mut base, &c.cfg), TAIJI_OK);
    for s in c.samples.iter().take(after) {
        assert_eq!(cycle(&mut base, s, &mut None).0, TAIJI_OK);
    }
    let timer = timer::Timer::new();
    let mut bits = Bits(seed);
    let mut r = OutputStrikes::default();
    let estimate = |mem: &mut [u64], out: &mut EstimateMsg| -> i32 {
        // SAFETY: an 8-aligned, initialised state and an output.
        unsafe { taiji_estimator_estimate(mem.as_mut_ptr() as *mut u8, out) }
    };
    let mut reference = EstimateMsg::default();
    assert_eq!(estimate(&mut base.clone(), &mut reference), TAIJI_OK);
    let clean = checkpoint(&mut base.clone());
    for t in 0..trials {
        let mut mem = base.clone();
        let (word, bit) = (
            bits.below(Campaign::state_words() as u64) as usize,
            bits.below(64) as u32,
        );
        let delay = 1 + bits.below(span_ns.max(1));
        let target = &mut mem[word] as *mut u64;
        if t % 2 == 0 {
            let mut out = EstimateMsg::default();
            let p = mem.as_mut_ptr() as *mut u8;
            // SAFETY: an 8-aligned, initialised state and an output.
            let (rc, landed) = timer.strike(target, bit, delay, || unsafe {
                taiji_estimator_estimate(p, &mut out)
            });
            if !landed {
                continue;
            }
            r.landed += 1;
            match rc {
                TAIJI_OK if out != reference => r.leaked += 1,
                TAIJI_OK => {}
                _ => r.refused += 1,
            }
        } else {
            let mut buf = vec![0u8; taiji_checkpoint_size()];
            let mut n = 0usize;
            let (p, b, len) = (mem.as_mut_ptr() as *mut u8, buf.as_mut_ptr(), buf.len());
            // SAFETY: an 8-aligned, initialised state and a buffer of the checkpoint's size.
            let (rc, landed) = timer.strike(target, bit, delay, || unsafe {
                taiji_estimator_checkpoint(p, b, len, &mut n)
            });
            if !landed {
                continue;
            }
            r.landed += 1;
            // What a host that ignored the code would restore: the whole buffer
            // (`written` is set on success only).
            let mut back = memory();
            let restored = restore(
                &mut back,
                if rc == TAIJI_OK {
                    &buf[..n.min(len)]
                } else {
                    &buf
                },
                &c.cfg,
            );
            match rc {
                TAIJI_OK if restored != TAIJI_OK || buf[..n] != clean[..] => r.leaked += 1,
                TAIJI_OK => {}
                _ if restored == TAIJI_OK => r.leaked += 1,
                _ => r.refused += 1,
            }
        }
    }
    r
}
